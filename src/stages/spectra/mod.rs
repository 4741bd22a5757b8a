//! Spectra stage numerics (§3.1 eqs 9-10, Appendix A.1 eqs A.1-A.6).
//!
//! A laid fibre (belt plane: x = machine direction, y = cross direction) is projected
//! on the belt, sampled at uniform arc length Δs ([`sample_fibre`]), turned into
//! curvature samples κ_m (eq 9) and their DFT K_r (eq 10, [`CurvatureSpectrum`]);
//! S_r = |K_r|² at ω_r = 2πr/L with L = NΔs exactly. The bending energy is
//! available from the samples and, by Parseval, from the spectrum. Idealised
//! square-wave spectra (eq A.1) come from [`SquareWaveParams`].
//!
//! ```
//! use laydown::stages::spectra::{sample_fibre, reconstruct};
//! use std::f64::consts::PI;
//! // A circle of length 1 m: all curvature in r = 0, e = 2π².
//! let nodes: Vec<[f64; 3]> = (0..=1000)
//!     .map(|i| { let a = 2.0 * PI * i as f64 / 1000.0; [a.sin() / (2.0 * PI), (1.0 - a.cos()) / (2.0 * PI), 0.0] })
//!     .collect();
//! let signal = sample_fibre(&nodes, 1e-3, None).unwrap();
//! let spectrum = signal.spectrum().unwrap();
//! let s = spectrum.energy_spectrum();
//! assert!((s[0].sqrt() - 2.0 * PI).abs() < 1e-3 && s[1..].iter().all(|&x| x < 1e-12));
//! // N = 999 samples fit (the 1000-gon is slightly shorter than 1 m): e ≈ 2π²·0.999².
//! assert!((spectrum.bending_energy() - 2.0 * PI * PI).abs() < 0.05);
//! let rebuilt = reconstruct(&spectrum, signal.tangent_angle_start, signal.start);
//! assert!((rebuilt[500][1] - 1.0 / PI).abs() < 1e-5);
//! ```
mod ideal;
mod sample;
mod spectrum;

pub use ideal::{SquareWaveParams, SQUARE_WAVE_PRESETS};
pub use sample::{integrate_curvature, reconstruct, sample_fibre, tangent_angles, turning_curvature, wrap_angle, CurvatureSignal};
pub use spectrum::{check_compatible, inverse_dft, CurvatureSpectrum};

use crate::params::{ParamError, ParamSpec};

/// Errors of the spectra stage.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectraError {
    #[error("no valid fibre: {0}")]
    InvalidFibre(String),
    #[error("sample spacing Δs = {spacing} m with N = {points} samples needs more than the fibre's projected length {length} m")]
    SpacingLongerThanFibre { spacing: f64, length: f64, points: usize },
    #[error("{samples} curvature samples; need at least 3 (reduce sample_spacing)")]
    TooFewSamples { samples: usize },
    #[error("cut-off n_c = {cutoff} is at or beyond the Nyquist bin N/2 = {} for N = {points} (need 2·n_c < N)", points / 2)]
    CutoffBeyondNyquist { cutoff: usize, points: usize },
    #[error("invalid spectrum: {0}")]
    InvalidSpectrum(String),
    #[error("no spectra given")]
    NoSpectra,
    #[error("spectrum {index} has N = {points}, L = {length} m but spectrum 0 has N = {first_points}, L = {first_length} m; a set must share N and L")]
    Incompatible { index: usize, points: usize, length: f64, first_points: usize, first_length: f64 },
    #[error(transparent)]
    Param(#[from] ParamError),
}

/// Parameters of the analysis of laid fibres.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpectraParams {
    /// Δs (m): arc-length spacing of the curvature samples. Default 1 mm, the FE
    /// element size (1 m fibre, 1000 elements).
    pub sample_spacing: f64,
    /// N: samples per fibre; 0 = the largest N that fits every fibre of the set
    /// (so all spectra share N and L = NΔs and can be joined or averaged).
    pub points_per_segment: usize,
}

impl Default for SpectraParams {
    fn default() -> Self {
        Self { sample_spacing: 1e-3, points_per_segment: 0 }
    }
}

impl SpectraParams {
    pub fn validate(&self) -> Result<(), SpectraError> {
        ParamSpec::find(SPECTRA_PARAMS, "sample_spacing").check_number(self.sample_spacing)?;
        ParamSpec::find(SPECTRA_PARAMS, "points_per_segment").check_number(self.points_per_segment as f64)?;
        Ok(())
    }
}

/// Parameter table of [`SpectraParams`].
pub const SPECTRA_PARAMS: &[ParamSpec] = &[
    ParamSpec::float("sample_spacing", "m", 1e-3, 1e-7, 1.0, "Δs, arc-length spacing of curvature samples (eq 9); default the FE element size"),
    ParamSpec::int("points_per_segment", "1", 0, 0, 10_000_000, "N, samples per fibre; 0 = largest N fitting every fibre of the set"),
];

/// Parameter table of [`SquareWaveParams`].
pub const SQUARE_WAVE_PARAMS: &[ParamSpec] = &[
    ParamSpec::float("bending_energy", "1", 2.5e3, 0.0, 1e9, "e = V_b L/EI of each generated segment (eqs A.3, A.5); presets 2.5e3 / 2.5e4 / 2.5e5"),
    ParamSpec::int("cutoff_number", "1", 20, 0, 5_000_000, "n_c, ω_c = n_c·2π/L (eq A.1); bins |r| ≤ n_c incl. r = 0 are non-zero; need 2n_c < N"),
    ParamSpec::float("segment_length", "m", 1.0, f64::MIN_POSITIVE, 1e3, "L, length of one random segment (the FE fibre length)"),
    ParamSpec::int("points_per_segment", "1", 1000, 4, 10_000_000, "N, curvature samples per segment; Δs = L/N"),
];


/// Spectrum analysis of one laid fibre.
#[derive(Debug, Clone, PartialEq)]
pub struct FibreAnalysis {
    pub signal: CurvatureSignal,
    pub spectrum: CurvatureSpectrum,
    /// e from the samples, (L/2)Σκ²Δs.
    pub bending_energy_samples: f64,
    /// e from the spectrum, (L²/2)ΣS_r (Parseval); equals the above to round-off.
    pub bending_energy_spectrum: f64,
}

/// Analyses a set of laid fibres with a common N (see [`SpectraParams`]).
/// Fails on the first fibre that is invalid or too short, naming its index.
pub fn analyse_fibres<F: AsRef<[[f64; 3]]>>(fibres: &[F], params: &SpectraParams) -> Result<Vec<FibreAnalysis>, (usize, SpectraError)> {
    params.validate().map_err(|e| (0, e))?;
    if fibres.is_empty() {
        return Err((0, SpectraError::InvalidFibre("empty set of fibres".into())));
    }
    let points = if params.points_per_segment > 0 {
        params.points_per_segment
    } else {
        let mut n = usize::MAX;
        for (i, f) in fibres.iter().enumerate() {
            n = n.min(sample_fibre(f.as_ref(), params.sample_spacing, None).map_err(|e| (i, e))?.points());
        }
        n
    };
    fibres
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let signal = sample_fibre(f.as_ref(), params.sample_spacing, Some(points)).map_err(|e| (i, e))?;
            let spectrum = signal.spectrum().map_err(|e| (i, e))?;
            Ok(FibreAnalysis {
                bending_energy_samples: signal.bending_energy(),
                bending_energy_spectrum: spectrum.bending_energy(),
                signal,
                spectrum,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests;

mod stage;
pub use stage::{declared_spectra, SpectraStage, SpectraStageParams};
