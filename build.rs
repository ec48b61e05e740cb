//! Generates the gRPC code from `proto/` with protox (no system `protoc`) and writes the
//! encoded file descriptor set that the reflection service serves.
//!
//! It also tells the tests whether the shared corpus of real programs is beside the checkout:
//! the corpus stays out of the repository (its programs carry no licence), so a fresh clone has
//! none, and the tests that read it are then reported as ignored, with the reason, instead of
//! failing. `cfg(corpus)` is set when `../shared/corpus/json` exists.

use std::path::{Path, PathBuf};

use prost::Message;
use sha2::{Digest, Sha256};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto = "proto/nextpose/v1/nextpose.proto";
    println!("cargo::rerun-if-changed={proto}");
    let fds = protox::compile([proto], ["proto"])?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    std::fs::write(out.join("nextpose_descriptor.bin"), fds.encode_to_vec())?;
    tonic_prost_build::configure().compile_fds(fds)?;

    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    corpus(&manifest.join("../shared"));
    placement_code(&manifest)?;
    bundled_robots(&manifest, &out)?;
    Ok(())
}

/// Writes `bundled_robots.rs`: every `robots/*.urdf` (by name) and `robots/catalog.json`,
/// included in the binary as text (`kinematics::bundled`), so the service needs no checkout
/// beside it, in every profile.
fn bundled_robots(manifest: &Path, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let dir = manifest.join("robots");
    println!("cargo::rerun-if-changed={}", dir.display());
    let mut urdfs = Vec::new();
    for entry in std::fs::read_dir(&dir)? {
        let path = entry?.path();
        if path.extension().is_some_and(|e| e == "urdf") {
            urdfs.push(path);
        }
    }
    urdfs.sort();
    let mut code = String::from(
        "/// Every bundled model: its name (the file stem) and its URDF text, by name.\n\
         pub const URDFS: &[(&str, &str)] = &[\n",
    );
    for path in &urdfs {
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        code.push_str(&format!(
            "    ({stem:?}, include_str!({:?})),\n",
            path.display().to_string()
        ));
    }
    code.push_str("];\n");
    code.push_str(&format!(
        "/// The data sheets of the bundled models (`robots/catalog.json`).\n\
         pub const CATALOG: &str = include_str!({:?});\n",
        dir.join("catalog.json").display().to_string()
    ));
    std::fs::write(out.join("bundled_robots.rs"), code)?;
    Ok(())
}

/// Sets `NEXTPOSE_PLACEMENT_CODE` to the SHA-256 of the placement's code: every file under
/// `src/kinematics/` and `src/engine/pose.rs`, by path in sorted order, path and contents.
fn placement_code(manifest: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let roots = [
        manifest.join("src/kinematics"),
        manifest.join("src/engine/pose.rs"),
    ];
    let mut files = Vec::new();
    let mut pending: Vec<PathBuf> = roots.to_vec();
    while let Some(path) = pending.pop() {
        if path.is_dir() {
            for entry in std::fs::read_dir(&path)? {
                pending.push(entry?.path());
            }
        } else {
            files.push(path);
        }
    }
    files.sort();
    let mut digest = Sha256::new();
    for file in &files {
        let name = file.strip_prefix(manifest)?.to_string_lossy().into_owned();
        digest.update(name.as_bytes());
        digest.update([0]);
        digest.update(std::fs::read(file)?);
        digest.update([0]);
    }
    for root in &roots {
        println!("cargo::rerun-if-changed={}", root.display());
    }
    println!(
        "cargo::rustc-env=NEXTPOSE_PLACEMENT_CODE={:x}",
        digest.finalize()
    );
    Ok(())
}

/// Sets `cfg(corpus)` when `<shared>/corpus/json` exists, and asks to be rerun when that
/// changes. Cargo reruns a build script on every build while a path it watches is missing, so
/// only a path that exists is watched: the corpus folder itself, or the nearest of its parents
/// up to `shared`. With no `../shared` at all nothing is watched; after putting it in place,
/// `touch build.rs` (or any change to the proto) makes the tests see it.
fn corpus(shared: &Path) {
    println!("cargo::rustc-check-cfg=cfg(corpus)");
    let json = shared.join("corpus/json");
    if json.is_dir() {
        println!("cargo::rustc-cfg=corpus");
    }
    let watched = [json.clone(), shared.join("corpus"), shared.to_path_buf()];
    if let Some(path) = watched.iter().find(|p| p.exists()) {
        println!("cargo::rerun-if-changed={}", path.display());
    }
}
