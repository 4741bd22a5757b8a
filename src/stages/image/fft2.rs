//! Two-dimensional FFT of any size (rows, then columns) on top of `rustfft`.
//!
//! Data are stored row-major as `Array2<Complex64>` of shape (rows, cols), i.e. (y, x).
//! The forward transform is unnormalised, `F[v, u] = Σ f[i, j] exp(−2πi (u j / W + v i / H))`;
//! the inverse divides by `H·W`, so `inverse(forward(f)) == f`. Any size works (prime
//! lengths such as 617 use rustfft's Rader/Bluestein algorithms).
//!
//! ```
//! use laydown::stages::image::fft2::Fft2;
//! use ndarray::Array2;
//! use num_complex::Complex64;
//! let f = Array2::from_shape_fn((5, 7), |(i, j)| Complex64::new((i * 7 + j) as f64, 0.0));
//! let plan = Fft2::new(5, 7);
//! let mut g = f.clone();
//! plan.forward(&mut g);
//! // DC bin is the sum of all samples.
//! assert!((g[[0, 0]].re - (0..35).sum::<usize>() as f64).abs() < 1e-9);
//! plan.inverse(&mut g);
//! assert!(g.iter().zip(f.iter()).all(|(a, b)| (a - b).norm() < 1e-9));
//! ```
use ndarray::Array2;
use num_complex::Complex64;
use rustfft::{Fft, FftDirection, FftPlanner};
use std::sync::Arc;

/// A planned 2D transform for one (rows, cols) shape; reusable across images of that shape.
pub struct Fft2 {
    rows: usize,
    cols: usize,
    row_fwd: Arc<dyn Fft<f64>>,
    row_inv: Arc<dyn Fft<f64>>,
    col_fwd: Arc<dyn Fft<f64>>,
    col_inv: Arc<dyn Fft<f64>>,
}

impl Fft2 {
    /// Plans transforms for images of `rows × cols` pixels (both ≥ 1).
    pub fn new(rows: usize, cols: usize) -> Self {
        assert!(rows >= 1 && cols >= 1, "FFT size must be at least 1×1");
        let mut planner = FftPlanner::<f64>::new();
        Fft2 {
            rows,
            cols,
            row_fwd: planner.plan_fft(cols, FftDirection::Forward),
            row_inv: planner.plan_fft(cols, FftDirection::Inverse),
            col_fwd: planner.plan_fft(rows, FftDirection::Forward),
            col_inv: planner.plan_fft(rows, FftDirection::Inverse),
        }
    }

    /// (rows, cols) this plan transforms.
    pub fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// In-place unnormalised forward transform.
    pub fn forward(&self, data: &mut Array2<Complex64>) {
        self.run(data, &self.row_fwd, &self.col_fwd);
    }

    /// In-place inverse transform, normalised by 1/(rows·cols).
    pub fn inverse(&self, data: &mut Array2<Complex64>) {
        self.run(data, &self.row_inv, &self.col_inv);
        let scale = 1.0 / (self.rows * self.cols) as f64;
        data.mapv_inplace(|z| z * scale);
    }

    fn run(&self, data: &mut Array2<Complex64>, row: &Arc<dyn Fft<f64>>, col: &Arc<dyn Fft<f64>>) {
        assert_eq!(data.dim(), (self.rows, self.cols), "array shape differs from the plan");
        let (h, w) = (self.rows, self.cols);
        // Rows: contiguous chunks of length w, transformed in one call.
        {
            let buf = data
                .as_slice_mut()
                .expect("Fft2 needs a standard-layout (row-major) array");
            let mut scratch = vec![Complex64::default(); row.get_inplace_scratch_len()];
            row.process_with_scratch(buf, &mut scratch);
        }
        // Columns: transpose into a (w, h) buffer so each column is contiguous.
        let mut t = vec![Complex64::default(); h * w];
        {
            let buf = data.as_slice().unwrap();
            transpose(buf, &mut t, h, w);
            let mut scratch = vec![Complex64::default(); col.get_inplace_scratch_len()];
            col.process_with_scratch(&mut t, &mut scratch);
        }
        let buf = data.as_slice_mut().unwrap();
        transpose(&t, buf, w, h);
    }
}

/// Cache-blocked transpose of a row-major (h, w) matrix into a row-major (w, h) one.
fn transpose(src: &[Complex64], dst: &mut [Complex64], h: usize, w: usize) {
    const B: usize = 32;
    for i0 in (0..h).step_by(B) {
        for j0 in (0..w).step_by(B) {
            for i in i0..(i0 + B).min(h) {
                for j in j0..(j0 + B).min(w) {
                    dst[j * h + i] = src[i * w + j];
                }
            }
        }
    }
}

/// Signed frequency index of bin `k` for a transform of length `n`: 0, 1, …, ⌈n/2⌉−1, −⌊n/2⌋, …, −1.
pub fn signed_index(k: usize, n: usize) -> isize {
    if k < n.div_ceil(2) {
        k as isize
    } else {
        k as isize - n as isize
    }
}

/// Storage index of signed frequency `s` (any integer, wrapped modulo `n`).
pub fn wrap_index(s: isize, n: usize) -> usize {
    s.rem_euclid(n as isize) as usize
}

/// Moves the zero-frequency bin to the centre (row ⌊H/2⌋, column ⌊W/2⌋), like numpy's `fftshift`.
pub fn fftshift(a: &Array2<f64>) -> Array2<f64> {
    let (h, w) = a.dim();
    Array2::from_shape_fn((h, w), |(i, j)| a[[(i + h - h / 2) % h, (j + w - w / 2) % w]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_dft_on_odd_prime_shape() {
        let (h, w) = (7, 5);
        let f = Array2::from_shape_fn((h, w), |(i, j)| {
            Complex64::new(((i * 31 + j * 17) % 11) as f64, ((i + 2 * j) % 3) as f64)
        });
        let mut g = f.clone();
        Fft2::new(h, w).forward(&mut g);
        for v in 0..h {
            for u in 0..w {
                let mut s = Complex64::default();
                for i in 0..h {
                    for j in 0..w {
                        let ph = -2.0 * std::f64::consts::PI * (u as f64 * j as f64 / w as f64 + v as f64 * i as f64 / h as f64);
                        s += f[[i, j]] * Complex64::from_polar(1.0, ph);
                    }
                }
                assert!((s - g[[v, u]]).norm() < 1e-9, "bin ({v},{u})");
            }
        }
    }

    #[test]
    fn signed_and_wrapped_indices_round_trip() {
        for n in [1usize, 2, 5, 6] {
            for k in 0..n {
                assert_eq!(wrap_index(signed_index(k, n), n), k);
            }
        }
        assert_eq!(signed_index(3, 6), -3);
        assert_eq!(signed_index(2, 5), 2);
        assert_eq!(signed_index(3, 5), -2);
    }

    #[test]
    fn fftshift_puts_dc_in_the_middle() {
        let mut a = Array2::zeros((5, 4));
        a[[0, 0]] = 1.0;
        let s = fftshift(&a);
        assert_eq!(s[[2, 2]], 1.0);
    }
}
