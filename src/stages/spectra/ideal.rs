//! Idealised square-wave curvature spectrum (Appendix A.1, eqs A.1-A.5).
use num_complex::Complex64;

use super::{CurvatureSpectrum, SpectraError, SQUARE_WAVE_PARAMS};
use crate::params::ParamSpec;

/// The paper's three idealised spectra (Fig 10): (name, e, n_c).
pub const SQUARE_WAVE_PRESETS: [(&str, f64, usize); 3] =
    [("spectrum1", 2.5e3, 20), ("spectrum2", 2.5e4, 50), ("spectrum3", 2.5e5, 100)];

/// Square-wave spectrum S(ω) = S0 for |ω| ≤ ω_c = n_c·2π/L (eq A.1) on N bins.
///
/// Discrete convention (REFERENCE.md §2): the non-zero bins are r = 0, ±1, …, ±n_c,
/// i.e. 2n_c + 1 bins **including r = 0** (the mean curvature; without it every
/// segment's tangent returns to its start angle and the fibres drift along it).
/// Each bin has S_r = S0_bin = 2e / (L²(2n_c + 1)) and K_r = +√S0_bin, so by
/// Parseval every segment built from it (any phases) has bending energy exactly
/// `bending_energy` = e. The continuous eq A.5, e = S0·ω_c·L/(2π), counts only 2n_c
/// bins' worth of width; its density S0 = L²·S0_bin·(2n_c+1)/(2n_c) is reported by
/// [`SquareWaveParams::continuous_density`] for comparison, a factor (2n_c+1)/(2n_c)
/// larger than L²·S0_bin.
///
/// ```
/// use laydown::stages::spectra::SquareWaveParams;
/// let p = SquareWaveParams::preset("spectrum1").unwrap();
/// let s = p.spectrum().unwrap();
/// assert_eq!(s.points(), 1000);
/// assert!((s.bending_energy() - 2.5e3).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SquareWaveParams {
    /// e, non-dimensional bending energy of one segment (eq A.3).
    pub bending_energy: f64,
    /// n_c, cut-off bin: ω_c = n_c·2π/L.
    pub cutoff_number: usize,
    /// L (m).
    pub segment_length: f64,
    /// N, samples per segment (Δs = L/N).
    pub points_per_segment: usize,
}

impl Default for SquareWaveParams {
    /// spectrum1 on L = 1 m, N = 1000 (the FE fibre's length and element count).
    fn default() -> Self {
        Self { bending_energy: 2.5e3, cutoff_number: 20, segment_length: 1.0, points_per_segment: 1000 }
    }
}

impl SquareWaveParams {
    /// One of [`SQUARE_WAVE_PRESETS`] with L = 1 m, N = 1000.
    pub fn preset(name: &str) -> Option<Self> {
        SQUARE_WAVE_PRESETS
            .iter()
            .find(|p| p.0 == name)
            .map(|&(_, e, nc)| Self { bending_energy: e, cutoff_number: nc, ..Self::default() })
    }

    pub fn validate(&self) -> Result<(), SpectraError> {
        let t = SQUARE_WAVE_PARAMS;
        ParamSpec::find(t, "bending_energy").check_number(self.bending_energy)?;
        ParamSpec::find(t, "cutoff_number").check_number(self.cutoff_number as f64)?;
        ParamSpec::find(t, "segment_length").check_number(self.segment_length)?;
        ParamSpec::find(t, "points_per_segment").check_number(self.points_per_segment as f64)?;
        if 2 * self.cutoff_number >= self.points_per_segment {
            return Err(SpectraError::CutoffBeyondNyquist {
                cutoff: self.cutoff_number,
                points: self.points_per_segment,
            });
        }
        Ok(())
    }

    /// S0_bin = 2e / (L²(2n_c+1)) (1/m²): the energy of each of the 2n_c+1 bins.
    pub fn bin_energy(&self) -> f64 {
        2.0 * self.bending_energy / (self.segment_length.powi(2) * (2 * self.cutoff_number + 1) as f64)
    }
    /// ω_c = n_c·2π/L (rad/m).
    pub fn cutoff_frequency(&self) -> f64 {
        self.cutoff_number as f64 * 2.0 * std::f64::consts::PI / self.segment_length
    }
    /// The continuous density S0 of eq A.5 for the same e: S0 = 2πe/(ω_c L) = e/n_c.
    pub fn continuous_density(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.bending_energy / (self.cutoff_frequency() * self.segment_length)
    }

    /// The spectrum K_r = √S0_bin for |r| ≤ n_c, 0 elsewhere (zero phases).
    pub fn spectrum(&self) -> Result<CurvatureSpectrum, SpectraError> {
        self.validate()?;
        let n = self.points_per_segment;
        let k = self.bin_energy().sqrt();
        let mut coefficients = vec![Complex64::new(0.0, 0.0); n];
        for r in 0..=self.cutoff_number {
            coefficients[r] = Complex64::new(k, 0.0);
            coefficients[(n - r) % n] = Complex64::new(k, 0.0);
        }
        CurvatureSpectrum::new(self.segment_length, coefficients)
    }
}
