//! KRL's tokens: a line at a time, its `;` comment cut off (outside strings).

use logos::Logos;

use crate::import::SourceFile;
use crate::import::tokens::{Kind, tokens};

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
#[logos(skip r"[ \t\r\f]+")]
pub(super) enum K {
    #[regex(r"[$#A-Za-z_][A-Za-z0-9_$]*")]
    Ident,
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?")]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?")]
    Num,
    #[regex(r#""[^"\n]*""#)]
    Str,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBrack,
    #[token("]")]
    RBrack,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(",")]
    Comma,
    #[token("=")]
    Eq,
    #[token("-")]
    Minus,
    #[token("+")]
    Plus,
    /// The geometric operator (`base:pos`).
    #[token(":")]
    Colon,
    Other,
}

impl Kind for K {
    const IDENT: K = K::Ident;
}

pub(super) type Tok<'s> = crate::import::tokens::Tok<'s, K>;

fn lex_line(line: &str, offset: usize) -> Vec<Tok<'_>> {
    let mut in_str = false;
    let mut cut = line.len();
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_str = !in_str,
            ';' if !in_str => {
                cut = i;
                break;
            }
            _ => {}
        }
    }
    let code = line.get(..cut).unwrap_or("");
    tokens(code, offset, K::Other)
}

pub(super) struct Line<'s> {
    pub(super) no: usize,
    pub(super) toks: Vec<Tok<'s>>,
}

pub(super) fn lines_of<'s>(f: &SourceFile<'s>) -> Vec<Line<'s>> {
    let mut out = Vec::new();
    let mut offset = 0;
    for (n, raw) in f.text.split('\n').enumerate() {
        let toks = lex_line(raw, offset);
        offset += raw.len() + 1;
        if !toks.is_empty() {
            out.push(Line { no: n + 1, toks });
        }
    }
    out
}
