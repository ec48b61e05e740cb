//! Programs: a cell's named lists of routines, and a program written for a controller.

use crate::api::{ExportedFile, Program, ProgramExport};

use super::wire::both_ways;

both_ways!(plain Program => Program { id, cell_id, name, created_at });
both_ways!(plain ExportedFile => ExportedFile { file_name, text });
both_ways!(ProgramExport => ProgramExport { format, files, warnings, unreachable });
