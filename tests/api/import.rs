//! Importing real offline programs from the shared corpus into a cell.

use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::corpus;
use crate::helpers::*;

/// The RAPID modules of one repository in the corpus, as an upload.
pub(crate) fn upload(repo: &str) -> Vec<Value> {
    corpus::rapid_modules(repo)
        .into_iter()
        .map(|(name, content)| json!({ "name": name, "content": content }))
        .collect()
}

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn imported_programs_teach_the_model_and_predictions_follow() {
    let app = spawn_app().await;
    // A fixed threshold: this is about what the import teaches the model. A cell steering its
    // own threshold offers nothing here, rightly by its record: its candidates on the welder's
    // programs are rarely right (ProgSide1: none in the replay), so no band of p_useful reaches
    // 85 % (the threshold it reports is 1.0), though a routine taught again exactly is.
    let cell = app
        .create_cell_with(
            "imported",
            json!({ "reach_policy": "flag", "offer_threshold": 0.7 }),
        )
        .await;
    let files = upload("ravenorb__abb-robot-welder");
    let result = app.import(cell, &json!({ "files": files })).await;
    let programs = result["programs"].as_array().unwrap();
    assert!(!programs.is_empty());
    let routines: u64 = programs
        .iter()
        .map(|p| p["routines"].as_u64().unwrap())
        .sum();
    assert!(routines >= 2);
    assert_eq!(result["model"]["routines"], routines);
    assert_eq!(result["model"]["version"], routines);
    assert!(result["skipped"].is_array());
    assert_eq!(programs[0]["language"], "rapid");

    // The imported routines are stored, learned and immutable.
    let program_id = programs[0]["program"]["id"].as_i64().unwrap();
    let list = app
        .get_ok(&format!("/v1/programs/{program_id}/routines"))
        .await;
    let first = &list[0];
    assert_eq!(first["imported"], true);
    assert_eq!(first["learned"], true);
    assert_eq!(first["finished"], true);
    let routine_id = first["id"].as_i64().unwrap();
    let detail = app.get_ok(&format!("/v1/routines/{routine_id}")).await;
    let waypoints: Vec<Value> = detail["waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["pose"].clone())
        .collect();
    assert_eq!(
        waypoints.len() as i64,
        first["waypoint_count"].as_i64().unwrap()
    );
    let r = app
        .post(
            &format!("/v1/routines/{routine_id}/waypoints"),
            &json!({"pose": waypoints[0]}),
        )
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;

    // Teaching the same routine again is predicted from the imported one.
    let program = app.create_program(cell, "retaught").await;
    let (_, predictions) = app.teach_routine(program, &waypoints).await;
    // Real programs: most offered predictions are exactly right (the model also knows the
    // other imported routines, so not every one is).
    let (mut offered, mut right) = (0, 0);
    for (i, p) in predictions.iter().enumerate() {
        if p["offered"] == true && i + 1 < waypoints.len() {
            offered += 1;
            right += usize::from(distance(&p["pose"], &waypoints[i + 1]) < 1e-6);
        }
    }
    assert!(right >= 1, "no right prediction ({offered} offered)");
    assert!(right * 10 >= offered * 8, "{right} of {offered} right");

    // The model after the import is the one a rebuild gives.
    let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let rebuilt = app.rebuild(cell).await;
    assert_eq!(before["model"], rebuilt);
    let app = app.restart().await;
    let after = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    assert_eq!(before, after);

    // The same upload again: the program names are taken, nothing is imported.
    let r = app
        .post(
            &format!("/v1/cells/{cell}/imports"),
            &json!({ "files": files }),
        )
        .await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    assert_eq!(app.get_ok(&format!("/v1/cells/{cell}/stats")).await, after);
}

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn import_errors() {
    let app = spawn_app().await;
    let cell = app.create_cell("import-errors").await;
    let url = format!("/v1/cells/{cell}/imports");
    let r = app.post(&url, &json!({"files": []})).await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    let r = app
        .post(
            &url,
            &json!({"files": [{"name": "a.txt", "content": "hello"}]}),
        )
        .await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    // A malformed robtarget: 422 naming file, line and column; nothing imported.
    let broken = "MODULE M\n  CONST robtarget p:=[[1,2],[1,0,0,0]];\nENDMODULE";
    let r = app
        .post(
            &url,
            &json!({"files": [{"name": "M.mod", "content": broken}]}),
        )
        .await;
    let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    assert!(message.contains("M.mod:2:22"), "{message}");
    let programs = app.get_ok(&format!("/v1/cells/{cell}/programs")).await;
    assert_eq!(programs.as_array().unwrap().len(), 0);
    let empty = json!({"files": [{"name": "m.mod", "content": "MODULE M\nENDMODULE\n"}]});
    let r = app.post("/v1/cells/999/imports", &empty).await;
    expect_error(r, StatusCode::NOT_FOUND, "not_found").await;

    // Learning while a routine is being taught would interleave it with the imported ones.
    let program = app.create_program(cell, "p").await;
    app.create_routine(program).await;
    let files = upload("ravenorb__abb-robot-welder");
    let r = app.post(&url, &json!({"files": files})).await;
    expect_error(r, StatusCode::CONFLICT, "conflict").await;
    // Without learning it is allowed; the model does not change.
    let before = app.get_ok(&format!("/v1/cells/{cell}/stats")).await;
    let result = app
        .post_ok(
            &url,
            &json!({"files": files, "learn": false}),
            StatusCode::CREATED,
        )
        .await;
    assert_eq!(result["model"], before["model"]);
    let pid = result["programs"][0]["program"]["id"].as_i64().unwrap();
    let list = app.get_ok(&format!("/v1/programs/{pid}/routines")).await;
    assert_eq!(list[0]["learned"], false);
    assert_eq!(list[0]["finished"], true);
}

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn nextpose_import_uploads_files_to_a_running_server() {
    let app = spawn_app().await;
    let dir = corpus::raw().join("ravenorb__abb-robot-welder");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mod"))
        .collect();
    files.sort();
    let base = app.base.clone();
    let output = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
            .arg("import")
            .args(&files)
            .args(["--cell", "from-cli", "--server", &base])
            .env_remove("NEXTPOSE_TOKEN")
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("imported "), "{stdout}");
    let cells = app.get_ok("/v1/cells").await;
    let cell = cells
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "from-cli")
        .expect("cell created");
    let stats = app.get_ok(&format!("/v1/cells/{}/stats", cell["id"])).await;
    assert!(stats["model"]["routines"].as_u64().unwrap() >= 2);
    // Against nothing: a clear error, non-zero exit.
    let output = tokio::task::spawn_blocking(|| {
        std::process::Command::new(env!("CARGO_BIN_EXE_nextpose"))
            .args([
                "import",
                "x.mod",
                "--cell",
                "c",
                "--server",
                "http://127.0.0.1:9",
            ])
            .output()
            .unwrap()
    })
    .await
    .unwrap();
    assert!(!output.status.success());
}

/// The methods of `nextpose replay`'s scoreboard, in run order: the engine, every baseline,
/// the oracle bounds.
pub(crate) fn scoreboard_methods() -> Vec<String> {
    use nextpose::replay::methods::baselines::{self, DEFAULT_NEAREST_SEQ_GATE};
    let config = nextpose::engine::EngineConfig::default();
    let mut names = vec!["engine".to_string()];
    names.extend(
        baselines::scoreboard(&config, DEFAULT_NEAREST_SEQ_GATE)
            .iter()
            .map(|m| m.name().to_string()),
    );
    names.extend(
        nextpose::replay::score::oracle::ORACLES
            .iter()
            .map(|o| o.name.to_string()),
    );
    names
}

/// A report's JSON without the measured time per waypoint (totals and per program).
fn without_timing(mut report: Value) -> Value {
    let strip = |methods: &mut Value| {
        for line in methods.as_object_mut().expect("methods").values_mut() {
            line.as_object_mut()
                .expect("a line")
                .remove("us_per_waypoint");
        }
    };
    strip(&mut report["totals"]);
    for p in report["programs"].as_array_mut().expect("programs") {
        strip(&mut p["methods"]);
    }
    report
}

#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn replay_scoreboard_from_the_api_matches_the_cli_form() {
    let app = spawn_app().await;
    let files = upload("ravenorb__abb-robot-welder");
    let report = app
        .post_ok("/v1/replays", &json!({ "files": files }), StatusCode::OK)
        .await;
    // Every method of the CLI's scoreboard, the baselines and oracle bounds of issue 13 too.
    let methods = scoreboard_methods();
    let mut expected: Vec<&str> = methods.iter().map(String::as_str).collect();
    expected.sort_unstable();
    let totals = report["totals"].as_object().unwrap();
    assert_eq!(
        totals.keys().map(String::as_str).collect::<Vec<_>>(),
        expected
    );
    for method in &methods {
        let t = &report["totals"][method];
        assert!(t["predictable"].as_u64().unwrap() > 10, "{method}: {t}");
        assert!(t["saved_pct"].is_number(), "{method}");
    }
    assert!(!report["programs"].as_array().unwrap().is_empty());
    assert!(report["oracles"]["kinds"].is_array());
    let calibration = &report["calibration"]["engine"];
    assert_eq!(calibration["bins"].as_array().map(Vec::len), Some(10));
    assert!(calibration["risk_coverage"].is_array());

    // The very report of the library function the CLI prints, but for the time per waypoint.
    let texts: Vec<(String, String)> = files
        .iter()
        .map(|f| {
            let text = |k: &str| f[k].as_str().unwrap().to_string();
            (text("name"), text("content"))
        })
        .collect();
    let texts: Vec<(&str, &str)> = texts
        .iter()
        .map(|(n, c)| (n.as_str(), c.as_str()))
        .collect();
    // As `nextpose replay FILES` reads them (replay::corpus::load_raw).
    let programs = nextpose::replay::corpus::import_upload(&texts).unwrap();
    let cli = nextpose::replay::report::scoreboard(
        &programs,
        "default",
        &nextpose::engine::EngineConfig::default(),
        nextpose::replay::methods::baselines::DEFAULT_NEAREST_SEQ_GATE,
    )
    .unwrap();
    assert_eq!(
        without_timing(report.clone()),
        without_timing(serde_json::to_value(&cli).unwrap())
    );

    // The same programs imported into a cell and replayed from there give the same totals.
    let cell = app.create_cell("replayed").await;
    app.import(cell, &json!({ "files": files, "learn": false }))
        .await;
    let stored = app
        .post_ok("/v1/replays", &json!({ "cell_id": cell }), StatusCode::OK)
        .await;
    for key in ["predictable", "offered_pct", "useful_pct", "saved_pct"] {
        assert_eq!(
            stored["totals"]["engine"][key], report["totals"]["engine"][key],
            "{key}"
        );
    }
    let r = app.post("/v1/replays", &json!({})).await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    let r = app
        .post("/v1/replays", &json!({"cell_id": cell, "delta": 2.0}))
        .await;
    expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid_settings").await;
}

/// Which phase of an import the server is in, read off its log events.
mod phases {
    use std::sync::OnceLock;
    use std::sync::atomic::{AtomicUsize, Ordering};

    use tokio::sync::Notify;
    use tracing::field::{Field, Visit};
    use tracing_subscriber::layer::{Context, SubscriberExt};

    /// Counts the "parsing an upload" and "parsed an upload" events of uploads of [`FILES`]
    /// files (other tests' uploads are smaller).
    pub struct Phases {
        pub parsing: AtomicUsize,
        pub parsed: AtomicUsize,
        pub changed: Notify,
    }

    pub const FILES: u64 = 42;

    #[derive(Default)]
    struct Message {
        text: Option<String>,
        files: Option<u64>,
    }

    impl Visit for Message {
        fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
            if field.name() == "message" {
                self.text = Some(format!("{value:?}"));
            }
        }

        fn record_u64(&mut self, field: &Field, value: u64) {
            if field.name() == "files" {
                self.files = Some(value);
            }
        }
    }

    struct Layer;

    impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Layer {
        fn on_event(&self, event: &tracing::Event<'_>, _: Context<'_, S>) {
            let mut m = Message::default();
            event.record(&mut m);
            if m.files != Some(FILES) {
                return;
            }
            let p = phases();
            match m.text.as_deref() {
                Some("parsing an upload") => p.parsing.fetch_add(1, Ordering::SeqCst),
                Some("parsed an upload") => p.parsed.fetch_add(1, Ordering::SeqCst),
                _ => return,
            };
            p.changed.notify_waiters();
        }
    }

    /// The binary's phase counters (installing the log layer on first use).
    pub fn phases() -> &'static Phases {
        static PHASES: OnceLock<Phases> = OnceLock::new();
        static INSTALLED: OnceLock<()> = OnceLock::new();
        let p = PHASES.get_or_init(|| Phases {
            parsing: AtomicUsize::new(0),
            parsed: AtomicUsize::new(0),
            changed: Notify::new(),
        });
        INSTALLED.get_or_init(|| {
            let subscriber = tracing_subscriber::registry().with(Layer);
            tracing::subscriber::set_global_default(subscriber).expect("one global subscriber");
        });
        p
    }
}

/// Parsing a large upload runs off the async workers: on this single-threaded test runtime
/// (the server's too), a request is answered between the server's "parsing" and "parsed" log
/// events. When the parse ran on the runtime's thread, nothing could be answered in between.
#[tokio::test(flavor = "current_thread")]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn a_large_import_does_not_stall_other_requests() {
    use std::sync::atomic::Ordering;
    let phases = phases::phases();
    let app = spawn_with(nextpose::transport::TransportOptions {
        body_limit: 8 << 20,
        ..Default::default()
    })
    .await;
    let cell = app.create_cell("large upload").await;
    // The welder's modules six times under other module names: about 4 MB of RAPID (the body
    // limit raised to take it), so the parse lasts far longer than one request.
    let mut files = Vec::new();
    for copy in 0..6 {
        for f in upload("ravenorb__abb-robot-welder") {
            let name = format!("c{copy}_{}", f["name"].as_str().unwrap());
            let text =
                f["content"]
                    .as_str()
                    .unwrap()
                    .replacen("MODULE ", &format!("MODULE C{copy}_"), 1);
            files.push(json!({ "name": name, "content": text }));
        }
    }
    assert_eq!(files.len() as u64, phases::FILES);
    let before = phases.parsed.load(Ordering::SeqCst);
    let started = phases.parsing.load(Ordering::SeqCst);
    let import = tokio::spawn({
        let url = app.url(&format!("/v1/cells/{cell}/imports"));
        let client = app.client.clone();
        async move {
            client
                .post(url)
                .json(&json!({ "files": files, "learn": false }))
                .send()
                .await
                .expect("import")
                .status()
        }
    });
    // Wait for the server to start parsing, then ask it something else.
    loop {
        let changed = phases.changed.notified();
        if phases.parsing.load(Ordering::SeqCst) > started {
            break;
        }
        changed.await;
    }
    let health = app.get("/healthz").await;
    assert_eq!(health.status(), StatusCode::OK);
    assert_eq!(
        phases.parsed.load(Ordering::SeqCst),
        before,
        "the server answered only after the parse had finished"
    );
    assert_eq!(import.await.unwrap(), StatusCode::CREATED);
    assert_eq!(phases.parsed.load(Ordering::SeqCst), before + 1);
}

/// Two files of one upload that declare the same RAPID module are refused with both files
/// named (the message blamed the cell: "already has a program with one of the names
/// [MainModule, MainModule]" although it was empty), and nothing is imported.
#[tokio::test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn two_files_declaring_one_module_are_named() {
    let app = spawn_app().await;
    let cell = app.create_cell("clash").await;
    let files = upload("EdgarIvanMM__PaletizadoCajasConFrascos");
    let r = app
        .post(
            &format!("/v1/cells/{cell}/imports"),
            &json!({ "files": files }),
        )
        .await;
    let message = expect_error(r, StatusCode::UNPROCESSABLE_ENTITY, "invalid").await;
    assert!(message.contains("MainModule"), "{message}");
    let named = files
        .iter()
        .filter(|f| message.contains(f["name"].as_str().unwrap()))
        .count();
    assert_eq!(named, 2, "{message}");
    let programs = app.get_ok(&format!("/v1/cells/{cell}/programs")).await;
    assert_eq!(programs.as_array().unwrap().len(), 0);
}
