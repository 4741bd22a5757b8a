//! Fibre synthesis: random-phase segments (eqs 11-12), joined and integrated with
//! belt drift (eqs 13-15). See the module docs of [`super`] for the conventions.
use std::f64::consts::PI;
use std::sync::Arc;

use num_complex::Complex64;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use rustfft::{Fft, FftPlanner};

use super::trig::{beyond_fast_range, sin_cos_slices, widest_isa};
use super::sde::{Draws, LayDownSde, SdeLanes, SdeStep, SDE_BLOCK};
use super::segments::LaidTemplates;
use super::{Generator, SegmentJoin, SpectrumSelection, WebError, WebParams};
use crate::stages::spectra::{check_compatible, CurvatureSpectrum};

/// Domain tag in the ChaCha key, so other stages' streams from the same seed differ.
const KEY_TAG: &[u8; 24] = b"laydown/web/fibre/v1\0\0\0\0";

/// The random stream of fibre `fibre` in realisation `realisation`: ChaCha8 keyed by
/// (seed, tag), stream number realisation·2³² + fibre.
pub fn fibre_rng(seed: u64, realisation: u32, fibre: u32) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..].copy_from_slice(KEY_TAG);
    let mut rng = ChaCha8Rng::from_seed(key);
    rng.set_stream(((realisation as u64) << 32) | fibre as u64);
    rng
}

/// Uniform in [0, 1) with 53 random bits (fixed here so it never depends on a
/// `rand` distribution's implementation).
#[inline]
fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Uniform index in 0..n (Lemire's multiply-shift; bias < n/2⁶⁴).
#[inline]
fn index(rng: &mut ChaCha8Rng, n: usize) -> usize {
    ((rng.next_u64() as u128 * n as u128) >> 64) as usize
}

/// A spectrum reduced to what eq 11 needs.
#[derive(Debug, Clone)]
struct Prepared {
    /// K_0 (real, signed).
    mean: f64,
    /// K_{N/2} (real, signed), 0 for odd N.
    nyquist: f64,
    /// (r, |K_r|) for 0 < r < N/2 with |K_r| > 0.
    bins: Vec<(usize, f64)>,
}

impl Prepared {
    fn new(s: &CurvatureSpectrum) -> Self {
        let k = s.coefficients();
        let n = k.len();
        let bins = (1..n.div_ceil(2)).map(|r| (r, k[r].norm())).filter(|&(_, m)| m > 0.0).collect();
        let nyquist = if n.is_multiple_of(2) { k[n / 2].re } else { 0.0 };
        Self { mean: k[0].re, nyquist, bins }
    }

    /// Adds w·K'_r (random phases, eq 11) into `buf`, for w = 1 or i. The phases are
    /// drawn first, in increasing r as always, then turned into sines and cosines in one
    /// vectorised pass (2πu < 2π is always in the fast kernel's range, so the values are
    /// [`sin_cos`](super::trig::sin_cos)'s).
    fn add_random(&self, rng: &mut ChaCha8Rng, w: Complex64, buf: &mut [Complex64], phases: &mut Phases) {
        let n = buf.len();
        buf[0] += w * self.mean;
        if n.is_multiple_of(2) {
            buf[n / 2] += w * self.nyquist;
        }
        let m = self.bins.len();
        phases.angle.clear();
        phases.angle.extend((0..m).map(|_| 2.0 * PI * uniform(rng)));
        phases.sin.resize(m, 0.0);
        phases.cos.resize(m, 0.0);
        sin_cos_slices(&phases.angle, &mut phases.sin, &mut phases.cos);
        for ((&(r, magnitude), s), c) in self.bins.iter().zip(&phases.sin).zip(&phases.cos) {
            let z = Complex64::new(magnitude * c, magnitude * s);
            buf[r] += w * z;
            buf[n - r] += w * z.conj();
        }
    }
}

/// The random phases of one segment, their sines and cosines.
#[derive(Default)]
struct Phases {
    angle: Vec<f64>,
    sin: Vec<f64>,
    cos: Vec<f64>,
}

/// Reusable buffers for generating one fibre at a time.
#[derive(Default)]
pub struct FibreScratch {
    phases: Phases,
    curvature: Vec<f64>,
    spectrum: Vec<Complex64>,
    fft: Vec<Complex64>,
    theta: Vec<f64>,
    sin: Vec<f64>,
    cos: Vec<f64>,
}

/// What the fibres are made from (one variant per [`Generator`]).
#[derive(Clone)]
enum Source {
    /// Spectra with random phases (eqs 11-12).
    Spectra { spectra: Vec<Prepared>, ifft: Arc<dyn Fft<f64>> },
    /// Laid fibres' curvature samples, N each, joined by integrating across (curvature join).
    Templates(Vec<Vec<f64>>),
    /// Laid fibres kept about their feed axis, joined at matched states (and their
    /// curvature samples and first tangent angles, as given).
    Matched { walk: LaidTemplates, curvature: Vec<Vec<f64>>, positions: Vec<Vec<[f64; 2]>> },
    /// The ITWM lay-down SDE.
    Sde(LayDownSde),
}

/// A web definition: parameters plus what its fibres are made from (a spectrum set,
/// laid-fibre templates or the lay-down SDE), ready to generate any fibre of any
/// realisation on demand.
#[derive(Clone)]
pub struct Web {
    params: WebParams,
    source: Source,
    points: usize,
    segment_length: f64,
}

impl std::fmt::Debug for Web {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let source = match &self.source {
            Source::Spectra { spectra, .. } => format!("{} spectra", spectra.len()),
            Source::Templates(t) | Source::Matched { curvature: t, .. } => format!("{} laid templates", t.len()),
            Source::Sde(m) => format!("{m:?}"),
        };
        f.debug_struct("Web")
            .field("params", &self.params)
            .field("source", &source)
            .field("points_per_segment", &self.points)
            .field("segment_length", &self.segment_length)
            .finish()
    }
}

impl Web {
    /// A `random_phase` web (the paper's surrogate). Validates the parameters and the
    /// spectrum set (non-empty, common N and L).
    pub fn new(params: WebParams, spectra: Vec<CurvatureSpectrum>) -> Result<Self, WebError> {
        params.validate()?;
        if params.generator != Generator::RandomPhase {
            return Err(WebError::WrongConstructor(params.generator.name()));
        }
        check_compatible(&spectra)?;
        let points = spectra[0].points();
        let segment_length = spectra[0].segment_length();
        let ifft = FftPlanner::new().plan_fft_inverse(points);
        Ok(Self { params, source: Source::Spectra { spectra: spectra.iter().map(Prepared::new).collect(), ifft }, points, segment_length })
    }

    /// A `laid_segments` web from laid fibres given as curvature samples (`templates`, all
    /// N long, at arc-length spacing `spacing`) and, for the matched join, their resampled
    /// belt-removed nodes (`positions`, N + 1 each; ignored by the curvature join), joined
    /// as `params.segment_join` says (see [`super::segments`]).
    pub fn laid_segments(params: WebParams, templates: Vec<Vec<f64>>, positions: Vec<Vec<[f64; 2]>>, spacing: f64) -> Result<Self, WebError> {
        params.validate()?;
        let points = templates.first().ok_or(WebError::NoTemplates)?.len();
        if points < 2 {
            return Err(WebError::ShortTemplates(points));
        }
        if let Some(i) = templates.iter().position(|t| t.len() != points) {
            return Err(WebError::TemplateLength { template: i, samples: templates[i].len(), expected: points });
        }
        if let Some(i) = templates.iter().position(|t| t.iter().any(|k| !k.is_finite())) {
            return Err(WebError::NonFiniteTemplate(i));
        }
        if !(spacing > 0.0 && spacing.is_finite()) {
            return Err(WebError::TemplateSpacing(spacing));
        }
        let source = match params.segment_join {
            SegmentJoin::Curvature => Source::Templates(templates),
            SegmentJoin::Matched => {
                if positions.len() != templates.len() {
                    return Err(WebError::TemplateNodeSets { fibres: positions.len(), templates: templates.len() });
                }
                if let Some(i) = positions.iter().position(|q| q.len() != points + 1 || q.iter().flatten().any(|v| !v.is_finite())) {
                    return Err(WebError::TemplateNodes { template: i, nodes: positions[i].len(), expected: points + 1 });
                }
                Source::Matched { walk: LaidTemplates::new(&positions, spacing), curvature: templates, positions }
            }
        };
        Ok(Self { params: WebParams { generator: Generator::LaidSegments, ..params }, source, points, segment_length: spacing * points as f64 })
    }

    /// A `lay_down_sde` web: fibres of the ITWM model integrated at Δs = `spacing`, with
    /// segments of `points` steps (the segment only counts the length: the SDE runs on
    /// across segments).
    pub fn lay_down_sde(params: WebParams, model: LayDownSde, spacing: f64, points: usize) -> Result<Self, WebError> {
        params.validate()?;
        model.validate()?;
        if !(spacing > 0.0 && spacing.is_finite()) || points == 0 {
            return Err(WebError::SdeStep { spacing, points });
        }
        Ok(Self { params: WebParams { generator: Generator::LayDownSde, ..params }, source: Source::Sde(model), points, segment_length: spacing * points as f64 })
    }

    pub fn params(&self) -> &WebParams {
        &self.params
    }
    /// The lay-down SDE's parameters, for a `lay_down_sde` web.
    pub fn sde_model(&self) -> Option<LayDownSde> {
        match &self.source {
            Source::Sde(m) => Some(*m),
            _ => None,
        }
    }
    /// The laid-fibre templates' curvature samples, for a `laid_segments` web.
    pub fn templates(&self) -> Option<&[Vec<f64>]> {
        match &self.source {
            Source::Templates(t) | Source::Matched { curvature: t, .. } => Some(t),
            _ => None,
        }
    }
    /// The laid-fibre templates' resampled nodes (matched join only).
    pub fn template_positions(&self) -> Option<&[Vec<[f64; 2]>]> {
        match &self.source {
            Source::Matched { positions, .. } => Some(positions),
            _ => None,
        }
    }
    /// N, samples per segment.
    pub fn points_per_segment(&self) -> usize {
        self.points
    }
    /// L (m).
    pub fn segment_length(&self) -> f64 {
        self.segment_length
    }
    /// Δs = L/N (m).
    pub fn spacing(&self) -> f64 {
        self.segment_length / self.points as f64
    }
    /// n_l·L (m).
    pub fn fibre_length(&self) -> f64 {
        self.segment_length * self.params.segments_per_fibre as f64
    }
    /// n_l·N + 1.
    pub fn nodes_per_fibre(&self) -> usize {
        self.params.segments_per_fibre * self.points + 1
    }
    /// Δm = ρ(πd²/4)Δs (kg), the point mass of each node but the last (§3.3).
    pub fn point_mass(&self) -> f64 {
        self.params.mass_per_length() * self.spacing()
    }
    /// Nominal MD length of the drift, c·n_l·L (m).
    pub fn drift_length(&self) -> f64 {
        self.params.belt_speed_ratio * self.fibre_length()
    }

    /// Start tangent angle and the n_l·N curvature samples of one fibre (eqs 11-12 for
    /// `random_phase`, the joined templates for `laid_segments`; for `lay_down_sde` the
    /// chord turning rates of its polyline, [`super::sde::chord_curvature`]).
    pub fn fibre_curvature(&self, realisation: u32, fibre: usize) -> (f64, Vec<f64>) {
        let mut scratch = FibreScratch::default();
        match &self.source {
            Source::Sde(_) => {
                self.tangent_angles_into(realisation, fibre, &mut scratch);
                (scratch.theta[0], super::sde::chord_curvature(&scratch.theta, self.spacing()))
            }
            Source::Matched { walk, .. } => {
                let mut rng = fibre_rng(self.params.seed, realisation, fibre as u32);
                let mut nodes = Vec::new();
                walk.walk(&mut Draws::new(&mut rng), self.params.mirror, self.params.segments_per_fibre * self.points, &mut nodes, &mut scratch.curvature);
                let first = &nodes[..2];
                (crate::geometry::chord_angle(first[0], first[1]), scratch.curvature)
            }
            _ => {
                let theta = self.curvature_into(realisation, fibre, &mut scratch);
                (theta, scratch.curvature)
            }
        }
    }

    fn curvature_into(&self, realisation: u32, fibre: usize, scratch: &mut FibreScratch) -> f64 {
        let n = self.points;
        let segments = self.params.segments_per_fibre;
        let mut rng = fibre_rng(self.params.seed, realisation, fibre as u32);
        let theta_start = 2.0 * PI * uniform(&mut rng);
        // Room for the closing κ the node pass appends (no reallocation there).
        scratch.curvature.reserve((segments * n + 1).saturating_sub(scratch.curvature.len()));
        scratch.curvature.resize(segments * n, 0.0);
        match &self.source {
            Source::Spectra { spectra, ifft } => {
                scratch.spectrum.resize(n, Complex64::default());
                scratch.fft.resize(ifft.get_inplace_scratch_len(), Complex64::default());
                let choose = |rng: &mut ChaCha8Rng| match self.params.spectrum_selection {
                    SpectrumSelection::Single => &spectra[0],
                    SpectrumSelection::PerSegment => &spectra[index(rng, spectra.len())],
                };
                // Two real segments per complex inverse FFT: IDFT(A + iB) = a + ib.
                for pair in (0..segments).step_by(2) {
                    let buf = &mut scratch.spectrum;
                    buf.fill(Complex64::default());
                    choose(&mut rng).add_random(&mut rng, Complex64::new(1.0, 0.0), buf, &mut scratch.phases);
                    let second = pair + 1 < segments;
                    if second {
                        choose(&mut rng).add_random(&mut rng, Complex64::new(0.0, 1.0), buf, &mut scratch.phases);
                    }
                    ifft.process_with_scratch(buf, &mut scratch.fft); // eq 12 (no 1/N)
                    let out = &mut scratch.curvature[pair * n..];
                    for m in 0..n {
                        out[m] = buf[m].re;
                    }
                    if second {
                        for m in 0..n {
                            out[n + m] = buf[m].im;
                        }
                    }
                }
            }
            Source::Templates(templates) => {
                // Per segment: the template index, then (with `mirror`) the mirror draw.
                for out in scratch.curvature.chunks_exact_mut(n) {
                    let template = &templates[index(&mut rng, templates.len())];
                    if self.params.mirror && uniform(&mut rng) < 0.5 {
                        for (o, k) in out.iter_mut().zip(template) {
                            *o = -k;
                        }
                    } else {
                        out.copy_from_slice(template);
                    }
                }
            }
            Source::Sde(_) | Source::Matched { .. } => unreachable!("the lay-down SDE and the matched join make nodes, not curvature to integrate"),
        }
        theta_start
    }

    /// Fills `scratch.theta` with the fibre's n_l·N + 1 tangent angles and returns the
    /// first node's offset from its starting point (non-zero only for the SDE, whose
    /// fibre starts at η_0 from its deposition point).
    fn tangent_angles_into(&self, realisation: u32, fibre: usize, scratch: &mut FibreScratch) -> [f64; 2] {
        let total = self.params.segments_per_fibre * self.points;
        if let Source::Sde(model) = &self.source {
            let mut rng = fibre_rng(self.params.seed, realisation, fibre as u32);
            let mut eta = Vec::new();
            model.integrate(&mut rng, total, self.spacing(), &mut scratch.theta, Some(&mut eta));
            return eta[0];
        }
        let theta_start = self.curvature_into(realisation, fibre, scratch);
        let kappa = &scratch.curvature;
        let closing = kappa[total - self.points]; // last segment's κ_0 (periodic close)
        let half_ds = 0.5 * self.spacing();
        let theta = &mut scratch.theta;
        theta.resize(total + 1, 0.0);
        let mut t = theta_start;
        theta[0] = t;
        for k in 0..total - 1 {
            t += (kappa[k] + kappa[k + 1]) * half_ds; // eq 13
            theta[k + 1] = t;
        }
        theta[total] = t + (kappa[total - 1] + closing) * half_ds;
        [0.0, 0.0]
    }

    /// All n_l·N + 1 nodes [x (MD), y (CD)] of one fibre (m). Bit-identical to the
    /// nodes the web visitors see for the same (realisation, fibre).
    pub fn generate_fibre(&self, realisation: u32, fibre: usize) -> Vec<[f64; 2]> {
        let mut nodes = Vec::new();
        self.generate_fibre_into(realisation, fibre, &mut FibreScratch::default(), &mut nodes);
        nodes
    }

    /// As [`Self::generate_fibre`], reusing buffers.
    pub fn generate_fibre_into(&self, realisation: u32, fibre: usize, scratch: &mut FibreScratch, nodes: &mut Vec<[f64; 2]>) {
        assert!(fibre < self.params.fibres_across, "fibre {fibre} of {}", self.params.fibres_across);
        if let Source::Matched { walk, .. } = &self.source {
            // Belt-removed nodes about the deposition point (0, y_j), then the drift of eq 14.
            let mut rng = fibre_rng(self.params.seed, realisation, fibre as u32);
            let (drift_ds, y) = (self.params.belt_speed_ratio * self.spacing(), self.params.start_y(fibre));
            walk.walk_nodes(&mut Draws::new(&mut rng), self.params.mirror, self.params.segments_per_fibre * self.points, nodes, |k, p| [p[0] + k * drift_ds, p[1] + y]);
            return;
        }
        if let Source::Sde(model) = &self.source {
            // One lane of the lockstep integration (the rotated tangent and the nodes in one pass).
            // One piece, written into the caller's buffer lent as the lane's.
            let mut lanes = SdeScratch { nodes: vec![std::mem::take(nodes)] };
            self.sde_batch(model, realisation, [fibre], usize::MAX, &mut lanes, &mut |_, _, _| {});
            *nodes = lanes.nodes.pop().unwrap();
            nodes.truncate(self.nodes_per_fibre());
            return;
        }
        // Curvature, then θ, its sines and cosines and the nodes in one blocked pass.
        let theta_start = self.curvature_into(realisation, fibre, scratch);
        let wide = widest_isa!(
            generic: self.nodes_from_curvature(theta_start, fibre, scratch, nodes),
            avx2: self.nodes_from_curvature_avx2(theta_start, fibre, scratch, nodes),
            avx512: self.nodes_from_curvature_avx512(theta_start, fibre, scratch, nodes),
        );
        if wide {
            // Some |θ| beyond the fast kernel: the whole fibre takes `f64::sin_cos`.
            self.generate_fibre_scalar_into(realisation, fibre, scratch, nodes);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn nodes_from_curvature_avx512(&self, theta_start: f64, fibre: usize, scratch: &mut FibreScratch, nodes: &mut Vec<[f64; 2]>) -> bool {
        self.nodes_from_curvature(theta_start, fibre, scratch, nodes)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn nodes_from_curvature_avx2(&self, theta_start: f64, fibre: usize, scratch: &mut FibreScratch, nodes: &mut Vec<[f64; 2]>) -> bool {
        self.nodes_from_curvature(theta_start, fibre, scratch, nodes)
    }

    /// The nodes of a random_phase or laid_segments fibre from its curvature
    /// (`scratch.curvature`) and start angle: θ by eq 13, sin θ and cos θ by the fast
    /// kernel and the nodes by eqs 13-14, block by block so all three stay in L1 and the
    /// kernel vectorises. The same operations in the same order as
    /// [`Self::tangent_angles_into`] then [`Self::generate_fibre_scalar_into`]'s passes,
    /// so the same bits, provided every |θ| ≤ [`FAST_LIMIT`](super::trig::FAST_LIMIT) (that path then uses the
    /// kernel for all); returns `true` (nodes to be remade by the scalar path) if not.
    #[inline(always)]
    fn nodes_from_curvature(&self, theta_start: f64, fibre: usize, scratch: &mut FibreScratch, nodes: &mut Vec<[f64; 2]>) -> bool {
        const BLOCK: usize = 64;
        let total = self.params.segments_per_fibre * self.points;
        let half_ds = 0.5 * self.spacing();
        let drift_ds = self.params.belt_speed_ratio * self.spacing();
        // κ_total := the last segment's κ_0, so the closing step is the recurrence's last.
        let kappa = &mut scratch.curvature;
        kappa.push(kappa[total - self.points]);
        let kappa = &kappa[..];
        // Every node is written below, so the buffer is not zero-filled first.
        nodes.clear();
        nodes.reserve(total + 1);
        let all = &mut nodes.spare_capacity_mut()[..total + 1];
        let mut p = [0.0, self.params.start_y(fibre) + 0.0];
        all[0].write(p);
        let mut t = theta_start;
        let mut wide = beyond_fast_range(t);
        let (mut s0, mut c0) = super::trig::kernel(t);
        let (mut theta, mut sin, mut cos) = ([0.0; BLOCK], [0.0; BLOCK], [0.0; BLOCK]);
        // Block b holds nodes b·BLOCK + 1 ..= b·BLOCK + its length, node k having
        // θ_k = θ_{k−1} + (κ_{k−1} + κ_k)Δs/2. Software-pipelined: the θ recurrence of
        // block b + 1 runs in the same loop as the node recurrence of block b (two
        // independent dependency chains), then the kernel turns block b + 1's θ into its
        // sines and cosines (vectorised, the whole block: a short last block's tail holds
        // earlier blocks' angles, already checked).
        let blocks = total.div_ceil(BLOCK);
        let turn = |theta: &mut [f64; BLOCK], sin: &mut [f64; BLOCK], cos: &mut [f64; BLOCK]| {
            let mut w = false;
            for i in 0..BLOCK {
                (sin[i], cos[i]) = super::trig::kernel(theta[i]);
                w |= beyond_fast_range(theta[i]);
            }
            w
        };
        {
            let k = &kappa[..BLOCK.min(total) + 1];
            for i in 0..k.len() - 1 {
                t += (k[i] + k[i + 1]) * half_ds; // eq 13
                theta[i] = t;
            }
            wide |= turn(&mut theta, &mut sin, &mut cos);
        }
        for (b, out) in all[1..].chunks_mut(BLOCK).enumerate() {
            let next = if b + 1 < blocks { &kappa[(b + 1) * BLOCK..(b + 1) * BLOCK + BLOCK.min(total - (b + 1) * BLOCK) + 1] } else { &[][..] };
            let both = next.len().saturating_sub(1); // ≤ out.len(): only the last block is short
            for i in 0..both {
                t += (next[i] + next[i + 1]) * half_ds; // eq 13, block b + 1
                theta[i] = t;
                p[0] += (c0 + cos[i]) * half_ds + drift_ds; // eqs 13-14, block b
                p[1] += (s0 + sin[i]) * half_ds;
                out[i].write(p);
                (s0, c0) = (sin[i], cos[i]);
            }
            for i in both..out.len() {
                p[0] += (c0 + cos[i]) * half_ds + drift_ds;
                p[1] += (s0 + sin[i]) * half_ds;
                out[i].write(p);
                (s0, c0) = (sin[i], cos[i]);
            }
            if both > 0 {
                wide |= turn(&mut theta, &mut sin, &mut cos);
            }
        }
        // SAFETY: nodes 0..=total were all written above.
        unsafe { nodes.set_len(total + 1) };
        wide
    }

    /// The one-fibre path: tangent angles, their sines and cosines, nodes.
    fn generate_fibre_scalar_into(&self, realisation: u32, fibre: usize, scratch: &mut FibreScratch, nodes: &mut Vec<[f64; 2]>) {
        // Three passes so the sin/cos loop vectorises: θ (eq 13 or the SDE), (sin θ, cos θ), nodes.
        let offset = self.tangent_angles_into(realisation, fibre, scratch);
        let total = scratch.theta.len() - 1;
        let half_ds = 0.5 * self.spacing();
        let drift_ds = self.params.belt_speed_ratio * self.spacing();
        scratch.sin.resize(total + 1, 0.0);
        scratch.cos.resize(total + 1, 0.0);
        sin_cos_slices(&scratch.theta, &mut scratch.sin, &mut scratch.cos);
        let (sin, cos) = (&scratch.sin[..], &scratch.cos[..]);
        nodes.clear();
        nodes.resize(total + 1, [0.0; 2]);
        let mut p = [offset[0], self.params.start_y(fibre) + offset[1]];
        nodes[0] = p;
        for (((out, c), s), (c1, s1)) in nodes[1..].iter_mut().zip(cos).zip(sin).zip(cos[1..].iter().zip(&sin[1..])) {
            p[0] += (c + c1) * half_ds + drift_ds; // eqs 13-14
            p[1] += (s + s1) * half_ds;
            *out = p;
        }
    }

    /// S (eq 5) and e (eq 6) of each of one fibre's n_l segments, belt drift removed
    /// (x − c·s): its nodes and curvature samples ([`Self::fibre_curvature`]) cut into
    /// segments and measured by [`super::sde::window_shape`], as the input's laid fibres
    /// are. What a generator keeps of its input's shape.
    pub fn segment_shapes(&self, realisation: u32, fibre: usize) -> Vec<(f64, f64)> {
        let drift_ds = self.params.belt_speed_ratio * self.spacing();
        let nodes: Vec<[f64; 2]> = self.generate_fibre(realisation, fibre).iter().enumerate().map(|(k, p)| [p[0] - k as f64 * drift_ds, p[1]]).collect();
        let (_, kappa) = self.fibre_curvature(realisation, fibre);
        let n = self.points;
        kappa.chunks_exact(n).enumerate().map(|(i, w)| super::sde::window_shape(Some(&nodes[i * n..=(i + 1) * n]), w, self.spacing())).collect()
    }

    /// Calls `visit(fibre, nodes)` for every fibre of a realisation, in parallel on
    /// the current rayon pool, holding one fibre per worker (a `lay_down_sde` web: sixteen,
    /// integrated in lockstep). Call order is not fixed; each fibre's nodes are.
    pub fn par_for_each_fibre<F>(&self, realisation: u32, visit: F)
    where
        F: Fn(usize, &[[f64; 2]]) + Sync + Send,
    {
        self.par_visit(realisation, usize::MAX, &|j, _, nodes| visit(j, nodes));
    }

    /// As [`Self::par_for_each_fibre`], but a fibre may come in consecutive pieces:
    /// `visit(fibre, first, nodes)` gets nodes `first..first + nodes.len()` of the fibre,
    /// and consecutive pieces share one node (the last of one is the first of the next),
    /// so every node and every chord is in exactly one piece, counting the shared node
    /// with the piece it ends. A fibre's pieces come in order, on one thread. A
    /// `lay_down_sde` web streams in pieces of about `SDE_PIECE_STEPS` steps, which
    /// keeps its sixteen fibres' nodes in cache for the visitor; the other generators
    /// give each fibre whole.
    ///
    /// ```
    /// use laydown::stages::web::{sde::LayDownSde, Web, WebParams};
    /// let params = WebParams { fibres_across: 3, segments_per_fibre: 20, ..WebParams::default() };
    /// let web = Web::lay_down_sde(params, LayDownSde { potential_length: 5e-3, noise: 2.0 }, 1e-3, 1000).unwrap();
    /// let whole = web.generate_fibre(0, 1);
    /// let rebuilt = std::sync::Mutex::new(vec![[f64::NAN; 2]; whole.len()]);
    /// web.par_for_each_fibre_piece(0, |j, first, nodes| {
    ///     if j == 1 {
    ///         rebuilt.lock().unwrap()[first..first + nodes.len()].copy_from_slice(nodes);
    ///     }
    /// });
    /// assert_eq!(rebuilt.into_inner().unwrap(), whole);
    /// ```
    pub fn par_for_each_fibre_piece<F>(&self, realisation: u32, visit: F)
    where
        F: Fn(usize, usize, &[[f64; 2]]) + Sync + Send,
    {
        self.par_visit(realisation, SDE_PIECE_STEPS, &visit);
    }

    fn par_visit(&self, realisation: u32, piece: usize, visit: &(dyn Fn(usize, usize, &[[f64; 2]]) + Sync)) {
        let n_w = self.params.fibres_across;
        if let Source::Sde(model) = &self.source {
            let lanes = self.sde_width();
            let batches = n_w.div_ceil(lanes);
            // Few jobs per thread, and their node buffers (16 fibres, 26 MB at paper size
            // when whole) handed from job to job through a pool: fresh ones per job cost
            // page faults (measured ~10 % of the paper web's time). Buffers are
            // overwritten, so which one a job gets changes no result.
            let min_len = (batches / (8 * rayon::current_num_threads())).max(1);
            let pool = std::sync::Mutex::new(Vec::new());
            (0..batches).into_par_iter().with_min_len(min_len).for_each_init(
                || Pooled::take(&pool),
                |scratch, batch| {
                    let first = batch * lanes;
                    self.sde_visit(model, realisation, first..(first + lanes).min(n_w), piece, &mut scratch.0, &mut |j, node, nodes| visit(j, node, nodes));
                },
            );
            return;
        }
        // The same pool for the one-fibre generators' buffers.
        let min_len = (n_w / (8 * rayon::current_num_threads())).max(2);
        let pool = std::sync::Mutex::new(Vec::new());
        (0..n_w).into_par_iter().with_min_len(min_len).for_each_init(
            || Pooled::<(FibreScratch, Vec<[f64; 2]>)>::take(&pool),
            |pooled, j| {
                let (scratch, nodes) = &mut pooled.0;
                self.generate_fibre_into(realisation, j, scratch, nodes);
                visit(j, 0, nodes);
            },
        );
    }

    /// Sequential [`Self::par_for_each_fibre`], fibres in index order.
    pub fn for_each_fibre<F: FnMut(usize, &[[f64; 2]])>(&self, realisation: u32, mut visit: F) {
        if let Source::Sde(model) = &self.source {
            let mut scratch = SdeScratch::default();
            let n_w = self.params.fibres_across;
            let lanes = self.sde_width();
            for first in (0..n_w).step_by(lanes) {
                self.sde_visit(model, realisation, first..(first + lanes).min(n_w), usize::MAX, &mut scratch, &mut |j, _, nodes| visit(j, nodes));
            }
            return;
        }
        let (mut scratch, mut nodes) = (FibreScratch::default(), Vec::new());
        for j in 0..self.params.fibres_across {
            self.generate_fibre_into(realisation, j, &mut scratch, &mut nodes);
            visit(j, &nodes);
        }
    }
}

/// A visitor of fibre pieces: (fibre or lane, index of the piece's first node, nodes).
type PieceVisitor<'a> = dyn FnMut(usize, usize, &[[f64; 2]]) + 'a;

/// Steps of a `lay_down_sde` piece in [`Web::par_for_each_fibre_piece`]: sixteen lanes'
/// pieces then take 16 × 1025 × 16 B = 262 kB, well inside a core's L2 cache, where the
/// visitor (the grid's deposit) reads them back.
pub const SDE_PIECE_STEPS: usize = 1024;

/// Fibres of a `lay_down_sde` web integrated in lockstep, one per lane: the recurrence of
/// one fibre is a dependent chain (the predictor's and the corrector's rotations of the
/// tangent per Heun step), so independent fibres side by side fill the vector units and
/// hide its latency.
const SDE_LANES: usize = 16;
/// Most bytes of lane node buffers one worker holds: fibres longer than 2²¹ nodes
/// (64 MiB / 16 lanes / 16 B) are integrated fewer at a time, down to one.
const SDE_LANE_BYTES: usize = 64 << 20;

/// Buffers taken from a pool, returned to it when dropped: rayon makes one per job, and
/// fresh ones would cost page faults on every job.
struct Pooled<'a, T: Default>(T, &'a std::sync::Mutex<Vec<T>>);

impl<'a, T: Default> Pooled<'a, T> {
    fn take(pool: &'a std::sync::Mutex<Vec<T>>) -> Self {
        Self(pool.lock().expect("pool").pop().unwrap_or_default(), pool)
    }
}

impl<T: Default> Drop for Pooled<'_, T> {
    fn drop(&mut self) {
        if let Ok(mut pool) = self.1.lock() {
            pool.push(std::mem::take(&mut self.0));
        }
    }
}

/// Buffers of one worker integrating SDE fibres up to [`SDE_LANES`] at a time.
#[derive(Default)]
struct SdeScratch {
    /// Each lane's nodes.
    nodes: Vec<Vec<[f64; 2]>>,
}

impl Web {
    /// Integrates the SDE fibres `fibres` (L of them, repeats allowed) of one realisation
    /// in lockstep ([`SdeLanes`]) and hands each lane's nodes to `emit(lane, first, nodes)`
    /// in pieces of at most `piece` steps: node `first` of the fibre is `nodes[0]`, and
    /// consecutive pieces share one node (the last of one is the first of the next), so
    /// each chord lies in exactly one piece. Node k is η_k + (c k Δs, y_j): the SDE's
    /// eq 13 and the belt drift of eq 14. Every lane performs the same IEEE operations on
    /// its own fibre's stream whatever L and `piece` (Rust contracts nothing to FMA; the
    /// fused operations are written out), so each fibre's bits are those of the one-fibre
    /// path.
    #[inline(always)]
    fn sde_lanes<const L: usize>(&self, model: &LayDownSde, realisation: u32, fibres: [usize; L], piece: usize, scratch: &mut SdeScratch, emit: &mut PieceVisitor) {
        let total = self.params.segments_per_fibre * self.points;
        let piece = piece.min(total).max(1);
        let spacing = self.spacing();
        let mut streams: Vec<ChaCha8Rng> = fibres.iter().map(|&j| fibre_rng(self.params.seed, realisation, j as u32)).collect();
        let mut lanes = SdeLanes::<L>::start(model, &mut streams);
        let drift_ds = self.params.belt_speed_ratio * spacing;
        let mut y = [0.0; L];
        if scratch.nodes.len() < L {
            scratch.nodes.resize_with(L, Vec::new);
        }
        // A piece ends at a block's end; blocks are SDE_BLOCK long, so a piece may run
        // up to SDE_BLOCK − 1 steps past `piece`.
        let capacity = (piece + SDE_BLOCK).min(total) + 1;
        let mut outs: [&mut [[f64; 2]]; L] = {
            let mut it = scratch.nodes.iter_mut();
            std::array::from_fn(|_| {
                let buffer = it.next().unwrap();
                if buffer.len() < capacity {
                    buffer.resize(capacity, [0.0; 2]);
                }
                &mut buffer[..capacity]
            })
        };
        for l in 0..L {
            y[l] = self.params.start_y(fibres[l]);
            outs[l][0] = [lanes.eta[0][l], y[l] + lanes.eta[1][l]];
        }
        let (mut normals, constants) = (Vec::new(), SdeStep::new(model, spacing));
        let (mut done, mut filled, mut first) = (0, 0, 0);
        while done < total {
            let block = lanes.draw_block(total - done, &mut normals);
            for (k, z) in normals[..block].iter().enumerate() {
                lanes.step::<false>(&constants, z);
                // Eq 14: node k sits at η_k + (c k Δs, y_j).
                let drift = (done + k + 1) as f64 * drift_ds;
                for l in 0..L {
                    outs[l][filled + 1 + k] = [lanes.eta[0][l] + drift, lanes.eta[1][l] + y[l]];
                }
            }
            lanes.end_block();
            done += block;
            filled += block;
            if filled >= piece || done == total {
                for (l, out) in outs.iter_mut().enumerate() {
                    emit(l, first, &out[..=filled]);
                    if done < total {
                        out[0] = out[filled]; // the next piece starts where this one ends
                    }
                }
                first += filled;
                filled = 0;
            }
        }
    }

    /// [`Self::sde_lanes`] compiled for the widest vector extension the CPU has (the same
    /// IEEE operations on wider registers, the written-out FMAs as instructions: the same
    /// bits).
    fn sde_batch<const L: usize>(&self, model: &LayDownSde, realisation: u32, fibres: [usize; L], piece: usize, scratch: &mut SdeScratch, emit: &mut PieceVisitor) {
        widest_isa!(
            generic: self.sde_lanes(model, realisation, fibres, piece, scratch, emit),
            avx2: self.sde_lanes_avx2(model, realisation, fibres, piece, scratch, emit),
            avx512: self.sde_lanes_avx512(model, realisation, fibres, piece, scratch, emit),
        )
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    unsafe fn sde_lanes_avx512<const L: usize>(&self, model: &LayDownSde, realisation: u32, fibres: [usize; L], piece: usize, scratch: &mut SdeScratch, emit: &mut PieceVisitor) {
        self.sde_lanes(model, realisation, fibres, piece, scratch, emit)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn sde_lanes_avx2<const L: usize>(&self, model: &LayDownSde, realisation: u32, fibres: [usize; L], piece: usize, scratch: &mut SdeScratch, emit: &mut PieceVisitor) {
        self.sde_lanes(model, realisation, fibres, piece, scratch, emit)
    }

    /// Fibres an SDE batch integrates at once: [`SDE_LANES`], fewer (a power of two) for
    /// fibres so long that their node buffers would pass [`SDE_LANE_BYTES`].
    fn sde_width(&self) -> usize {
        let fibre_bytes = self.nodes_per_fibre() * std::mem::size_of::<[f64; 2]>();
        let mut lanes = SDE_LANES;
        while lanes > 1 && lanes * fibre_bytes > SDE_LANE_BYTES {
            lanes /= 2;
        }
        lanes
    }

    /// Calls `visit(j, first_node, nodes)` for the fibres `batch` of an SDE
    /// web in pieces of about `piece` steps (see [`Self::sde_lanes`]), integrated
    /// [`Self::sde_width`] at a time (one lane for a lone fibre; a short batch repeats its
    /// first fibre in the idle lanes).
    fn sde_visit(&self, model: &LayDownSde, realisation: u32, batch: std::ops::Range<usize>, piece: usize, scratch: &mut SdeScratch, visit: &mut PieceVisitor) {
        let (first, count) = (batch.start, batch.len());
        let fibres = |l: usize| if l < count { first + l } else { first };
        let mut emit = |l: usize, node: usize, nodes: &[[f64; 2]]| {
            if l < count {
                visit(first + l, node, nodes)
            }
        };
        match count {
            1 => self.sde_batch(model, realisation, [first], piece, scratch, &mut emit),
            2 => self.sde_batch::<2>(model, realisation, std::array::from_fn(fibres), piece, scratch, &mut emit),
            3 | 4 => self.sde_batch::<4>(model, realisation, std::array::from_fn(fibres), piece, scratch, &mut emit),
            5..=8 => self.sde_batch::<8>(model, realisation, std::array::from_fn(fibres), piece, scratch, &mut emit),
            _ => self.sde_batch::<SDE_LANES>(model, realisation, std::array::from_fn(fibres), piece, scratch, &mut emit),
        }
    }
}

/// Bit-identity of every generator's fibres: each fibre of a set of webs (random_phase,
/// laid_segments with and without mirroring, lay_down_sde at paper size and beyond the
/// fast-trig range) is compared with a straightforward scalar implementation of the
/// generators as they stood before the fibre-batched SDE (kept here, one fibre at a time,
/// its own copy of the trig kernel), and the hashes of both with the ones recorded from
/// that code (commit d053cab), so a change to the reference is caught too.
#[cfg(test)]
mod bit_identity {
    use super::*;
    use crate::stages::spectra::SquareWaveParams;
    use std::sync::Mutex;

    /// The scalar code of d053cab, one fibre at a time.
    mod reference {
        use super::super::{fibre_rng, Source, Web};
        use crate::stages::web::SpectrumSelection;
        use num_complex::Complex64;
        use rand_chacha::rand_core::RngCore;
        use rand_chacha::ChaCha8Rng;
        use std::f64::consts::PI;

        #[allow(clippy::excessive_precision)] // fdlibm's constants, as trig.rs writes them
        fn kernel(x: f64) -> (f64, f64) {
            const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;
            const PIO2_1: f64 = 1.570_796_326_734_125_614_17e+00;
            const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
            const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21;
            const S: [f64; 6] = [-1.666_666_666_666_663_243_48e-01, 8.333_333_333_322_489_461_24e-03, -1.984_126_982_985_794_931_34e-04, 2.755_731_370_707_006_767_89e-06, -2.505_076_025_340_686_341_95e-08, 1.589_690_995_211_550_102_21e-10];
            const C: [f64; 6] = [4.166_666_666_666_660_190_37e-02, -1.388_888_888_887_410_957_49e-03, 2.480_158_728_947_672_941_78e-05, -2.755_731_435_139_066_330_35e-07, 2.087_572_321_298_174_827_90e-09, -1.135_964_755_778_819_482_65e-11];
            const MAGIC: f64 = 6_755_399_441_055_744.0;
            let t = x * TWO_OVER_PI + MAGIC;
            let q_bits = t.to_bits();
            let q = t - MAGIC;
            let r = ((x - q * PIO2_1) - q * PIO2_2) - q * PIO2_3;
            let z = r * r;
            let s = r + r * z * (S[0] + z * (S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])))));
            let c = 1.0 - 0.5 * z + z * z * (C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5])))));
            let (s, c) = if q_bits & 1 == 1 { (c, -s) } else { (s, c) };
            if q_bits & 2 == 2 {
                (-s, -c)
            } else {
                (s, c)
            }
        }
        pub fn sin_cos(x: f64) -> (f64, f64) {
            if x.abs() <= 8.0e5 {
                kernel(x)
            } else {
                x.sin_cos()
            }
        }
        fn uniform(rng: &mut ChaCha8Rng) -> f64 {
            (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
        }
        fn index(rng: &mut ChaCha8Rng, n: usize) -> usize {
            ((rng.next_u64() as u128 * n as u128) >> 64) as usize
        }
        /// xoshiro256++ seeded with four words of the fibre's stream, Box–Muller pairs.
        struct Normals([u64; 4], Option<f64>);
        impl Normals {
            fn new(rng: &mut ChaCha8Rng) -> Self {
                Self([rng.next_u64(), rng.next_u64(), rng.next_u64(), rng.next_u64()], None)
            }
            fn word(&mut self) -> u64 {
                let s = &mut self.0;
                let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
                let t = s[1] << 17;
                s[2] ^= s[0];
                s[3] ^= s[1];
                s[1] ^= s[2];
                s[0] ^= s[3];
                s[2] ^= t;
                s[3] = s[3].rotate_left(45);
                out
            }
            fn unit(&mut self) -> f64 {
                f64::from_bits(0x3FF0_0000_0000_0000 | (self.word() >> 12)) - 1.0
            }
            fn next(&mut self) -> f64 {
                if let Some(z) = self.1.take() {
                    return z;
                }
                let u1 = 1.0 - self.unit();
                let u2 = self.unit();
                let r = (-2.0 * crate::stages::web::sde::ln_normal(u1)).sqrt();
                let (s, c) = sin_cos(2.0 * PI * u2);
                self.1 = Some(r * s);
                r * c
            }
        }

        /// The SDE's tangent angles and positions η_k (stochastic Heun, eq 13), one fibre,
        /// one step at a time: the predictor's turn rotates τ_k with the small-angle
        /// polynomials (the kernel beyond π/4), the corrector's turn rotates the predicted
        /// tangent with the tiny-angle ones (`sin_cos` beyond 1/8), τ renormalised every
        /// 128 steps, the multiply-adds fused where the scheme fuses them.
        pub fn sde_angles(b: f64, noise: f64, rng: &mut ChaCha8Rng, steps: usize, spacing: f64) -> (Vec<f64>, Vec<[f64; 2]>) {
            use crate::stages::web::trig::{small_sin_cos, tiny_sin_cos, TINY_ANGLE};
            let mut draws = Normals::new(rng);
            let mut eta = [b * draws.next(), b * draws.next()];
            draws.1 = None;
            let mut angle = 2.0 * PI * draws.unit();
            let (inv_b2, kick) = (1.0 / (b * b), noise * spacing.sqrt());
            let (half_ds, drift_ds, drift_half_ds) = (0.5 * spacing, inv_b2 * spacing, 0.5 * inv_b2 * spacing);
            let (mut sin, mut cos) = sin_cos(angle);
            let (mut alpha, mut etas) = (vec![angle], vec![eta]);
            let turn = |sin: f64, cos: f64, (sd, cd): (f64, f64)| (sin.mul_add(cd, cos * sd), cos.mul_add(cd, -(sin * sd)));
            for k in 0..steps {
                let z = draws.next();
                let torque = eta[0].mul_add(sin, -(eta[1] * cos));
                let step_p = torque.mul_add(drift_ds, kick * z);
                let half = [cos.mul_add(half_ds, eta[0]), sin.mul_add(half_ds, eta[1])];
                let (sin_p, cos_p) = turn(sin, cos, if step_p.abs() <= std::f64::consts::FRAC_PI_4 { small_sin_cos(step_p) } else { sin_cos(step_p) });
                let eta_p = [cos_p.mul_add(half_ds, half[0]), sin_p.mul_add(half_ds, half[1])];
                let torque_p = eta_p[0].mul_add(sin_p, -(eta_p[1] * cos_p));
                let turn_c = (torque_p - torque) * drift_half_ds;
                angle += step_p + turn_c;
                let (sin1, cos1) = turn(sin_p, cos_p, if turn_c.abs() <= TINY_ANGLE { tiny_sin_cos(turn_c) } else { sin_cos(turn_c) });
                eta = [cos1.mul_add(half_ds, half[0]), sin1.mul_add(half_ds, half[1])];
                (sin, cos) = (sin1, cos1);
                alpha.push(angle);
                etas.push(eta);
                if (k + 1) % 128 == 0 {
                    let norm = (cos * cos + sin * sin).sqrt();
                    (cos, sin) = (cos / norm, sin / norm);
                }
            }
            (alpha, etas)
        }

        /// Start angle and curvature of a random_phase or laid_segments fibre.
        pub fn curvature(web: &Web, realisation: u32, fibre: usize) -> (f64, Vec<f64>) {
            let (n, segments) = (web.points, web.params.segments_per_fibre);
            let mut rng = fibre_rng(web.params.seed, realisation, fibre as u32);
            let theta_start = 2.0 * PI * uniform(&mut rng);
            let mut kappa = vec![0.0; segments * n];
            match &web.source {
                Source::Spectra { spectra, .. } => {
                    let ifft = rustfft::FftPlanner::new().plan_fft_inverse(n);
                    let add = |rng: &mut ChaCha8Rng, w: Complex64, buf: &mut [Complex64]| {
                        let p = match web.params.spectrum_selection {
                            SpectrumSelection::Single => &spectra[0],
                            SpectrumSelection::PerSegment => &spectra[index(rng, spectra.len())],
                        };
                        buf[0] += w * p.mean;
                        if n % 2 == 0 {
                            buf[n / 2] += w * p.nyquist;
                        }
                        for &(r, m) in &p.bins {
                            let (s, c) = sin_cos(2.0 * PI * uniform(rng));
                            let z = Complex64::new(m * c, m * s);
                            buf[r] += w * z;
                            buf[n - r] += w * z.conj();
                        }
                    };
                    for pair in (0..segments).step_by(2) {
                        let mut buf = vec![Complex64::default(); n];
                        add(&mut rng, Complex64::new(1.0, 0.0), &mut buf);
                        let second = pair + 1 < segments;
                        if second {
                            add(&mut rng, Complex64::new(0.0, 1.0), &mut buf);
                        }
                        ifft.process(&mut buf);
                        for m in 0..n {
                            kappa[pair * n + m] = buf[m].re;
                            if second {
                                kappa[(pair + 1) * n + m] = buf[m].im;
                            }
                        }
                    }
                }
                Source::Templates(templates) => {
                    for out in kappa.chunks_exact_mut(n) {
                        let template = &templates[index(&mut rng, templates.len())];
                        let mirror = web.params.mirror && uniform(&mut rng) < 0.5;
                        for (o, k) in out.iter_mut().zip(template) {
                            *o = if mirror { -k } else { *k };
                        }
                    }
                }
                Source::Sde(_) | Source::Matched { .. } => unreachable!(),
            }
            (theta_start, kappa)
        }

        /// All nodes of one fibre.
        pub fn fibre(web: &Web, realisation: u32, fibre: usize) -> Vec<[f64; 2]> {
            let total = web.params.segments_per_fibre * web.points;
            let (theta, offset) = match &web.source {
                Source::Sde(m) => {
                    // Eq 14: node k is η_k + (c k Δs, y_j).
                    let mut rng = fibre_rng(web.params.seed, realisation, fibre as u32);
                    let (_, etas) = sde_angles(m.potential_length, m.noise, &mut rng, total, web.spacing());
                    let (drift_ds, y) = (web.params.belt_speed_ratio * web.spacing(), web.params.start_y(fibre));
                    return etas.iter().enumerate().map(|(k, e)| [e[0] + k as f64 * drift_ds, e[1] + y]).collect();
                }
                _ => {
                    let (t0, kappa) = curvature(web, realisation, fibre);
                    let closing = kappa[total - web.points];
                    let half_ds = 0.5 * web.spacing();
                    let mut theta = vec![t0];
                    let mut t = t0;
                    for k in 0..total - 1 {
                        t += (kappa[k] + kappa[k + 1]) * half_ds;
                        theta.push(t);
                    }
                    theta.push(t + (kappa[total - 1] + closing) * half_ds);
                    (theta, [0.0, 0.0])
                }
            };
            let fast = theta.iter().all(|a| a.abs() <= 8.0e5);
            let sc: Vec<(f64, f64)> = theta.iter().map(|&a| if fast { kernel(a) } else { a.sin_cos() }).collect();
            let sums: Vec<(f64, f64)> = sc.windows(2).map(|w| (w[0].0 + w[1].0, w[0].1 + w[1].1)).collect();
            nodes_from(web, fibre, offset, &sums)
        }

        /// Nodes from the first node's offset and (sin α_k + sin α_{k+1}, cos α_k + cos α_{k+1}) per step (eqs 13-14).
        fn nodes_from(web: &Web, fibre: usize, offset: [f64; 2], sums: &[(f64, f64)]) -> Vec<[f64; 2]> {
            let half_ds = 0.5 * web.spacing();
            let drift_ds = web.params.belt_speed_ratio * web.spacing();
            let mut p = [offset[0], web.params.start_y(fibre) + offset[1]];
            let mut nodes = vec![p];
            for &(sum_sin, sum_cos) in sums {
                p[0] += sum_cos * half_ds + drift_ds;
                p[1] += sum_sin * half_ds;
                nodes.push(p);
            }
            nodes
        }
    }

    fn hash_nodes(h: &mut blake3::Hasher, nodes: &[[f64; 2]]) {
        for p in nodes {
            h.update(&p[0].to_bits().to_le_bytes());
            h.update(&p[1].to_bits().to_le_bytes());
        }
    }

    fn spectrum(name: &str) -> crate::stages::spectra::CurvatureSpectrum {
        SquareWaveParams::preset(name).unwrap().spectrum().unwrap()
    }

    fn params(n_w: usize, n_l: usize, seed: u64) -> WebParams {
        WebParams { fibres_across: n_w, segments_per_fibre: n_l, belt_speed_ratio: 0.04, seed, ..WebParams::default() }
    }

    /// Every fibre of realisations 0 and 3 by every path (generate_fibre, the sequential
    /// and the parallel visitors) equals the reference; returns the hash of all of them.
    fn check(name: &str, web: &Web) -> String {
        let n_w = web.params().fibres_across;
        let mut h = blake3::Hasher::new();
        for r in [0u32, 3] {
            let expected: Vec<Vec<[f64; 2]>> = (0..n_w).map(|j| reference::fibre(web, r, j)).collect();
            let par = Mutex::new(vec![Vec::new(); n_w]);
            web.par_for_each_fibre(r, |j, nodes| par.lock().unwrap()[j] = nodes.to_vec());
            let mut seq = vec![Vec::new(); n_w];
            web.for_each_fibre(r, |j, nodes| seq[j] = nodes.to_vec());
            // Pieces put back together: each starts on the node the last one ended on.
            let pieces = Mutex::new(vec![Vec::new(); n_w]);
            web.par_for_each_fibre_piece(r, |j, first, nodes| {
                let mut pieces = pieces.lock().unwrap();
                assert_eq!(pieces[j].len(), if first == 0 { 0 } else { first + 1 }, "{name}: piece of fibre {j} at node {first}");
                pieces[j].truncate(first);
                pieces[j].extend_from_slice(nodes);
            });
            for (j, want) in expected.iter().enumerate() {
                assert!(web.generate_fibre(r, j) == *want, "{name}: generate_fibre({r}, {j})");
                assert!(par.lock().unwrap()[j] == *want, "{name}: par_for_each_fibre({r}) fibre {j}");
                assert!(pieces.lock().unwrap()[j] == *want, "{name}: par_for_each_fibre_piece({r}) fibre {j}");
                assert!(seq[j] == *want, "{name}: for_each_fibre({r}) fibre {j}");
                hash_nodes(&mut h, want);
            }
        }
        h.finalize().to_hex()[..16].to_string()
    }

    fn sde_web(n_w: usize, n_l: usize, b: f64, noise: f64, seed: u64) -> Web {
        Web::lay_down_sde(params(n_w, n_l, seed), LayDownSde { potential_length: b, noise }, 1e-3, 1000).unwrap()
    }

    #[test]
    fn random_phase_fibres_are_unchanged() {
        let mut got = Vec::new();
        let web = Web::new(params(5, 3, 3), vec![spectrum("spectrum1")]).unwrap();
        got.push(check("random_phase", &web));
        let per = WebParams { spectrum_selection: SpectrumSelection::PerSegment, ..params(4, 5, 8) };
        let web = Web::new(per, vec![spectrum("spectrum1"), spectrum("spectrum2")]).unwrap();
        got.push(check("random_phase per_segment", &web));
        // A laid-fibre-like spectrum: every bin non-zero, a negative mean, a Nyquist term.
        let n = 512;
        let mut k = vec![Complex64::new(0.0, 0.0); n];
        k[0].re = -3.0;
        for r in 1..n / 2 {
            k[r] = Complex64::from_polar(40.0 / (1.0 + (r as f64 / 15.0).powi(2)), 0.1 * r as f64);
            k[n - r] = k[r].conj();
        }
        k[n / 2].re = 0.5;
        let full = crate::stages::spectra::CurvatureSpectrum::new(0.5, k).unwrap();
        let web = Web::new(params(5, 7, 4), vec![full]).unwrap();
        got.push(check("random_phase all bins", &web));
        assert_eq!(got, ["385897f4f75cc268", "ad667dd12a8d93ef", "607c161fbc86f6f5"]);
    }

    #[test]
    fn laid_segments_fibres_are_unchanged() {
        let mut got = Vec::new();
        let source = Web::new(params(9, 2, 1), vec![spectrum("spectrum2")]).unwrap();
        let templates: Vec<Vec<f64>> = (0..7).map(|j| source.fibre_curvature(1, j).1[..1000].to_vec()).collect();
        for mirror in [false, true] {
            let web = Web::laid_segments(WebParams { mirror, segment_join: SegmentJoin::Curvature, ..params(6, 20, 5) }, templates.clone(), vec![], 1e-3).unwrap();
            got.push(check(&format!("laid_segments mirror {mirror}"), &web));
        }
        assert_eq!(got, ["1328e2245dcfc970", "ecda30d14ebac161"]);
    }

    #[test]
    fn lay_down_sde_fibres_are_unchanged() {
        // Paper-size fibres (b = 5 mm, A = 2 at Δs = 1 mm, N = 1000, n_l = 100), a fibre
        // count that is no multiple of any batch width (17: a batch of 16 and a lone
        // fibre), another model, a noise whose increments pass π/4 in some lanes of a
        // step and not in others (the rotation's fallback), and one so strong that every
        // increment does and the angles leave the fast-trig range. The hashes are those of
        // this scheme as it stands: the fused step whose corrector turns the predicted
        // tangent, nodes η_k + (c k Δs, y_j) (the two-rotation step before it, and the
        // Box–Muller/ChaCha8 angle scheme of d053cab, had other values).
        let mut got = Vec::new();
        let web = sde_web(17, 100, 5e-3, 2.0, 0);
        got.push(check("lay_down_sde paper", &web));
        let web = sde_web(3, 3, 1e-3, 5.0, 7);
        got.push(check("lay_down_sde b = 1 mm", &web));
        let web = sde_web(9, 10, 5e-3, 25.0, 5);
        let wide = reference::sde_angles(5e-3, 25.0, &mut fibre_rng(5, 0, 0), 10_000, 1e-3).0.windows(2).filter(|w| (w[1] - w[0]).abs() > std::f64::consts::FRAC_PI_4).count();
        assert!(wide > 100 && wide < 9_000, "{wide} of 10 000 increments beyond π/4");
        got.push(check("lay_down_sde increments beyond π/4", &web));
        let web = sde_web(9, 10, 5e-3, 2e5, 2);
        let escaped = (0..9).filter(|&j| reference::sde_angles(5e-3, 2e5, &mut fibre_rng(2, 0, j as u32), 10_000, 1e-3).0.iter().any(|a| a.abs() > 8.0e5)).count();
        assert!(escaped > 0, "{escaped} of 9 fibres beyond the fast range");
        got.push(check("lay_down_sde beyond the fast range", &web));
        assert_eq!(got, ["af0e4deaa7db86a6", "c1acda5700175d56", "96659edd58882ca9", "c2b162b323dc31d3"]);
    }

    #[test]
    fn every_instruction_set_gives_the_same_fibres() {
        // The dispatch picks one path per CPU; call each this CPU has directly.
        let sde = sde_web(5, 4, 5e-3, 2.0, 3);
        let model = sde.sde_model().unwrap();
        let fibres = [0, 1, 2, 3, 4, 0, 1, 2];
        let want: Vec<Vec<[f64; 2]>> = fibres.iter().map(|&j| reference::fibre(&sde, 6, j)).collect();
        // Whole fibres, and pieces of 128 and 384 steps put back together.
        let mut paths: Vec<(String, Vec<Vec<[f64; 2]>>)> = Vec::new();
        for piece in [usize::MAX, 128, 384] {
            let run = |name: &str, lanes: &dyn Fn(&mut SdeScratch, &mut PieceVisitor)| {
                let mut got = vec![Vec::new(); 8];
                lanes(&mut SdeScratch::default(), &mut |l, first, nodes| {
                    assert_eq!(got[l].len(), if first == 0 { 0 } else { first + 1 }, "{name}: pieces share one node");
                    got[l].truncate(first);
                    got[l].extend_from_slice(nodes);
                });
                (format!("{name}, pieces of {piece}"), got)
            };
            paths.push(run("generic", &|s, e| sde.sde_lanes(&model, 6, fibres, piece, s, e)));
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                    paths.push(run("avx2", &|s, e| unsafe { sde.sde_lanes_avx2(&model, 6, fibres, piece, s, e) }));
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    paths.push(run("avx512f", &|s, e| unsafe { sde.sde_lanes_avx512(&model, 6, fibres, piece, s, e) }));
                }
            }
        }
        eprintln!("SDE lanes checked: {:?}", paths.iter().map(|p| &p.0).collect::<Vec<_>>());
        for (name, got) in &paths {
            for (l, w) in want.iter().enumerate() {
                assert!(got[l] == *w, "{name}: lane {l}");
            }
        }
        let web = Web::new(params(3, 5, 9), vec![spectrum("spectrum2")]).unwrap();
        for j in 0..3 {
            let want = reference::fibre(&web, 1, j);
            let mut scratch = FibreScratch::default();
            type NodePass<'a> = &'a dyn Fn(&Web, f64, &mut FibreScratch, &mut Vec<[f64; 2]>) -> bool;
            let mut run = |name: &str, f: NodePass| {
                let theta_start = web.curvature_into(1, j, &mut scratch);
                let mut nodes = Vec::new();
                assert!(!f(&web, theta_start, &mut scratch, &mut nodes));
                assert!(nodes == want, "{name}: fibre {j}");
            };
            run("generic", &|w, t, s, n| w.nodes_from_curvature(t, j, s, n));
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    run("avx2", &|w, t, s, n| unsafe { w.nodes_from_curvature_avx2(t, j, s, n) });
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    run("avx512f", &|w, t, s, n| unsafe { w.nodes_from_curvature_avx512(t, j, s, n) });
                }
            }
        }
    }

    #[test]
    fn lay_down_sde_angles_and_calibration_are_unchanged() {
        let model = LayDownSde { potential_length: 5e-3, noise: 2.0 };
        let web = sde_web(4, 2, 5e-3, 2.0, 11);
        let mut h = blake3::Hasher::new();
        for j in 0..4 {
            let (theta0, kappa) = web.fibre_curvature(1, j);
            let (alpha, _) = reference::sde_angles(5e-3, 2.0, &mut fibre_rng(11, 1, j as u32), 2000, 1e-3);
            assert_eq!(theta0.to_bits(), alpha[0].to_bits());
            let want = crate::stages::web::sde::chord_curvature(&alpha, 1e-3);
            assert!(kappa.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()) && kappa.len() == want.len(), "fibre {j}");
            for k in &kappa {
                h.update(&k.to_bits().to_le_bytes());
            }
        }
        // `positions` (now through the fast trig kernel) and `measure` (S of the nodes, not of
        // the rebuilt curve) changed on purpose after d053cab, and all of it with the rotated
        // tangent and xoshiro256++ draws (issue 14's speed work), then with the fused
        // step and the corrector turning the predicted tangent: the hash is that scheme's.
        let positions = model.positions(&mut fibre_rng(1, 2, 3), 5000, 1e-3);
        hash_nodes(&mut h, &positions);
        let m = crate::stages::web::sde::measure(&model, 1e-3, 300, 4);
        h.update(&m.radius_of_gyration.to_bits().to_le_bytes());
        h.update(&m.bending_energy.to_bits().to_le_bytes());
        assert_eq!(&h.finalize().to_hex()[..16], "b6e9a73a461d75d2");
    }
}
