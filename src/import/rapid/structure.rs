//! The shape of a module: its name, its declarations, and its routines as lists of statements
//! (token ranges), with block headers (`IF … THEN`, `CASE 1:`) skipped and their nesting
//! bounded by [`MAX_BLOCK_NESTING`].

use super::MAX_BLOCK_NESTING;
use super::lexer::{K, Tok, closing, is_kw, lex, scan_statement, statement_end};
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
    pub(super) collect: bool,
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
    let err = |i: usize, msg: &str| {
        let at = toks.get(i).map(|t| t.at).unwrap_or(file.text.len());
        ImportError::syntax(file.name, m.lines.locate(file.text, at), msg)
    };
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
    let mut i = 0;
    while i < n {
        let t = toks[i];
        if t.k == K::Semi {
            i += 1;
            continue;
        }
        let word = if t.k == K::Ident {
            t.s.to_ascii_uppercase()
        } else {
            String::new()
        };
        match word.as_str() {
            "MODULE" => {
                blocks = 0;
                match toks.get(i + 1) {
                    Some(name) if name.k == K::Ident => m.name = name.s.to_string(),
                    _ => return Err(err(i + 1, "MODULE must be followed by its name")),
                }
                i += 2;
                if toks.get(i).is_some_and(|t| t.k == K::LParen) {
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed module attributes"))?
                        + 1;
                }
            }
            "LOCAL" | "TASK" | "SYSMODULE" | "NOSTEPIN" | "VIEWONLY" | "READONLY" | "NOVIEW" => {
                local |= word == "LOCAL";
                i += 1;
            }
            "PROC" | "TRAP" | "FUNC" => {
                if let Some(r) = routine.take() {
                    m.routines.push(r);
                }
                let name_at = if word == "FUNC" { i + 2 } else { i + 1 };
                let name = match toks.get(name_at) {
                    Some(t) if t.k == K::Ident => t.s.to_string(),
                    _ => {
                        return Err(err(
                            name_at,
                            &format!("{word} must be followed by its name"),
                        ));
                    }
                };
                i = name_at + 1;
                if word != "TRAP" {
                    if !toks.get(i).is_some_and(|t| t.k == K::LParen) {
                        return Err(err(
                            i,
                            &format!("{word} {name}: expected '(' and parameters"),
                        ));
                    }
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed parameter list"))? + 1;
                }
                routine = Some(RoutineAst {
                    name,
                    line: m.lines.line(t.at),
                    collect: word != "FUNC",
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
                i += 1;
            }
            "ENDMODULE" => {
                blocks = 0;
                i += 1;
            }
            "ENDIF" | "ENDWHILE" | "ENDFOR" | "ENDTEST" => {
                blocks = blocks.saturating_sub(1);
                i += 1;
            }
            "ELSE" => i += 1,
            "ERROR" | "BACKWARD" | "UNDO" if routine.is_some() => {
                in_error = true;
                i += 1;
                if toks.get(i).is_some_and(|t| t.k == K::LParen) {
                    i = closing(toks, i, n).ok_or_else(|| err(i, "unclosed error number list"))?
                        + 1;
                }
            }
            "RECORD" => {
                while i < n && !is_kw(toks.get(i), "ENDRECORD") {
                    i += 1;
                }
                i += 1;
            }
            "IF" | "ELSEIF" | "WHILE" | "FOR" => {
                if let (Some(r), true) = (routine.as_mut(), word == "FOR") {
                    r.stmts.push(Stmt {
                        start: i,
                        end: i,
                        in_error_handler: in_error,
                        local: false,
                        loop_var: toks.get(i + 1).map(|t| t.s.to_ascii_lowercase()),
                    });
                }
                // Skip the condition up to THEN/DO; a compact IF (no THEN) is one statement.
                let head =
                    scan_statement(toks, i, |t| is_kw(Some(t), "THEN") || is_kw(Some(t), "DO"));
                match head {
                    Ok(j) => {
                        if word != "ELSEIF" {
                            open_block(&mut blocks, t.at)?;
                        }
                        i = j + 1;
                    }
                    Err(end) => i = end + 1,
                }
            }
            "TEST" => {
                open_block(&mut blocks, t.at)?;
                i += 1;
                while i < n && !is_kw(toks.get(i), "CASE") && !is_kw(toks.get(i), "DEFAULT") {
                    i += 1;
                }
            }
            "CASE" | "DEFAULT" => match scan_statement(toks, i, |t| t.k == K::Colon) {
                Ok(j) | Err(j) => i = j + 1,
            },
            _ if t.k == K::Ident && toks.get(i + 1).is_some_and(|t| t.k == K::Colon) => {
                i += 2; // label
            }
            _ => {
                let end = statement_end(toks, i);
                let st = Stmt {
                    start: i,
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
                i = end + 1;
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
