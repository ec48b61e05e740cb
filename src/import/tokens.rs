//! The token type and tokenising loop the three parsers share. Each language has its own
//! `logos` token kinds; what a token is — a kind, its text and where it starts in the file — and
//! how a piece of text becomes tokens is the same for all of them.

use logos::Logos;

/// One token: its kind, its text, and the byte offset of its first character in the file.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tok<'s, K> {
    pub k: K,
    pub s: &'s str,
    pub at: usize,
}

/// The tokens of `text`, which starts at byte `offset` of its file; what the lexer cannot read
/// becomes `other` (the parsers decide what a stray character means).
pub(crate) fn tokens<'s, K>(text: &'s str, offset: usize, other: K) -> Vec<Tok<'s, K>>
where
    K: Logos<'s, Source = str> + Copy,
    K::Extras: Default,
{
    let mut lexer = K::lexer(text);
    let mut out = Vec::new();
    while let Some(r) = lexer.next() {
        out.push(Tok {
            k: r.unwrap_or(other),
            s: lexer.slice(),
            at: offset + lexer.span().start,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Logos, Debug, Clone, Copy, PartialEq, Eq)]
    #[logos(skip r" +")]
    enum K {
        #[regex(r"[a-z]+")]
        Word,
        Other,
    }

    #[test]
    fn tokens_carry_kind_text_and_file_offset() {
        let toks = tokens("ab ?c", 10, K::Other);
        let got: Vec<_> = toks.iter().map(|t| (t.k, t.s, t.at)).collect();
        assert_eq!(
            got,
            [(K::Word, "ab", 10), (K::Other, "?", 13), (K::Word, "c", 14)]
        );
    }
}
