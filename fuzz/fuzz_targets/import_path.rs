//! Past the parser, shared by the three targets: an upload that parses is taken the way
//! `POST /v1/cells/{id}/imports` takes it, without the database — its poses converted and
//! checked as the route stores them (`app::imports::routines_learned`), then a fresh engine
//! (a new cell's settings) taught its routines in program order, as the route learns them, and
//! asked for a prediction.

use nextpose::engine::{EngineConfig, Teacher};

/// Imports `files` as one upload into a fresh engine; an upload the parser refuses stops there.
pub fn import(files: &[(&str, &str)]) {
    let Ok(report) = nextpose::import::parse_upload(files) else {
        return;
    };
    // The parser checked every pose; the route's conversion must find nothing more to refuse.
    let routines = match nextpose::app::imports::routines_learned(&report) {
        Ok(routines) => routines,
        Err(e) => panic!("the parser let through a pose the route refuses: {e}"),
    };
    let Ok(mut teacher) = Teacher::new(EngineConfig::default()) else {
        panic!("the default engine configuration is refused");
    };
    for routine in &routines {
        teacher.learn_routine(routine);
    }
    let _ = teacher.predict();
}
