//! Offline programs (RAPID, KRL, FANUC TP) imported into a cell (`POST /v1/cells/{id}/imports`).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::cells::ModelInfo;
use super::programs::Program;

/// One uploaded program file. A file of an export's answer (`{"file_name", "text"}`) is
/// accepted as it comes: `file_name` is read as `name` and `text` as `content`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct UploadedFile {
    /// File name with its extension (`.mod`, `.modx`, `.prg`, `.sys`, `.src`, `.dat`, `.ls`);
    /// keep the folder (`job/main.ls`) where programs span several files. Not blank; at most
    /// 200 characters. Also read as `file_name`.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*\.([mM][oO][dD][xX]?|[pP][rR][gG]|[sS][yY][sS]|[sS][rR][cC]|[dD][aA][tT]|[lL][sS])$"
    )]
    #[serde(alias = "file_name")]
    pub name: String,
    /// The file's text. Also read as `text`. Text only: no NUL nor another C0 control
    /// character but tab, line feed, vertical tab, form feed, carriage return and SUB (the DOS
    /// end-of-file mark).
    #[schema(pattern = r"^[^\x00-\x08\x0e-\x19\x1b-\x1f]*$")]
    #[serde(alias = "text")]
    pub content: String,
}

/// Offline programs to import into a cell.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ImportRequest {
    /// The files of one upload, parsed together (RAPID targets resolve across modules; a KRL
    /// `.src` pairs with its `.dat`).
    #[schema(min_items = 1)]
    pub files: Vec<UploadedFile>,
    /// Learn the imported routines into the cell's model, in program order (default true).
    /// The cell must not be teaching a routine.
    pub learn: Option<bool>,
}

/// A program created by an import.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[schema(as = ImportedProgramDto)]
pub struct ImportedProgram {
    pub program: Program,
    /// `rapid`, `krl` or `fanuc`.
    pub language: String,
    pub source: String,
    pub routines: usize,
    pub waypoints: usize,
}

/// Something in the upload that was not imported, and why.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[schema(as = SkippedDto)]
pub struct Skipped {
    pub file: String,
    pub line: usize,
    pub routine: Option<String>,
    /// `joint-move`, `unresolved-name`, `computed-at-run-time`, `in-error-handler`,
    /// `invalid-target`, `short-routine`, `data-only`, `no-routines` (a file or FANUC folder
    /// with no routine left: no program is made of it).
    pub reason: String,
    pub text: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ImportResult {
    pub programs: Vec<ImportedProgram>,
    pub skipped: Vec<Skipped>,
    /// The cell's model after the import.
    pub model: ModelInfo,
}
