//! Errors of the importer. Every error names the file, and a syntax error its 1-based line and
//! column, because the person reading it has the source open in an editor.

use thiserror::Error;

use crate::engine::PoseError;

/// Why an upload could not be imported at all. Things the importer merely cannot use (joint
/// moves, targets computed at run time) are not errors: they are listed in
/// [`super::ImportReport::skipped`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ImportError {
    /// The file's extension names no language the importer reads.
    #[error(
        "{file}: unsupported file type (expected RAPID .mod/.modx/.prg/.sys, KRL .src/.dat or FANUC .ls)"
    )]
    UnsupportedFile { file: String },
    /// The text does not follow the language's grammar where the importer needs it to.
    #[error("{file}:{line}:{column}: {message}")]
    Syntax {
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        message: String,
    },
    /// The file is not text: it holds a NUL or another control character no program source
    /// contains (binary data, or bytes decoded as the wrong encoding).
    #[error(
        "{file}:{line}:{column}: not a program text (control character U+{code:04X}); upload the source file, not a binary"
    )]
    NotText {
        file: String,
        /// 1-based line of the first such character.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// The character's code point.
        code: u32,
    },
    /// Two files (or FANUC folders) of one upload give programs of the same name, which a cell
    /// cannot hold (see [`super::ImportReport::check_unique_names`]).
    #[error(
        "{first} and {second} both give a program named {name:?}; a cell's programs need distinct names, so upload one of them, or rename one"
    )]
    DuplicateProgram {
        name: String,
        /// The file or folder of the first program of that name, in upload order.
        first: String,
        /// The file or folder of the second.
        second: String,
    },
    /// Blocks (`IF … THEN`, `WHILE`, `FOR`, `TEST`) nested deeper than the importer reads. No
    /// real program comes near the limit; a file beyond it is refused rather than read in time
    /// that grows with its depth.
    #[error("{file}:{line}:{column}: blocks nested more than {limit} levels deep")]
    NestingTooDeep {
        file: String,
        /// 1-based line of the block that goes past the limit.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        limit: usize,
    },
    /// A waypoint whose pose the service does not accept: a number that is not finite, a
    /// coordinate beyond ±100 m of its frame (see [`crate::engine::POSITION_LIMIT_MM`]). Named
    /// by the file and line of the instruction that moves to it, and the target as written.
    #[error("{file} line {line}: {source} (target {target})")]
    Pose {
        file: String,
        /// 1-based line of the motion instruction.
        line: usize,
        /// The target as written (`p10`, `P[3]`, `{X 1e308, ...}`).
        target: String,
        #[source]
        source: PoseError,
    },
}

impl ImportError {
    pub(crate) fn syntax(file: &str, at: super::Location, message: impl Into<String>) -> Self {
        ImportError::Syntax {
            file: file.to_string(),
            line: at.line,
            column: at.column,
            message: message.into(),
        }
    }
}
