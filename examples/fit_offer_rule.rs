//! Fits the offer rule's model of agreement and reports it out of fold
//! (`nextpose::replay::offer_rule_fit`, whose module doc says how).
//!
//! `cargo run --release --example fit_offer_rule -- ../shared/corpus/json ../shared/corpus2/json`
//! prints the report and the weights file; `--write src/engine/experts/agreement_weights.rs`
//! writes the file instead of printing it. `--scores FILE` also writes the best group's
//! out-of-fold probability at every scored waypoint as CSV (for analyses of other rules).

use std::fmt::Write as _;
use std::path::PathBuf;

use nextpose::replay::load_paths;
use nextpose::replay::offer_rule_fit::OfferRuleFit;

fn main() -> anyhow::Result<()> {
    let mut paths = Vec::new();
    let (mut write, mut scores) = (None, None);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--write" => write = args.next().map(PathBuf::from),
            "--scores" => scores = args.next().map(PathBuf::from),
            _ => paths.push(PathBuf::from(a)),
        }
    }
    let fit = OfferRuleFit::new(&load_paths(&paths)?)?;
    print!("{}", fit.report());
    if let Some(path) = scores {
        let mut text = String::from("set,repo,p,right\n");
        for b in &fit.best {
            writeln!(text, "{},{},{:?},{}", b.set, b.repo, b.p, u8::from(b.right))?;
        }
        std::fs::write(path, text)?;
    }
    match write {
        Some(path) => {
            std::fs::write(&path, fit.weights_file())?;
            println!("wrote {}", path.display());
        }
        None => print!("{}", fit.weights_file()),
    }
    Ok(())
}
