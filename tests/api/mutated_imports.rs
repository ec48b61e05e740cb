//! Damaged controller files through the real import route (issue 46): the corpus's real programs,
//! mutated the way an outside tester's 600 uploads were (cut, spliced, characters flipped, lines
//! repeated, numbers made huge or not numbers, terminators dropped), uploaded by the thousand to
//! `POST /v1/cells/{id}/imports` on a real server. Every answer is a 2xx or a 4xx with an error
//! body, never a 5xx; the server still answers `/healthz` and teaches and predicts afterwards.
//!
//! The mutations are drawn from a fixed seed, so a failure names an upload that can be made
//! again (its index); the failing upload is printed whole. `MUTATED_SHOW=1` prints every
//! answer (the programs imported, or the error message) to see what the mutations reach.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use reqwest::StatusCode;
use serde_json::{Value, json};

use crate::corpus;
use crate::helpers::*;

/// Uploads made. Each is small (one or two files of at most [`WHOLE`] bytes, or a window of a
/// longer one), so that thousands of them are parsed and learned in a minute of a dev build.
const UPLOADS: usize = 5_000;
/// Uploads per cell: each cell's model learns what its uploads import, so later uploads land
/// on a model that already holds what the earlier ones taught.
const PER_CELL: usize = 25;
/// Uploads in flight at once.
const WORKERS: usize = 4;
/// Lines a window keeps at most.
const WINDOW: usize = 120;
/// Files up to this size are mutated whole.
const WHOLE: usize = 16 * 1024;
const SEED: u64 = 46;

/// Numbers that must not reach the engine as they are, and a few at and past the ±100 m bound.
const BAD_NUMBERS: [&str; 10] = [
    "1e308",
    "-1e308",
    "NaN",
    "1e999",
    "-1e999",
    "1.7976931348623157e308",
    "100000",
    "-100000.5",
    "9E+99",
    "0",
];

/// The lines a program ends its blocks with, which a cut file loses.
fn is_terminator(line: &str) -> bool {
    let t = line.trim().to_ascii_uppercase();
    [
        "ENDPROC",
        "ENDMODULE",
        "ENDFUNC",
        "ENDTRAP",
        "END",
        "ENDIF",
        "ENDFOR",
        "ENDWHILE",
        "/END",
        "ENDLOOP",
    ]
    .iter()
    .any(|k| t == *k || t.starts_with(&format!("{k} ")) || t.starts_with(&format!("{k};")))
}

/// A window of at most [`WINDOW`] lines of `text`.
fn window(rng: &mut StdRng, lines: &[&str]) -> Vec<String> {
    if lines.is_empty() {
        return Vec::new();
    }
    let len = rng.random_range(1..=WINDOW.min(lines.len()));
    let start = rng.random_range(0..=lines.len() - len);
    lines[start..start + len]
        .iter()
        .map(|l| l.to_string())
        .collect()
}

/// The file to mutate: whole when at most [`WHOLE`] bytes; of a longer one its first ten lines
/// (the header: `MODULE`, `DEF`, `/PROG … /MN`), a window of the rest and its last 60 lines
/// (a FANUC listing's positions), so that an upload stays small.
fn base(rng: &mut StdRng, text: &str) -> Vec<String> {
    let lines: Vec<&str> = text.lines().collect();
    if text.len() <= WHOLE || lines.len() <= 70 + WINDOW {
        return lines.iter().map(|l| l.to_string()).collect();
    }
    let mut out: Vec<String> = lines[..10].iter().map(|l| l.to_string()).collect();
    out.extend(window(rng, &lines[10..lines.len() - 60]));
    out.extend(lines[lines.len() - 60..].iter().map(|l| l.to_string()));
    out
}

/// Every number of a line replaced, each with probability `p`, by one of [`BAD_NUMBERS`].
fn bad_numbers(rng: &mut StdRng, line: &str, p: f64) -> String {
    let mut out = String::with_capacity(line.len());
    let mut chars = line.chars().peekable();
    let mut previous: Option<char> = None;
    while let Some(c) = chars.next() {
        let starts =
            c.is_ascii_digit() && !previous.is_some_and(|p| p.is_alphanumeric() || p == '_');
        if !starts {
            out.push(c);
            previous = Some(c);
            continue;
        }
        let mut number = c.to_string();
        while let Some(&d) = chars.peek() {
            if d.is_ascii_digit() || d == '.' || d == 'e' || d == 'E' {
                number.push(d);
                chars.next();
            } else {
                break;
            }
        }
        if rng.random_bool(p) {
            out.push_str(BAD_NUMBERS[rng.random_range(0..BAD_NUMBERS.len())]);
        } else {
            out.push_str(&number);
        }
        previous = number.chars().last();
    }
    out
}

/// One mutated file: [`base`] of `text`, then one to three mutations: a cut (the rest of the
/// file lost), a window of `other` spliced in, characters flipped, a line repeated, numbers
/// made huge or not numbers, block terminators or semicolons dropped.
fn mutate(rng: &mut StdRng, text: &str, other: &str) -> String {
    let mut lines = base(rng, text);
    for _ in 0..rng.random_range(1..=3) {
        if lines.is_empty() {
            break;
        }
        match rng.random_range(0..7) {
            // Cut: the file ends early.
            5 => lines.truncate(rng.random_range(1..=lines.len())),
            // Spliced: a window of another file in the middle of this one.
            6 => {
                let other: Vec<&str> = other.lines().collect();
                let tail = window(rng, &other);
                let at = rng.random_range(0..=lines.len());
                lines.splice(at..at, tail);
            }
            // Characters flipped: to program punctuation, digits, letters, and now and then a
            // control character (an upload that is not text).
            0 => {
                const ALPHABET: &[u8] = b"[]{}(),;:=.-+eE0123456789 \"'!&#PXYZABCWR\t";
                for _ in 0..rng.random_range(1..=8) {
                    let i = rng.random_range(0..lines.len());
                    let mut chars: Vec<char> = lines[i].chars().collect();
                    if chars.is_empty() {
                        continue;
                    }
                    let k = rng.random_range(0..chars.len());
                    chars[k] = if rng.random_bool(0.02) {
                        '\u{1}'
                    } else {
                        char::from(ALPHABET[rng.random_range(0..ALPHABET.len())])
                    };
                    lines[i] = chars.into_iter().collect();
                }
            }
            // A line repeated (a routine of thousands of moves to one place, a declaration
            // twice).
            1 => {
                let i = rng.random_range(0..lines.len());
                let times = rng.random_range(1..=40);
                let line = lines[i].clone();
                lines.splice(i..i, std::iter::repeat_n(line, times));
            }
            // Numbers made huge, infinite or not numbers.
            2 => {
                let p = rng.random_range(0.01..0.3);
                for line in &mut lines {
                    *line = bad_numbers(rng, line, p);
                }
            }
            // Terminators dropped: the block ends, or the statements' semicolons.
            3 => lines.retain(|l| !is_terminator(l)),
            _ => {
                for line in &mut lines {
                    if rng.random_bool(0.5) {
                        *line = line.trim_end().trim_end_matches(';').to_string();
                    }
                }
            }
        }
    }
    let mut text = lines.join("\n");
    text.push('\n');
    text
}

/// The language of a file name (`rapid`, `krl`, `fanuc`).
fn language(name: &str) -> usize {
    match name
        .rsplit('.')
        .next()
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("src" | "dat") => 1,
        Some("ls") => 2,
        _ => 0,
    }
}

/// An upload: one mutated file, or (one in four) two files mutated together (RAPID modules
/// that resolve across files, a KRL `.src` and a `.dat`), of a language drawn evenly (the
/// corpus holds many more FANUC listings than the others).
fn upload(rng: &mut StdRng, by_language: &[Vec<&corpus::File>; 3]) -> Vec<Value> {
    let files = &by_language[rng.random_range(0..3)];
    let count = if rng.random_bool(0.25) { 2 } else { 1 };
    let mut out = Vec::new();
    for k in 0..count {
        let (name, text) = files[rng.random_range(0..files.len())];
        let (_, other) = files[rng.random_range(0..files.len())];
        let content = mutate(rng, text, other);
        // Distinct names within the upload (a second copy of a name is another file).
        let name = if k == 0 {
            name.clone()
        } else {
            format!("second/{name}")
        };
        out.push(json!({ "name": name, "content": content }));
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
async fn thousands_of_damaged_programs_are_imported_or_refused_never_a_server_error() {
    let files = corpus::raw_files();
    assert!(files.len() >= 40, "{} raw files", files.len());
    let app = std::sync::Arc::new(spawn_app().await);
    let mut rng = StdRng::seed_from_u64(SEED);
    let mut by_language: [Vec<&corpus::File>; 3] = Default::default();
    for f in &files {
        by_language[language(&f.0)].push(f);
    }
    assert!(
        by_language.iter().all(|l| !l.is_empty()),
        "a language without files"
    );
    let uploads: Vec<Vec<Value>> = (0..UPLOADS)
        .map(|_| upload(&mut rng, &by_language))
        .collect();
    let uploads = std::sync::Arc::new(uploads);
    let started = std::time::Instant::now();
    let mut workers = tokio::task::JoinSet::new();
    for w in 0..WORKERS {
        let (app, uploads) = (app.clone(), uploads.clone());
        workers.spawn(async move {
            // (created, refused) and the statuses seen.
            let mut outcome = (0usize, 0usize, std::collections::BTreeMap::new());
            let mut cell = 0;
            for (i, files) in uploads.iter().enumerate().skip(w).step_by(WORKERS) {
                if (i / WORKERS).is_multiple_of(PER_CELL) {
                    cell = app
                        .create_cell_with(&format!("mutated-{i}"), json!({"reach_policy": "flag"}))
                        .await;
                }
                let r = app
                    .post(
                        &format!("/v1/cells/{cell}/imports"),
                        &json!({ "files": files }),
                    )
                    .await;
                let status = r.status();
                let text = r.text().await.expect("a body");
                *outcome.2.entry(status.as_u16()).or_insert(0usize) += 1;
                let shown = || {
                    format!(
                        "upload {i} answered {status}: {text}\nfiles: {:#}",
                        json!(files)
                    )
                };
                assert!(
                    status.is_success() || status.is_client_error(),
                    "{}",
                    shown()
                );
                let body: Value =
                    serde_json::from_str(&text).unwrap_or_else(|_| panic!("{}", shown()));
                if status.is_success() {
                    assert!(body["programs"].is_array(), "{}", shown());
                    if std::env::var("MUTATED_SHOW").is_ok() {
                        eprintln!("IMPORTED {} {}", body["programs"], body["model"]);
                    }
                    outcome.0 += 1;
                } else {
                    let message = body["error"]["message"].as_str().unwrap_or("");
                    assert!(
                        body["error"]["code"].is_string() && !message.is_empty(),
                        "{}",
                        shown()
                    );
                    outcome.1 += 1;
                    if std::env::var("MUTATED_SHOW").is_ok() {
                        eprintln!("REFUSED {message}");
                    }
                }
            }
            outcome
        });
    }
    let (mut created, mut refused) = (0, 0);
    let mut statuses = std::collections::BTreeMap::new();
    while let Some(done) = workers.join_next().await {
        let (c, r, s) = done.expect("a worker panicked: see its message above");
        created += c;
        refused += r;
        for (k, n) in s {
            *statuses.entry(k).or_insert(0) += n;
        }
    }
    println!(
        "{UPLOADS} mutated uploads in {:.1} s: {created} imported, {refused} refused, by status {statuses:?}",
        started.elapsed().as_secs_f64()
    );
    assert_eq!(created + refused, UPLOADS);
    // Both kinds are made: the mutations neither all break the files nor all leave them whole.
    assert!(created >= UPLOADS / 10, "{created} imported");
    assert!(
        statuses.get(&422).copied().unwrap_or(0) >= UPLOADS / 10,
        "{statuses:?}"
    );

    // The server still answers, and still teaches and predicts.
    let health = expect(app.get("/healthz").await, StatusCode::OK).await;
    assert!(health.is_object(), "{health}");
    let cell = app.create_cell("after-the-mutants").await;
    let program = app.create_program(cell, "seam").await;
    let seam = u_seam([0.0, 0.0, 0.0], 0.0);
    app.teach_routine(program, &seam).await;
    let copy = u_seam([800.0, -300.0, 50.0], 1.0);
    let routine = app.create_routine(program).await;
    let mut offered = 0;
    for (i, p) in copy.iter().enumerate() {
        let prediction = &app.append(routine, p).await["prediction"];
        if prediction["offered"] == true && i + 1 < copy.len() {
            offered += 1;
            let err = distance(&prediction["pose"], &copy[i + 1]);
            assert!(err < 1e-6, "waypoint {}: {err} mm", i + 2);
        }
    }
    assert!(offered >= 1, "nothing offered after the mutated uploads");
}
