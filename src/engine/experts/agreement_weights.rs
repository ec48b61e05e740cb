//! The offer rule's logistic model of agreement (read by `agreement::Scorer`, which checks
//! the length), fitted on the shared corpora by `examples/fit_offer_rule.rs` (its module doc
//! says how). Generated: do not edit by hand; run the example again with `--write` and
//! commit the result.

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
