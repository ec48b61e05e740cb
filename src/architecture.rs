//! The layering the README describes, checked on the source tree: which top-level modules may
//! use which, no cycles between them (nor between the application's own modules), and no I/O
//! in the pure ones. Read from `src/` with `use crate::…` / `crate::…` and `super::…` paths
//! (comments left out), so a new dependency that breaks the house fails here, named.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Graph = BTreeMap<String, BTreeSet<String>>;

/// Code lines of a file (line comments and doc comments dropped).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The names `prefix` is followed by in `text` (`crate::engine::Pose` → `engine`).
fn targets<'a>(text: &'a str, prefix: &str) -> Vec<&'a str> {
    text.match_indices(prefix)
        .filter_map(|(i, _)| {
            let rest = &text[i + prefix.len()..];
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            (end > 0).then(|| &rest[..end])
        })
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ readable") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Top-level module → the top-level modules it uses; and, inside `app/`, file → files.
fn graphs() -> (Graph, Graph) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut top = Graph::new();
    let mut app = Graph::new();
    for path in files {
        let rel = path.strip_prefix(&src).expect("under src");
        let parts: Vec<String> = rel
            .iter()
            .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
            .collect();
        let module = parts[0].clone();
        if module == "lib" || module == "main" || module == "architecture" {
            continue;
        }
        let text = code(&std::fs::read_to_string(&path).expect("readable"));
        let uses = top.entry(module.clone()).or_default();
        for t in targets(&text, "crate::") {
            if t != module {
                uses.insert(t.to_string());
            }
        }
        if module == "app" && parts.len() == 2 {
            let file = parts[1].clone();
            let uses = app.entry(file.clone()).or_default();
            for t in targets(&text, "super::") {
                if t != file && t != "mod" && src.join("app").join(format!("{t}.rs")).exists() {
                    uses.insert(t.to_string());
                }
            }
        }
    }
    (top, app)
}

/// A cycle of `g`, if it has one.
fn cycle(g: &Graph) -> Option<Vec<String>> {
    fn visit(
        g: &Graph,
        n: &str,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == n) {
            let mut c = path[i..].to_vec();
            c.push(n.to_string());
            return Some(c);
        }
        if done.contains(n) {
            return None;
        }
        path.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(g, m, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(n.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys()
        .find_map(|n| visit(g, n, &mut Vec::new(), &mut done))
}

#[test]
fn no_cycles_between_top_level_modules() {
    let (top, _) = graphs();
    assert!(
        top.contains_key("engine") && top.contains_key("app") && top.contains_key("export"),
        "{top:?}"
    );
    assert_eq!(cycle(&top), None, "{top:#?}");
}

#[test]
fn no_cycles_between_the_application_modules() {
    let (_, app) = graphs();
    assert!(
        app.contains_key("teaching") && app.contains_key("registry"),
        "{app:?}"
    );
    assert_eq!(cycle(&app), None, "{app:#?}");
}

/// Each module and what it may use of the crate; the pure ones first.
#[test]
fn modules_use_only_what_their_layer_allows() {
    let allowed: &[(&str, &[&str])] = &[
        ("engine", &[]),
        ("program", &["engine"]),
        ("kinematics", &["engine"]),
        ("import", &["engine", "program"]),
        ("export", &["engine", "kinematics", "program"]),
        ("sim", &["engine", "kinematics", "program"]),
        ("replay", &["engine", "import", "kinematics", "program"]),
        ("storage", &[]),
        ("telemetry", &[]),
        ("transport", &[]),
        ("api", &["engine", "export", "kinematics"]),
        (
            "app",
            &[
                "api",
                "engine",
                "export",
                "import",
                "kinematics",
                "program",
                "replay",
                "storage",
                "telemetry",
            ],
        ),
    ];
    let (top, _) = graphs();
    for (module, may) in allowed {
        let uses = top.get(*module).cloned().unwrap_or_default();
        let extra: Vec<&String> = uses.iter().filter(|u| !may.contains(&u.as_str())).collect();
        assert!(extra.is_empty(), "{module} uses {extra:?}");
    }
    // The adapters share what they share through `transport`, not through each other, and
    // the client (the other end of the wire) is not part of the service.
    for (adapter, other) in [
        ("http", "grpc"),
        ("grpc", "http"),
        ("http", "client"),
        ("grpc", "client"),
        ("app", "client"),
        ("server", "client"),
    ] {
        assert!(
            !top.get(adapter).is_some_and(|u| u.contains(other)),
            "{adapter} uses {other}"
        );
    }
    // Nothing below the adapters reaches up into them.
    for (module, uses) in &top {
        if ["http", "grpc", "server", "cli", "simulate", "client"].contains(&module.as_str()) {
            continue;
        }
        for adapter in ["http", "grpc", "server", "cli"] {
            assert!(!uses.contains(adapter), "{module} uses {adapter}");
        }
    }
}

/// The engine, the program type, the importer and the exporter do no I/O and know no async runtime.
#[test]
fn pure_modules_do_no_io() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for module in ["engine", "program.rs", "import", "export"] {
        let mut files = Vec::new();
        let path = src.join(module);
        if path.is_dir() {
            rust_files(&path, &mut files);
        } else {
            files.push(path);
        }
        for f in files {
            let text = code(&std::fs::read_to_string(&f).expect("readable"));
            for io in [
                "std::fs", "std::net", "tokio", "sqlx", "axum", "reqwest", "tonic",
            ] {
                assert!(!text.contains(io), "{} uses {io}", f.display());
            }
        }
    }
}
