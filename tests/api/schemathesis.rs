//! The server against its own spec, by a schema-based fuzzer: schemathesis generates requests
//! for every operation of `openapi.yaml` (valid and invalid ones, and stateful sequences that
//! follow the ids responses return) and checks each answer. The test fails on any 5xx, a status,
//! content type, header or body the spec does not describe, or an invalid request accepted.
//!
//! Not part of a plain `cargo test` (it needs schemathesis, a Python tool): `.ci/run` installs
//! it in a venv and runs `cargo test --test api schemathesis -- --ignored` with `SCHEMATHESIS`
//! naming its `st`. Without the tool the test fails; it never passes without having run.
//!
//! `positive_data_acceptance` is left out: the spec cannot say everything the server checks
//! (unit quaternions, cell settings that must fit together, known file types, `adjusted` needing
//! a pose, `files` xor `cell_id`), so some schema-valid requests are rightly refused with 422.

use std::path::PathBuf;
use std::process::Command;

use crate::helpers::*;

/// Generated cases per operation: about a minute on two cores.
const MAX_EXAMPLES: &str = "300";
/// Fixed, so that a failure reproduces (`st run --seed`).
const SEED: &str = "1";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "needs schemathesis: .ci/run installs it and runs this test with --ignored"]
async fn schemathesis_finds_no_server_error_and_no_answer_outside_the_spec() {
    let st = std::env::var_os("SCHEMATHESIS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("st"));
    // With the bootstrap admin token: a token it creates through `POST /v1/tokens` turns
    // authentication on, and every route stays open to an admin.
    const ADMIN: &str = "schemathesis-admin";
    let app = spawn_with(nextpose::transport::TransportOptions {
        token: Some(ADMIN.into()),
        ..Default::default()
    })
    .await;
    let spec = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("openapi.yaml");
    // schemathesis and Hypothesis keep their state in the working directory.
    let work = tempfile::tempdir().unwrap();
    let mut command = Command::new(&st);
    command
        .arg("run")
        .arg(&spec)
        .args(["--url", &app.base])
        .args(["--header", &format!("Authorization: Bearer {ADMIN}")])
        .args(["--checks", "all"])
        .args(["--exclude-checks", "positive_data_acceptance"])
        .args(["--max-examples", MAX_EXAMPLES])
        .args(["--seed", SEED])
        // One worker: with two, Hypothesis describes lambdas by parsing their source in two
        // threads at once, and CPython 3.11's AST constructor (Debian's) can fail its recursion
        // depth check under that ("AST constructor recursion depth mismatch", CPython issue
        // 106905), which schemathesis reports as a runtime error of an operation.
        .args(["--workers", "1"])
        .current_dir(work.path())
        .env("NO_COLOR", "1");
    let output = tokio::task::spawn_blocking(move || command.output())
        .await
        .unwrap()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run schemathesis ({}: {e}); install it (`pip install schemathesis`, \
                 see .ci/run) and set SCHEMATHESIS to its `st`",
                st.display()
            )
        });
    let report = String::from_utf8_lossy(&output.stdout);
    println!("{report}");
    eprintln!("{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        output.status.success(),
        "schemathesis found problems ({}), see its report above",
        output.status
    );
    // Every operation of the spec was tested (none skipped or filtered out).
    let operations: usize = nextpose::http::openapi()
        .paths
        .paths
        .values()
        .map(|item| {
            [&item.get, &item.post, &item.delete, &item.put, &item.patch]
                .iter()
                .filter(|op| op.is_some())
                .count()
        })
        .sum();
    assert!(
        report.contains(&format!("Tested: {operations}\n")),
        "not all {operations} operations were tested:\n{report}"
    );
}
