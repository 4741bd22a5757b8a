//! Periodic-plus-smooth decomposition (L. Moisan, "Periodic plus smooth image
//! decomposition", J. Math. Imaging Vis. 39, 2011).
//!
//! The DFT treats an image as one tile of a periodic plane; the jumps between opposite
//! edges of a real scan then put a bright "+" of power along both frequency axes, which a
//! peak detector would report as thousands of peaks. Moisan splits the image `u = p + s`
//! into a periodic component `p` (no edge jumps, no cross) and a smooth component `s`
//! (zero mean, a discrete harmonic field driven by the edge jumps, carrying almost only
//! low frequencies). The image stage detects and notches peaks in the spectrum of `p` and
//! adds `s` back afterwards, so no image content is lost.
//!
//! ```
//! use laydown::stages::image::{fft2::Fft2, periodic::periodic_smooth_spectra};
//! use ndarray::Array2;
//! // A ramp has a large jump between its first and last column.
//! let u = Array2::from_shape_fn((16, 16), |(_, j)| j as f64);
//! let (p_hat, s_hat) = periodic_smooth_spectra(&u, &Fft2::new(16, 16));
//! // Spectrum of u = spectrum of p + spectrum of s, and s has zero mean.
//! assert!(s_hat[[0, 0]].norm() < 1e-9);
//! assert!((p_hat[[0, 0]].re - u.sum()).abs() < 1e-9);
//! ```
use super::fft2::Fft2;
use ndarray::Array2;
use num_complex::Complex64;

/// Returns the spectra `(P̂, Ŝ)` of the periodic and smooth components of `u`
/// (unnormalised forward DFTs; `P̂ + Ŝ` is the DFT of `u`).
pub fn periodic_smooth_spectra(u: &Array2<f64>, plan: &Fft2) -> (Array2<Complex64>, Array2<Complex64>) {
    let u_hat = plan.forward_real(u);
    let sm = SmoothSpectrum::new(u, plan);
    let s_hat = Array2::from_shape_fn(u.dim(), |(q, r)| sm.at(q, r));
    let p_hat = &u_hat - &s_hat;
    (p_hat, s_hat)
}

/// Returns `(P̂, Û)`: the spectrum of the periodic component and that of the whole image,
/// without storing `Ŝ = Û − P̂` (what the image stage needs).
pub fn periodic_and_image_spectra(u: &Array2<f64>, plan: &Fft2) -> (Array2<Complex64>, Array2<Complex64>) {
    let u_hat = plan.forward_real(u);
    let sm = SmoothSpectrum::new(u, plan);
    let mut p_hat = u_hat.clone();
    for ((q, r), z) in p_hat.indexed_iter_mut() {
        *z -= sm.at(q, r);
    }
    (p_hat, u_hat)
}

/// Ŝ(q, r) = V(q, r) / (2cos(2πq/h) + 2cos(2πr/w) − 4), V the DFT of the boundary image
/// v: +d on the first row/column and −d on the last, d the jump to the periodic
/// neighbour. V needs only two 1D transforms:
/// `V(q, r) = D(r)·(1 − e^{2πiq/h}) + E(q)·(1 − e^{2πir/w})`,
/// D = DFT_w of the row jumps `u[h−1, ·] − u[0, ·]`, E = DFT_h of `u[·, w−1] − u[·, 0]`.
struct SmoothSpectrum {
    d: Vec<Complex64>,
    e: Vec<Complex64>,
    fy: Vec<Complex64>,
    fx: Vec<Complex64>,
    cy: Vec<f64>,
    cx: Vec<f64>,
}

impl SmoothSpectrum {
    fn new(u: &Array2<f64>, plan: &Fft2) -> Self {
        let (h, w) = u.dim();
        let mut d: Vec<Complex64> = (0..w).map(|j| Complex64::new(u[[h - 1, j]] - u[[0, j]], 0.0)).collect();
        let mut e: Vec<Complex64> = (0..h).map(|i| Complex64::new(u[[i, w - 1]] - u[[i, 0]], 0.0)).collect();
        plan.forward_row(&mut d);
        plan.forward_column(&mut e);
        let two_pi = 2.0 * std::f64::consts::PI;
        let one = Complex64::new(1.0, 0.0);
        SmoothSpectrum {
            d,
            e,
            fy: (0..h).map(|q| one - Complex64::from_polar(1.0, two_pi * q as f64 / h as f64)).collect(),
            fx: (0..w).map(|r| one - Complex64::from_polar(1.0, two_pi * r as f64 / w as f64)).collect(),
            cy: (0..h).map(|q| 2.0 * (two_pi * q as f64 / h as f64).cos()).collect(),
            cx: (0..w).map(|r| 2.0 * (two_pi * r as f64 / w as f64).cos()).collect(),
        }
    }

    #[inline]
    fn at(&self, q: usize, r: usize) -> Complex64 {
        if q == 0 && r == 0 {
            Complex64::default()
        } else {
            (self.d[r] * self.fy[q] + self.e[q] * self.fx[r]) / (self.cy[q] + self.cx[r] - 4.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn periodic_component_has_no_axis_cross() {
        // A linear ramp in x: its raw spectrum has a strong 1/u² line along ky = 0.
        let (h, w) = (32, 40);
        let u = Array2::from_shape_fn((h, w), |(i, j)| j as f64 + 0.5 * i as f64);
        let plan = Fft2::new(h, w);
        let (p_hat, s_hat) = periodic_smooth_spectra(&u, &plan);
        let mut raw = u.mapv(|x| Complex64::new(x, 0.0));
        plan.forward(&mut raw);
        let axis_raw: f64 = (1..w).map(|r| raw[[0, r]].norm_sqr()).sum();
        let axis_p: f64 = (1..w).map(|r| p_hat[[0, r]].norm_sqr()).sum();
        assert!(axis_p < 1e-3 * axis_raw, "{axis_p} vs {axis_raw}");
        let (p2, u2) = periodic_and_image_spectra(&u, &plan);
        assert!(p2.iter().zip(p_hat.iter()).all(|(a, b)| (a - b).norm() < 1e-9));
        assert!(u2.iter().zip(raw.iter()).all(|(a, b)| (a - b).norm() < 1e-9));
        // p + s reproduces u.
        let mut back = &p_hat + &s_hat;
        plan.inverse(&mut back);
        assert!(back.iter().zip(u.iter()).all(|(a, b)| (a.re - b).abs() < 1e-9));
    }
}
