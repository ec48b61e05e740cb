//! The controller languages a program is written in: ABB RAPID, KUKA KRL and FANUC TP. The one
//! name of a language everywhere: the importer reads files by it, the exporter writes it, the
//! corpus records it and the API names it (`rapid`, `krl`, `fanuc`).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A robot program language.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Language {
    /// ABB RAPID modules (`.mod`, `.modx`, `.prg`, `.sys`).
    Rapid,
    /// KUKA KRL: a `.src` and the `.dat` of the same name.
    Krl,
    /// FANUC TP listings (`.ls`), one per routine, a folder per program.
    Fanuc,
}

/// A name that is no language's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown language {0:?} (rapid, krl or fanuc)")]
pub struct UnknownLanguage(pub String);

impl Language {
    pub const ALL: [Language; 3] = [Language::Rapid, Language::Krl, Language::Fanuc];

    /// The language's name: in the corpus, on the wire, in reports (`rapid`, `krl`, `fanuc`).
    pub fn as_str(self) -> &'static str {
        match self {
            Language::Rapid => "rapid",
            Language::Krl => "krl",
            Language::Fanuc => "fanuc",
        }
    }

    /// The language a file name's extension says, if any (case-insensitive).
    pub fn from_file_name(name: &str) -> Option<Language> {
        let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "mod" | "modx" | "prg" | "sys" => Some(Language::Rapid),
            "src" | "dat" => Some(Language::Krl),
            "ls" => Some(Language::Fanuc),
            _ => None,
        }
    }
}

impl fmt::Display for Language {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Language {
    type Err = UnknownLanguage;
    /// `rapid`, `krl` or `fanuc`, in any case.
    fn from_str(s: &str) -> Result<Language, UnknownLanguage> {
        Language::ALL
            .into_iter()
            .find(|l| l.as_str().eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownLanguage(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn languages_by_extension() {
        assert_eq!(Language::from_file_name("a/B.MOD"), Some(Language::Rapid));
        assert_eq!(Language::from_file_name("x.modx"), Some(Language::Rapid));
        assert_eq!(Language::from_file_name("x.dat"), Some(Language::Krl));
        assert_eq!(Language::from_file_name("UP001.LS"), Some(Language::Fanuc));
        assert_eq!(Language::from_file_name("x.json"), None);
        assert_eq!(Language::from_file_name("noext"), None);
    }

    #[test]
    fn names_parse_print_and_are_what_serde_writes() {
        for l in Language::ALL {
            assert_eq!(l.as_str().parse::<Language>(), Ok(l));
            assert_eq!(l.to_string(), l.as_str());
            assert_eq!(serde_json::to_value(l).unwrap(), l.as_str(), "{l:?}");
            let back: Language = serde_json::from_value(l.as_str().into()).unwrap();
            assert_eq!(back, l);
        }
        assert_eq!("RAPID".parse::<Language>(), Ok(Language::Rapid));
        assert_eq!(
            "gcode".parse::<Language>(),
            Err(UnknownLanguage("gcode".into()))
        );
    }
}
