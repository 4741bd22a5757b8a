//! The curvature spectrum of one fibre segment: DFT coefficients K_r (eq 10),
//! energy spectrum S_r = |K_r|², frequencies ω_r = 2πr/L and the Parseval link to e.
use num_complex::Complex64;
use rustfft::FftPlanner;

use super::SpectraError;

/// DFT coefficients K_r, r = 0..N−1, of the curvature of a segment of length L
/// sampled at Δs = L/N (eqs 9-10). K_r is periodic in r with K_{−r} = K_r*.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvatureSpectrum {
    segment_length: f64,
    coefficients: Vec<Complex64>,
}

impl CurvatureSpectrum {
    /// Wraps coefficients K_r (r = 0..N−1) of a segment of length L (m).
    /// They must describe a real curvature: K_0 (and K_{N/2} for even N) real and
    /// K_{N−r} = K_r*, within 1e-9 of the largest |K_r|.
    pub fn new(segment_length: f64, coefficients: Vec<Complex64>) -> Result<Self, SpectraError> {
        let n = coefficients.len();
        if !(segment_length > 0.0 && segment_length.is_finite()) {
            return Err(SpectraError::InvalidSpectrum(format!("segment length {segment_length} m must be positive")));
        }
        if n < 2 {
            return Err(SpectraError::InvalidSpectrum(format!("{n} coefficients; need at least 2")));
        }
        if coefficients.iter().any(|k| !k.re.is_finite() || !k.im.is_finite()) {
            return Err(SpectraError::InvalidSpectrum("non-finite coefficient".into()));
        }
        let scale = coefficients.iter().map(|k| k.norm()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        for r in 0..n {
            let mirror = coefficients[(n - r) % n].conj();
            if (coefficients[r] - mirror).norm() > 1e-9 * scale {
                return Err(SpectraError::InvalidSpectrum(format!(
                    "K_{r} is not the conjugate of K_{}: the curvature would not be real",
                    (n - r) % n
                )));
            }
        }
        Ok(Self { segment_length, coefficients })
    }

    /// K_r = (1/N) Σ_m κ_m e^{−2πirm/N} (eq 10) of N curvature samples spaced
    /// Δs = L/N along a segment of length L.
    pub fn from_curvature(curvature: &[f64], segment_length: f64) -> Result<Self, SpectraError> {
        let n = curvature.len();
        if n < 2 {
            return Err(SpectraError::TooFewSamples { samples: n });
        }
        let mut buf: Vec<Complex64> = curvature.iter().map(|&k| Complex64::new(k, 0.0)).collect();
        FftPlanner::new().plan_fft_forward(n).process(&mut buf);
        let inv_n = 1.0 / n as f64;
        for k in &mut buf {
            *k *= inv_n;
        }
        // Exact symmetry for a real signal (removes FFT round-off in the imaginary parts).
        buf[0].im = 0.0;
        if n.is_multiple_of(2) {
            buf[n / 2].im = 0.0;
        }
        Ok(Self { segment_length, coefficients: buf })
    }

    /// Number of samples (and DFT bins) N.
    pub fn points(&self) -> usize {
        self.coefficients.len()
    }
    /// Segment length L (m).
    pub fn segment_length(&self) -> f64 {
        self.segment_length
    }
    /// Sample spacing Δs = L/N (m).
    pub fn spacing(&self) -> f64 {
        self.segment_length / self.points() as f64
    }
    /// The coefficients K_r (1/m), r = 0..N−1.
    pub fn coefficients(&self) -> &[Complex64] {
        &self.coefficients
    }
    /// Energy spectrum S_r = |K_r|² (1/m²), r = 0..N−1.
    pub fn energy_spectrum(&self) -> Vec<f64> {
        self.coefficients.iter().map(|k| k.norm_sqr()).collect()
    }
    /// Signed bin index of bin r: r for r ≤ N/2, r − N above (negative frequencies).
    pub fn signed_index(&self, r: usize) -> i64 {
        let n = self.points();
        if 2 * r <= n { r as i64 } else { r as i64 - n as i64 }
    }
    /// Angular frequency ω_r = 2πr/L (rad/m) of bin r, negative above N/2.
    pub fn angular_frequency(&self, r: usize) -> f64 {
        2.0 * std::f64::consts::PI * self.signed_index(r) as f64 / self.segment_length
    }
    /// Bending energy from the spectrum by Parseval: with Σ_m κ_m² = N Σ_r S_r and
    /// e = (L/2) Σ_m κ_m² Δs (eq A.3), e = (L²/2) Σ_r S_r.
    pub fn bending_energy(&self) -> f64 {
        0.5 * self.segment_length * self.segment_length * self.energy_spectrum().iter().sum::<f64>()
    }
    /// Curvature samples κ_m = Σ_r K_r e^{2πirm/N} (eq 12).
    pub fn curvature(&self) -> Vec<f64> {
        inverse_dft(&self.coefficients)
    }

    /// Energy-averaged spectrum of replicates sharing N and L: S̄_r = mean S_r,
    /// K̄_r = √S̄_r with zero phase, except K̄_0 (and K̄_{N/2}) which keep the
    /// sign of the replicates' mean (the mean curvature).
    pub fn mean(spectra: &[CurvatureSpectrum]) -> Result<Self, SpectraError> {
        check_compatible(spectra)?;
        let n = spectra[0].points();
        let count = spectra.len() as f64;
        let mut coefficients = vec![Complex64::new(0.0, 0.0); n];
        for (r, out) in coefficients.iter_mut().enumerate() {
            let energy = spectra.iter().map(|s| s.coefficients[r].norm_sqr()).sum::<f64>() / count;
            let mut magnitude = energy.sqrt();
            if r == 0 || 2 * r == n {
                let mean_re = spectra.iter().map(|s| s.coefficients[r].re).sum::<f64>();
                if mean_re < 0.0 {
                    magnitude = -magnitude;
                }
            }
            *out = Complex64::new(magnitude, 0.0);
        }
        Ok(Self { segment_length: spectra[0].segment_length, coefficients })
    }
}

/// Checks that a non-empty set of spectra share N and L (needed to join their
/// segments into one fibre and to average them).
pub fn check_compatible(spectra: &[CurvatureSpectrum]) -> Result<(), SpectraError> {
    let first = spectra.first().ok_or(SpectraError::NoSpectra)?;
    for (i, s) in spectra.iter().enumerate() {
        if s.points() != first.points() || (s.segment_length - first.segment_length).abs() > 1e-12 * first.segment_length {
            return Err(SpectraError::Incompatible {
                index: i,
                points: s.points(),
                length: s.segment_length,
                first_points: first.points(),
                first_length: first.segment_length,
            });
        }
    }
    Ok(())
}

/// κ_m = Σ_r K_r e^{2πirm/N} (eq 12), real part (the imaginary part is round-off
/// for conjugate-symmetric K_r).
pub fn inverse_dft(coefficients: &[Complex64]) -> Vec<f64> {
    let mut buf = coefficients.to_vec();
    FftPlanner::new().plan_fft_inverse(buf.len()).process(&mut buf);
    buf.iter().map(|z| z.re).collect()
}
