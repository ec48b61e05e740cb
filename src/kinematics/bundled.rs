//! The arm models shipped inside the binary: every `robots/*.urdf` and `robots/catalog.json`,
//! included as text when the crate is built (`build.rs`), so a binary copied to a plant's PC
//! (or installed with `cargo install`) needs no checkout beside it. `serve --robots DIR` adds
//! models to these or overrides them by name (`app::robots`).

use super::catalog::{ArmFacts, parse_catalog};
use super::{KinematicsError, Robot};

mod files {
    include!(concat!(env!("OUT_DIR"), "/bundled_robots.rs"));
}

/// Every bundled model, by name.
pub fn bundled_robots() -> Result<Vec<Robot>, KinematicsError> {
    files::URDFS
        .iter()
        .map(|(name, urdf)| Robot::from_urdf_str(name, urdf))
        .collect()
}

/// One bundled model by name; [`KinematicsError::UnknownRobot`] when none has it.
pub fn bundled_robot(name: &str) -> Result<Robot, KinematicsError> {
    let (name, urdf) = files::URDFS
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| KinematicsError::UnknownRobot(name.to_string()))?;
    Robot::from_urdf_str(name, urdf)
}

/// Every bundled file as (file name, text), sorted by file name: the URDFs and the catalogue
/// (what the replay's placement cache digests, so a changed model invalidates it).
pub fn bundled_files() -> Vec<(String, &'static str)> {
    let mut files: Vec<(String, &'static str)> = files::URDFS
        .iter()
        .map(|(name, urdf)| (format!("{name}.urdf"), *urdf))
        .chain([("catalog.json".to_string(), files::CATALOG)])
        .collect();
    files.sort();
    files
}

/// The bundled models' data sheets (`robots/catalog.json`).
pub fn bundled_catalog() -> Result<Vec<ArmFacts>, KinematicsError> {
    parse_catalog(files::CATALOG, "the bundled robots/catalog.json")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{bundled_robots_dir, load_catalog, load_robots};

    #[test]
    fn the_binary_carries_every_model_and_the_catalogue_of_robots() {
        let on_disk = load_robots(&bundled_robots_dir()).unwrap();
        let carried = bundled_robots().unwrap();
        let names = |rs: &[Robot]| rs.iter().map(|r| r.name().to_string()).collect::<Vec<_>>();
        assert_eq!(names(&carried), names(&on_disk));
        assert!(carried.len() >= 18, "{}", carried.len());
        for (a, b) in carried.iter().zip(&on_disk) {
            assert_eq!(a.model(), b.model());
        }
        assert_eq!(
            bundled_catalog().unwrap(),
            load_catalog(&bundled_robots_dir()).unwrap()
        );
        assert_eq!(bundled_robot("abb_irb140").unwrap().name(), "abb_irb140");
        assert!(matches!(
            bundled_robot("../Cargo"),
            Err(KinematicsError::UnknownRobot(_))
        ));
    }
}
