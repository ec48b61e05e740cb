//! The offer rule's committed model is what its fit gives on the shared corpora, bit for bit.

use nextpose::replay::load_paths;
use nextpose::replay::offer_rule_fit::OfferRuleFit;

use crate::corpus;

/// `cargo run --release --example fit_offer_rule -- ../shared/corpus/json
/// ../shared/corpus2/json --write src/engine/experts/agreement_weights.rs` writes the file the
/// engine builds with; fitted here again from both corpora, it is the same text. A fit that
/// changed (new features, a changed expert, a changed corpus) fails here until the file is
/// written again and committed.
#[test]
#[cfg_attr(not(corpus), ignore = "needs ../shared/corpus beside the checkout")]
fn the_committed_weights_are_the_fit_of_both_corpora() {
    let corpus2 = corpus::dir().join("../corpus2/json");
    assert!(
        corpus2.is_dir(),
        "the fit reads both corpora: {} is missing",
        corpus2.display()
    );
    let programs = load_paths(&[corpus::json(), corpus2]).expect("the corpora");
    let fit = OfferRuleFit::new(&programs).expect("a fit");
    let committed = include_str!("../../src/engine/experts/agreement_weights.rs");
    assert!(
        fit.weights_file() == committed,
        "src/engine/experts/agreement_weights.rs is not the fit of the corpora: run the \
         example again with --write and commit it\n--- fitted:\n{}",
        fit.weights_file()
    );
    // Out of fold, offers from the threshold of the default target keep its word on the
    // corpora pooled (the table the engine reads says so, by construction), and the rule with
    // its cautious start stays at 89 % or above on each corpus.
    for (set, (right, offered)) in fit.rule(nextpose::engine::OfferRule::TARGET) {
        assert!(offered > 400, "{set}: {offered} offers");
        assert!(
            right as f64 >= 0.89 * offered as f64,
            "{set}: {right} of {offered}"
        );
    }
}
