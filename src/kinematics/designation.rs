//! Arm model designations in free text (pure): a program file's header comment
//! (`Robot Type : IRB 6700-205/2.80`), a controller's serial number (`Robot Ser# 2600-501273`,
//! ABB's serials start with the arm type), a corpus note (`(IRB 140)`), a repository name
//! (`ABB-IRB-140--Robot-Industrial`). [`find_designation`] finds the first one and writes it
//! the way the makers do; [`catalog_arm`] finds the library arm of the same family (the
//! designation without its payload/reach variant: `IRB 6700`, `KR 210 R2700`, `M-20iA`).

use std::sync::LazyLock;

use regex::Regex;

use super::catalog::ArmFacts;

/// The designation patterns, in the makers' spelling once normalised by [`canonical`]:
/// ABB `IRB <type>[-<payload>/<reach>]` and serial numbers `Ser# <type>-<number>`, KUKA
/// `KR <payload>[ R<reach>][-<generation>]`, FANUC `R-2000iC/165F`, `M-20iA`, `LR Mate 200iD`,
/// Universal Robots `UR5e`.
static PATTERNS: LazyLock<Vec<(Maker, Regex)>> = LazyLock::new(|| {
    let p = |maker, re: &str| {
        // The patterns are constants: a failure here is a bug the unit tests catch.
        (maker, Regex::new(re).expect("a valid designation pattern"))
    };
    vec![
        p(
            Maker::Abb,
            r"(?i)\bIRB[\s_-]*(\d{3,4})(?:[\s_-]*(\d{1,3})\s*/\s*(\d\.\d{1,2}))?\b",
        ),
        p(
            Maker::AbbSerial,
            r"(?i)\bSer(?:ial)?\s*(?:#|No\.?|number)\s*:?\s*(\d{3,4})-\d{4,}",
        ),
        p(
            Maker::Kuka,
            r"\bKR[\s_-]*(\d{1,4})(?:[\s_-]*R[\s_-]*(\d{3,4}))?(?:-(\d))?\b",
        ),
        p(
            Maker::Fanuc,
            r"(?i)\b((?:R-\d{4}|M-\d{1,4}|ARC\s*Mate\s*\d{2,3}|LR\s*Mate\s*\d{3})i[A-D])(/\d+[A-Z]*)?",
        ),
        p(Maker::Ur, r"(?i)\bUR(3|5|10|16|20|30)(e?)\b"),
    ]
});

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Maker {
    Abb,
    AbbSerial,
    Kuka,
    Fanuc,
    Ur,
}

/// A designation found in a text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Found {
    /// The designation in the maker's spelling (`IRB 6700-205/2.80`, `IRB 2600`).
    pub designation: String,
    /// 1-based line of the text it is on.
    pub line: usize,
}

/// The first arm designation in `text` (the earliest in the text; at one place, the first
/// pattern), or `None`.
pub fn find_designation(text: &str) -> Option<Found> {
    let (at, designation) = PATTERNS
        .iter()
        .filter_map(|(maker, re)| {
            re.captures(text).map(|c| {
                let at = c.get(0).map_or(0, |m| m.start());
                (at, canonical(*maker, &c))
            })
        })
        .min_by_key(|(at, _)| *at)?;
    let line = text[..at].matches('\n').count() + 1;
    Some(Found { designation, line })
}

fn canonical(maker: Maker, c: &regex::Captures<'_>) -> String {
    let group = |i: usize| c.get(i).map(|m| m.as_str());
    let squeeze = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    match maker {
        Maker::Abb => match (group(1), group(2), group(3)) {
            (Some(t), Some(payload), Some(reach)) => format!("IRB {t}-{payload}/{reach}"),
            (t, _, _) => format!("IRB {}", t.unwrap_or_default()),
        },
        Maker::AbbSerial => format!("IRB {}", group(1).unwrap_or_default()),
        Maker::Kuka => {
            let mut s = format!("KR {}", group(1).unwrap_or_default());
            if let Some(reach) = group(2) {
                s.push_str(&format!(" R{reach}"));
            }
            if let Some(generation) = group(3) {
                s.push_str(&format!("-{generation}"));
            }
            s
        }
        Maker::Fanuc => {
            // Upper case but a lower-case `i` before the series letter and `Mate`
            // (`M-20iA`, `LR Mate 200iD`).
            let base = squeeze(group(1).unwrap_or_default()).to_uppercase();
            let (head, series) = base.split_at(base.len().saturating_sub(1));
            let head = head
                .strip_suffix('I')
                .unwrap_or(head)
                .replace("MATE", "Mate");
            let variant = group(2).unwrap_or_default().to_uppercase();
            format!("{head}i{series}{variant}")
        }
        Maker::Ur => format!(
            "UR{}{}",
            group(1).unwrap_or_default(),
            group(2).unwrap_or_default().to_lowercase()
        ),
    }
}

/// A designation's family: the text before its variant, i.e. before the first `/`, or the first
/// `-` that follows a digit (`IRB 6700-205/2.80` → `IRB 6700`, `KR 210 R2700-2` →
/// `KR 210 R2700`, `R-2000iC/165F` → `R-2000iC`, `IRB 140` → `IRB 140`).
pub fn family(designation: &str) -> &str {
    let bytes = designation.as_bytes();
    let end = (0..bytes.len())
        .find(|&i| bytes[i] == b'/' || (bytes[i] == b'-' && i > 0 && bytes[i - 1].is_ascii_digit()))
        .unwrap_or(bytes.len());
    designation[..end].trim_end()
}

/// The library arm a designation names: the one whose model is the designation, else the first
/// of the same family (`IRB 2600` → the library's IRB 2600-12/1.65). Case and the UR `e`
/// suffix must match.
pub fn catalog_arm<'a>(designation: &str, catalog: &'a [ArmFacts]) -> Option<&'a ArmFacts> {
    catalog.iter().find(|f| f.model == designation).or_else(|| {
        catalog
            .iter()
            .find(|f| family(&f.model) == family(designation))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn found(text: &str) -> Option<String> {
        find_designation(text).map(|f| f.designation)
    }

    #[test]
    fn designations_in_the_corpus_spellings() {
        assert_eq!(
            found("!*           Robot Type\t\t\t: IRB 6700-205/2.80\n").as_deref(),
            Some("IRB 6700-205/2.80")
        );
        assert_eq!(
            found("    !\tRobot Ser# 2600-501273").as_deref(),
            Some("IRB 2600")
        );
        assert_eq!(
            found("academic/lab RobotStudio program (IRB 140)").as_deref(),
            Some("IRB 140")
        );
        assert_eq!(
            found("Theyloramaya/ABB-IRB-140--Robot-Industrial").as_deref(),
            Some("IRB 140")
        );
        assert_eq!(
            found("a KR 210 R2700-2 cell").as_deref(),
            Some("KR 210 R2700-2")
        );
        assert_eq!(found("KR16-2 palletiser").as_deref(), Some("KR 16-2"));
        assert_eq!(
            found("r-2000ic/165f spot").as_deref(),
            Some("R-2000iC/165F")
        );
        assert_eq!(
            found("an LR Mate 200iD/7L").as_deref(),
            Some("LR Mate 200iD/7L")
        );
        assert_eq!(found("M-20iA").as_deref(), Some("M-20iA"));
        assert_eq!(found("ur10e on a cart").as_deref(), Some("UR10e"));
    }

    #[test]
    fn the_earliest_designation_wins_and_its_line_is_given() {
        let f = find_designation("header\nUR5e\nIRB 140\n").unwrap();
        assert_eq!((f.designation.as_str(), f.line), ("UR5e", 2));
    }

    #[test]
    fn words_that_only_look_like_designations_are_not() {
        for text in [
            "KRC4 controller",
            "IRB",
            "PERS tooldata tWeldGun",
            "MoveL p10, v1000, z50, tool0\\WObj:=wobj1;",
            "SERIAL 12",
            "KRL program",
            "user frame UF1",
            "URL",
        ] {
            assert_eq!(found(text), None, "{text}");
        }
    }

    #[test]
    fn families_and_the_library_arm() {
        assert_eq!(family("IRB 6700-205/2.80"), "IRB 6700");
        assert_eq!(family("KR 210 R2700-2"), "KR 210 R2700");
        assert_eq!(family("R-2000iC/165F"), "R-2000iC");
        assert_eq!(family("M-20iA"), "M-20iA");
        let catalog =
            crate::kinematics::load_catalog(&crate::kinematics::bundled_robots_dir()).unwrap();
        let arm = |d: &str| catalog_arm(d, &catalog).map(|f| f.name.as_str());
        assert_eq!(arm("IRB 6700-205/2.80"), Some("abb_irb6700"));
        assert_eq!(arm("IRB 2600"), Some("abb_irb2600"));
        assert_eq!(arm("IRB 2600-20/1.65"), Some("abb_irb2600"));
        assert_eq!(arm("IRB 140"), Some("abb_irb140"));
        // An IRB 120 is not an IRB 1200.
        assert_eq!(arm("IRB 120"), None);
        assert_eq!(arm("KR 16-2"), Some("kuka_kr16_2"));
        assert_eq!(arm("KR 16"), Some("kuka_kr16_2"));
        assert_eq!(arm("R-2000iC/210F"), Some("fanuc_r2000ic"));
        assert_eq!(arm("UR5e"), Some("ur5e"));
        assert_eq!(arm("UR5"), None);
    }
}
