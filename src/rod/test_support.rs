//! Helpers shared by the tests of the rod physics and of the stages that use it.

/// The median and 90th percentile of `values` (the lower of two middle values; NaN for
/// none).
pub(crate) fn median_and_p90(mut values: Vec<f64>) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    values.sort_by(f64::total_cmp);
    let q = |p: f64| values[((values.len() - 1) as f64 * p) as usize];
    (q(0.5), q(0.9))
}
