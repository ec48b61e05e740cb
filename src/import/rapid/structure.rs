//! The shape of a module: its name, its declarations, and its routines as lists of statements
//! (token ranges), with block headers (`IF … THEN`, `CASE 1:`) skipped and their nesting
//! bounded by [`MAX_BLOCK_NESTING`].

use super::MAX_BLOCK_NESTING;
use super::lexer::{Cursor, K, Tok, closing, lex, scan_statement, statement_end};
use crate::import::{ImportError, LineIndex, SourceFile, stem_of};

/// A statement: a token range, its routine part.
#[derive(Debug, Clone)]
pub(super) struct Stmt {
    pub(super) start: usize,
    pub(super) end: usize,
    pub(super) in_error_handler: bool,
    pub(super) local: bool,
    /// A `FOR` loop's variable: from here on its value is only known at run time.
    pub(super) loop_var: Option<String>,
}

#[derive(Debug)]
pub(super) struct RoutineAst {
    pub(super) name: String,
    pub(super) line: usize,
    /// A `FUNC`: imported like a `PROC` when it moves the arm (see [`super::parse`]).
    pub(super) function: bool,
    pub(super) stmts: Vec<Stmt>,
}

pub(super) struct ModuleAst<'s> {
    pub(super) file: SourceFile<'s>,
    pub(super) name: String,
    pub(super) toks: Vec<Tok<'s>>,
    pub(super) lines: LineIndex,
    pub(super) decls: Vec<Stmt>,
    pub(super) routines: Vec<RoutineAst>,
}

/// Splits a module into declarations and routines.
pub(super) fn structure(file: SourceFile<'_>) -> Result<ModuleAst<'_>, ImportError> {
    let toks = lex(file.text);
    let lines = LineIndex::new(file.text);
    let mut m = ModuleAst {
        file,
        name: stem_of(file.name).to_string(),
        toks,
        lines,
        decls: Vec::new(),
        routines: Vec::new(),
    };
    let toks = &m.toks;
    let n = toks.len();
    // Errors name the token they are about, or the end of the file past the last one.
    let eof = file.text.len();
    let err =
        |at: usize, msg: &str| ImportError::syntax(file.name, m.lines.locate(file.text, at), msg);
    let mut routine: Option<RoutineAst> = None;
    let mut in_error = false;
    let mut local = false;
    // Blocks open in the current routine (a routine, module or file boundary closes them all,
    // so a missing ENDIF in one routine does not count against the next).
    let mut blocks: usize = 0;
    let open_block = |blocks: &mut usize, at: usize| {
        *blocks += 1;
        if *blocks > MAX_BLOCK_NESTING {
            let loc = m.lines.locate(file.text, at);
            return Err(ImportError::NestingTooDeep {
                file: file.name.to_string(),
                line: loc.line,
                column: loc.column,
                limit: MAX_BLOCK_NESTING,
            });
        }
        Ok(())
    };
    let mut c = Cursor::new(toks);
    while let Some(&t) = c.peek(0) {
        if t.k == K::Semi {
            c.skip(1);
            continue;
        }
        let word = t.word().unwrap_or_default();
        match word.as_str() {
            "MODULE" => {
                blocks = 0;
                match c.expect(1, K::Ident) {
                    Some(name) => m.name = name.s.to_string(),
                    None => {
                        return Err(err(c.offset(1, eof), "MODULE must be followed by its name"));
                    }
                }
                c.skip(2);
                if c.is(0, K::LParen) {
                    let close = closing(toks, c.pos(), n)
                        .ok_or_else(|| err(c.offset(0, eof), "unclosed module attributes"))?;
                    c.seek(close + 1);
                }
            }
            "LOCAL" | "TASK" | "SYSMODULE" | "NOSTEPIN" | "VIEWONLY" | "READONLY" | "NOVIEW" => {
                local |= word == "LOCAL";
                c.skip(1);
            }
            "PROC" | "TRAP" | "FUNC" => {
                if let Some(r) = routine.take() {
                    m.routines.push(r);
                }
                let name_at = if word == "FUNC" { 2 } else { 1 };
                let name = match c.expect(name_at, K::Ident) {
                    Some(t) => t.s.to_string(),
                    None => {
                        return Err(err(
                            c.offset(name_at, eof),
                            &format!("{word} must be followed by its name"),
                        ));
                    }
                };
                c.skip(name_at + 1);
                if word != "TRAP" {
                    if !c.is(0, K::LParen) {
                        return Err(err(
                            c.offset(0, eof),
                            &format!("{word} {name}: expected '(' and parameters"),
                        ));
                    }
                    let close = closing(toks, c.pos(), n)
                        .ok_or_else(|| err(c.offset(0, eof), "unclosed parameter list"))?;
                    c.seek(close + 1);
                }
                routine = Some(RoutineAst {
                    name,
                    line: m.lines.line(t.at),
                    function: word == "FUNC",
                    stmts: Vec::new(),
                });
                in_error = false;
                local = false;
                blocks = 0;
            }
            "ENDPROC" | "ENDTRAP" | "ENDFUNC" => {
                if let Some(r) = routine.take() {
                    m.routines.push(r);
                }
                in_error = false;
                blocks = 0;
                c.skip(1);
            }
            "ENDMODULE" => {
                blocks = 0;
                c.skip(1);
            }
            "ENDIF" | "ENDWHILE" | "ENDFOR" | "ENDTEST" => {
                blocks = blocks.saturating_sub(1);
                c.skip(1);
            }
            "ELSE" => c.skip(1),
            "ERROR" | "BACKWARD" | "UNDO" if routine.is_some() => {
                in_error = true;
                c.skip(1);
                if c.is(0, K::LParen) {
                    let close = closing(toks, c.pos(), n)
                        .ok_or_else(|| err(c.offset(0, eof), "unclosed error number list"))?;
                    c.seek(close + 1);
                }
            }
            "RECORD" => {
                while !c.at_end() && !c.is_kw(0, "ENDRECORD") {
                    c.skip(1);
                }
                c.skip(1);
            }
            "IF" | "ELSEIF" | "WHILE" | "FOR" => {
                if let (Some(r), true) = (routine.as_mut(), word == "FOR") {
                    r.stmts.push(Stmt {
                        start: c.pos(),
                        end: c.pos(),
                        in_error_handler: in_error,
                        local: false,
                        loop_var: c.peek(1).map(|t| t.s.to_ascii_lowercase()),
                    });
                }
                // Skip the condition up to THEN/DO; a compact IF (no THEN) is one statement.
                let head = scan_statement(toks, c.pos(), |t| t.is_kw("THEN") || t.is_kw("DO"));
                match head {
                    Ok(j) => {
                        if word != "ELSEIF" {
                            open_block(&mut blocks, t.at)?;
                        }
                        c.seek(j + 1);
                    }
                    Err(end) => c.seek(end + 1),
                }
            }
            "TEST" => {
                open_block(&mut blocks, t.at)?;
                c.skip(1);
                while !c.at_end() && !c.is_kw(0, "CASE") && !c.is_kw(0, "DEFAULT") {
                    c.skip(1);
                }
            }
            "CASE" | "DEFAULT" => match scan_statement(toks, c.pos(), |t| t.k == K::Colon) {
                Ok(j) | Err(j) => c.seek(j + 1),
            },
            _ if t.k == K::Ident && c.is(1, K::Colon) => {
                c.skip(2); // label
            }
            _ => {
                let end = statement_end(toks, c.pos());
                let st = Stmt {
                    start: c.pos(),
                    end,
                    in_error_handler: in_error,
                    local,
                    loop_var: None,
                };
                match routine.as_mut() {
                    Some(r) => r.stmts.push(st),
                    None => m.decls.push(st),
                }
                local = false;
                c.seek(end + 1);
            }
        }
    }
    if let Some(r) = routine.take() {
        m.routines.push(r);
    }
    Ok(m)
}

/// Source text of a token range.
pub(super) fn text_of<'s>(m: &ModuleAst<'s>, a: usize, b: usize) -> &'s str {
    let (Some(first), Some(last)) = (m.toks.get(a), b.checked_sub(1).and_then(|l| m.toks.get(l)))
    else {
        return "";
    };
    m.file
        .text
        .get(first.at..last.at + last.s.len())
        .unwrap_or("")
}
