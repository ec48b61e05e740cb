//! Imports: offline program files uploaded into a cell, and what was read from them (the
//! programs stored, the lines skipped and why, the model after).

use crate::api::{ImportRequest, ImportResult, ImportedProgram, Skipped, UploadedFile};
use crate::grpc::pb;

use super::wire::both_ways;

both_ways!(plain UploadedFile => UploadedFile { name, content });
both_ways!(ImportedProgram => ImportedProgram { program, language, source, routines, waypoints });
both_ways!(Skipped => Skipped { file, line, routine, reason, text });
both_ways!(ImportResult => ImportResult { programs, skipped, model });

pub fn import_request(r: pb::ImportProgramsRequest) -> ImportRequest {
    ImportRequest {
        files: r.files.into_iter().map(Into::into).collect(),
        learn: r.learn,
    }
}

/// The request as a client sends it.
pub fn import_programs_request(cell_id: i64, r: ImportRequest) -> pb::ImportProgramsRequest {
    pb::ImportProgramsRequest {
        cell_id,
        files: r.files.into_iter().map(Into::into).collect(),
        learn: r.learn,
    }
}
