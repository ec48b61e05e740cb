//! Errors of the importer. Every error names the file, and a syntax error its 1-based line and
//! column, because the person reading it has the source open in an editor.

use thiserror::Error;

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
