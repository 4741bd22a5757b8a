//! Fibre synthesis: random-phase segments (eqs 11-12), joined and integrated with
//! belt drift (eqs 13-15). See the module docs of [`super`] for the conventions.
use std::f64::consts::PI;
use std::sync::Arc;

use num_complex::Complex64;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use rustfft::{Fft, FftPlanner};

use super::trig::{sin_cos, sin_cos_slices};
use super::sde::{Draws, LayDownSde};
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
        let nyquist = if n % 2 == 0 { k[n / 2].re } else { 0.0 };
        Self { mean: k[0].re, nyquist, bins }
    }

    /// Adds w·K'_r (random phases, eq 11) into `buf`, for w = 1 or i.
    fn add_random(&self, rng: &mut ChaCha8Rng, w: Complex64, buf: &mut [Complex64]) {
        let n = buf.len();
        buf[0] += w * self.mean;
        if n % 2 == 0 {
            buf[n / 2] += w * self.nyquist;
        }
        for &(r, magnitude) in &self.bins {
            let (s, c) = sin_cos(2.0 * PI * uniform(rng));
            let z = Complex64::new(magnitude * c, magnitude * s);
            buf[r] += w * z;
            buf[n - r] += w * z.conj();
        }
    }
}

/// Reusable buffers for generating one fibre at a time.
#[derive(Default)]
pub struct FibreScratch {
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
            return Err(WebError::Generator(format!("a {} web is built with Web::{}", params.generator.name(), params.generator.name())));
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
        let bad = |m: String| Err(WebError::Generator(m));
        let points = match templates.first() {
            None => return bad("laid_segments needs at least one laid fibre (template)".into()),
            Some(t) => t.len(),
        };
        if points < 2 {
            return bad(format!("laid_segments: templates of {points} samples are too short"));
        }
        if let Some(i) = templates.iter().position(|t| t.len() != points) {
            return bad(format!("laid_segments: template {i} has {} samples, template 0 has {points}; all must share N", templates[i].len()));
        }
        if let Some(i) = templates.iter().position(|t| t.iter().any(|k| !k.is_finite())) {
            return bad(format!("laid_segments: template {i} has a non-finite curvature sample"));
        }
        if !(spacing > 0.0 && spacing.is_finite()) {
            return bad(format!("laid_segments: sample spacing must be positive, got {spacing}"));
        }
        let source = match params.segment_join {
            SegmentJoin::Curvature => Source::Templates(templates),
            SegmentJoin::Matched => {
                if positions.len() != templates.len() {
                    return bad(format!("laid_segments (matched join): nodes of {} laid fibres for {} templates", positions.len(), templates.len()));
                }
                if let Some(i) = positions.iter().position(|q| q.len() != points + 1 || q.iter().flatten().any(|v| !v.is_finite())) {
                    return bad(format!("laid_segments (matched join): laid fibre {i} has {} finite nodes, needs N + 1 = {}", positions[i].len(), points + 1));
                }
                Source::Matched { walk: LaidTemplates::new(&positions, &templates, spacing), curvature: templates, positions }
            }
        };
        Ok(Self { params: WebParams { generator: Generator::LaidSegments, ..params }, source, points, segment_length: spacing * points as f64 })
    }

    /// A `lay_down_sde` web: fibres of the ITWM model integrated at Δs = `spacing`, with
    /// segments of `points` steps (the segment only counts the length: the SDE runs on
    /// across segments).
    pub fn lay_down_sde(params: WebParams, model: LayDownSde, spacing: f64, points: usize) -> Result<Self, WebError> {
        params.validate()?;
        model.validate().map_err(WebError::Generator)?;
        if !(spacing > 0.0 && spacing.is_finite()) || points == 0 {
            return Err(WebError::Generator(format!("lay_down_sde: need a positive step and segment, got Δs = {spacing}, N = {points}")));
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
                ((first[1][1] - first[0][1]).atan2(first[1][0] - first[0][0]), scratch.curvature)
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
                    choose(&mut rng).add_random(&mut rng, Complex64::new(1.0, 0.0), buf);
                    let second = pair + 1 < segments;
                    if second {
                        choose(&mut rng).add_random(&mut rng, Complex64::new(0.0, 1.0), buf);
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
            return model.tangent_angles_into(&mut Draws::new(&mut rng), total, self.spacing(), &mut scratch.theta);
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
            walk.walk(&mut Draws::new(&mut rng), self.params.mirror, self.params.segments_per_fibre * self.points, nodes, &mut scratch.curvature);
            let (drift_ds, y) = (self.params.belt_speed_ratio * self.spacing(), self.params.start_y(fibre));
            for (k, p) in nodes.iter_mut().enumerate() {
                *p = [p[0] + k as f64 * drift_ds, p[1] + y];
            }
            return;
        }
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
    /// the current rayon pool, holding one fibre per worker. Call order is not fixed;
    /// each fibre's nodes are.
    pub fn par_for_each_fibre<F>(&self, realisation: u32, visit: F)
    where
        F: Fn(usize, &[[f64; 2]]) + Sync + Send,
    {
        (0..self.params.fibres_across).into_par_iter().with_min_len(2).for_each_init(
            || (FibreScratch::default(), Vec::new()),
            |(scratch, nodes), j| {
                self.generate_fibre_into(realisation, j, scratch, nodes);
                visit(j, nodes);
            },
        );
    }

    /// Sequential [`Self::par_for_each_fibre`], fibres in index order.
    pub fn for_each_fibre<F: FnMut(usize, &[[f64; 2]])>(&self, realisation: u32, mut visit: F) {
        let (mut scratch, mut nodes) = (FibreScratch::default(), Vec::new());
        for j in 0..self.params.fibres_across {
            self.generate_fibre_into(realisation, j, &mut scratch, &mut nodes);
            visit(j, &nodes);
        }
    }
}
