//! The arm models cells can name: the bundled ones (`robots/*.urdf`, carried by the binary), those
//! of `serve --robots DIR`, and those uploaded through
//! the API, which are stored in the database and loaded again at start-up. Every model is
//! loaded through the same path (`kinematics::Robot::from_urdf_str`): six revolute joints with
//! limits and velocities, a closed-form solver derived from the chain and checked against it.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, RwLock};

use tokio::sync::Mutex as AsyncMutex;

use super::error::AppError;
use super::settings::parse_settings;
use super::{App, Result, check_name};
use crate::api::{self, RobotSource, RobotUpload};
use crate::kinematics::catalog::{ArmFacts, computed_reach_mm, load_catalog};
use crate::kinematics::{self, KinematicsError, Robot, SolverKind};
use crate::storage::RobotRow;

/// Longest robot name (letters, digits, `_` and `-`).
pub const MAX_ROBOT_NAME: usize = 64;
/// Largest URDF text accepted (a plain six-joint URDF is a few kB; meshes are not read).
pub const MAX_URDF_BYTES: usize = 256 * 1024;

/// What a data sheet says about an arm, where it is known.
#[derive(Debug, Clone, PartialEq)]
struct Datasheet {
    maker: Option<String>,
    /// The maker's designation (`IRB 2600-12/1.65`).
    product: Option<String>,
    payload_kg: Option<f64>,
    /// The data sheet's reach, mm.
    reach_mm: Option<f64>,
    /// The reach computed from the kinematics (axis-1 line to the wrist centre at full
    /// stretch; UR arms: to the flange), mm: known for every model.
    computed_reach_mm: f64,
    /// Program languages of the arm's controller (`rapid`, `krl`, `fanuc`, `urscript`).
    languages: Vec<String>,
}

#[derive(Debug, Clone)]
struct Entry {
    robot: Arc<Robot>,
    source: RobotSource,
    datasheet: Datasheet,
}

impl Entry {
    /// A model the service starts with, with its data sheet from `catalog` where it has one.
    fn bundled(robot: Robot, catalog: &[ArmFacts]) -> Entry {
        let facts = catalog.iter().find(|f| f.name == robot.name());
        let datasheet = Datasheet {
            maker: facts.map(|f| f.maker.clone()),
            product: facts.map(|f| f.model.clone()),
            payload_kg: facts.map(|f| f.payload_kg),
            reach_mm: facts.map(|f| f.reach_mm),
            computed_reach_mm: computed_reach_mm(&robot),
            languages: facts.map(|f| f.languages.clone()).unwrap_or_default(),
        };
        Entry {
            robot: Arc::new(robot),
            source: RobotSource::Bundled,
            datasheet,
        }
    }

    /// The model as the service lists it.
    fn resource(&self) -> api::Robot {
        let model = self.robot.model();
        let sheet = self.datasheet.clone();
        api::Robot {
            name: model.name,
            source: self.source,
            maker: sheet.maker,
            product: sheet.product,
            payload_kg: sheet.payload_kg,
            reach_mm: sheet.reach_mm,
            computed_reach_mm: sheet.computed_reach_mm,
            languages: sheet.languages,
            solver: match model.solver {
                SolverKind::Opw => "opw",
                SolverKind::Ur => "ur",
            }
            .to_string(),
            root: model.root,
            tip: model.tip,
            joints: model
                .joints
                .into_iter()
                .map(|j| api::Joint {
                    name: j.name,
                    lower: j.lower,
                    upper: j.upper,
                    velocity: j.velocity,
                })
                .collect(),
        }
    }
}

/// The models the service knows. Reads are many and short (a cell's model load, a listing);
/// uploads and deletes are serialised by `changes`, so a check and the write that follows it
/// see the same registry.
#[derive(Debug, Default)]
pub struct Robots {
    by_name: RwLock<BTreeMap<String, Entry>>,
    changes: AsyncMutex<()>,
}

impl Robots {
    /// The bundled models (carried by the binary, `kinematics::bundled`), with the models of
    /// `extra` (`serve --robots DIR`: every `*.urdf` there, data sheets from its
    /// `catalog.json`) added or overriding a bundled one of the same name.
    pub fn load(extra: Option<&Path>) -> std::result::Result<Robots, KinematicsError> {
        let mut by_name = BTreeMap::new();
        let catalog = kinematics::bundled_catalog()?;
        for robot in kinematics::bundled_robots()? {
            let entry = Entry::bundled(robot, &catalog);
            by_name.insert(entry.robot.name().to_string(), entry);
        }
        if let Some(dir) = extra {
            let catalog = load_catalog(dir)?;
            for robot in kinematics::load_robots(dir)? {
                let entry = Entry::bundled(robot, &catalog);
                by_name.insert(entry.robot.name().to_string(), entry);
            }
        }
        Ok(Robots {
            by_name: RwLock::new(by_name),
            changes: AsyncMutex::new(()),
        })
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, BTreeMap<String, Entry>> {
        // Every write is a single insert or remove: a poisoned lock still holds a whole map.
        self.by_name.read().unwrap_or_else(|p| p.into_inner())
    }

    fn write(&self) -> std::sync::RwLockWriteGuard<'_, BTreeMap<String, Entry>> {
        self.by_name.write().unwrap_or_else(|p| p.into_inner())
    }

    /// Adds the stored uploads at start-up. A stored model that no longer loads (a later
    /// version checks more) is logged and left out: the cells naming it work on without a
    /// reachability check, as with a missing bundled model.
    pub fn add_stored(&self, rows: &[RobotRow]) {
        for row in rows {
            match Robot::from_urdf_str(&row.name, &row.urdf) {
                Ok(robot) => {
                    self.write().insert(row.name.clone(), uploaded(robot, row));
                }
                Err(e) => {
                    tracing::warn!(robot = %row.name, error = %e, "stored robot model does not load; left out");
                }
            }
        }
    }

    pub fn get(&self, name: &str) -> Option<Arc<Robot>> {
        self.read().get(name).map(|e| e.robot.clone())
    }

    pub fn resource(&self, name: &str) -> Option<api::Robot> {
        self.read().get(name).map(Entry::resource)
    }

    pub fn resources(&self) -> Vec<api::Robot> {
        self.read().values().map(Entry::resource).collect()
    }

    /// The robot a cell names, or a 422 listing the known ones.
    pub fn require(&self, name: &str) -> Result<Arc<Robot>> {
        let map = self.read();
        map.get(name).map(|e| e.robot.clone()).ok_or_else(|| {
            let known: Vec<&str> = map.keys().map(String::as_str).collect();
            AppError::Invalid(format!(
                "unknown robot {name:?}; known robots: {}",
                known.join(", ")
            ))
        })
    }
}

fn uploaded(robot: Robot, row: &RobotRow) -> Entry {
    let datasheet = Datasheet {
        maker: row.maker.clone(),
        product: row.product.clone(),
        payload_kg: row.payload_kg,
        reach_mm: None,
        computed_reach_mm: computed_reach_mm(&robot),
        languages: Vec::new(),
    };
    Entry {
        robot: Arc::new(robot),
        source: RobotSource::Uploaded,
        datasheet,
    }
}

fn check_robot_name(name: &str) -> Result<()> {
    let valid = !name.is_empty()
        && name.len() <= MAX_ROBOT_NAME
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if valid {
        Ok(())
    } else {
        Err(AppError::Invalid(format!(
            "robot name {name:?} must be 1–{MAX_ROBOT_NAME} letters, digits, '_' or '-'"
        )))
    }
}

impl App {
    /// The robot models cells can use.
    pub fn robots(&self) -> Vec<api::Robot> {
        self.robots.resources()
    }

    pub fn robot(&self, name: &str) -> Result<api::Robot> {
        self.robots
            .resource(name)
            .ok_or_else(|| AppError::NotFoundName {
                what: "robot",
                name: name.to_string(),
            })
    }

    /// Uploads an arm model: checked like a bundled one (a 422 says what is wrong), stored, and
    /// from then on a cell may name it.
    pub async fn upload_robot(&self, upload: RobotUpload) -> Result<api::Robot> {
        check_robot_name(&upload.name)?;
        for (what, v) in [("maker", &upload.maker), ("product", &upload.product)] {
            if let Some(v) = v {
                check_name(what, v)?;
            }
        }
        if let Some(p) = upload.payload_kg
            && !(p.is_finite() && p > 0.0)
        {
            return Err(AppError::Invalid(format!(
                "payload_kg must be a positive number, not {p}"
            )));
        }
        if upload.urdf.len() > MAX_URDF_BYTES {
            return Err(AppError::Invalid(format!(
                "the URDF is {} bytes; at most {MAX_URDF_BYTES} are accepted",
                upload.urdf.len()
            )));
        }
        let _changing = self.robots.changes.lock().await;
        if self.robots.get(&upload.name).is_some() {
            return Err(AppError::Exists(format!(
                "robot {:?} already exists",
                upload.name
            )));
        }
        let (name, urdf) = (upload.name.clone(), upload.urdf.clone());
        let robot = super::blocking(move || Robot::from_urdf_str(&name, &urdf)).await??;
        let row = self
            .store
            .insert_robot(
                &upload.name,
                &upload.urdf,
                upload.maker.as_deref(),
                upload.product.as_deref(),
                upload.payload_kg,
            )
            .await?;
        let entry = uploaded(robot, &row);
        let robot = entry.resource();
        self.robots.write().insert(row.name.clone(), entry);
        Ok(robot)
    }

    /// Deletes an uploaded model that no cell names. Bundled models stay.
    pub async fn delete_robot(&self, name: &str) -> Result<()> {
        let _changing = self.robots.changes.lock().await;
        let source = self.robots.read().get(name).map(|e| e.source);
        match source {
            None => {
                return Err(AppError::NotFoundName {
                    what: "robot",
                    name: name.to_string(),
                });
            }
            Some(RobotSource::Bundled) => {
                return Err(AppError::Conflict(format!(
                    "robot {name:?} is bundled with the service and cannot be deleted"
                )));
            }
            Some(RobotSource::Uploaded) => {}
        }
        let mut users = Vec::new();
        for cell in self.store.cells().await? {
            if parse_settings(&cell)?.robot == name {
                users.push(cell.name);
            }
        }
        if !users.is_empty() {
            return Err(AppError::Conflict(format!(
                "robot {name:?} is the arm of cell(s) {}; change their robot first",
                users.join(", ")
            )));
        }
        self.store.delete_robot(name).await?;
        self.robots.write().remove(name);
        Ok(())
    }
}
