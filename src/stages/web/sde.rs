//! The stochastic lay-down model of Fraunhofer ITWM (Götz, Klar, Marheineke & Wegener,
//! SIAM J. Appl. Math. 67, 2007) as a web generator, and its calibration on laid fibres.
//!
//! A fibre is a planar curve in arc length s. Its position η relative to its deposition
//! point and its tangent angle α obey
//!
//! ```text
//! dη = τ(α) ds,    dα = −(∇V(η)·τ⊥(α)) ds + A dW_s,    V(η) = |η|²/(2b²),
//! ```
//!
//! with τ = (cos α, sin α), τ⊥ = (−sin α, cos α) and W a Brownian motion in s. The
//! potential V holds the fibre around its deposition point: the stationary density of η
//! is ∝ exp(−V(η)) whatever A (set ∂_α-independent p(η) in the Fokker-Planck equation:
//! τ·(∇p + p∇V) = 0), a Gaussian of standard deviation b per axis. The noise A makes the
//! loops: the tangent decorrelates over 2/A² of arc length where the potential is weak.
//! `b` is [`LayDownSde::potential_length`] (m), `A` is [`LayDownSde::noise`] (m^-1/2).
//!
//! **Belt.** η is the belt-removed curve (the frame the spectra stage analyses laid
//! fibres in), so the belt enters as for the other generators, by eq 14: the laid fibre
//! is η(s) + c·s·e_x. (ITWM's belt model writes dη = (τ − c e_x) ds with the laid curve
//! at unit speed instead; the two differ by O(c) in the laid curve's length per s.)
//!
//! **Scheme** (step Δs, the input's sample spacing): the stochastic Heun method for the
//! angle (the noise is additive, so Itô and Stratonovich agree) and the trapezoidal rule
//! of eq 13 for the position. With f(η, α) = −η·τ⊥(α)/b² and ΔW_k = √Δs ξ_k:
//!
//! ```text
//! α̃ = α_k + f(η_k, α_k) Δs + A ΔW_k,              η̃ = η_k + (τ(α_k) + τ(α̃)) Δs/2,
//! α_{k+1} = α_k + (f(η_k, α_k) + f(η̃, α̃)) Δs/2 + A ΔW_k,   η_{k+1} = η_k + (τ(α_k) + τ(α_{k+1})) Δs/2.
//! ```
//!
//! Euler–Maruyama was tried first: its rotation gains energy every orbit, and at
//! Δs = b/25 the stationary variance of η came out 20 % above b² (A = 2 m^-1/2). With
//! Heun it is within 1 % for Δs ≤ b/5 ([`RESOLUTION`]) and 27 % low at b/2; a calibrated
//! model coarser than b/5 is flagged. ξ_k standard normal (Box–Muller on the fibre's ChaCha8 stream). A fibre starts in the
//! stationary state: η_0 ~ N(0, b²I), α_0 uniform. The curvature κ = dα/ds is white noise
//! plus the potential's turning, so the bending energy e depends on Δs: the model is
//! calibrated at the input's Δs and meant to be used there.
//!
//! **Calibration** ([`calibrate`]): b and A are found so that segments of the input's
//! length L, measured like the input fibres ([`window_shape`] of their nodes and [`chord_curvature`]), have
//! the input's mean radius of gyration S (eq 5) and mean bending energy e (eq 6): damped
//! fixed-point updates b ← b (S*/S)^0.8, A ← A (e*/e)^0.4 on a fixed set of simulated
//! segments (common random numbers, so the measured S and e are smooth in b and A).
//!
//! ```
//! use laydown::stages::web::sde::{calibrate, LayDownSde, ShapeTarget};
//! // Segments of L = 0.5 m sampled at Δs = 1 mm: make the model reach S = 4 mm, e = 2e4.
//! let target = ShapeTarget { radius_of_gyration: 4e-3, bending_energy: 2e4 };
//! let fit = calibrate(target, 1e-3, 500, 7).unwrap();
//! assert!(fit.converged, "{fit:?}");
//! assert!((fit.achieved.radius_of_gyration / 4e-3 - 1.0).abs() < 0.01);
//! assert!((fit.achieved.bending_energy / 2e4 - 1.0).abs() < 0.02);
//! ```
use std::f64::consts::PI;

use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::trig::{kernel, sin_cos};
use crate::geometry::radius_of_gyration;
use crate::stages::spectra::integrate_curvature;

/// A lay-down SDE that cannot be built or calibrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SdeError {
    #[error("sde_potential_length must be a positive length in m, got {0}")]
    PotentialLength(f64),
    #[error("sde_noise must be ≥ 0 (m^-1/2), got {0}")]
    Noise(f64),
    #[error("cannot calibrate the lay-down SDE on S = {radius_of_gyration} m, e = {bending_energy}: both must be positive")]
    Target { radius_of_gyration: f64, bending_energy: f64 },
    #[error("cannot calibrate the lay-down SDE on segments of {0} samples (need ≥ 8)")]
    ShortSegments(usize),
}

/// The two parameters of the lay-down SDE.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayDownSde {
    /// b (m): V(η) = |η|²/(2b²); the stationary position spread per axis.
    pub potential_length: f64,
    /// A (m^-1/2): strength of the Brownian noise on the tangent angle.
    pub noise: f64,
}

/// Draws of one fibre: uniform and standard normal variates from its stream.
pub(crate) struct Draws<'a> {
    rng: &'a mut ChaCha8Rng,
    spare: Option<f64>,
}

impl<'a> Draws<'a> {
    pub(crate) fn new(rng: &'a mut ChaCha8Rng) -> Self {
        Self { rng, spare: None }
    }
    /// Uniform in [0, 1) with 53 random bits.
    #[inline(always)]
    pub(crate) fn uniform(&mut self) -> f64 {
        (self.rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Standard normal by Box–Muller (both variates of a pair are used), fixed here so a
    /// fibre never depends on a distribution crate's implementation.
    pub(crate) fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = sin_cos(2.0 * PI * u2);
        self.spare = Some(r * s);
        r * c
    }
    /// The next `out.len()` values of [`Self::normal`], the same bits in the same order
    /// (a pending spare first; an odd tail leaves its pair's second variate as the
    /// spare). The logarithms stay the scalar libm calls; the square roots and the
    /// trig kernel (2πu₂ < 2π is always in its fast range) run over blocks of pairs.
    #[inline(always)]
    pub(crate) fn fill_normals(&mut self, mut out: &mut [f64]) {
        if out.is_empty() {
            return;
        }
        if let Some(z) = self.spare.take() {
            out[0] = z;
            out = &mut out[1..];
        }
        const BLOCK: usize = 64;
        let (mut log, mut turn, mut cos, mut sin) = ([0.0; BLOCK], [0.0; BLOCK], [0.0; BLOCK], [0.0; BLOCK]);
        while !out.is_empty() {
            let pairs = out.len().div_ceil(2).min(BLOCK);
            for p in 0..pairs {
                let u1 = 1.0 - self.uniform(); // (0, 1]
                let u2 = self.uniform();
                log[p] = u1.ln();
                turn[p] = 2.0 * PI * u2;
            }
            for p in 0..BLOCK {
                // Whole blocks so the loop vectorises (the unused tail is never read).
                let r = (-2.0 * log[p]).sqrt();
                let (s, c) = kernel(turn[p]);
                cos[p] = r * c;
                sin[p] = r * s;
            }
            let (whole, odd) = if 2 * pairs > out.len() { (pairs - 1, true) } else { (pairs, false) };
            for (o, (c, s)) in out.chunks_exact_mut(2).zip(cos.iter().zip(&sin)).take(whole) {
                o[0] = *c;
                o[1] = *s;
            }
            if odd {
                out[2 * whole] = cos[whole];
                self.spare = Some(sin[whole]);
                return;
            }
            out = &mut out[2 * pairs..];
        }
    }
}

impl LayDownSde {
    /// Checks that both parameters are positive and finite.
    pub fn validate(&self) -> Result<(), SdeError> {
        if !(self.potential_length.is_finite() && self.potential_length > 0.0) {
            return Err(SdeError::PotentialLength(self.potential_length));
        }
        if !(self.noise.is_finite() && self.noise >= 0.0) {
            return Err(SdeError::Noise(self.noise));
        }
        Ok(())
    }

    /// Integrates `steps` steps of Δs = `spacing` from the stationary state: fills
    /// `alpha` with the steps + 1 tangent angles and returns η_0 (the first node relative
    /// to the deposition point). The positions η_k are those eq 13 rebuilds from the
    /// angles, starting at η_0.
    pub(crate) fn tangent_angles_into(&self, draws: &mut Draws, steps: usize, spacing: f64, alpha: &mut Vec<f64>) -> [f64; 2] {
        let b = self.potential_length;
        let start = [b * draws.normal(), b * draws.normal()];
        let mut angle = 2.0 * PI * draws.uniform();
        let (inv_b2, kick) = (1.0 / (b * b), self.noise * spacing.sqrt());
        let mut eta = start;
        let (mut sin, mut cos) = sin_cos(angle);
        alpha.clear();
        alpha.reserve(steps + 1);
        alpha.push(angle);
        // The normal draws a block ahead (the same sequence as one `normal()` per step).
        let mut normals = [0.0; 256];
        let mut done = 0;
        while done < steps {
            let block = (steps - done).min(normals.len());
            draws.fill_normals(&mut normals[..block]);
            done += block;
            for &z in &normals[..block] {
                // Stochastic Heun (additive noise): predictor, then the trapezoid of the drift.
                let noise = kick * z;
                let drift = -(-eta[0] * sin + eta[1] * cos) * inv_b2; // −∇V·τ⊥
                let predicted = angle + drift * spacing + noise;
                let (sin_p, cos_p) = sin_cos(predicted);
                let eta_p = [eta[0] + 0.5 * (cos + cos_p) * spacing, eta[1] + 0.5 * (sin + sin_p) * spacing];
                let drift_p = -(-eta_p[0] * sin_p + eta_p[1] * cos_p) * inv_b2;
                angle += 0.5 * (drift + drift_p) * spacing + noise;
                let (sin1, cos1) = sin_cos(angle);
                eta[0] += 0.5 * (cos + cos1) * spacing; // eq 13
                eta[1] += 0.5 * (sin + sin1) * spacing;
                (sin, cos) = (sin1, cos1);
                alpha.push(angle);
            }
        }
        start
    }

    /// The positions η_k of one simulated fibre of `steps` steps (m), from the stream `rng`.
    pub fn positions(&self, rng: &mut ChaCha8Rng, steps: usize, spacing: f64) -> Vec<[f64; 2]> {
        let mut alpha = Vec::new();
        let start = self.tangent_angles_into(&mut Draws::new(rng), steps, spacing, &mut alpha);
        positions_from(start, &alpha, spacing)
    }
}

/// The nodes eq 13 builds from `start` and the tangent angles.
fn positions_from(start: [f64; 2], alpha: &[f64], spacing: f64) -> Vec<[f64; 2]> {
    let mut p = start;
    let mut out = Vec::with_capacity(alpha.len());
    out.push(p);
    for w in alpha.windows(2) {
        let ((s0, c0), (s1, c1)) = (sin_cos(w[0]), sin_cos(w[1]));
        p[0] += 0.5 * (c0 + c1) * spacing;
        p[1] += 0.5 * (s0 + s1) * spacing;
        out.push(p);
    }
    out
}

/// Steps per potential length b the scheme needs for its stationary spread to be within
/// 3 % of the SDE's (Δs ≤ b/5; measured in the tests).
pub const RESOLUTION: f64 = 5.0;

/// Mean shape of fibre segments of one length: S (eq 5, m) and e (eq 6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeTarget {
    pub radius_of_gyration: f64,
    pub bending_energy: f64,
}

/// S and e of a window of a fibre, belt removed: S (eq 5) of its N + 1 nodes and
/// e = (L/2) Σ κ² Δs (eq A.3) of its N curvature samples at Δs, as the spectra stage reports
/// a laid fibre's e. Every generator's fibres and the input's laid fibres are measured by
/// this one function. Without nodes (`None`) S is that of the curve the samples rebuild
/// by eq 13 (for idealised spectra, which have no nodes).
pub fn window_shape(nodes: Option<&[[f64; 2]]>, curvature: &[f64], spacing: f64) -> (f64, f64) {
    let nodes: Vec<[f64; 3]> = match nodes {
        Some(n) => n.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        None => integrate_curvature(curvature, spacing, 0.0, [0.0, 0.0], 0.0).iter().map(|p| [p[0], p[1], 0.0]).collect(),
    };
    let length = spacing * curvature.len() as f64;
    let e = 0.5 * length * curvature.iter().map(|k| k * k).sum::<f64>() * spacing;
    (radius_of_gyration(&nodes), e)
}

/// Curvature samples of a run of tangent angles as the spectra stage reads them off a
/// polyline (the turning between consecutive chords over Δs): the trapezoid chord k runs
/// along (α_k + α_{k+1})/2, so κ_m = (α_{m+1} − α_{m−1})/(2Δs) for m ≥ 1 and the free
/// end takes the one-sided κ_0 = (α_1 − α_0)/Δs. `alpha.len() − 1` samples.
pub fn chord_curvature(alpha: &[f64], spacing: f64) -> Vec<f64> {
    let n = alpha.len().saturating_sub(1);
    (0..n).map(|m| if m == 0 { (alpha[1] - alpha[0]) / spacing } else { (alpha[m + 1] - alpha[m - 1]) / (2.0 * spacing) }).collect()
}

/// The result of [`calibrate`]: the model and how well it reproduces its target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    pub model: LayDownSde,
    pub target: ShapeTarget,
    /// Mean S and e of the calibration segments with the final model.
    pub achieved: ShapeTarget,
    pub iterations: usize,
    /// Simulated segments each evaluation measures.
    pub segments: usize,
    /// Both within tolerance (S 0.5 %, e 1 %).
    pub converged: bool,
}

/// Segments each calibration evaluation simulates.
pub const CALIBRATION_SEGMENTS: usize = 96;
/// Most fixed-point iterations.
pub const CALIBRATION_ITERATIONS: usize = 60;

/// Mean S and e of [`CALIBRATION_SEGMENTS`] segments of `points` samples at `spacing`,
/// each from its own stream of the calibration key `seed` (the same draws for every model).
pub fn measure(model: &LayDownSde, spacing: f64, points: usize, seed: u64) -> ShapeTarget {
    let (mut s, mut e) = (0.0, 0.0);
    for i in 0..CALIBRATION_SEGMENTS {
        let mut rng = calibration_rng(seed, i as u64);
        // N + 1 steps: the window's N samples are κ_1..κ_N (central differences) and its
        // nodes η_0..η_N.
        let mut alpha = Vec::new();
        let start = model.tangent_angles_into(&mut Draws::new(&mut rng), points + 1, spacing, &mut alpha);
        let kappa = chord_curvature(&alpha, spacing);
        let nodes = positions_from(start, &alpha, spacing);
        let (si, ei) = window_shape(Some(&nodes[..=points]), &kappa[1..], spacing);
        s += si;
        e += ei;
    }
    let n = CALIBRATION_SEGMENTS as f64;
    ShapeTarget { radius_of_gyration: s / n, bending_energy: e / n }
}

fn calibration_rng(seed: u64, segment: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..].copy_from_slice(b"laydown/web/sde-calib/v1");
    let mut rng = ChaCha8Rng::from_seed(key);
    rng.set_stream(segment);
    rng
}

/// Finds b and A so that segments of `points` samples at `spacing` have the target's
/// mean S and e (see the module docs). Deterministic in `seed`.
pub fn calibrate(target: ShapeTarget, spacing: f64, points: usize, seed: u64) -> Result<Calibration, SdeError> {
    let (s_target, e_target) = (target.radius_of_gyration, target.bending_energy);
    if !(s_target > 0.0 && s_target.is_finite() && e_target > 0.0 && e_target.is_finite()) {
        return Err(SdeError::Target { radius_of_gyration: s_target, bending_energy: e_target });
    }
    if points < 8 {
        return Err(SdeError::ShortSegments(points));
    }
    let length = spacing * points as f64;
    // Start: the stationary spread (S² = 2b² for an infinitely long fibre) and the noise
    // that gives the target's mean κ² beyond the 1/b² of a circular orbit.
    let b = s_target / 2f64.sqrt();
    let kappa2 = 2.0 * e_target / (length * length);
    let noise = ((kappa2 - 1.0 / (b * b)).max(0.1 * kappa2) * spacing).sqrt();
    let mut model = LayDownSde { potential_length: b, noise };
    let mut achieved = measure(&model, spacing, points, seed);
    let mut iterations = 0;
    let within = |a: &ShapeTarget| (a.radius_of_gyration / s_target - 1.0).abs() < 5e-3 && (a.bending_energy / e_target - 1.0).abs() < 1e-2;
    while !within(&achieved) && iterations < CALIBRATION_ITERATIONS {
        model.potential_length *= (s_target / achieved.radius_of_gyration).powf(0.8);
        model.noise *= (e_target / achieved.bending_energy).powf(0.4);
        achieved = measure(&model, spacing, points, seed);
        iterations += 1;
    }
    Ok(Calibration { model, target, achieved, iterations, segments: CALIBRATION_SEGMENTS, converged: within(&achieved) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stationary_positions_follow_the_potential() {
        // Without a belt, η is distributed ∝ exp(−V): N(0, b²) per axis, whatever A.
        // Long fibres sampled every 50 steps (decorrelated over ~b): mean 0, variance b².
        let b = 5e-3;
        for noise in [2.0, 8.0] {
            let model = LayDownSde { potential_length: b, noise };
            let (mut n, mut sum, mut sum2, mut sum4) = (0.0, [0.0; 2], [0.0; 2], 0.0);
            for f in 0..40u64 {
                let nodes = model.positions(&mut calibration_rng(99, f), 200_000, 2e-4);
                for p in nodes.iter().step_by(50) {
                    n += 1.0;
                    for k in 0..2 {
                        sum[k] += p[k];
                        sum2[k] += p[k] * p[k];
                    }
                    sum4 += p[0].powi(4);
                }
            }
            for k in 0..2 {
                let (mean, var) = (sum[k] / n, sum2[k] / n);
                assert!(mean.abs() < 0.05 * b, "A = {noise}: mean {mean}");
                assert!((var / (b * b) - 1.0).abs() < 0.05, "A = {noise}: var/b² = {}", var / (b * b));
            }
            // Gaussian, not just the right variance: E x⁴ = 3 (E x²)².
            let kurtosis = sum4 / n / (sum2[0] / n).powi(2);
            assert!((kurtosis - 3.0).abs() < 0.25, "A = {noise}: kurtosis {kurtosis}");
        }
    }

    /// Stationary variance of η per axis over b², from long fibres at step Δs.
    fn stationary_variance(model: &LayDownSde, spacing: f64, length: f64) -> f64 {
        let steps = (length / spacing) as usize;
        let stride = ((0.2 * model.potential_length / spacing) as usize).max(1);
        let (mut n, mut sum2) = (0.0, 0.0);
        for f in 0..40u64 {
            let nodes = model.positions(&mut calibration_rng(77, f), steps, spacing);
            for p in nodes.iter().step_by(stride) {
                n += 2.0;
                sum2 += p[0] * p[0] + p[1] * p[1];
            }
        }
        sum2 / n / model.potential_length.powi(2)
    }

    #[test]
    fn step_refinement_of_the_stationary_spread() {
        // The stationary variance of the discrete model against b² (exact for the SDE):
        // measured 0.734 at Δs = b/2, 0.995 at b/5, 0.992 at b/25 (sampling error ~1 %),
        // hence the resolution rule Δs ≤ b/5 the stage checks.
        let model = LayDownSde { potential_length: 5e-3, noise: 2.0 };
        for ratio in [2.0, RESOLUTION, 25.0] {
            let v = stationary_variance(&model, 5e-3 / ratio, 40.0);
            eprintln!("Δs = b/{ratio}: var/b² = {v:.4}");
            if ratio >= RESOLUTION {
                assert!((v - 1.0).abs() < 0.03, "Δs = b/{ratio}: {v}");
            } else {
                assert!((v - 1.0).abs() > 0.1, "Δs = b/{ratio}: {v} (under-resolved, expected a visible bias)");
            }
        }
    }

    #[test]
    fn noise_sets_the_tangent_correlation_without_a_potential() {
        // A very weak potential: ⟨cos(α(s) − α(0))⟩ = exp(−A² s/2).
        let model = LayDownSde { potential_length: 1e6, noise: 3.0 };
        let ds = 1e-3;
        let mut alpha = Vec::new();
        let lag = 100; // s = 0.1 m: exp(−0.45) = 0.638
        let (mut sum, mut n) = (0.0, 0.0);
        for f in 0..20u64 {
            let mut rng = calibration_rng(5, f);
            model.tangent_angles_into(&mut Draws::new(&mut rng), 20_000, ds, &mut alpha);
            for k in (0..alpha.len() - lag).step_by(10) {
                sum += (alpha[k + lag] - alpha[k]).cos();
                n += 1.0;
            }
        }
        let expected = (-0.5 * 9.0 * lag as f64 * ds).exp();
        assert!((sum / n - expected).abs() < 0.02, "{} vs {expected}", sum / n);
    }

    #[test]
    fn normal_draws_are_standard() {
        let mut rng = calibration_rng(1, 0);
        let mut d = Draws::new(&mut rng);
        let z: Vec<f64> = (0..200_000).map(|_| d.normal()).collect();
        let mean = z.iter().sum::<f64>() / z.len() as f64;
        let var = z.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / z.len() as f64;
        assert!(mean.abs() < 0.01 && (var - 1.0).abs() < 0.01, "{mean} {var}");
    }

    #[test]
    fn calibration_recovers_the_parameters_it_was_given() {
        // Targets measured on the model itself (another seed) are met by parameters
        // close to the true ones.
        let truth = LayDownSde { potential_length: 3e-3, noise: 4.0 };
        let (ds, n) = (1e-3, 400);
        let target = measure(&truth, ds, n, 11);
        let fit = calibrate(target, ds, n, 12).unwrap();
        assert!(fit.converged, "{fit:?}");
        assert!((fit.model.potential_length / truth.potential_length - 1.0).abs() < 0.1, "{fit:?}");
        assert!((fit.model.noise / truth.noise - 1.0).abs() < 0.1, "{fit:?}");
    }

    #[test]
    fn bad_targets_are_refused() {
        assert!(calibrate(ShapeTarget { radius_of_gyration: 0.0, bending_energy: 1.0 }, 1e-3, 100, 0).is_err());
        assert!(calibrate(ShapeTarget { radius_of_gyration: 1e-3, bending_energy: f64::NAN }, 1e-3, 100, 0).is_err());
        assert!(LayDownSde { potential_length: -1.0, noise: 1.0 }.validate().is_err());
    }
}
