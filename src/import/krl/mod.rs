//! KUKA KRL programs: a `.src` (code) with the `.dat` of the same name (its data list).
//!
//! KRL is line-oriented: each line (minus its `;` comment) is tokenised with a `logos` lexer
//! and matched on its leading tokens. Declarations (`DECL [GLOBAL] E6POS|POS|FRAME name={…}`,
//! in the `.dat` or at the top of a `DEF`) bind names; `E6AXIS`/`AXIS` ones are remembered as
//! joint-space so moves to them are counted as such. Arrays of positions (`DECL FRAME f[12]`)
//! bind each element the data list initialises (`f[1]={X 10,…}`). Motions are `PTP`, `LIN`,
//! `CIRC aux, end` and their `_REL` forms, with a named target, an array element with constant
//! indices (`f[2]`), an inline aggregate `{X …, Y …, …}`, or such operands joined by the
//! geometric operator (`f[2]:{X 0,Y 4,…}`: the right frame given in the left one, the product of
//! their transforms, with the right operand's Status and Turn). An element indexed by a variable,
//! or never initialised in the data list, is only known at run time and is skipped as such.
//!
//! `A B C` are ZYX Euler angles in degrees (`R = Rz(A)·Ry(B)·Rx(C)`); `S` (Status) and `T`
//! (Turn) are kept. Names are case-insensitive. An inline aggregate missing any of `X Y Z A B C`
//! takes the rest from the robot's position at run time and is skipped; `_REL` moves resolve
//! against the previous waypoint of the routine (`#BASE` unless `#TOOL` is given).
//!
//! One file per step: [`lexer`] (tokens, a line at a time), [`data`] (declarations and the
//! data list's positions), [`motions`] (routines and their motion instructions → waypoints and
//! skip records), [`targets`] (a motion's target: names, array elements, aggregates, the
//! geometric operator, `_REL` moves).

mod data;
mod lexer;
mod motions;
mod targets;

use std::collections::{HashMap, HashSet};

use super::{
    ImportError, ImportReport, Imported, LineIndex, SkipReason, Skipped, SourceFile, directory_of,
    drop_short_routines, stem_of,
};
use crate::program::Language;
use data::{Value, declaration, element};
use lexer::lines_of;
use motions::routines;

/// What pairs a `.src` with its `.dat`: the directory and the stem, case-insensitive.
fn key<'s>(f: &SourceFile<'s>) -> (&'s str, String) {
    (directory_of(f.name), stem_of(f.name).to_ascii_lowercase())
}

/// Parses the KRL files of an upload: one program per `.src`, with its `.dat`.
pub(crate) fn parse(
    files: &[SourceFile<'_>],
    report: &mut ImportReport,
) -> Result<(), ImportError> {
    // A `.src` and a `.dat` pair when directory and stem (case-insensitive) agree; keyed once,
    // so an upload of many files pairs in linear time.
    let is_ext = |f: &SourceFile<'_>, e: &str| f.name.to_ascii_lowercase().ends_with(e);
    let (srcs, dats): (Vec<&SourceFile<'_>>, Vec<&SourceFile<'_>>) = files
        .iter()
        .filter(|f| is_ext(f, ".src") || is_ext(f, ".dat"))
        .partition(|f| is_ext(f, ".src"));
    let mut dat_of: HashMap<(&str, String), &SourceFile<'_>> = HashMap::new();
    for d in &dats {
        dat_of.entry(key(d)).or_insert(d);
    }
    let src_keys: HashSet<(&str, String)> = srcs.iter().map(|s| key(s)).collect();
    for src in srcs {
        let dat = dat_of.get(&key(src)).copied();
        let mut names: HashMap<String, Value> = HashMap::new();
        if let Some(dat) = dat {
            let idx = LineIndex::new(dat.text);
            for line in lines_of(dat) {
                if !declaration(dat, &idx, &line.toks, &mut names)? {
                    element(dat, &idx, &line.toks, &mut names)?;
                }
            }
        }
        let routines = routines(src, &names, &mut report.skipped)?;
        let routines = drop_short_routines(routines, &mut report.skipped);
        report.programs.push(Imported::of(
            stem_of(src.name),
            src.name,
            Language::Krl,
            routines,
        ));
    }
    for dat in dats {
        if !src_keys.contains(&key(dat)) {
            report.skipped.push(Skipped {
                file: dat.name.to_string(),
                line: 1,
                routine: None,
                reason: SkipReason::DataOnly,
                text: dat.name.to_string(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
