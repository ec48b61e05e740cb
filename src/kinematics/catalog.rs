//! The facts sheet of the bundled arms (`robots/catalog.json`): maker, model, data-sheet payload
//! and reach, the controller languages a program for the arm is written in; and the reach
//! computed from an arm's kinematics, so the two can be compared.
//!
//! Reach is meant as the makers' data sheets mean it:
//!
//! - ABB, KUKA, FANUC (OPW arms): the horizontal distance from the axis-1 line to the wrist
//!   centre (axes 4/5/6 meeting point) with the arm at full stretch, upper arm and forearm in
//!   line: `|a1| + c2 + √(c3² + a2²)` in OPW terms, with a lateral offset `b` added in
//!   quadrature.
//! - Universal Robots: the distance from the base (shoulder-pan) axis to the centre of the
//!   tool flange (`tool0`) with the arm stretched out at the zero pose. This matches the UR3e,
//!   UR5e and UR16e data-sheet figures within 2 %; `robots/README.md` explains the UR10e,
//!   whose 1300 mm is the in-plane sum `|a2| + |a3| + d5` instead.
//!
//! The only I/O is reading `catalog.json`.

use std::collections::HashSet;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::Robot;
use super::error::KinematicsError;
use super::opw::OpwSolver;
use super::units::MM_PER_M;
use super::urdf::{Chain, DOF};

/// The file name of the catalogue in a robot directory.
pub const CATALOG_FILE: &str = "catalog.json";

/// One arm's data-sheet facts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArmFacts {
    /// Model name: the URDF file's stem (`abb_irb2600`).
    pub name: String,
    pub maker: String,
    /// The maker's model designation (`IRB 2600-12/1.65`).
    pub model: String,
    /// Rated (maximum) payload from the data sheet, kg.
    pub payload_kg: f64,
    /// Reach from the data sheet, mm (see the module documentation for what it measures).
    pub reach_mm: f64,
    /// Controller languages of the arm's programs (`rapid`, `krl`, `fanuc`, `urscript`).
    pub languages: Vec<String>,
}

/// Reads `dir/catalog.json`. A directory without one has an empty catalogue; a file that is not
/// a JSON array of [`ArmFacts`], or that names an arm twice, is an error.
pub fn load_catalog(dir: &Path) -> Result<Vec<ArmFacts>, KinematicsError> {
    let path = dir.join(CATALOG_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(KinematicsError::io(&path, &e)),
    };
    parse_catalog(&text, &path.display().to_string())
}

/// Parses a catalogue's text; `origin` names it in errors. Text that is not a JSON array of
/// [`ArmFacts`], or that names an arm twice, is an error.
pub fn parse_catalog(text: &str, origin: &str) -> Result<Vec<ArmFacts>, KinematicsError> {
    let malformed = |message: String| KinematicsError::Catalog {
        path: origin.to_string(),
        message,
    };
    let facts: Vec<ArmFacts> = serde_json::from_str(text).map_err(|e| malformed(e.to_string()))?;
    let mut seen = HashSet::new();
    for f in &facts {
        if !seen.insert(f.name.as_str()) {
            return Err(malformed(format!("arm {:?} is listed twice", f.name)));
        }
    }
    Ok(facts)
}

/// The arm's reach computed from its kinematics, mm, as the data sheets define it (module
/// documentation): to the wrist centre for OPW arms, to the flange at zero for UR arms.
pub fn computed_reach_mm(robot: &Robot) -> f64 {
    reach_mm(robot.chain(), robot.opw())
}

/// [`computed_reach_mm`] of a chain and its OPW model, if it has one (while a [`Robot`] is built).
pub(crate) fn reach_mm(chain: &Chain, opw: Option<&OpwSolver>) -> f64 {
    match opw {
        Some(opw) => {
            let p = opw.parameters();
            let stretch = p.a1.abs() + p.c2.abs() + p.c3.hypot(p.a2);
            stretch.hypot(p.b) * MM_PER_M
        }
        None => {
            let (axes, tip) = chain.axes_at(&[0.0; DOF]);
            let (w1, o1) = axes[0];
            (tip.translation.vector - o1).cross(&w1).norm() * MM_PER_M
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{bundled_robots_dir, load_robot};

    fn robot(name: &str) -> Robot {
        load_robot(&bundled_robots_dir(), name).unwrap()
    }

    #[test]
    fn opw_reach_is_the_stretched_wrist_centre() {
        // IRB 140: a1 70 + c2 360 + c3 380 mm (a2 = 0).
        assert!((computed_reach_mm(&robot("abb_irb140")) - 810.0).abs() < 1e-9);
        // KR 16-2: 260 + 680 + √(670² + 35²) mm; the flange (158 mm) does not count.
        let kr16 = 260.0 + 680.0 + 670.0f64.hypot(35.0);
        assert!((computed_reach_mm(&robot("kuka_kr16_2")) - kr16).abs() < 1e-9);
    }

    #[test]
    fn ur_reach_is_the_flange_at_zero() {
        // UR5e at zero: flange at (−817.2, −232.9, 62.8) mm.
        let want = 817.2f64.hypot(232.9);
        assert!((computed_reach_mm(&robot("ur5e")) - want).abs() < 1e-9);
    }

    #[test]
    fn missing_catalog_is_empty_and_a_malformed_one_an_error() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(load_catalog(dir.path()).unwrap(), Vec::new());
        let file = dir.path().join(CATALOG_FILE);
        for bad in [
            "{",
            r#"{"name": "x"}"#,
            r#"[{"name": "x", "maker": "ABB"}]"#,
            r#"[{"name": "x", "maker": "ABB", "model": "m", "payload_kg": "6", "reach_mm": 1.0, "languages": []}]"#,
        ] {
            std::fs::write(&file, bad).unwrap();
            let err = load_catalog(dir.path()).unwrap_err();
            assert!(
                matches!(err, KinematicsError::Catalog { .. }),
                "{bad}: {err}"
            );
        }
        let one = r#"{"name": "a", "maker": "KUKA", "model": "KR 16-2", "payload_kg": 16, "reach_mm": 1610, "languages": ["krl"]}"#;
        std::fs::write(&file, format!("[{one}, {one}]")).unwrap();
        let err = load_catalog(dir.path()).unwrap_err();
        assert!(err.to_string().contains("listed twice"), "{err}");
        std::fs::write(&file, format!("[{one}]")).unwrap();
        assert_eq!(
            load_catalog(dir.path()).unwrap(),
            vec![ArmFacts {
                name: "a".into(),
                maker: "KUKA".into(),
                model: "KR 16-2".into(),
                payload_kg: 16.0,
                reach_mm: 1610.0,
                languages: vec!["krl".into()],
            }]
        );
    }

    #[test]
    fn bundled_catalog_loads() {
        let facts = load_catalog(&bundled_robots_dir()).unwrap();
        assert!(
            facts
                .iter()
                .any(|f| f.name == "abb_irb140" && f.maker == "ABB")
        );
        assert!(facts.iter().all(|f| f.payload_kg > 0.0 && f.reach_mm > 0.0));
    }
}
