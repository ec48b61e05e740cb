//! Sums of probabilities held as logarithms, without underflow: the forward recursion, the
//! gates and the mixture all add up likelihoods far below `f64`'s smallest normal number.

/// `ln Σ exp(v)`, taken from the largest value so that no term underflows; −∞ for no values or
/// only −∞.
pub(super) fn log_sum_exp(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = values.clone().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    max + values.map(|v| (v - max).exp()).sum::<f64>().ln()
}
