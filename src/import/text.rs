//! The text of an upload's files: decoding bytes, file names' folders and stems, and byte
//! offsets as lines and columns.

use serde::Serialize;

/// One file of an upload: its name (a path; directories group FANUC files and pair KRL files)
/// and its text.
#[derive(Debug, Clone, Copy)]
pub struct SourceFile<'a> {
    pub name: &'a str,
    pub text: &'a str,
}

/// A 1-based position in a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Location {
    pub line: usize,
    pub column: usize,
}

/// Decodes a file's bytes: UTF-8 when valid, otherwise Latin-1 (controllers write Windows-1252
/// comments), so any file can be handed to [`super::parse_files`].
pub fn decode_text(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
}

/// The directory part of a file name (`a/b/c.ls` → `a/b`), `""` when none.
pub(crate) fn directory_of(name: &str) -> &str {
    name.rsplit_once(['/', '\\']).map(|(d, _)| d).unwrap_or("")
}

/// The file name without directory and extension (`a/b/Main.mod` → `Main`).
pub(crate) fn stem_of(name: &str) -> &str {
    let base = name
        .rsplit_once(['/', '\\'])
        .map(|(_, b)| b)
        .unwrap_or(name);
    base.rsplit_once('.').map(|(s, _)| s).unwrap_or(base)
}

/// Byte offset → line and column, for error messages and waypoint lines.
pub(crate) struct LineIndex {
    starts: Vec<usize>,
}

impl LineIndex {
    pub(crate) fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { starts }
    }

    pub(crate) fn locate(&self, text: &str, offset: usize) -> Location {
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let start = self.starts.get(line - 1).copied().unwrap_or(0);
        let column = text
            .get(start..offset.min(text.len()))
            .map(|s| s.chars().count())
            .unwrap_or(0)
            + 1;
        Location { line, column }
    }

    pub(crate) fn line(&self, offset: usize) -> usize {
        self.starts.partition_point(|&s| s <= offset).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_index_locates() {
        let text = "ab\ncdé\nf";
        let idx = LineIndex::new(text);
        assert_eq!(idx.locate(text, 0), Location { line: 1, column: 1 });
        assert_eq!(idx.locate(text, 4), Location { line: 2, column: 2 });
        assert_eq!(
            idx.locate(text, text.len()),
            Location { line: 3, column: 2 }
        );
    }

    #[test]
    fn folders_and_stems_of_file_names() {
        assert_eq!(directory_of("a/b/c.ls"), "a/b");
        assert_eq!(directory_of("a\\b.ls"), "a");
        assert_eq!(directory_of("c.ls"), "");
        assert_eq!(stem_of("a/b/Main.mod"), "Main");
        assert_eq!(stem_of("noext"), "noext");
    }
}
