//! The shared corpus of real programs, read only: `../shared/corpus` beside the checkout, with
//! `json/` (one program per file, as the replay reads them) and `raw/` (one folder per
//! repository, its files named by their path with `/` written `__`).
//!
//! The corpus stays out of the repository (its programs carry no licence), so a fresh clone has
//! none. `build.rs` sets `cfg(corpus)` when `../shared/corpus/json` exists, and every test that
//! reads the corpus carries
//! `#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]`:
//! without it the test is reported as ignored, with that reason; with it the test runs.
//!
//! Several test binaries include this file (`#[path = "../common/corpus.rs"] mod corpus;`), each
//! using the part it needs.
#![allow(dead_code)]

use std::fs;
use std::path::{Path, PathBuf};

use nextpose::import::decode_text;

/// `../shared/corpus`.
pub fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus")
}

/// The JSON programs, `../shared/corpus/json`.
pub fn json() -> PathBuf {
    dir().join("json")
}

/// The raw files, `../shared/corpus/raw`, one folder per repository.
pub fn raw() -> PathBuf {
    dir().join("raw")
}

/// The raw files of the second corpus, `../shared/corpus2/raw` (same layout as [`raw`]).
pub fn raw2() -> PathBuf {
    dir().join("../corpus2/raw")
}

/// Every raw file of both corpora (the second when it is there), as an upload names it (the
/// original path, `__` → `/`) with its text, sorted by repository folder and file.
pub fn raw_files() -> Vec<File> {
    let mut out = Vec::new();
    for root in [raw(), raw2()].into_iter().filter(|r| r.is_dir()) {
        let mut paths: Vec<PathBuf> = fs::read_dir(&root)
            .expect("raw folder")
            .map(|e| e.expect("entry").path())
            .filter(|p| p.is_dir())
            .flat_map(|dir| {
                fs::read_dir(dir)
                    .expect("repository folder")
                    .map(|e| e.expect("entry").path())
                    .collect::<Vec<_>>()
            })
            .filter(|p| p.is_file())
            .collect();
        paths.sort();
        out.extend(
            paths
                .iter()
                .map(|p| (file_name(p).replace("__", "/"), read_text(p))),
        );
    }
    out
}

/// A file as an upload gives it: (name, text).
pub type File = (String, String);

/// Every repository's raw files as one upload each, by repository folder name: a file's name
/// is its original path (`__` → `/`), and the files are sorted by it.
pub fn uploads() -> Vec<(String, Vec<File>)> {
    let mut repos: Vec<PathBuf> = fs::read_dir(raw())
        .expect("corpus/raw")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.is_dir())
        .collect();
    repos.sort();
    repos
        .into_iter()
        .map(|dir| {
            let mut files: Vec<File> = fs::read_dir(&dir)
                .expect("repository folder")
                .map(|e| e.expect("entry").path())
                .map(|p| {
                    let flat = file_name(&p);
                    (flat.replace("__", "/"), read_text(&p))
                })
                .collect();
            files.sort();
            (file_name(&dir), files)
        })
        .collect()
}

/// The RAPID modules (`.mod`) of one repository, by their file name in the corpus (the path
/// still written with `__`), sorted.
pub fn rapid_modules(repo: &str) -> Vec<File> {
    let dir = raw().join(repo);
    let mut paths: Vec<PathBuf> = fs::read_dir(&dir)
        .expect("repository folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "mod"))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "{}", dir.display());
    paths.iter().map(|p| (file_name(p), read_text(p))).collect()
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .expect("a name")
        .to_string_lossy()
        .into_owned()
}

fn read_text(p: &Path) -> String {
    decode_text(&fs::read(p).expect("read"))
}
