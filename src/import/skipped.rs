//! What an upload held that the importer could not use, and why: the skip records of an
//! [`super::ImportReport`].

use serde::Serialize;

/// Why something in the source was not imported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SkipReason {
    /// A joint-space move (`MoveAbsJ`, KRL `AXIS`/`E6AXIS`, FANUC joint representation).
    JointMove,
    /// The target names nothing declared in the upload.
    UnresolvedName,
    /// The target is computed at run time (function call, record field, a variable assigned from
    /// a value the importer cannot evaluate, offsets that are not constants).
    ComputedAtRunTime,
    /// A move inside a RAPID `ERROR` handler: recovery, not the taught path.
    InErrorHandler,
    /// A target whose orientation is not a rotation (e.g. an all-zero quaternion).
    InvalidTarget,
    /// A routine with fewer than two Cartesian waypoints: nothing to learn from.
    ShortRoutine,
    /// A file that is not a program on its own (a KRL `.dat` without its `.src`).
    DataOnly,
    /// A file (a FANUC folder) with no routine left to import — empty, only declarations, or
    /// only routines too short to keep: it gives no program.
    NoRoutines,
}

impl SkipReason {
    pub const ALL: [SkipReason; 8] = [
        SkipReason::JointMove,
        SkipReason::UnresolvedName,
        SkipReason::ComputedAtRunTime,
        SkipReason::InErrorHandler,
        SkipReason::InvalidTarget,
        SkipReason::ShortRoutine,
        SkipReason::DataOnly,
        SkipReason::NoRoutines,
    ];

    /// The reason's name on the wire and in reports (`joint-move`, `unresolved-name`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            SkipReason::JointMove => "joint-move",
            SkipReason::UnresolvedName => "unresolved-name",
            SkipReason::ComputedAtRunTime => "computed-at-run-time",
            SkipReason::InErrorHandler => "in-error-handler",
            SkipReason::InvalidTarget => "invalid-target",
            SkipReason::ShortRoutine => "short-routine",
            SkipReason::DataOnly => "data-only",
            SkipReason::NoRoutines => "no-routines",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            SkipReason::JointMove => "joint-space move",
            SkipReason::UnresolvedName => "target not declared in the upload",
            SkipReason::ComputedAtRunTime => "target computed at run time",
            SkipReason::InErrorHandler => "move in an ERROR handler",
            SkipReason::InvalidTarget => "target orientation is not a rotation",
            SkipReason::ShortRoutine => "routine with fewer than two waypoints",
            SkipReason::DataOnly => "data file without its program",
            SkipReason::NoRoutines => "no routine to import, so no program",
        }
    }
}

/// One thing not imported: where, what and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    pub file: String,
    pub line: usize,
    pub routine: Option<String>,
    pub reason: SkipReason,
    /// The target or routine as written (shortened to 120 characters).
    pub text: String,
}

/// Shortens source text for a skip record.
pub(crate) fn excerpt(text: &str) -> String {
    let t: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if t.chars().count() > 120 {
        t.chars().take(117).chain("...".chars()).collect()
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_what_serde_writes() {
        for r in SkipReason::ALL {
            assert_eq!(serde_json::to_value(r).unwrap(), r.as_str(), "{r:?}");
        }
    }

    #[test]
    fn excerpts_join_whitespace_and_cut_at_120_characters() {
        assert_eq!(excerpt(" MoveL  p1,\n v100 "), "MoveL p1, v100");
        let long = "é".repeat(130);
        let cut = excerpt(&long);
        assert_eq!(cut.chars().count(), 120);
        assert!(cut.ends_with("..."));
    }
}
