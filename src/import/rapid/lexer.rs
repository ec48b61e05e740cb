//! RAPID tokens and the token-range helpers the other passes share: where a statement ends,
//! which bracket closes which, how a range splits into arguments.
//!
//! Every helper scans forward from where it is asked, stops as soon as it knows the answer and,
//! where it is given one, stays inside the statement's range: a header or a bracket never costs
//! the rest of the file.

use logos::Logos;

use crate::import::tokens::{Kind, tokens};

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t\r\n\f]+")]
#[logos(skip(r"![^\n]*", allow_greedy = true))]
pub(super) enum K {
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r#""([^"\n]|"")*""#)]
    Str,
    #[token(":=")]
    Assign,
    #[token("[")]
    LBrack,
    #[token("]")]
    RBrack,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token(":")]
    Colon,
    #[token("\\")]
    Backslash,
    #[token(".")]
    Dot,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    /// Anything else (operators the importer does not evaluate, stray characters).
    Other,
}

impl Kind for K {
    const IDENT: K = K::Ident;
}

pub(super) type Tok<'s> = crate::import::tokens::Tok<'s, K>;
pub(super) type Cursor<'t, 's> = crate::import::tokens::Cursor<'t, 's, K>;

pub(super) fn lex(text: &str) -> Vec<Tok<'_>> {
    // A `%%% VERSION:1 LANGUAGE:ENGLISH %%%` header (RobotWare 5 files) is not RAPID.
    let start = text
        .trim_start()
        .strip_prefix("%%%")
        .and_then(|rest| rest.find("%%%").map(|i| text.len() - rest.len() + i + 3))
        .unwrap_or(0);
    tokens(text.get(start..).unwrap_or(""), start, K::Other)
}

/// Index of the `;` ending the statement starting at `i` (or of the block keyword that cuts a
/// statement missing its `;`, or the end of input), at bracket depth 0.
pub(super) fn statement_end(toks: &[Tok<'_>], i: usize) -> usize {
    match scan_statement(toks, i, |_| false) {
        Ok(j) | Err(j) => j,
    }
}

/// Scans the statement starting at `i` up to its first token that `stop` accepts: `Ok` with
/// that token's index, or `Err` with the statement's end (see [`statement_end`]) when there is
/// none. It stops *at* the match, so reading a block header (`IF c THEN`, `CASE 1:`) costs the
/// tokens of the header, not those of the nested body up to the first `;` — which, read from
/// every opener of a deeply nested file, made parsing time grow with the square of the depth.
pub(super) fn scan_statement(
    toks: &[Tok<'_>],
    i: usize,
    mut stop: impl FnMut(&Tok<'_>) -> bool,
) -> Result<usize, usize> {
    let mut depth: usize = 0;
    let mut j = i;
    while let Some(t) = toks.get(j) {
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => depth = depth.saturating_sub(1),
            K::Semi if depth == 0 => return Err(j),
            K::Ident if j > i && depth == 0 => {
                const CUT: &[&str] = &[
                    "ENDPROC",
                    "ENDFUNC",
                    "ENDTRAP",
                    "ENDMODULE",
                    "PROC",
                    "FUNC",
                    "TRAP",
                ];
                if CUT.iter().any(|c| t.s.eq_ignore_ascii_case(c)) {
                    return Err(j.saturating_sub(1).max(i));
                }
            }
            _ => {}
        }
        if stop(t) {
            return Ok(j);
        }
        j += 1;
    }
    Err(toks.len())
}

/// Index of the bracket closing the one at `i`, if it is before `end`.
pub(super) fn closing(toks: &[Tok<'_>], i: usize, end: usize) -> Option<usize> {
    let mut depth: usize = 0;
    let within = toks.get(..end.min(toks.len())).unwrap_or(toks);
    for (j, t) in within.iter().enumerate().skip(i) {
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return Some(j);
                }
            }
            _ => {}
        }
    }
    None
}

/// Splits `toks[start..end]` at depth-0 `sep` tokens.
pub(super) fn split_top(toks: &[Tok<'_>], start: usize, end: usize, sep: K) -> Vec<(usize, usize)> {
    let mut parts = Vec::new();
    let mut depth: usize = 0;
    let mut from = start;
    for j in start..end {
        let Some(t) = toks.get(j) else { break };
        match t.k {
            K::LBrack | K::LParen | K::LBrace => depth += 1,
            K::RBrack | K::RParen | K::RBrace => depth = depth.saturating_sub(1),
            k if k == sep && depth == 0 => {
                parts.push((from, j));
                from = j + 1;
            }
            _ => {}
        }
    }
    parts.push((from, end));
    parts
}

/// Arguments of a procedure or function call: positional ranges, and optional `\Name[:=value]`.
pub(super) struct Args {
    pub(super) positional: Vec<(usize, usize)>,
    pub(super) optional: Vec<(String, Option<(usize, usize)>)>,
}

pub(super) fn arguments(toks: &[Tok<'_>], start: usize, end: usize) -> Args {
    let mut args = Args {
        positional: Vec::new(),
        optional: Vec::new(),
    };
    if start >= end {
        return args;
    }
    for (a, b) in split_top(toks, start, end, K::Comma) {
        let pieces = split_top(toks, a, b, K::Backslash);
        for (n, (pa, pb)) in pieces.into_iter().enumerate() {
            if n == 0 {
                if pb > pa {
                    args.positional.push((pa, pb));
                }
                continue;
            }
            let Some(name) = toks.get(pa).filter(|t| t.k == K::Ident) else {
                continue;
            };
            let value = toks
                .get(pa + 1)
                .filter(|t| t.k == K::Assign)
                .map(|_| (pa + 2, pb));
            args.optional.push((name.s.to_string(), value));
        }
    }
    args
}
