//! Times the importer on inputs that could make it superlinear:
//! `cargo run --example import_scaling -- 5000 10000`.
use std::time::Instant;

const T: &str = "[[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]";

fn rapid_if(depth: usize) -> String {
    let mut s = String::from("MODULE Deep\n PROC main()\n");
    for _ in 0..depth {
        s.push_str("  IF TRUE THEN\n");
    }
    s.push_str("  x := 1;\n");
    for _ in 0..depth {
        s.push_str("  ENDIF\n");
    }
    s.push_str(" ENDPROC\nENDMODULE\n");
    s
}

fn rapid_test(depth: usize) -> String {
    let mut s = String::from("MODULE Deep\n PROC main()\n");
    for _ in 0..depth {
        s.push_str("  TEST a CASE 1:\n");
    }
    s.push_str("  x := 1;\n");
    for _ in 0..depth {
        s.push_str("  ENDTEST\n");
    }
    s.push_str(" ENDPROC\nENDMODULE\n");
    s
}

fn rapid_unclosed(n: usize) -> String {
    let mut s = String::from("MODULE Deep\n PROC main()\n");
    for _ in 0..n {
        s.push_str("  x := (1;\n");
    }
    s.push_str(" ENDPROC\nENDMODULE\n");
    s
}

fn rapid_array(n: usize) -> String {
    let mut s = format!("MODULE Deep\n CONST robtarget ps{{{n}}} := [");
    for i in 0..n {
        s.push_str(if i == 0 { "" } else { ",\n" });
        s.push_str(T);
    }
    s.push_str("];\n PROC main()\n");
    for i in 0..n {
        s.push_str(&format!("  MoveL ps{{{}}}, v100, fine, tool0;\n", i + 1));
    }
    s.push_str(" ENDPROC\nENDMODULE\n");
    s
}

fn krl_if(depth: usize) -> String {
    let mut s = String::from("DEF deep()\n");
    for _ in 0..depth {
        s.push_str("IF TRUE THEN\n");
    }
    for _ in 0..depth {
        s.push_str("ENDIF\n");
    }
    s.push_str("END\n");
    s
}

fn time(label: &str, files: &[(String, String)]) {
    let refs: Vec<(&str, &str)> = files
        .iter()
        .map(|(n, t)| (n.as_str(), t.as_str()))
        .collect();
    let bytes: usize = files.iter().map(|(_, t)| t.len()).sum();
    let t = Instant::now();
    let r = nextpose::import::parse_files(&refs);
    let outcome = match r {
        Ok(r) => format!(
            "ok, {} programs, {} skipped",
            r.programs.len(),
            r.skipped.len()
        ),
        Err(e) => format!(
            "error: {}",
            e.to_string().chars().take(100).collect::<String>()
        ),
    };
    println!(
        "{label:<28} {bytes:>9} bytes {:>8.3} s  {outcome}",
        t.elapsed().as_secs_f64()
    );
}

fn main() {
    let kinds: Vec<String> = std::env::var("KINDS")
        .unwrap_or_else(|_| "if,test,unclosed,array,krl,krlfiles,fanucdirs".into())
        .split(',')
        .map(str::to_string)
        .collect();
    for arg in std::env::args().skip(1) {
        let n: usize = arg.parse().expect("a size");
        for k in &kinds {
            let files: Vec<(String, String)> = match k.as_str() {
                "if" => vec![("Deep.mod".into(), rapid_if(n))],
                "test" => vec![("Deep.mod".into(), rapid_test(n))],
                "unclosed" => vec![("Deep.mod".into(), rapid_unclosed(n))],
                "array" => vec![("Deep.mod".into(), rapid_array(n))],
                "krl" => vec![("deep.src".into(), krl_if(n))],
                "krlfiles" => (0..n)
                    .flat_map(|i| {
                        [
                            (format!("d/p{i}.src"), "DEF a()\nEND\n".to_string()),
                            (format!("d/p{i}.dat"), String::new()),
                        ]
                    })
                    .collect(),
                "fanucdirs" => (0..n)
                    .map(|i| {
                        (
                            format!("d{i}/a.ls"),
                            "/PROG A\n/MN\n/POS\n/END\n".to_string(),
                        )
                    })
                    .collect(),
                _ => panic!("unknown kind {k}"),
            };
            time(&format!("{k} {n}"), &files);
        }
    }
}
