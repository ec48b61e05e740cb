//! The token type, tokenising loop and token cursor the three parsers share. Each language has
//! its own `logos` token kinds; what a token is — a kind, its text and where it starts in the
//! file —, how a piece of text becomes tokens, and how a parser steps through them (look ahead,
//! step over, test a keyword, name the offset an error is reported at) is the same for all of
//! them.

use logos::Logos;

/// One token: its kind, its text, and the byte offset of its first character in the file.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tok<'s, K> {
    pub k: K,
    pub s: &'s str,
    pub at: usize,
}

/// A language's token kinds, as far as the shared reading needs them.
pub(crate) trait Kind: Copy + PartialEq {
    /// The kind of identifiers (and so of keywords).
    const IDENT: Self;
}

impl<K: Kind> Tok<'_, K> {
    /// Whether the token is the keyword `kw` (keywords are case-insensitive in all three).
    pub(crate) fn is_kw(&self, kw: &str) -> bool {
        self.k == K::IDENT && self.s.eq_ignore_ascii_case(kw)
    }

    /// An identifier's text in upper case, for matching keywords and case-insensitive names.
    pub(crate) fn word(&self) -> Option<String> {
        (self.k == K::IDENT).then(|| self.s.to_ascii_uppercase())
    }
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

/// A reading position in a slice of tokens. Every step is constant time; the helpers that scan
/// ahead ([`Cursor::find`]) scan from the position only, so a parser that moves on past what it
/// scanned stays linear.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cursor<'t, 's, K> {
    toks: &'t [Tok<'s, K>],
    pos: usize,
}

impl<'t, 's, K: Kind> Cursor<'t, 's, K> {
    pub(crate) fn new(toks: &'t [Tok<'s, K>]) -> Self {
        Cursor { toks, pos: 0 }
    }

    /// Index of the next token in the slice (it may be past the end).
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// Moves to index `pos` (where a helper that scanned a range says to go on).
    pub(crate) fn seek(&mut self, pos: usize) {
        self.pos = pos;
    }

    /// Steps over `n` tokens.
    pub(crate) fn skip(&mut self, n: usize) {
        self.pos += n;
    }

    /// Whether no token is left.
    pub(crate) fn at_end(&self) -> bool {
        self.pos >= self.toks.len()
    }

    /// The token `n` places ahead (0: the next one).
    pub(crate) fn peek(&self, n: usize) -> Option<&'t Tok<'s, K>> {
        self.toks.get(self.pos + n)
    }

    /// Whether the token `n` places ahead is of kind `k`.
    pub(crate) fn is(&self, n: usize, k: K) -> bool {
        self.peek(n).is_some_and(|t| t.k == k)
    }

    /// Whether the token `n` places ahead is the keyword `kw`.
    pub(crate) fn is_kw(&self, n: usize, kw: &str) -> bool {
        self.peek(n).is_some_and(|t| t.is_kw(kw))
    }

    /// The token `n` places ahead as an upper-case word, if it is an identifier.
    pub(crate) fn word(&self, n: usize) -> Option<String> {
        self.peek(n).and_then(Tok::word)
    }

    /// The token `n` places ahead if it is of kind `k`.
    pub(crate) fn expect(&self, n: usize, k: K) -> Option<&'t Tok<'s, K>> {
        self.peek(n).filter(|t| t.k == k)
    }

    /// The tokens from `n` places ahead to the end.
    pub(crate) fn rest(&self, n: usize) -> &'t [Tok<'s, K>] {
        self.toks.get(self.pos + n..).unwrap_or(&[])
    }

    /// Index of the first token of kind `k` from the position on.
    pub(crate) fn find(&self, k: K) -> Option<usize> {
        self.rest(0)
            .iter()
            .position(|t| t.k == k)
            .map(|j| self.pos + j)
    }

    /// Takes the tokens up to index `end` (exclusive) and moves there.
    pub(crate) fn take_to(&mut self, end: usize) -> &'t [Tok<'s, K>] {
        let taken = self.toks.get(self.pos..end).unwrap_or(&[]);
        self.pos = end;
        taken
    }

    /// Byte offset in the file of the token `n` places ahead, or `end` when there is none:
    /// where an error about it is reported (`LineIndex::locate` makes it file:line:column).
    pub(crate) fn offset(&self, n: usize, end: usize) -> usize {
        self.peek(n).map_or(end, |t| t.at)
    }
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

    impl Kind for K {
        const IDENT: K = K::Word;
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

    #[test]
    fn cursor_looks_ahead_steps_and_names_offsets() {
        let toks = tokens("ab ? c de", 0, K::Other);
        let mut c = Cursor::new(&toks);
        assert!(c.is_kw(0, "AB") && c.is(1, K::Other) && !c.is(1, K::Word));
        assert_eq!(c.word(2).as_deref(), Some("C"));
        assert_eq!(c.find(K::Other), Some(1));
        c.skip(1);
        assert_eq!(c.expect(0, K::Other).map(|t| t.at), Some(3));
        assert_eq!(c.take_to(3).len(), 2);
        assert_eq!((c.pos(), c.rest(0).len(), c.offset(0, 99)), (3, 1, 7));
        c.skip(1);
        assert!(c.at_end() && c.peek(0).is_none() && c.find(K::Word).is_none());
        assert_eq!((c.offset(0, 99), c.peek(1).map(|t| t.s)), (99, None));
        c.skip(1);
        assert_eq!((c.rest(0).len(), c.take_to(9).len()), (0, 0));
    }
}
