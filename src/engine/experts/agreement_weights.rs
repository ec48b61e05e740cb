//! The offer rule's logistic model of agreement (read by `agreement::Scorer`, which checks
//! the length) and the precision of its offers from each threshold, out of fold, fitted on
//! the shared corpora by `cargo run --release --example fit_offer_rule -- ../shared/corpus/json
//! ../shared/corpus2/json --write src/engine/experts/agreement_weights.rs`
//! (`replay::offer_rule_fit`). Generated: do not edit by hand; a corpus test checks it.

pub const INTERCEPT: f64 = -3.632386414741906;

pub const WEIGHTS: [f64; 21] = [
    1.0621527243978683,   // log_size
    0.32561154302527734,  // kinds
    2.9962509232471253,   // p_first
    -0.25663735975882146, // context
    1.9604586914896105,   // long_share
    -1.0967978792846371,  // longest
    -0.48333561085042415, // log_groups
    0.2182778481545487,   // places
    0.878904699730296,    // all_agree
    -0.6741981385040617,  // in_routine
    0.7230467039463061,   // model
    0.2401257910903079,   // gated
    -1.4942013940752963,  // tool
    -0.12211669569082928, // work
    0.49967252788045546,  // absolute
    0.0,                  // template
    -0.069397947328002,   // station
    -0.783068941218579,   // walk
    0.4588350924721447,   // follower
    -1.4623723291536903,  // share
    -0.426985396334563,   // log_competitor
];

/// (threshold, share of the offers from it that were right), out of fold.
pub const PRECISION_FROM: [(f64, f64); 10] = [
    (0.5, 0.8533529845246868),
    (0.55, 0.8663101604278075),
    (0.6, 0.8809523809523809),
    (0.65, 0.9004149377593361),
    (0.7, 0.909248055315471),
    (0.75, 0.9156079854809437),
    (0.8, 0.9318403115871471),
    (0.85, 0.9324324324324325),
    (0.9, 0.9390581717451524),
    (0.95, 0.945619335347432),
];
