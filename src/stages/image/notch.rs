//! Circular Gaussian notch filters.
//!
//! A notch at fractional bin position `(v0, u0)` (signed frequency indices, rows then
//! columns) with width `σ` bins multiplies the spectrum by
//! `1 − exp(−d² / (2σ²))`, where `d` is the distance in bin-index space to the notch
//! centre, taken on the periodic frequency torus. Each notch is applied together with its
//! conjugate at `(−v0, −u0)`, so the filtered image stays real. Only bins within
//! `4σ` of a centre are touched (the factor there differs from 1 by < 3.4e-4).
//!
//! ```
//! use laydown::stages::image::notch::NotchMask;
//! let mut m = NotchMask::new(16, 16);
//! m.add_pair(2.0, 3.0, 1.5);
//! assert!(m.gain[[2, 3]] < 1e-12 && m.gain[[14, 13]] < 1e-12); // peak and conjugate
//! assert!((m.gain[[8, 8]] - 1.0).abs() < 1e-4);                 // far away: almost untouched
//! ```
use ndarray::Array2;

use super::fft2::wrap_index;

/// A multiplicative spectral mask, DC at [0, 0], initially all ones.
#[derive(Debug, Clone)]
pub struct NotchMask {
    /// Gain per bin, in [0, 1].
    pub gain: Array2<f64>,
    /// Number of Gaussian notches applied (a peak and its conjugate count as two).
    pub count: usize,
}

impl NotchMask {
    /// An all-pass mask for an (rows, cols) spectrum.
    pub fn new(rows: usize, cols: usize) -> Self {
        NotchMask { gain: Array2::ones((rows, cols)), count: 0 }
    }

    /// Applies one notch at (v0, u0) (signed, fractional bin indices) of width `sigma`
    /// bins, and its conjugate. A self-conjugate centre gets a single notch.
    pub fn add_pair(&mut self, v0: f64, u0: f64, sigma: f64) {
        self.add_one(v0, u0, sigma);
        let (h, w) = self.gain.dim();
        let same = |a: f64, n: usize| {
            let d = (a - (-a)).rem_euclid(n as f64);
            d.min(n as f64 - d) < 1e-9
        };
        if same(v0, h) && same(u0, w) {
            return;
        }
        self.add_one(-v0, -u0, sigma);
    }

    fn add_one(&mut self, v0: f64, u0: f64, sigma: f64) {
        let (h, w) = self.gain.dim();
        let reach = (4.0 * sigma).ceil() as isize;
        let vc = v0.round() as isize;
        let uc = u0.round() as isize;
        let inv2s2 = 1.0 / (2.0 * sigma * sigma);
        // Visit each storage bin once even when the window wraps around a small axis.
        let rows: Vec<isize> = window(vc, reach, h);
        let cols: Vec<isize> = window(uc, reach, w);
        for &v in &rows {
            let dv = v as f64 - v0;
            for &u in &cols {
                let du = u as f64 - u0;
                let g = 1.0 - (-(dv * dv + du * du) * inv2s2).exp();
                self.gain[[wrap_index(v, h), wrap_index(u, w)]] *= g;
            }
        }
        self.count += 1;
    }

    /// Resets the DC gain to 1 (a notch near DC must not change the image mean).
    pub fn keep_dc(&mut self) {
        self.gain[[0, 0]] = 1.0;
    }
}

/// Signed indices `c − reach ..= c + reach`, trimmed to at most `n` distinct storage bins
/// (keeping those nearest the centre).
fn window(c: isize, reach: isize, n: usize) -> Vec<isize> {
    let n = n as isize;
    if 2 * reach < n {
        return (c - reach..=c + reach).collect();
    }
    let lo = c - (n - 1) / 2;
    (lo..lo + n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notch_is_gaussian_in_bin_distance_and_wraps() {
        let mut m = NotchMask::new(20, 20);
        m.add_pair(0.0, 9.5, 2.0);
        // Distance 0.5 bin from the centre, conjugate at u = −9.5 ≡ 10.5 also 0.5 away from u = 10.
        let d2 = 0.25;
        let expected_one = 1.0 - (-d2 / 8.0f64).exp();
        // Bin u = 10 (signed −10) is 0.5 from both the notch (9.5) and its conjugate (−9.5 ≡ 10.5).
        assert!((m.gain[[0, 10]] - expected_one * expected_one).abs() < 1e-12);
        assert_eq!(m.count, 2);
        // Conjugate symmetry of the gain keeps images real.
        for q in 0..20 {
            for r in 0..20 {
                assert!((m.gain[[q, r]] - m.gain[[(20 - q) % 20, (20 - r) % 20]]).abs() < 1e-12);
            }
        }
    }
}
