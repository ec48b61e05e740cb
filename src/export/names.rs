//! Names in the exported files: which names a target language accepts as they are, and a
//! deterministic valid name for everything else.
//!
//! A name is kept exactly when it is an identifier of the language (letters, digits and `_`,
//! starting with a letter, not longer than the language allows, not a reserved word, not
//! already taken by something else in the same namespace). Anything else gets a name made from
//! it: characters other than ASCII letters, digits and `_` become `_`, runs of `_` collapse,
//! leading/trailing `_` go, a `p` goes in front when it would not start with a letter, it is
//! cut to the length limit, and `_2`, `_3`, … is appended until it is free. So
//! `Offs(p10,0,0,50)` becomes `Offs_p10_0_0_50`, `literal@L12` becomes `literal_L12`, and a
//! second export of the result keeps it (a fixpoint).

use std::collections::{HashMap, HashSet};

use super::ExportWarning;
use crate::program::{Program, Routine, Waypoint};

/// What one language accepts as a name.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rules {
    /// Longest accepted name, in characters.
    pub max_len: usize,
    /// Reserved words, upper case (names compare case-insensitively in all three languages).
    pub reserved: &'static [&'static str],
    /// Whether names are upper case only (FANUC program names).
    pub upper_only: bool,
}

/// RAPID reserved words (ABB, *RAPID overview*, "Reserved words").
pub(crate) const RAPID_RESERVED: &[&str] = &[
    "ALIAS",
    "AND",
    "BACKWARD",
    "CASE",
    "CONNECT",
    "CONST",
    "DEFAULT",
    "DIV",
    "DO",
    "ELSE",
    "ELSEIF",
    "ENDFOR",
    "ENDFUNC",
    "ENDIF",
    "ENDMODULE",
    "ENDPROC",
    "ENDRECORD",
    "ENDTEST",
    "ENDTRAP",
    "ENDWHILE",
    "ERROR",
    "EXIT",
    "FALSE",
    "FOR",
    "FROM",
    "FUNC",
    "GOTO",
    "IF",
    "INOUT",
    "LOCAL",
    "MOD",
    "MODULE",
    "NOSTEPIN",
    "NOT",
    "NOVIEW",
    "OR",
    "PERS",
    "PROC",
    "RAISE",
    "READONLY",
    "RECORD",
    "RETRY",
    "RETURN",
    "STEP",
    "SYSMODULE",
    "TEST",
    "THEN",
    "TO",
    "TRAP",
    "TRUE",
    "TRYNEXT",
    "UNDO",
    "VAR",
    "VIEWONLY",
    "WHILE",
    "WITH",
    "XOR",
];

/// KRL keywords and predefined type names a user name must not take.
pub(crate) const KRL_RESERVED: &[&str] = &[
    "AND",
    "ANIN",
    "ANOUT",
    "AXIS",
    "BAS",
    "C_DIS",
    "C_ORI",
    "C_PTP",
    "C_VEL",
    "B_AND",
    "B_EXOR",
    "B_NOT",
    "B_OR",
    "BOOL",
    "BRAKE",
    "CA",
    "CASE",
    "CHAR",
    "CIRC",
    "CIRC_REL",
    "CONST",
    "CONTINUE",
    "DECL",
    "DEF",
    "DEFAULT",
    "DEFDAT",
    "DEFFCT",
    "DELAY",
    "DISTANCE",
    "DO",
    "E6AXIS",
    "E6POS",
    "ELSE",
    "END",
    "ENDDAT",
    "ENDFCT",
    "ENDFOR",
    "ENDIF",
    "ENDLOOP",
    "ENDSWITCH",
    "ENDWHILE",
    "ENUM",
    "EXIT",
    "EXOR",
    "EXT",
    "EXTFCT",
    "FALSE",
    "FOR",
    "FRAME",
    "GLOBAL",
    "GOTO",
    "HALT",
    "IF",
    "IMPORT",
    "INT",
    "INTERRUPT",
    "IS",
    "LIN",
    "LIN_REL",
    "LOOP",
    "MAXIMUM",
    "MINIMUM",
    "NOT",
    "OR",
    "POS",
    "PRIO",
    "PTP",
    "PTP_REL",
    "PUBLIC",
    "REAL",
    "REPEAT",
    "RESUME",
    "RETURN",
    "SCIRC",
    "SEC",
    "SIGNAL",
    "SLIN",
    "SPTP",
    "STEP",
    "STRUC",
    "SWITCH",
    "THEN",
    "TO",
    "TRIGGER",
    "TRUE",
    "UNTIL",
    "WAIT",
    "WHEN",
    "WHILE",
    "WITH",
];

/// RAPID: identifiers of up to 32 characters (ABB, *RAPID overview*, "Identifiers").
pub(crate) const RAPID: Rules = Rules {
    max_len: 32,
    reserved: RAPID_RESERVED,
    upper_only: false,
};

/// KRL: names of up to 24 characters (KUKA, *KSS expert programming*, "Names").
pub(crate) const KRL: Rules = Rules {
    max_len: 24,
    reserved: KRL_RESERVED,
    upper_only: false,
};

/// FANUC TP program names: upper-case letters, digits and `_`, starting with a letter, up to
/// 36 characters (R-30iB; older controllers take 8).
pub(crate) const FANUC_PROGRAM: Rules = Rules {
    max_len: 36,
    reserved: &[],
    upper_only: true,
};

impl Rules {
    /// Whether `name` is an identifier of the language (taken names aside).
    pub fn is_valid(&self, name: &str) -> bool {
        let mut chars = name.chars();
        let Some(first) = chars.next() else {
            return false;
        };
        first.is_ascii_alphabetic()
            && name.chars().count() <= self.max_len
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !(self.upper_only && name.chars().any(|c| c.is_ascii_lowercase()))
            && !self.reserved.iter().any(|r| r.eq_ignore_ascii_case(name))
    }

    /// A valid name made from `raw` (not yet checked against taken names).
    pub fn sanitize(&self, raw: &str) -> String {
        let mut s = String::with_capacity(raw.len());
        for c in raw.chars() {
            let c = if c.is_ascii_alphanumeric() { c } else { '_' };
            if !(c == '_' && s.ends_with('_')) {
                s.push(c);
            }
        }
        let mut s = s.trim_matches('_').to_string();
        if self.upper_only {
            s = s.to_ascii_uppercase();
        }
        if !s.starts_with(|c: char| c.is_ascii_alphabetic()) {
            s.insert(0, if self.upper_only { 'P' } else { 'p' });
        }
        s.truncate(self.max_len);
        let s = s.trim_end_matches('_').to_string();
        if self.reserved.iter().any(|r| r.eq_ignore_ascii_case(&s)) {
            let mut t = format!("{s}_1");
            t.truncate(self.max_len);
            return t;
        }
        s
    }
}

/// One namespace: the names taken so far, compared case-insensitively.
#[derive(Debug, Clone)]
pub(crate) struct Namespace {
    rules: Rules,
    taken: HashSet<String>,
}

impl Namespace {
    pub fn new(rules: Rules) -> Namespace {
        Namespace {
            rules,
            taken: HashSet::new(),
        }
    }

    pub fn rules(&self) -> &Rules {
        &self.rules
    }

    /// Marks `name` as taken.
    pub fn reserve(&mut self, name: &str) {
        self.taken.insert(name.to_ascii_lowercase());
    }

    pub fn is_taken(&self, name: &str) -> bool {
        self.taken.contains(&name.to_ascii_lowercase())
    }

    /// `name` itself when it is valid and free, else a fresh name made from it; taken either way.
    pub fn claim(&mut self, name: &str) -> String {
        if self.rules.is_valid(name) && !self.is_taken(name) {
            self.reserve(name);
            return name.to_string();
        }
        self.fresh(name)
    }

    /// A free valid name made from `base` (see the module docs); taken.
    pub fn fresh(&mut self, base: &str) -> String {
        let base = self.rules.sanitize(base);
        if !self.is_taken(&base) {
            self.reserve(&base);
            return base;
        }
        for k in 2usize.. {
            let suffix = format!("_{k}");
            let keep = self.rules.max_len.saturating_sub(suffix.len());
            let head: String = base.chars().take(keep).collect();
            let candidate = format!("{}{suffix}", head.trim_end_matches('_'));
            if !self.is_taken(&candidate) {
                self.reserve(&candidate);
                return candidate;
            }
        }
        unreachable!("an unbounded counter finds a free name")
    }
}

/// The declarations of a module's targets and which one each waypoint uses.
#[derive(Debug, Clone, Default)]
pub(crate) struct Targets {
    /// Name and printed value of each declaration, in order of first use.
    pub decls: Vec<(String, String)>,
    /// Per routine, per waypoint: the index into `decls`.
    pub uses: Vec<Vec<usize>>,
}

impl Targets {
    /// The declared name of routine `routine`'s `index`-th waypoint ("" when there is none).
    pub fn name(&self, routine: usize, index: usize) -> &str {
        self.uses
            .get(routine)
            .and_then(|uses| uses.get(index))
            .and_then(|&d| self.decls.get(d))
            .map_or("", |(n, _)| n.as_str())
    }
}

/// Names the targets of a program whose positions share one namespace (a RAPID module, a KRL
/// data list). `value` is a waypoint's printed value: a waypoint whose original name and value
/// were seen before reuses that declaration; a valid name is kept for its first value, and
/// everything else gets a fresh name made from the original (or from `unnamed` and the
/// waypoint's 1-based number), with a warning. `routines` are the routines' exported names.
pub(crate) fn name_targets(
    ns: &mut Namespace,
    program: &Program<Waypoint>,
    routines: &[String],
    unnamed: &str,
    value: impl Fn(&Waypoint) -> String,
    warnings: &mut Vec<ExportWarning>,
) -> Targets {
    // Valid names are claimed first, so a made-up name never takes one a later waypoint has.
    let mut owned: HashSet<String> = HashSet::new();
    for w in program.routines.iter().flat_map(|r| &r.waypoints) {
        if let Some(n) = &w.name
            && ns.rules().is_valid(n)
            && !ns.is_taken(n)
        {
            ns.reserve(n);
            owned.insert(n.to_ascii_lowercase());
        }
    }
    let mut targets = Targets::default();
    let mut by_original: HashMap<(Option<String>, String), usize> = HashMap::new();
    let mut declared: HashSet<String> = HashSet::new();
    for (r, routine) in program.routines.iter().enumerate() {
        let routine_name = routines
            .get(r)
            .cloned()
            .unwrap_or_else(|| routine.name.clone());
        let mut uses = Vec::with_capacity(routine.waypoints.len());
        for (index, w) in routine.waypoints.iter().enumerate() {
            let v = value(w);
            let key = (w.name.clone(), v.clone());
            let decl = if let Some(&d) = by_original.get(&key) {
                d
            } else {
                let name = match &w.name {
                    Some(n)
                        if owned.contains(&n.to_ascii_lowercase())
                            && declared.insert(n.to_ascii_lowercase()) =>
                    {
                        n.clone()
                    }
                    Some(n) => ns.fresh(n),
                    None => ns.fresh(&format!("{unnamed}{}", index + 1)),
                };
                targets.decls.push((name, v));
                by_original.insert(key, targets.decls.len() - 1);
                targets.decls.len() - 1
            };
            let name = &targets.decls[decl].0;
            if w.name.as_deref() != Some(name.as_str()) {
                warnings.push(ExportWarning::RenamedTarget {
                    routine: routine_name.clone(),
                    seq: index + 1,
                    from: w.name.clone(),
                    to: name.clone(),
                });
            }
            uses.push(decl);
        }
        targets.uses.push(uses);
    }
    targets
}

/// The exported names of the routines (claimed in `ns`), with a warning for each one changed.
pub(crate) fn name_routines(
    ns: &mut Namespace,
    routines: &[Routine<Waypoint>],
    warnings: &mut Vec<ExportWarning>,
) -> Vec<String> {
    routines
        .iter()
        .enumerate()
        .map(|(index, r)| {
            let name = ns.claim(&r.name);
            if name != r.name {
                warnings.push(ExportWarning::RenamedRoutine {
                    position: index + 1,
                    from: r.name.clone(),
                    to: name.clone(),
                });
            }
            name
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn valid_names_are_kept_and_others_made_valid() {
        assert!(RAPID.is_valid("p10"));
        assert!(!RAPID.is_valid("10p"));
        assert!(!RAPID.is_valid("PROC"));
        assert!(!RAPID.is_valid(&"a".repeat(33)));
        assert_eq!(RAPID.sanitize("Offs(p10,0,0,50)"), "Offs_p10_0_0_50");
        assert_eq!(RAPID.sanitize("literal@L12"), "literal_L12");
        assert_eq!(RAPID.sanitize("P[3]"), "P_3");
        assert_eq!(RAPID.sanitize("{X 10, Y 0}"), "X_10_Y_0");
        assert_eq!(RAPID.sanitize("12"), "p12");
        assert_eq!(RAPID.sanitize(""), "p");
        assert_eq!(RAPID.sanitize("proc"), "proc_1");
        assert_eq!(FANUC_PROGRAM.sanitize("main"), "MAIN");
        for raw in [
            "Offs(p10,0,0,50)",
            "",
            "__",
            "ä",
            "PROC",
            &"x".repeat(80),
            "9",
        ] {
            for rules in [RAPID, KRL, FANUC_PROGRAM] {
                let s = rules.sanitize(raw);
                assert!(rules.is_valid(&s), "{raw:?} → {s:?}");
                assert_eq!(rules.sanitize(&s), s, "fixpoint");
            }
        }
    }

    #[test]
    fn taken_names_get_a_suffix() {
        let mut ns = Namespace::new(KRL);
        assert_eq!(ns.claim("XP1"), "XP1");
        assert_eq!(ns.claim("xp1"), "xp1_2");
        assert_eq!(ns.claim("XP1"), "XP1_3");
        let long = "A".repeat(24);
        assert_eq!(ns.claim(&long), long);
        assert_eq!(ns.claim(&long), format!("{}_2", "A".repeat(22)));
    }
}
