//! The importer's behaviour on whole uploads: files that are not programs or not text, files
//! that give no program, programs of one name, and waypoints refused for their values.

use super::*;

#[test]
fn unsupported_file_is_an_error_naming_it() {
    let err = parse_files(&[("notes.txt", "hello")]).unwrap_err();
    assert!(err.to_string().contains("notes.txt"), "{err}");
}

const MODULE: &str = "MODULE M\n CONST robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];\n PROC main()\n  MoveL p, v1, z1, tool0;\n  MoveL Offs(p,0,0,10), v1, z1, tool0;\n ENDPROC\nENDMODULE\n";

#[test]
fn binary_content_is_an_error_naming_file_line_and_column() {
    for name in ["a.mod", "a.prg", "a.sys", "a.src", "a.dat", "a.ls"] {
        for garbage in ["\0", "\u{1}", "\u{7}", "\u{1B}", "\u{1F}"] {
            let text = format!("MODULE M\n ! {garbage}\nENDMODULE\n");
            let err = parse_files(&[(name, &text)]).unwrap_err();
            assert_eq!(
                err,
                ImportError::NotText {
                    file: name.into(),
                    line: 2,
                    column: 4,
                    code: u32::from(garbage.chars().next().unwrap()),
                }
            );
            assert!(
                err.to_string().starts_with(&format!("{name}:2:4:")),
                "{err}"
            );
        }
    }
    // One binary file refuses the whole upload.
    let err =
        parse_files(&[("M.mod", MODULE), ("x.mod", "\u{89}PNG\r\n\u{1A}\n\0\0")]).unwrap_err();
    assert!(
        matches!(err, ImportError::NotText { ref file, .. } if file == "x.mod"),
        "{err}"
    );
}

#[test]
fn text_controls_and_latin1_are_text() {
    // Tab, CR LF, form feed, a DOS end-of-file mark, and Windows-1252 bytes read as Latin-1.
    let bytes = [
        MODULE.replace('\n', "\r\n").as_bytes(),
        b"\t! \x80 \x96 \xe9\x0c\x0b\x1a",
    ]
    .concat();
    let text = decode_text(&bytes);
    let report = parse_files(&[("M.mod", &text)]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report.programs.len(), 1);
    assert_eq!(report.programs[0].program.routines[0].waypoints.len(), 2);
}

#[test]
fn a_file_with_no_routine_is_skipped_and_gives_no_program() {
    let cases = [
        ("empty.mod", ""),
        ("blank.prg", " \n\r\n\t"),
        ("comment.sys", "! nothing here\n"),
        ("data.mod", "MODULE Data\n CONST num n:=1;\nENDMODULE\n"),
        (
            "short.mod",
            "MODULE Short\n PROC a()\n  MoveL p, v1, z1, tool0;\n ENDPROC\nENDMODULE\n",
        ),
        ("empty.src", ""),
        ("nodef.src", "&ACCESS RVP\n; just a comment\n"),
    ];
    for (name, text) in cases {
        let report = parse_files(&[(name, text)]).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(report.programs.is_empty(), "{name}: {:?}", report.programs);
        let last = report.skipped.last().expect("a skip record");
        assert_eq!(
            (last.file.as_str(), last.reason, last.routine.as_deref()),
            (name, SkipReason::NoRoutines, None),
            "{name}"
        );
    }
    // With other files: only the empty ones are left out, each reported once.
    let report = parse_files(&[("empty.mod", ""), ("M.mod", MODULE), ("e.src", "")]).unwrap();
    let programs: Vec<_> = report.programs.iter().map(|p| p.source()).collect();
    assert_eq!(programs, ["M.mod"]);
    let skipped: Vec<_> = report
        .skipped
        .iter()
        .map(|s| (s.file.as_str(), s.reason))
        .collect();
    assert_eq!(
        skipped,
        [
            ("empty.mod", SkipReason::NoRoutines),
            ("e.src", SkipReason::NoRoutines)
        ]
    );
    // A FANUC folder whose listings are all too short gives no program either.
    let ls = "/PROG A\n/MN\n 1:J P[1] 100% FINE ;\n/POS\nP[1]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 3 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n/END\n";
    let report = parse_files(&[("cell/prog/a.ls", ls)]).unwrap_or_else(|e| panic!("{e}"));
    assert!(report.programs.is_empty());
    let reasons: Vec<_> = report
        .skipped
        .iter()
        .map(|s| (s.file.as_str(), s.reason))
        .collect();
    assert_eq!(
        reasons,
        [
            ("cell/prog/a.ls", SkipReason::ShortRoutine),
            ("cell/prog", SkipReason::NoRoutines)
        ]
    );
}

#[test]
fn ten_thousand_empty_files_make_no_program() {
    let names: Vec<String> = (0..10_000)
        .map(|i| format!("f{i}.{}", ["mod", "src", "prg", "sys"][i % 4]))
        .collect();
    let files: Vec<(&str, &str)> = names.iter().map(|n| (n.as_str(), "")).collect();
    let report = parse_upload(&files).unwrap_or_else(|e| panic!("{e}"));
    assert!(report.programs.is_empty());
    assert_eq!(report.skipped.len(), 10_000);
    assert!(
        report
            .skipped
            .iter()
            .all(|s| s.reason == SkipReason::NoRoutines)
    );
}

#[test]
fn an_upload_with_two_programs_of_one_name_is_refused_naming_both_files() {
    let other = MODULE.replace("PROC main", "PROC other");
    let files = [
        ("A/Main.mod", MODULE),
        ("B/x.mod", "MODULE X\nENDMODULE"),
        ("B/M.mod", &other),
    ];
    // Replay reads both; a cell cannot store both.
    assert_eq!(parse_files(&files).unwrap().programs.len(), 2);
    let err = parse_upload(&files).unwrap_err();
    assert_eq!(
        err,
        ImportError::DuplicateProgram {
            name: "M".into(),
            first: "A/Main.mod".into(),
            second: "B/M.mod".into(),
        }
    );
    let message = err.to_string();
    assert!(
        message.contains("A/Main.mod") && message.contains("B/M.mod"),
        "{message}"
    );
    // KRL programs of one stem in two folders, FANUC folders of one name under two parents.
    let src = "DEF a()\nLIN {X 1,Y 2,Z 3,A 0,B 0,C 0}\nLIN {X 2,Y 2,Z 3,A 0,B 0,C 0}\nEND\n";
    let err = parse_upload(&[("r1/main.src", src), ("r2/main.src", src)]).unwrap_err();
    assert!(
        matches!(&err, ImportError::DuplicateProgram { first, second, .. } if first == "r1/main.src" && second == "r2/main.src"),
        "{err}"
    );
    let ls = "/PROG A\n/MN\n 1:J P[1] 100% FINE ;\n 2:L P[1] 100mm/sec FINE ;\n/POS\nP[1]{\n GP1:\n UF : 0, UT : 1,\n X = 1 mm, Y = 2 mm, Z = 3 mm,\n W = 0 deg, P = 0 deg, R = 0 deg\n};\n/END\n";
    let err = parse_upload(&[("x/prog/a.ls", ls), ("y/prog/a.ls", ls)]).unwrap_err();
    assert!(
        matches!(&err, ImportError::DuplicateProgram { name, first, second } if name == "prog" && first == "x/prog" && second == "y/prog"),
        "{err}"
    );
    // Names are compared exactly, as the cell stores them; distinct names pass.
    let lower = MODULE.replace("MODULE M", "MODULE m");
    assert_eq!(
        parse_upload(&[("a.mod", MODULE), ("b.mod", &lower)])
            .unwrap()
            .programs
            .len(),
        2
    );
    // A file that gives no program clashes with nothing.
    assert!(parse_upload(&[("a.mod", MODULE), ("b.mod", "MODULE M\nENDMODULE")]).is_ok());
}

/// Issue 46: an import let −1e308 through to the learner, whose k-d tree panicked. Every
/// waypoint's pose is checked once the files are parsed: a number that is not finite or a
/// coordinate beyond ±100 m refuses the upload, naming the file, the line of the move, the
/// value and the target, in each language; a finite quaternion that is not a rotation is
/// still only skipped.
#[test]
fn a_waypoint_out_of_range_or_not_finite_refuses_the_upload_naming_it() {
    let rapid = |p2: &str, q2: &str| {
        format!(
            "MODULE Weld
 CONST robtarget p1:=[[1,2,3],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];
                  CONST robtarget p2:=[[{p2}],[{q2}],[0,0,0,0],[0,0,0,0,0,0]];
 PROC main()
                   MoveL p1, v1, z1, tool0;
  MoveL p2, v1, z1, tool0;
  MoveL p1, v1, z1, tool0;
                  ENDPROC
ENDMODULE
"
        )
    };
    let krl = |x: &str| {
        format!(
            "DEF a()
LIN {{X 1,Y 2,Z 3,A 0,B 0,C 0}}
LIN {{X {x},Y 2,Z 3,A 0,B 0,C 0}}
END
"
        )
    };
    let fanuc = |z: &str| {
        format!(
            "/PROG A
/MN
 1:L P[1] 100mm/sec FINE ;
 2:L P[2] 100mm/sec FINE ;
/POS
                 P[1]{{
 GP1:
 UF : 0, UT : 1,
 X = 1 mm, Y = 2 mm, Z = 3 mm,
 W = 0 deg, P = 0 deg, R = 0 deg
}};
                 P[2]{{
 GP1:
 UF : 0, UT : 1,
 X = 1 mm, Y = 2 mm, Z = {z} mm,
 W = 0 deg, P = 0 deg, R = 0 deg
}};
/END
"
        )
    };
    let cases = [
        (
            "weld.mod",
            rapid("-1e308,2,3", "1,0,0,0"),
            "weld.mod line 6: x = -1e308 is outside ±100000 mm (target p2)",
        ),
        (
            "weld.mod",
            rapid("1,2,1e999", "1,0,0,0"),
            "weld.mod line 6: z = inf is not a finite number (target p2)",
        ),
        (
            "weld.mod",
            rapid("1,2,3", "1e999,0,0,0"),
            "weld.mod line 6: qw = inf is not a finite number (target p2)",
        ),
        (
            "r/a.src",
            krl("1e308"),
            "r/a.src line 3: x = 1e308 is outside ±100000 mm",
        ),
        (
            "r/a.src",
            krl("-100000.5"),
            "r/a.src line 3: x = -100000.5 is outside ±100000 mm",
        ),
        (
            "c/a/A.LS",
            fanuc("-250000"),
            "c/a/A.LS line 4: z = -250000.0 is outside ±100000 mm (target P[2])",
        ),
    ];
    for (name, text, said) in &cases {
        let err = parse_upload(&[(name, text)]).unwrap_err();
        assert!(matches!(err, ImportError::Pose { .. }), "{err:?}");
        assert_eq!(
            err.to_string().split(" (target").next(),
            said.split(" (target").next(),
            "{err}"
        );
        assert!(err.to_string().starts_with(said), "{err}");
    }
    // At the bound: imported. A quaternion of norm 1e308: skipped as not a rotation.
    let report = parse_upload(&[("k.src", &krl("-100000"))]).unwrap();
    assert_eq!(
        report.programs[0].program.routines[0].waypoints[1]
            .pose
            .position()
            .x,
        -100_000.0
    );
    let report = parse_upload(&[("weld.mod", &rapid("1,2,3", "1e308,0,0,0"))]).unwrap();
    assert_eq!(report.programs[0].program.waypoint_count(), 2);
    assert_eq!(
        report.skipped_counts().get(&SkipReason::InvalidTarget),
        Some(&1)
    );
}
