//! The arms of replayed programs, searched once. Placing a program's arm
//! ([`ReachCheck::place`], a layout search per candidate arm) takes about half a second per
//! program, almost all of a corpus replay's time, and gives the same answer for the same
//! program every time. [`PlacementCache`] keeps each answer in a directory, one small JSON file
//! per placement, under the SHA-256 of everything the answer depends on:
//!
//! - the code of the search (`NEXTPOSE_PLACEMENT_CODE`, which `build.rs` digests from
//!   `src/kinematics/` and `src/engine/pose.rs`) and a format tag;
//! - the bundled arm library (every file of `robots/`);
//! - the reach setup (placement kind, seed, evaluations), the program's language, the arm it
//!   names and its taught poses.
//!
//! A change to any of them is another key, so an entry is never stale; old entries are merely
//! unused. An entry that cannot be read is searched again and rewritten; one that cannot be
//! written is counted ([`CacheUse::unwritten`]) and the replay goes on. `nextpose replay` keeps the cache in the user's
//! cache directory ([`PlacementCache::user_dir`]) unless told otherwise; the library's
//! [`super::replay_all`] uses one only when [`super::RunConfig::placement_cache`] names it.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::engine::Pose;
use crate::kinematics::LayoutError;
use crate::kinematics::bundled_files;
use crate::kinematics::placement::{PlacedArm, ProgramArm, ReachCheck};

/// Changes when the entries' format or meaning does.
const FORMAT: &str = "nextpose placement cache 1";

/// A directory of placements (module documentation).
#[derive(Debug, Clone)]
pub struct PlacementCache {
    dir: PathBuf,
    /// The digest of the code and the arm library, the first part of every key.
    origin: [u8; 32],
}

/// One entry: the placement's answer (`None`: no arm for the program).
#[derive(Serialize, Deserialize)]
struct Entry {
    arm: Option<ProgramArm>,
}

/// What a lookup did: the counts a replay reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CacheUse {
    /// Placements read from the cache.
    pub hits: usize,
    /// Placements searched.
    pub searched: usize,
    /// Searched placements that could not be written (the directory is not writable).
    pub unwritten: usize,
}

impl PlacementCache {
    /// The cache in `dir` (created on the first write), for the bundled arm library the
    /// binary carries.
    pub fn new(dir: impl Into<PathBuf>) -> PlacementCache {
        let mut origin = Sha256::new();
        origin.update(FORMAT.as_bytes());
        origin.update([0]);
        origin.update(env!("NEXTPOSE_PLACEMENT_CODE").as_bytes());
        origin.update([0]);
        for (name, text) in bundled_files() {
            origin.update(name.as_bytes());
            origin.update([0]);
            origin.update(text.as_bytes());
            origin.update([0]);
        }
        PlacementCache {
            dir: dir.into(),
            origin: origin.finalize().into(),
        }
    }

    /// `$XDG_CACHE_HOME/nextpose/placements`, else `$HOME/.cache/nextpose/placements`; `None`
    /// when neither variable is set.
    pub fn user_dir() -> Option<PathBuf> {
        let base = std::env::var_os("XDG_CACHE_HOME")
            .filter(|d| !d.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache")))?;
        Some(base.join("nextpose").join("placements"))
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// [`ReachCheck::place`], from the cache when it holds the answer, else searched and kept.
    pub fn place(
        &self,
        check: &ReachCheck,
        language: &str,
        named: Option<&str>,
        poses: &[Pose],
        used: &mut CacheUse,
    ) -> Result<Option<PlacedArm>, LayoutError> {
        let path = self
            .dir
            .join(format!("{}.json", self.key(check, language, named, poses)));
        if let Some(entry) = read(&path) {
            match entry.arm {
                None => {
                    used.hits += 1;
                    return Ok(None);
                }
                Some(arm) => {
                    if let Some(placed) = check.placed(arm) {
                        used.hits += 1;
                        return Ok(Some(placed));
                    }
                }
            }
        }
        let placed = check.place(language, named, poses)?;
        used.searched += 1;
        let entry = Entry {
            arm: placed.as_ref().map(|p| p.arm.clone()),
        };
        if write(&self.dir, &path, &entry).is_err() {
            used.unwritten += 1;
        }
        Ok(placed)
    }

    /// The hex SHA-256 of the origin, the setup and the program's inputs to the placement.
    fn key(
        &self,
        check: &ReachCheck,
        language: &str,
        named: Option<&str>,
        poses: &[Pose],
    ) -> String {
        let mut key = Sha256::new();
        key.update(self.origin);
        // The setup is plain data; its JSON is a stable description of it.
        key.update(serde_json::to_vec(check.setup()).unwrap_or_default());
        key.update([0]);
        key.update(language.as_bytes());
        key.update([0]);
        match named {
            Some(n) => {
                key.update([1]);
                key.update(n.as_bytes());
            }
            None => key.update([0]),
        }
        key.update([0]);
        for pose in poses {
            let v = pose.values();
            for x in [v.x, v.y, v.z, v.qw, v.qx, v.qy, v.qz] {
                key.update(x.to_le_bytes());
            }
        }
        format!("{:x}", key.finalize())
    }
}

fn read(path: &Path) -> Option<Entry> {
    let text = std::fs::read(path).ok()?;
    serde_json::from_slice(&text).ok()
}

/// Writes `entry` to `path` through a temporary file in `dir` and a rename, so that a reader
/// never sees half an entry.
fn write(dir: &Path, path: &Path, entry: &Entry) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut file = tempfile::NamedTempFile::new_in(dir)?;
    file.write_all(&serde_json::to_vec(entry)?)?;
    file.persist(path).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::placement::{FitSetup, ReachSetup};

    /// A square of 100 mm steps, tool pointing down, and one waypoint 2 m away.
    fn program() -> Vec<Pose> {
        let down = [0.0, 0.0, 1.0, 0.0];
        [
            [0.0, 0.0],
            [100.0, 0.0],
            [100.0, 100.0],
            [0.0, 100.0],
            [2000.0, 0.0],
        ]
        .iter()
        .map(|[x, y]| Pose::new([*x, *y, 0.0], down).unwrap())
        .collect()
    }

    #[test]
    fn a_placement_is_searched_once_and_read_back_equal() {
        let dir = tempfile::tempdir().unwrap();
        let cache = PlacementCache::new(dir.path().join("placements"));
        let check = ReachCheck::new(ReachSetup::Fitted(FitSetup {
            seed: 0,
            evaluations: 300,
        }))
        .unwrap();
        let poses = program();
        let fresh = check
            .place("rapid", None, &poses)
            .unwrap()
            .expect("an ABB arm");
        let mut used = CacheUse::default();
        let first = cache
            .place(&check, "rapid", None, &poses, &mut used)
            .unwrap()
            .unwrap();
        let second = cache
            .place(&check, "rapid", None, &poses, &mut used)
            .unwrap()
            .unwrap();
        assert_eq!(
            used,
            CacheUse {
                hits: 1,
                searched: 1,
                unwritten: 0
            }
        );
        for placed in [&first, &second] {
            assert_eq!(placed.arm, fresh.arm);
            assert_eq!(placed.robot.name(), fresh.robot.name());
            assert_eq!(placed.cell.base.values(), fresh.cell.base.values());
        }
        // Another program, language or setup is another entry; no arm is an answer too.
        let mut moved = poses.clone();
        moved[0] = Pose::new([0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 0.0]).unwrap();
        cache
            .place(&check, "rapid", None, &moved, &mut used)
            .unwrap();
        cache.place(&check, "krl", None, &poses, &mut used).unwrap();
        assert_eq!(
            cache
                .place(&check, "gcode", None, &poses, &mut used)
                .unwrap()
                .map(|p| p.arm),
            None
        );
        assert_eq!(used.searched, 4);
        assert!(
            cache
                .place(&check, "gcode", None, &poses, &mut used)
                .unwrap()
                .is_none()
        );
        assert_eq!(used.hits, 2);
        let files = std::fs::read_dir(cache.dir()).unwrap().count();
        assert_eq!(files, 4);

        // A damaged entry is searched again and rewritten.
        for entry in std::fs::read_dir(cache.dir()).unwrap() {
            std::fs::write(entry.unwrap().path(), b"{").unwrap();
        }
        let mut used = CacheUse::default();
        let again = cache
            .place(&check, "rapid", None, &poses, &mut used)
            .unwrap()
            .unwrap();
        assert_eq!(again.arm, fresh.arm);
        assert_eq!(
            used,
            CacheUse {
                hits: 0,
                searched: 1,
                unwritten: 0
            }
        );
        cache
            .place(&check, "rapid", None, &poses, &mut used)
            .unwrap();
        assert_eq!(used.hits, 1);
    }

    #[test]
    fn an_unwritable_cache_is_counted_and_the_placement_still_found() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("a file");
        std::fs::write(&blocker, b"").unwrap();
        let cache = PlacementCache::new(blocker.join("placements"));
        let check = ReachCheck::new(ReachSetup::Fitted(FitSetup {
            seed: 0,
            evaluations: 300,
        }))
        .unwrap();
        let mut used = CacheUse::default();
        let placed = cache
            .place(&check, "rapid", None, &program(), &mut used)
            .unwrap();
        assert!(placed.is_some());
        assert_eq!(
            used,
            CacheUse {
                hits: 0,
                searched: 1,
                unwritten: 1
            }
        );
    }
}
