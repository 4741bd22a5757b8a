//! From a laid fibre (nodes on the belt) to curvature samples at uniform arc length
//! (eq 9), and back to a planar curve by the trapezoidal rule (eq 13).
use std::f64::consts::PI;

use super::{CurvatureSpectrum, SpectraError};
use crate::geometry::chord_angle;

/// Curvature of a fibre sampled at uniform arc length, with the initial state
/// needed to rebuild the curve by eq 13.
///
/// Conventions (all in the belt plane, x = machine direction, y = cross direction):
/// - `resampled[m]` is the input polyline at arc length s_m = mΔs, m = 0..=N, so the
///   segment length is L = NΔs exactly and the DFT frequencies are ω_r = 2πr/L.
/// - κ_m for m = 1..N−1 is the turning angle between the chords either side of
///   `resampled[m]` divided by Δs; the free end has no turning angle and takes its
///   neighbour's value, κ_0 = κ_1.
/// - θ_0 = φ_{1/2} − κ_0Δs/2 with φ_{1/2} the direction of the first chord, so the
///   first chord runs along the mean of θ_0 and θ_1, as eq 13 assumes.
///
/// [`CurvatureSignal::reconstruct`] (eq 13) differs from `resampled` by
/// O((κΔs)²) relative; it is the discrete curve the spectrum describes exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvatureSignal {
    /// Δs (m).
    pub spacing: f64,
    /// r_0 (m).
    pub start: [f64; 2],
    /// θ_0 (rad).
    pub tangent_angle_start: f64,
    /// κ_m (1/m), m = 0..N−1.
    pub curvature: Vec<f64>,
    /// The input polyline at s_m = mΔs, m = 0..=N (m).
    pub resampled: Vec<[f64; 2]>,
}

impl CurvatureSignal {
    /// N.
    pub fn points(&self) -> usize {
        self.curvature.len()
    }
    /// L = NΔs (m).
    pub fn segment_length(&self) -> f64 {
        self.spacing * self.points() as f64
    }
    /// Unwrapped tangent angles θ_m (rad), m = 0..N−1, by eq 13.
    pub fn tangent_angles(&self) -> Vec<f64> {
        tangent_angles(&self.curvature, self.spacing, self.tangent_angle_start)
    }
    /// e = (L/2) Σ_m κ_m² Δs (eq A.3, rectangle rule over the periodic samples).
    pub fn bending_energy(&self) -> f64 {
        0.5 * self.segment_length() * self.curvature.iter().map(|k| k * k).sum::<f64>() * self.spacing
    }
    /// The spectrum K_r (eq 10).
    pub fn spectrum(&self) -> Result<CurvatureSpectrum, SpectraError> {
        CurvatureSpectrum::from_curvature(&self.curvature, self.segment_length())
    }
    /// The curve rebuilt from the samples by eq 13: N + 1 nodes.
    pub fn reconstruct(&self) -> Vec<[f64; 2]> {
        integrate_curvature(&self.curvature, self.spacing, self.tangent_angle_start, self.start, 0.0)
    }
}

/// Samples the fibre's projection on the belt plane (x, y of each node; z is dropped)
/// at uniform arc length `spacing` = Δs.
///
/// `points` = N fixes the number of samples (the fibre must be at least NΔs long);
/// `None` takes N = ⌊length/Δs⌋, dropping the last partial interval so that Δs stays
/// exactly as requested and L = NΔs.
pub fn sample_fibre(nodes: &[[f64; 3]], spacing: f64, points: Option<usize>) -> Result<CurvatureSignal, SpectraError> {
    if !(spacing > 0.0 && spacing.is_finite()) {
        return Err(SpectraError::Param(crate::params::ParamSpec::find(super::SPECTRA_PARAMS, "sample_spacing").check_number(spacing).unwrap_err()));
    }
    if nodes.len() < 2 {
        return Err(SpectraError::InvalidFibre(format!("{} node(s); need at least 2", nodes.len())));
    }
    if let Some(i) = nodes.iter().position(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return Err(SpectraError::InvalidFibre(format!("node {i} has a non-finite coordinate")));
    }
    // Cumulative arc length of the projected polyline.
    let mut cumulative = Vec::with_capacity(nodes.len());
    let mut total = 0.0;
    cumulative.push(0.0);
    for w in nodes.windows(2) {
        total += (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Err(SpectraError::InvalidFibre("zero projected length".into()));
    }
    if spacing > total {
        return Err(SpectraError::SpacingLongerThanFibre { spacing, length: total, points: 1 });
    }
    let n = match points {
        Some(n) => {
            if n as f64 * spacing > total * (1.0 + 1e-9) {
                return Err(SpectraError::SpacingLongerThanFibre { spacing, length: total, points: n });
            }
            n
        }
        None => (total / spacing * (1.0 + 1e-12)).floor() as usize,
    };
    if n < 3 {
        return Err(SpectraError::TooFewSamples { samples: n });
    }
    // Linear interpolation at s_m = mΔs, m = 0..=n.
    let mut resampled = Vec::with_capacity(n + 1);
    let mut j = 0;
    for m in 0..=n {
        let s = (m as f64 * spacing).min(total);
        while j + 2 < cumulative.len() && cumulative[j + 1] < s {
            j += 1;
        }
        let seg = cumulative[j + 1] - cumulative[j];
        let t = if seg > 0.0 { ((s - cumulative[j]) / seg).clamp(0.0, 1.0) } else { 0.0 };
        let (a, b) = (nodes[j], nodes[j + 1]);
        resampled.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
    }
    let curvature = turning_curvature(&resampled, spacing);
    let first_chord = chord_angle(resampled[0], resampled[1]);
    let tangent_angle_start = first_chord - 0.5 * curvature[0] * spacing;
    Ok(CurvatureSignal { spacing, start: resampled[0], tangent_angle_start, curvature, resampled })
}

/// Curvature samples (eq 9) of a polyline whose N + 1 nodes lie Δs = `spacing` apart
/// along it, as [`sample_fibre`] reads them off the nodes it resampled: κ_m is the
/// turning angle between the chords either side of node m, wrapped to (−π, π], over Δs,
/// for m = 1..N−1, and κ_0 = κ_1 (a single chord, N = 1: κ_0 = 0). Nodes not exactly Δs
/// apart are not resampled: the turning angles are theirs, divided by the nominal Δs.
///
/// ```
/// use laydown::stages::spectra::turning_curvature;
/// // A right-angle corner at node 1 of three nodes 1 mm apart: κ_1 = (π/2)/Δs.
/// let k = turning_curvature(&[[0.0, 0.0], [1e-3, 0.0], [1e-3, 1e-3]], 1e-3);
/// assert_eq!(k.len(), 2);
/// assert!((k[1] - std::f64::consts::FRAC_PI_2 / 1e-3).abs() < 1e-9 && k[0] == k[1]);
/// ```
pub fn turning_curvature(nodes: &[[f64; 2]], spacing: f64) -> Vec<f64> {
    let n = nodes.len().saturating_sub(1);
    // Chord directions φ_{m+1/2}, m = 0..n−1.
    let chord: Vec<f64> = nodes.windows(2).map(|w| chord_angle(w[0], w[1])).collect();
    let mut curvature = vec![0.0; n];
    for m in 1..n {
        curvature[m] = wrap_angle(chord[m] - chord[m - 1]) / spacing;
    }
    if n >= 2 {
        curvature[0] = curvature[1];
    }
    curvature
}

/// θ_{m+1} = θ_m + (κ_m + κ_{m+1})Δs/2 (eq 13), m = 0..N−2: N angles.
pub fn tangent_angles(curvature: &[f64], spacing: f64, theta0: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(curvature.len());
    let mut theta = theta0;
    for (m, &k) in curvature.iter().enumerate() {
        if m > 0 {
            theta += 0.5 * (curvature[m - 1] + k) * spacing;
        }
        out.push(theta);
    }
    out
}

/// Builds the planar curve from curvature samples by the trapezoidal rule (eq 13)
/// with belt drift dx/ds = cos θ + c (eq 14, `drift` = c; 0 for the fibre as laid).
/// The samples are treated as one period (κ_N = κ_0), so N samples give N + 1 nodes
/// spanning the whole segment length L = NΔs.
pub fn integrate_curvature(curvature: &[f64], spacing: f64, theta0: f64, start: [f64; 2], drift: f64) -> Vec<[f64; 2]> {
    let n = curvature.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut p = start;
    let mut theta = theta0;
    let (mut s0, mut c0) = theta.sin_cos();
    out.push(p);
    for m in 0..n {
        theta += 0.5 * (curvature[m] + curvature[(m + 1) % n]) * spacing;
        let (s1, c1) = theta.sin_cos();
        p[0] += (0.5 * (c0 + c1) + drift) * spacing;
        p[1] += 0.5 * (s0 + s1) * spacing;
        out.push(p);
        (s0, c0) = (s1, c1);
    }
    out
}

/// Rebuilds a curve from DFT coefficients: inverse DFT (eq 12) then eq 13.
pub fn reconstruct(spectrum: &CurvatureSpectrum, theta0: f64, start: [f64; 2]) -> Vec<[f64; 2]> {
    integrate_curvature(&spectrum.curvature(), spectrum.spacing(), theta0, start, 0.0)
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let w = a - 2.0 * PI * (a / (2.0 * PI)).round();
    if w <= -PI { w + 2.0 * PI } else { w }
}
