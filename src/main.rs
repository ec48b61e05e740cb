//! `nextpose` binary: all the work is in the library ([`nextpose::cli`]); this only turns an
//! error into a message on stderr and a non-zero exit status (no panic, no backtrace).

use std::process::ExitCode;

fn main() -> ExitCode {
    match nextpose::cli::run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("nextpose: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
