//! Uniformity statistics of 2D maps (areal density grids, grey-level images):
//! coefficient of variation, CV over zone sizes, and the formation number against
//! a random network of straight lines (Dodson & Sampson; REFERENCE.md §2).
//!
//! ```
//! use laydown::uniformity::{coefficient_of_variation, cv_by_zone_size};
//! use ndarray::Array2;
//! let map = Array2::from_shape_fn((8, 8), |(i, j)| ((i + j) % 2) as f64);
//! // A checkerboard of 0 and 1: CV 1 at the cell scale, 0 once zones hold 2×2 cells.
//! assert!((coefficient_of_variation(map.iter().copied()) - 1.0).abs() < 1e-12);
//! let curve = cv_by_zone_size(map.view(), 1e-3, &[1e-3, 2e-3]);
//! assert_eq!(curve[1].cells_per_side, 2);
//! assert!(curve[1].cv.abs() < 1e-12);
//! ```
use ndarray::{Array2, ArrayView2};

/// E1 = 4 ln(1+√2) − (4/3)(√2 − 1): the mean of 1/r between two random points of a unit square.
pub const E1: f64 = 2.973_210_0;

/// Population coefficient of variation (standard deviation over mean) of the values.
/// Returns NaN when there are no values or the mean is zero.
pub fn coefficient_of_variation(values: impl IntoIterator<Item = f64>) -> f64 {
    // Welford's update keeps the variance accurate for large, nearly constant maps.
    let (mut n, mut mean, mut m2) = (0.0f64, 0.0f64, 0.0f64);
    for v in values {
        n += 1.0;
        let delta = v - mean;
        mean += delta / n;
        m2 += delta * (v - mean);
    }
    if n == 0.0 || mean == 0.0 {
        return f64::NAN;
    }
    (m2 / n).max(0.0).sqrt() / mean
}

/// Sums of non-overlapping k×k blocks of cells; rows and columns that do not fill a
/// whole block at the far edges are dropped (a partial zone would bias the CV).
pub fn block_sums(map: ArrayView2<f64>, k: usize) -> Array2<f64> {
    assert!(k >= 1, "block size must be at least one cell");
    let (rows, cols) = (map.nrows() / k, map.ncols() / k);
    let mut out = Array2::zeros((rows, cols));
    for i in 0..rows * k {
        for j in 0..cols * k {
            out[[i / k, j / k]] += map[[i, j]];
        }
    }
    out
}

/// CV of the map at one zone size.
#[derive(Debug, Clone, PartialEq)]
pub struct ZoneCv {
    /// Requested zone side (m).
    pub zone_size: f64,
    /// Cells per zone side actually used (zone side = cells_per_side × cell size).
    pub cells_per_side: usize,
    /// Number of whole zones the CV is taken over.
    pub zones: usize,
    pub cv: f64,
}

/// CV of the map aggregated into square zones of (approximately) each requested side.
/// Zone sides are rounded to a whole number of cells; sizes below one cell or leaving
/// fewer than 4 zones are skipped, so the returned curve may be shorter than asked.
pub fn cv_by_zone_size(map: ArrayView2<f64>, cell_size: f64, zone_sizes: &[f64]) -> Vec<ZoneCv> {
    let mut out: Vec<ZoneCv> = Vec::new();
    for &zone_size in zone_sizes {
        let k = (zone_size / cell_size).round() as usize;
        if k == 0 || out.iter().any(|z| z.cells_per_side == k) {
            continue;
        }
        let blocks = block_sums(map, k);
        if blocks.len() < 4 {
            continue;
        }
        out.push(ZoneCv {
            zone_size,
            cells_per_side: k,
            zones: blocks.len(),
            cv: coefficient_of_variation(blocks.iter().copied()),
        });
    }
    out
}

/// Zone sizes from `min` to `max` (m), `per_octave` points per doubling, log-spaced.
pub fn log_zone_sizes(min: f64, max: f64, per_octave: usize) -> Vec<f64> {
    let steps = ((max / min).log2() * per_octave as f64).round() as usize;
    (0..=steps)
        .map(|i| min * 2f64.powf(i as f64 / per_octave as f64))
        .collect()
}

/// Squared CV of mass in square zones of side `zone_size` for a Poisson network of
/// infinite straight lines with total length `line_length_per_area` per unit area:
/// CV² = E1 / (π L_A x) (Dodson & Sampson; REFERENCE.md §2).
pub fn random_line_cv_squared(line_length_per_area: f64, zone_size: f64) -> f64 {
    E1 / (std::f64::consts::PI * line_length_per_area * zone_size)
}

/// Formation number n_f(x) = Var(x) / Var_random(x) = CV² / CV²_random at equal mean.
pub fn formation_number(cv: f64, line_length_per_area: f64, zone_size: f64) -> f64 {
    cv * cv / random_line_cv_squared(line_length_per_area, zone_size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e1_matches_its_closed_form() {
        let closed = 4.0 * (1.0 + 2f64.sqrt()).ln() - 4.0 / 3.0 * (2f64.sqrt() - 1.0);
        assert!((E1 - closed).abs() < 1e-6);
    }

    #[test]
    fn cv_of_constant_is_zero_and_of_known_values() {
        assert_eq!(coefficient_of_variation([2.0; 10]), 0.0);
        // values 1, 3: mean 2, population std 1.
        assert!((coefficient_of_variation([1.0, 3.0]) - 0.5).abs() < 1e-15);
        assert!(coefficient_of_variation(std::iter::empty()).is_nan());
    }

    #[test]
    fn block_sums_drop_partial_edges() {
        let map = Array2::from_elem((5, 7), 1.0);
        let b = block_sums(map.view(), 2);
        assert_eq!(b.dim(), (2, 3));
        assert!(b.iter().all(|&v| v == 4.0));
    }

    #[test]
    fn white_noise_cv_falls_as_one_over_zone_side() {
        // Independent cells: CV(k) = CV(1)/k for k×k zones.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let map = Array2::from_shape_fn((512, 512), |_| 1.0 + 0.3 * (rng.random::<f64>() - 0.5));
        let curve = cv_by_zone_size(map.view(), 1.0, &[1.0, 2.0, 4.0, 8.0]);
        let cv1 = curve[0].cv;
        for z in &curve[1..] {
            let expected = cv1 / z.cells_per_side as f64;
            assert!((z.cv - expected).abs() / expected < 0.1, "{z:?} expected {expected}");
        }
    }

    #[test]
    fn log_zone_sizes_span_the_range() {
        let z = log_zone_sizes(0.5e-3, 16e-3, 2);
        assert_eq!(z.len(), 11);
        assert!((z[0] - 0.5e-3).abs() < 1e-15 && (z[10] - 16e-3).abs() < 1e-12);
    }
}
