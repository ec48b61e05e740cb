//! ABB RAPID modules (`.mod`, `.modx`, `.prg`, `.sys`).
//!
//! A module is tokenised with a `logos` lexer (comments `!` to end of line, strings with `""`
//! escapes); the token stream is then split into the module's declarations and its routines'
//! statements. Targets are evaluated by a small expression evaluator that knows robtarget
//! aggregates, `Offs`, `RelTool` (`\Rx \Ry \Rz`), constant array indices and `num` arithmetic
//! over declared values. Control flow is not followed: statements are read in text order, and an
//! assignment to a target variable holds until the next one — a reading of the program as
//! written, which is what the operator taught.
//!
//! Routines are `PROC`s, `TRAP`s and `FUNC`s: a function that moves the arm (a calibration
//! routine that answers what it measured) is a path like any other; one without a motion
//! instruction only computes and is left out without a report.
//!
//! Names resolve first in the routine (its `VAR`s and assignments so far), then in the module,
//! then in the other modules of the upload (RAPID names are case-insensitive). A target that
//! can only be known at run time (function results, record fields, loop-dependent offsets, a
//! variable assigned from those) is skipped and reported.
//!
//! The passes, one file each: [`lexer`] (tokens and token-range helpers), [`structure`]
//! (declarations and routine statements), [`eval`] (values and expressions), [`resolve`]
//! (declarations, assignments and motions → waypoints and skip records).

mod eval;
mod lexer;
mod resolve;
mod structure;

use std::collections::HashMap;

use super::{ImportError, ImportReport, Imported, ReadRoutine, SourceFile, drop_short_routines};
use crate::program::Language;
use eval::Binding;
use resolve::{eval_decl, is_motion, routine_stmt};
use structure::structure;

/// Deepest nesting of blocks (`IF … THEN`, `WHILE`, `FOR`, `TEST`) in a routine that is read;
/// a file nested deeper is refused with [`ImportError::NestingTooDeep`]. Taught programs nest a
/// handful of levels; the limit bounds what an upload can ask of the parser.
pub const MAX_BLOCK_NESTING: usize = 256;

/// Parses the RAPID modules of an upload, resolving targets across them.
pub(crate) fn parse(
    files: &[SourceFile<'_>],
    report: &mut ImportReport,
) -> Result<(), ImportError> {
    let modules = files
        .iter()
        .map(|f| structure(*f))
        .collect::<Result<Vec<_>, _>>()?;

    // Module-level declarations, twice so that forward references across modules resolve.
    let mut module_envs: Vec<HashMap<String, Binding>> = vec![HashMap::new(); modules.len()];
    let mut global: HashMap<String, Binding> = HashMap::new();
    for _ in 0..2 {
        for (mi, m) in modules.iter().enumerate() {
            for d in &m.decls {
                let Some((name, binding)) = eval_decl(m, d, &[&module_envs[mi], &global])? else {
                    continue;
                };
                if !d.local {
                    global
                        .entry(name.clone())
                        .or_insert_with(|| binding.clone());
                    if let Some(b) = global.get_mut(&name)
                        && *b == Binding::RunTime
                    {
                        *b = binding.clone();
                    }
                }
                module_envs[mi].insert(name, binding);
            }
        }
    }

    for (mi, m) in modules.iter().enumerate() {
        let mut routines = Vec::new();
        for r in &m.routines {
            // A FUNC that issues no motion computes a value: no path, nothing to report.
            if r.function && !r.stmts.iter().any(|st| is_motion(m, st)) {
                continue;
            }
            let mut locals: HashMap<String, Binding> = HashMap::new();
            let mut routine = ReadRoutine::new(r.name.clone(), m.file.name, r.line);
            for st in &r.stmts {
                let envs = [&module_envs[mi], &global];
                routine_stmt(
                    m,
                    r,
                    st,
                    &mut locals,
                    &envs,
                    &mut routine,
                    &mut report.skipped,
                )?;
            }
            routines.push(routine);
        }
        let routines = drop_short_routines(routines, &mut report.skipped);
        report.programs.push(Imported::of(
            &m.name,
            m.file.name,
            Language::Rapid,
            routines,
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{CircleRole, SkipReason, parse_files};
    use crate::program::{Configuration, Motion, RapidConfdata};

    const MODULE: &str = r#"MODULE Demo
    CONST robtarget p10:=[[100,0,50],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget ps{2}:=[[[1,2,3],[1,0,0,0],[0,-1,2,1],[9E9,9E9,9E9,9E9,9E9,9E9]],
                            [[4,5,6],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];
    CONST num dz:=25;
    PROC main()
        MoveJ p10, v100, z10, tool0;
        MoveL Offs(p10, 0, 0, dz*2), v100, fine, tool0\WObj:=wobj1;
        MoveL RelTool(p10, 10, 0, 0 \Rz:=90), v100, fine, tool0;
        MoveC ps{1}, ps{2}, v100, z10, tool0;
        MoveAbsJ jHome, v100, fine, tool0;
        MoveL CRobT(), v100, fine, tool0;
    ERROR
        MoveL p10, v100, fine, tool0;
    ENDPROC
ENDMODULE
"#;

    #[test]
    fn reads_targets_offsets_reltool_circles_and_skips() {
        let report = parse_files(&[("Demo.mod", MODULE)]).unwrap();
        let (r, at) = (
            &report.programs[0].program.routines[0],
            &report.programs[0].origins[0],
        );
        assert_eq!(r.name, "main");
        let names: Vec<_> = r.waypoints.iter().map(|w| w.name.as_deref()).collect();
        assert_eq!(
            names,
            [
                Some("p10"),
                Some("Offs(p10, 0, 0, dz*2)"),
                Some("RelTool(p10, 10, 0, 0 \\Rz:=90)"),
                Some("ps{1}"),
                Some("ps{2}")
            ]
        );
        let motions: Vec<_> = r.waypoints.iter().map(|w| w.motion).collect();
        let (j, l, c) = (Motion::Joint, Motion::Linear, Motion::Circular);
        assert_eq!(motions, [j, l, l, c, c].map(Some));
        let p = |i: usize| r.waypoints[i].pose.position();
        assert!((p(1).z - 100.0).abs() < 1e-12);
        // The target is rotated 180° about y: tool x points along base −x.
        assert!((p(2).x - 90.0).abs() < 1e-9, "{}", p(2));
        assert_eq!(at.waypoints[3].role, Some(CircleRole::Via));
        assert_eq!(at.waypoints[1].frame.as_deref(), Some("wobj1"));
        assert_eq!(
            r.waypoints[3].configuration,
            Some(Configuration::Rapid(RapidConfdata {
                cf1: 0,
                cf4: -1,
                cf6: 2,
                cfx: 1
            }))
        );
        let reasons: Vec<_> = report.skipped.iter().map(|s| s.reason).collect();
        assert_eq!(
            reasons,
            [
                SkipReason::JointMove,
                SkipReason::ComputedAtRunTime,
                SkipReason::InErrorHandler
            ]
        );
    }

    #[test]
    fn resolves_across_modules_and_tracks_assignments() {
        let a = "MODULE A\n PROC r()\n  VAR robtarget t;\n  MoveL pB, v1, z1, tool0;\n  t := Offs(pB,1,0,0);\n  MoveL t, v1, z1, tool0;\n  t := CRobT();\n  MoveL t, v1, z1, tool0;\n ENDPROC\nENDMODULE";
        let b =
            "MODULE B\n PERS robtarget pB:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\nENDMODULE";
        let report = parse_files(&[("A.mod", a), ("B.sys", b)]).unwrap();
        let r = &report.programs[0].program.routines[0];
        assert_eq!(r.waypoints.len(), 2);
        assert!((r.waypoints[1].pose.position().x - 2.0).abs() < 1e-12);
        assert_eq!(report.skipped[0].reason, SkipReason::ComputedAtRunTime);
        assert_eq!(report.skipped[0].line, 8);
    }

    const CALIBRATION: &str = include_str!("../../../tests/fixtures/import/rapid/Calibration.mod");

    #[test]
    fn a_func_that_moves_the_arm_is_a_routine_and_its_array_targets_resolve() {
        let report =
            parse_files(&[("HOME/Calibration.mod", CALIBRATION)]).unwrap_or_else(|e| panic!("{e}"));
        // ProbeOk() only computes: no routine and no skip record.
        assert!(report.skipped.is_empty(), "{:?}", report.skipped);
        let (routines, origins) = (
            &report.programs[0].program.routines,
            &report.programs[0].origins,
        );
        let names: Vec<_> = routines.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["main", "MeasureSphere"]);
        assert_eq!(origins[1].line, 26);
        // Positions and quaternions as the module writes them; the quaternions normalised here.
        let down = [0.0, 0.0, 1.0, 0.0];
        // The module writes 0.7071068: the same rotation once normalised.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let expected = [
            ("Offs(pSphereTop,0,0,50)", [0.0, 0.0, 170.0], down, None),
            ("pSphereTop", [0.0, 0.0, 120.0], down, None),
            ("pApproach{1}", [60.0, 0.0, 60.0], down, None),
            ("pApproach{2}", [0.0, 60.0, 60.0], [0.0, h, h, 0.0], None),
            (
                "pApproach{3}",
                [-60.0, 0.0, 60.0],
                [0.0, 1.0, 0.0, 0.0],
                Some(CircleRole::Via),
            ),
            (
                "pApproach{4}",
                [0.0, -60.0, 60.0],
                [0.0, h, -h, 0.0],
                Some(CircleRole::To),
            ),
            // The tool points down: 30 mm back along the tool's z is 30 mm up.
            ("RelTool(pSphereTop,0,0,-30)", [0.0, 0.0, 150.0], down, None),
        ];
        let waypoints = &routines[1].waypoints;
        assert_eq!(waypoints.len(), expected.len());
        let read = waypoints.iter().zip(&origins[1].waypoints);
        for ((w, at), (name, p, q, role)) in read.zip(expected) {
            assert_eq!((w.name.as_deref(), at.role), (Some(name), role));
            assert_eq!(at.frame.as_deref(), Some("wCalib"), "{name}");
            let want = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                q[0], q[1], q[2], q[3],
            ));
            let mm = (w.pose.position() - nalgebra::Vector3::from(p)).norm();
            let rad = w.pose.rotation().angle_to(&want);
            assert!(mm < 1e-9 && rad < 1e-9, "{name}: {mm:e} mm, {rad:e} rad");
        }
        assert_eq!(
            waypoints[5].configuration,
            Some(Configuration::Rapid(RapidConfdata {
                cf1: -1,
                cf4: -1,
                cf6: 0,
                cfx: 0
            }))
        );
        // The same moves in a PROC import the same routine.
        let as_proc = CALIBRATION
            .replace("FUNC num MeasureSphere", "PROC MeasureSphere")
            .replace("RETURN sum / 4;", "")
            .replacen("ENDFUNC", "ENDPROC", 1);
        let in_proc = parse_files(&[("HOME/Calibration.mod", &as_proc)]).unwrap();
        assert_eq!(in_proc.programs[0], report.programs[0]);
    }

    /// `depth` nested blocks of the given opener/closer around one move pair, in one routine.
    fn nested(depth: usize, open: &str, close: &str) -> String {
        let mut s = String::from(
            "MODULE Deep\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n",
        );
        for _ in 0..depth {
            s.push_str(open);
            s.push('\n');
        }
        s.push_str("MoveL p, v1, z1, tool0;\nMoveL Offs(p,1,0,0), v1, z1, tool0;\n");
        for _ in 0..depth {
            s.push_str(close);
            s.push('\n');
        }
        s.push_str(" ENDPROC\nENDMODULE\n");
        s
    }

    #[test]
    fn blocks_nested_up_to_the_limit_are_read() {
        for (open, close) in [
            ("IF a THEN", "ENDIF"),
            ("WHILE a DO", "ENDWHILE"),
            ("FOR i FROM 1 TO 2 DO", "ENDFOR"),
            ("TEST a CASE 1:", "ENDTEST"),
        ] {
            let text = nested(MAX_BLOCK_NESTING, open, close);
            let report = parse_files(&[("Deep.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
            let at = &report.programs[0].origins[0];
            assert_eq!(at.waypoints.len(), 2, "{open}");
            assert_eq!(at.waypoints[0].line, 4 + MAX_BLOCK_NESTING, "{open}");
        }
    }

    #[test]
    fn blocks_nested_past_the_limit_are_refused_naming_file_line_and_limit() {
        for (open, close) in [
            ("IF a THEN", "ENDIF"),
            ("WHILE a DO", "ENDWHILE"),
            ("TEST a CASE 1:", "ENDTEST"),
        ] {
            let text = nested(MAX_BLOCK_NESTING + 1, open, close);
            let err = parse_files(&[("Deep.mod", &text)]).unwrap_err();
            assert_eq!(
                err,
                ImportError::NestingTooDeep {
                    file: "Deep.mod".into(),
                    // Line 4 holds the first block; the one past the limit is the last opener.
                    line: 4 + MAX_BLOCK_NESTING,
                    column: 1,
                    limit: MAX_BLOCK_NESTING,
                },
                "{open}"
            );
            let message = err.to_string();
            assert!(
                message.starts_with(&format!("Deep.mod:{}:1:", 4 + MAX_BLOCK_NESTING))
                    && message.contains(&MAX_BLOCK_NESTING.to_string()),
                "{message}"
            );
        }
    }

    #[test]
    fn a_huge_nested_file_is_refused() {
        // 40,000 levels (about 0.9 MB): the parse stops at the limit, 256 lines in.
        let text = nested(40_000, "IF a THEN", "ENDIF");
        let err = parse_files(&[("Deep.mod", &text)]).unwrap_err();
        assert!(
            matches!(err, ImportError::NestingTooDeep { line, .. } if line == 4 + MAX_BLOCK_NESTING),
            "{err}"
        );
    }

    #[test]
    fn nesting_counts_open_blocks_not_blocks_seen() {
        // Many blocks one after another, compact IFs and ELSEIF branches do not add up.
        let mut body = String::new();
        for _ in 0..(3 * MAX_BLOCK_NESTING) {
            body.push_str("IF a THEN\n x := 1;\nELSEIF b THEN\n x := 2;\nELSE\n x := 3;\nENDIF\n");
            body.push_str("IF a x := 1;\nWHILE a DO\n x := 1;\nENDWHILE\n");
            body.push_str("TEST a\nCASE 1:\n x := 1;\nDEFAULT:\n x := 2;\nENDTEST\n");
        }
        let text = format!(
            "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n{body}MoveL p, v1, z1, tool0;\nMoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n"
        );
        let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.programs[0].program.routines[0].waypoints.len(), 2);
        // A routine that leaves blocks open (a missing ENDIF) does not count against the next.
        let open = "IF a THEN\n".repeat(MAX_BLOCK_NESTING - 1);
        let text = format!(
            "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC a()\n{open} ENDPROC\n PROC b()\n{open}MoveL p, v1, z1, tool0;\nMoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n"
        );
        let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.programs[0].program.routines.len(), 1);
        assert_eq!(report.programs[0].program.routines[0].name, "b");
    }

    #[test]
    fn a_block_header_ends_at_then_or_where_its_statement_ends() {
        // THEN found: the body follows; no THEN (compact IF): the whole statement is skipped,
        // also when a routine keyword cuts a statement missing its `;`.
        let text = "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC a()\n  IF x MoveL p, v1, z1, tool0;\n  IF (x) THEN MoveL p, v1, z1, tool0; MoveL p, v1, z1, tool0; ENDIF\n  IF x THEN\n ENDPROC\n PROC b()\n  WHILE [x DO;\n  MoveL p, v1, z1, tool0;\n  MoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n";
        let report = parse_files(&[("M.mod", text)]).unwrap_or_else(|e| panic!("{e}"));
        let origins = &report.programs[0].origins;
        let lines: Vec<Vec<usize>> = origins
            .iter()
            .map(|r| r.waypoints.iter().map(|w| w.line).collect())
            .collect();
        assert_eq!(lines, [vec![5, 5], vec![10, 11]]);
    }

    #[test]
    fn malformed_robtarget_is_an_error_with_line_and_column() {
        let text = "MODULE M\n  CONST robtarget p:=[[1,2],[1,0,0,0]];\nENDMODULE";
        let err = parse_files(&[("M.mod", text)]).unwrap_err();
        match err {
            ImportError::Syntax {
                line, column, file, ..
            } => {
                assert_eq!((file.as_str(), line, column), ("M.mod", 2, 22));
            }
            other => panic!("{other:?}"),
        }
        let err = parse_files(&[("M.mod", "MODULE M\nPROC\nENDMODULE")]).unwrap_err();
        assert!(err.to_string().starts_with("M.mod:3:"), "{err}");
    }
}
