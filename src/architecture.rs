//! The layering docs/architecture.md describes, checked on the source tree: which top-level
//! modules may use which, no import cycle between the modules of any folder, and no I/O or web
//! code in the pure ones. Read from `src/` (comments and `#[cfg(test)]` modules left out): every
//! `use` tree and every `crate::…`, `super::…` and `self::…` path names a module, so a new
//! dependency that breaks the house fails here, named.
//!
//! **Cycles.** Each folder of `src/` is a graph whose nodes are its children (files and
//! subfolders): child A depends on child B when some file under A names something under B.
//! A name a folder's `mod.rs` re-exports (`pub use predict::Prediction`) counts as the child it
//! comes from. A cycle in any folder's graph fails [`no_import_cycle_in_any_folder`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Graph = BTreeMap<String, BTreeSet<String>>;
/// A module's path below `crate` (`["engine", "cdhmm", "learner"]`; the crate root is `[]`).
type ModPath = Vec<String>;

/// Code lines of a file: line comments and doc comments dropped, and the `#[cfg(test)]`
/// modules (tests may use whatever they test).
fn code(text: &str) -> String {
    let lines: Vec<&str> = text
        .lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let is_test_mod = lines[i].trim() == "#[cfg(test)]"
            && lines
                .get(i + 1)
                .is_some_and(|l| l.trim_start().starts_with("mod "));
        if !is_test_mod {
            out.push(lines[i]);
            i += 1;
            continue;
        }
        if lines[i + 1].trim_end().ends_with(';') {
            // `#[cfg(test)] mod name;`: the module is a file of its own.
            i += 2;
            continue;
        }
        // Skip to the brace that closes the module.
        let mut depth = 0i64;
        let mut opened = false;
        i += 1;
        while i < lines.len() {
            for c in lines[i].chars() {
                match c {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            i += 1;
            if opened && depth <= 0 {
                break;
            }
        }
    }
    out.join("\n")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ readable") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file is (`engine/cdhmm/mod.rs` → `engine::cdhmm`).
fn module_of(rel: &Path) -> ModPath {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The paths of a `use` tree (`super::{a::X, b}` → `super::a::X`, `super::b`), as segments.
fn use_paths(tree: &str) -> Vec<Vec<String>> {
    fn expand(prefix: &[String], tree: &str, out: &mut Vec<Vec<String>>) {
        let tree = tree.trim();
        if tree.is_empty() {
            return;
        }
        // Split off `prefix::{…}` or a plain path.
        match tree.find('{') {
            Some(open) => {
                let head = tree[..open].trim().trim_end_matches("::");
                let mut base = prefix.to_vec();
                base.extend(segments(head));
                let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
                for part in split_top(inner) {
                    expand(&base, part, out);
                }
            }
            None => {
                let path = tree.split(" as ").next().unwrap_or(tree);
                let mut full = prefix.to_vec();
                full.extend(segments(path));
                // `a::{self, X}`: `self` is `a` itself.
                if full.len() > 1 && full.last().is_some_and(|s| s == "self") {
                    full.pop();
                }
                out.push(full);
            }
        }
    }
    fn segments(path: &str) -> Vec<String> {
        path.split("::")
            .map(str::trim)
            .filter(|s| !s.is_empty() && *s != "*")
            .map(str::to_string)
            .collect()
    }
    /// `a, b::{c, d}, e` split at the commas outside braces.
    fn split_top(s: &str) -> Vec<&str> {
        let (mut parts, mut depth, mut start) = (Vec::new(), 0, 0);
        for (i, c) in s.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    parts.push(&s[start..i]);
                    start = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&s[start..]);
        parts
    }
    let mut out = Vec::new();
    expand(&[], tree, &mut out);
    out
}

/// Every path a file's code names that starts at `crate`, `super` or `self`, as written.
fn named_paths(text: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    let mut rest = text;
    // `use` trees (possibly grouped over several lines).
    let mut other = String::new();
    while let Some(i) = find_use(rest) {
        other.push_str(&rest[..i]);
        let after = &rest[i..];
        let start = after.find("use ").map_or(0, |k| k + 4);
        let end = after.find(';').unwrap_or(after.len());
        paths.extend(use_paths(&after[start..end]));
        rest = &after[(end + 1).min(after.len())..];
    }
    other.push_str(rest);
    // Paths in the code itself (`crate::engine::Pose::new`, `super::blocking(…)`).
    for root in ["crate::", "super::", "self::"] {
        for (i, _) in other.match_indices(root) {
            let before = other[..i].chars().last();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            let tail = &other[i..];
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            let path: Vec<String> = tail[..end]
                .split("::")
                .filter(|s| !s.is_empty())
                .map(str::to_string)
                .collect();
            paths.push(path);
        }
    }
    paths
}

/// Where the next `use` item starts (`use`, `pub use`, `pub(crate) use`, at a line start).
fn find_use(text: &str) -> Option<usize> {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        let is_use = t.starts_with("use ")
            || (t.starts_with("pub") && t.split_whitespace().nth(1) == Some("use"));
        if is_use {
            return Some(offset + (line.len() - t.len()));
        }
        offset += line.len();
    }
    None
}

/// The source tree read once: each module's named paths, the modules that exist, and what
/// each folder's `mod.rs` re-exports (name → the child it comes from).
struct Tree {
    uses: BTreeMap<ModPath, Vec<ModPath>>,
    modules: BTreeSet<ModPath>,
    folders: BTreeSet<ModPath>,
    reexports: BTreeMap<ModPath, BTreeMap<String, ModPath>>,
}

impl Tree {
    fn read() -> Tree {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        rust_files(&src, &mut files);
        let mut texts = BTreeMap::new();
        let mut modules = BTreeSet::new();
        let mut folders = BTreeSet::new();
        for path in files {
            let rel = path.strip_prefix(&src).expect("under src").to_path_buf();
            let module = module_of(&rel);
            if rel.file_name().is_some_and(|n| n == "mod.rs") {
                folders.insert(module.clone());
            }
            modules.insert(module.clone());
            let text = code(&std::fs::read_to_string(&path).expect("readable"));
            texts.insert(module, text);
        }
        folders.insert(Vec::new());
        // Absolute paths, each cut to the deepest module it names.
        let mut uses = BTreeMap::new();
        let mut reexports: BTreeMap<ModPath, BTreeMap<String, ModPath>> = BTreeMap::new();
        for (module, text) in &texts {
            let mut named = Vec::new();
            for path in named_paths(text) {
                let Some(abs) = absolute(module, &path) else {
                    continue;
                };
                named.push(abs);
            }
            if folders.contains(module) {
                // `pub use child::{X, Y}`: X and Y come from `child`.
                for line in text.split(';') {
                    let t = line.trim_start();
                    if !(t.starts_with("pub use") || t.starts_with("pub(crate) use")) {
                        continue;
                    }
                    let tree = &t[t.find("use ").map_or(0, |k| k + 4)..];
                    for path in use_paths(tree) {
                        let Some(abs) = absolute(module, &path) else {
                            continue;
                        };
                        if let Some(name) = abs.last() {
                            let from = deepest(&modules, &abs);
                            reexports
                                .entry(module.clone())
                                .or_default()
                                .insert(name.clone(), from);
                        }
                    }
                }
            }
            uses.insert(module.clone(), named);
        }
        Tree {
            uses,
            modules,
            folders,
            reexports,
        }
    }

    /// The module a path names, through the re-exports of the folders it passes.
    fn target(&self, path: &[String]) -> ModPath {
        let mut module = deepest(&self.modules, path);
        // `crate::engine::Pose` → `engine`'s re-export of Pose → `engine::pose`.
        for _ in 0..8 {
            let Some(name) = path.get(module.len()) else {
                break;
            };
            match self.reexports.get(&module).and_then(|r| r.get(name)) {
                Some(from) if from.len() > module.len() => module = from.clone(),
                _ => break,
            }
        }
        module
    }

    /// Each folder's graph of its children.
    fn graphs(&self) -> BTreeMap<ModPath, Graph> {
        let mut graphs: BTreeMap<ModPath, Graph> = self
            .folders
            .iter()
            .map(|f| (f.clone(), Graph::new()))
            .collect();
        for (module, named) in &self.uses {
            for path in named {
                let target = self.target(path);
                let common = module
                    .iter()
                    .zip(&target)
                    .take_while(|(a, b)| a == b)
                    .count();
                let (Some(from), Some(to)) = (module.get(common), target.get(common)) else {
                    continue;
                };
                let folder = module[..common].to_vec();
                graphs
                    .entry(folder)
                    .or_default()
                    .entry(from.clone())
                    .or_default()
                    .insert(to.clone());
            }
            // Every child appears, with or without edges.
            if let Some((last, folder)) = module.split_last() {
                graphs
                    .entry(folder.to_vec())
                    .or_default()
                    .entry(last.clone())
                    .or_default();
            }
        }
        graphs
    }
}

/// `path` as written in `module` made absolute (`super::x` → the parent's `x`); `None` for a
/// path that does not start at `crate`, `super` or `self`.
fn absolute(module: &[String], path: &[String]) -> Option<ModPath> {
    let first = path.first()?;
    let mut abs: ModPath = match first.as_str() {
        "crate" => Vec::new(),
        // In `a/mod.rs`, `self` is `a`; in `a/b.rs` it is `a::b`.
        "self" => module.to_vec(),
        "super" => module[..module.len().saturating_sub(1)].to_vec(),
        _ => return None,
    };
    let mut rest = &path[1..];
    while rest.first().is_some_and(|s| s == "super") {
        abs.pop();
        rest = &rest[1..];
    }
    abs.extend(rest.iter().filter(|s| *s != "self").cloned());
    Some(abs)
}

/// The longest prefix of `path` that is a module of the tree.
fn deepest(modules: &BTreeSet<ModPath>, path: &[String]) -> ModPath {
    (0..=path.len())
        .rev()
        .map(|n| path[..n].to_vec())
        .find(|p| modules.contains(p) || p.is_empty())
        .unwrap_or_default()
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

/// Top-level module → the top-level modules it uses (the crate root's graph).
fn top_level() -> Graph {
    let mut top = Tree::read()
        .graphs()
        .remove(&Vec::new())
        .unwrap_or_default();
    top.remove("architecture");
    top
}

#[test]
fn use_trees_and_paths_are_read() {
    assert_eq!(
        use_paths("super::{forward::{Prior, next_state}, gates, hmm::Hmm as H}"),
        vec![
            vec!["super", "forward", "Prior"],
            vec!["super", "forward", "next_state"],
            vec!["super", "gates"],
            vec!["super", "hmm", "Hmm"],
        ]
    );
    let text =
        "use crate::engine::{self, Pose};\nfn f() { super::blocking(); let x = crate::app::X; }";
    let paths = named_paths(text);
    assert!(
        paths.contains(&vec!["crate".into(), "engine".into()]),
        "{paths:?}"
    );
    assert!(
        paths.contains(&vec!["super".into(), "blocking".into()]),
        "{paths:?}"
    );
    assert!(
        paths.contains(&vec!["crate".into(), "app".into(), "X".into()]),
        "{paths:?}"
    );
    let in_file = ["engine".to_string(), "cdhmm".into(), "learner".into()];
    assert_eq!(
        absolute(&in_file, &["super".into(), "super".into(), "pose".into()]),
        Some(vec!["engine".to_string(), "pose".into()])
    );
    // A cycle is found and named; a chain is not one.
    let mut g = Graph::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    assert_eq!(cycle(&g), None);
    g.entry("c".into()).or_default().insert("a".into());
    assert_eq!(
        cycle(&g),
        Some(vec!["a".into(), "b".into(), "c".into(), "a".into()])
    );
}

#[test]
fn no_import_cycle_in_any_folder() {
    let graphs = Tree::read().graphs();
    // The check sees the folders and their edges (a reader that found nothing would pass).
    let root = &graphs[&Vec::new()];
    assert!(
        root["app"].contains("engine") && root["http"].contains("app"),
        "{root:?}"
    );
    assert!(graphs.len() >= 10, "{:?}", graphs.keys());
    // The engine's folders are read too: the lattice expert's files use one another.
    let lattice = &graphs[&["engine", "experts", "lattice"].map(String::from).to_vec()];
    assert!(
        lattice["expert"].contains("walk") && lattice["expert"].contains("followers"),
        "{lattice:?}"
    );
    // The noise estimator's parts: aligning stretches gives the pairs the mixture is fitted to.
    let estimate = &graphs[&["engine", "experts", "noise", "estimate"]
        .map(String::from)
        .to_vec()];
    assert!(estimate["stretches"].contains("mixture"), "{estimate:?}");
    // The simulation's folders: the pattern programs are placed as the lab's are, and the lab's
    // tasks are a file of their own.
    let simulation = &graphs[&vec!["simulation".to_string()]];
    assert!(simulation["pattern"].contains("lab"), "{simulation:?}");
    let lab = &graphs[&["simulation", "lab"].map(String::from).to_vec()];
    assert!(lab.contains_key("tasks"), "{lab:?}");
    // The program model's and the KRL reader's: the model's files share its waypoint, the
    // reader's files its lexer.
    let program = &graphs[&vec!["program".to_string()]];
    assert!(
        program["routines"].contains("waypoints") && program["configuration"].contains("language"),
        "{program:?}"
    );
    let krl = &graphs[&["import", "krl"].map(String::from).to_vec()];
    assert!(
        krl["motions"].contains("lexer") && krl["motions"].contains("targets"),
        "{krl:?}"
    );
    let cycles: Vec<String> = graphs
        .iter()
        .filter_map(|(folder, g)| {
            cycle(g).map(|c| format!("src/{}: {}", folder.join("/"), c.join(" → ")))
        })
        .collect();
    assert!(cycles.is_empty(), "import cycles:\n{}", cycles.join("\n"));
}

/// Each module and what it may use of the crate; the pure ones first.
#[test]
fn modules_use_only_what_their_layer_allows() {
    let allowed: &[(&str, &[&str])] = &[
        ("engine", &[]),
        // The program model: a leaf over the engine's pose; the controllers' notations of an
        // arm configuration are its, and kinematics computes them.
        ("program", &["engine"]),
        ("kinematics", &["engine", "program"]),
        ("import", &["engine", "program"]),
        ("export", &["engine", "program"]),
        ("simulation", &["engine", "kinematics", "program"]),
        ("replay", &["engine", "import", "kinematics", "program"]),
        ("storage", &["engine", "program"]),
        ("telemetry", &[]),
        // What both adapters share, finding a request's caller with the app among it.
        ("transport", &["app"]),
        ("api", &["engine", "export", "kinematics", "program"]),
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
    let top = top_level();
    for (module, _) in allowed {
        assert!(top.contains_key(*module), "{module} not found: {top:?}");
    }
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
        ("client", "http"),
    ] {
        assert!(
            !top.get(adapter).is_some_and(|u| u.contains(other)),
            "{adapter} uses {other}"
        );
    }
    // Nothing below the adapters reaches up into them.
    for (module, uses) in &top {
        if [
            "http",
            "grpc",
            "server",
            "cli",
            "simulation_driver",
            "client",
        ]
        .contains(&module.as_str())
        {
            continue;
        }
        for adapter in ["http", "grpc", "server", "cli"] {
            assert!(!uses.contains(adapter), "{module} uses {adapter}");
        }
    }
}

/// The engine, the program type, the importer, the exporter and the simulation (its driver
/// against a server is `simulation_driver`) do no I/O and know no async runtime; the engine
/// knows nothing of the web either (its wire schemas are in `api`).
#[test]
fn pure_modules_do_no_io() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for module in ["engine", "program", "import", "export", "simulation"] {
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
            if module == "engine" {
                assert!(!text.contains("utoipa"), "{} uses utoipa", f.display());
            }
        }
    }
}
