//! Web stage numerics (§3.1 eqs 11-15, §3.2, §3.3): stochastic fibres, n_w of them
//! started Δw apart across the belt, each n_l segments long, drifting in the machine
//! direction with the belt. Three generators make the fibres ([`Generator`]): random
//! phases of a curvature spectrum (the paper's, described below), laid fibres followed one
//! after another ([`segments`]) and the ITWM stochastic lay-down model ([`sde`]); all
//! share the belt drift, the starting points and the random streams described here.
//!
//! Conventions (x = machine direction MD, y = cross direction CD, metres):
//! - **Random segments** (eqs 11-12): K'_r = |K_r|e^{iθ_r}, θ_r uniform in [0, 2π)
//!   for 0 < r < N/2, K'_{N−r} = K'_r*; K'_0 = K_0 and K'_{N/2} = K_{N/2} keep their
//!   (real) values including sign, i.e. θ_0 = θ_{N/2} = 0 adds no phase. Only bins
//!   with |K_r| > 0 draw a phase. Every segment therefore has exactly the input S_r
//!   and, by Parseval, exactly the input bending energy.
//! - **Joining** (§3.2): a fibre's curvature is its n_l segments' κ samples
//!   concatenated (n_l·N samples at Δs = L/N); θ and r are integrated by eq 13 along
//!   the whole sequence, so position and tangent angle are continuous and the step
//!   across a joint uses the last κ of one segment and the first of the next. The
//!   final step closes the last segment periodically (its own κ_0), so a fibre has
//!   n_l·N + 1 nodes spanning arc length exactly n_l·L. Node k sits at s = kΔs and
//!   carries the point mass of the interval [s, s + Δs) (the last node carries none).
//! - **Belt drift** (eqs 14-15): x_{k+1} = x_k + ((cos θ_k + cos θ_{k+1})/2 + c)Δs.
//! - **Start**: fibre j starts at x = 0, y = (j − (n_w − 1)/2)Δw, with a tangent
//!   angle uniform in [0, 2π) drawn first from its own stream. The web occupies
//!   |y| ≤ n_wΔw/2 at the start and drifts to x ≈ c·n_l·L.
//! - **Random numbers**: ChaCha8 with key (seed, domain tag) and stream number
//!   realisation·2³² + fibre, so any fibre can be regenerated alone, bit for bit,
//!   and results do not depend on the thread count. Per fibre the draws are: start
//!   angle, then per segment (spectrum index if [`SpectrumSelection::PerSegment`],)
//!   the phases of its non-zero bins in increasing r. Uniform f64 = (u64 >> 11)·2⁻⁵³.
//!
//! ```
//! use laydown::stages::spectra::SquareWaveParams;
//! use laydown::stages::web::{Web, WebParams};
//! let spectrum = SquareWaveParams::preset("spectrum1").unwrap().spectrum().unwrap();
//! let params = WebParams { fibres_across: 4, segments_per_fibre: 3, ..WebParams::default() };
//! let web = Web::new(params, vec![spectrum]).unwrap();
//! let fibre = web.generate_fibre(0, 2);
//! assert_eq!(fibre.len(), 3 * 1000 + 1);
//! assert_eq!(fibre[0], [0.0, 0.5 * 2.5e-3]);
//! // Stream every fibre without holding the web (in parallel; order is not fixed):
//! let nodes = std::sync::atomic::AtomicUsize::new(0);
//! web.par_for_each_fibre(0, |_j, f| { nodes.fetch_add(f.len(), std::sync::atomic::Ordering::Relaxed); });
//! assert_eq!(nodes.into_inner(), 4 * 3001);
//! ```
mod generate;
pub mod sde;
pub mod segments;
mod stage;
pub mod trig;

pub use stage::{declared_webs, stored_bytes, web_from_input, DeclaredWeb, WebStage, WebStageParams, SCRATCH_BYTES_PER_NODE, SDE_SCRATCH_BYTES_PER_NODE};

pub use generate::{fibre_rng, FibreScratch, Web};
pub use segments::LaidTemplates;

use crate::params::{ParamError, ParamSpec};
use crate::stages::spectra::SpectraError;

crate::params::choice_enum! {
    /// How a web's fibres are made (the `generator` parameter).
    pub enum Generator {
        /// The paper's surrogate (eqs 11-13): segments with the input's curvature spectrum
        /// and random phases.
        #[default]
        RandomPhase = "random_phase",
        /// Laid fibres (belt removed) followed one after another with their own shape and
        /// phases, each drawn uniformly, optionally mirrored; joined as [`SegmentJoin`] says.
        LaidSegments = "laid_segments",
        /// The ITWM stochastic lay-down model ([`sde`]), calibrated on the laid fibres or given.
        LayDownSde = "lay_down_sde",
    }
}


crate::params::choice_enum! {
    /// How `laid_segments` joins one laid fibre to the next (the `segment_join` parameter).
    pub enum SegmentJoin {
        /// Each laid fibre kept in its place about the feed axis and its laid orientation,
        /// entered where it best continues the previous one ([`segments`]).
        #[default]
        Matched = "matched",
        /// The laid fibres' curvature samples concatenated and integrated by eq 13: each
        /// template rotated to continue the previous tangent, starting where it ended.
        Curvature = "curvature",
    }
}


crate::params::choice_enum! {
    /// Which spectrum of the set each segment uses.
    pub enum SpectrumSelection {
        /// Every segment uses the first spectrum of the set (pass a mean spectrum, e.g.
        /// [`crate::stages::spectra::CurvatureSpectrum::mean`], or an idealised one).
        #[default]
        Single = "single",
        /// Each segment draws one spectrum of the set uniformly (replicate spectra).
        PerSegment = "per_segment",
    }
}


/// Parameters of a web. Defaults are the paper's converged webs (Tables 2-3:
/// n_w = 1500, n_l = 100, Δw = 2.5 mm, d = 20 µm) with the baseline belt-to-fibre
/// speed ratio of Table 1 (v_belt/v_f = 0.2/5.0 = 0.04; the tables' ρ_av ≈ 2.8 g/m²
/// matches ρA/(Δw·c) = 2.98 g/m² for c = 0.04, not 2.39 for 0.05).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WebParams {
    /// n_w, fibres across the machine.
    pub fibres_across: usize,
    /// n_l, random segments joined into one fibre (fibre length n_l·L).
    pub segments_per_fibre: usize,
    /// Δw (m), CD spacing of the fibres' starting points.
    pub fibre_spacing: f64,
    /// c = v_b/v_f (eq 15).
    pub belt_speed_ratio: f64,
    /// d (m).
    pub fibre_diameter: f64,
    /// ρ (kg/m³).
    pub fibre_density: f64,
    pub spectrum_selection: SpectrumSelection,
    pub generator: Generator,
    /// `laid_segments`: mirror each template with probability ½.
    pub mirror: bool,
    /// `laid_segments`: how templates are joined.
    pub segment_join: SegmentJoin,
    /// Master seed of the random streams.
    pub seed: u64,
}

impl Default for WebParams {
    fn default() -> Self {
        Self {
            fibres_across: 1500,
            segments_per_fibre: 100,
            fibre_spacing: 2.5e-3,
            belt_speed_ratio: 0.04,
            fibre_diameter: 20e-6,
            fibre_density: 950.0,
            spectrum_selection: SpectrumSelection::Single,
            generator: Generator::RandomPhase,
            mirror: false,
            segment_join: SegmentJoin::Matched,
            seed: 0,
        }
    }
}

impl WebParams {
    pub fn validate(&self) -> Result<(), WebError> {
        let t = WEB_PARAMS;
        ParamSpec::find(t, "fibres_across").check_number(self.fibres_across as f64)?;
        ParamSpec::find(t, "segments_per_fibre").check_number(self.segments_per_fibre as f64)?;
        ParamSpec::find(t, "fibre_spacing").check_number(self.fibre_spacing)?;
        ParamSpec::find(t, "belt_speed_ratio").check_number(self.belt_speed_ratio)?;
        ParamSpec::find(t, "fibre_diameter").check_number(self.fibre_diameter)?;
        ParamSpec::find(t, "fibre_density").check_number(self.fibre_density)?;
        Ok(())
    }
    /// Fibre mass per unit length ρπd²/4 (kg/m).
    pub fn mass_per_length(&self) -> f64 {
        self.fibre_density * std::f64::consts::PI * self.fibre_diameter.powi(2) / 4.0
    }
    /// Interior mean areal density (kg/m²): each fibre lays its mass per length
    /// over a strip Δw wide and advances c in x per unit of its length, so
    /// ρ_int = (ρπd²/4)/(Δw·c). Infinite for c = 0 (stationary belt: no interior).
    pub fn interior_areal_density(&self) -> f64 {
        self.mass_per_length() / (self.fibre_spacing * self.belt_speed_ratio)
    }
    /// CD coordinate of fibre j's starting point.
    pub fn start_y(&self, fibre: usize) -> f64 {
        (fibre as f64 - 0.5 * (self.fibres_across as f64 - 1.0)) * self.fibre_spacing
    }
    /// Half-width of the row of starting points, n_wΔw/2 (m).
    pub fn half_width(&self) -> f64 {
        0.5 * self.fibres_across as f64 * self.fibre_spacing
    }
}

/// Parameter table of [`WebParams`].
pub const WEB_PARAMS: &[ParamSpec] = &[
    ParamSpec::int("fibres_across", "1", 1500, 1, u32::MAX as i64, "n_w, fibres started across the machine (Table 3)"),
    ParamSpec::int("segments_per_fibre", "1", 100, 1, 1_000_000, "n_l, random segments of length L joined per fibre (Table 2)"),
    ParamSpec::float("fibre_spacing", "m", 2.5e-3, f64::MIN_POSITIVE, 10.0, "Δw, CD spacing of the fibres' starting points (§3.3)"),
    ParamSpec::float("belt_speed_ratio", "1", 0.04, 0.0, 100.0, "c = v_b/v_f, belt drift per unit fibre length (eqs 14-15); 0.04 = Table 1"),
    ParamSpec::float("fibre_diameter", "m", 20e-6, f64::MIN_POSITIVE, 1e-2, "d, fibre diameter (point mass ρπd²/4·Δs)"),
    ParamSpec::float("fibre_density", "kg/m^3", 950.0, f64::MIN_POSITIVE, 1e5, "ρ, fibre material density"),
    ParamSpec::choice("spectrum_selection", SpectrumSelection::NAMES, "single", "single: every segment uses the first spectrum; per_segment: each segment draws one of the set"),
    ParamSpec::choice("generator", Generator::NAMES, "random_phase", "random_phase: the paper's surrogate (eqs 11-13); laid_segments: the input's laid fibres followed one after another (see segment_join); lay_down_sde: the ITWM stochastic lay-down model (see sde_potential_length, sde_noise)"),
    ParamSpec::flag("mirror", false, "laid_segments: mirror each joined template in CD (y → −y, κ → −κ) with probability 1/2"),
    ParamSpec::choice("segment_join", SegmentJoin::NAMES, "matched", "laid_segments: matched keeps each laid fibre about its feed axis in its laid orientation, entered where it continues the previous one; curvature integrates the joined curvature (templates rotated, fibre drifts from its hole)"),
    ParamSpec::int("seed", "1", 0, 0, i64::MAX, "master seed; fibre j of realisation k uses ChaCha8 stream k·2³²+j"),
];

/// Errors of the web stage.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WebError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("spectra: {0}")]
    Spectra(#[from] SpectraError),
    #[error("realisation {0} is beyond 2³²−1")]
    Realisation(u64),
    #[error("a {0} web is built with Web::{0}")]
    WrongConstructor(&'static str),
    #[error("laid_segments needs at least one laid fibre (template)")]
    NoTemplates,
    #[error("laid_segments: templates of {0} samples are too short")]
    ShortTemplates(usize),
    #[error("laid_segments: template {template} has {samples} samples, template 0 has {expected}; all must share N")]
    TemplateLength { template: usize, samples: usize, expected: usize },
    #[error("laid_segments: template {0} has a non-finite curvature sample")]
    NonFiniteTemplate(usize),
    #[error("laid_segments: sample spacing must be positive, got {0}")]
    TemplateSpacing(f64),
    #[error("laid_segments (matched join): nodes of {fibres} laid fibres for {templates} templates")]
    TemplateNodeSets { fibres: usize, templates: usize },
    #[error("laid_segments (matched join): laid fibre {template} has {nodes} finite nodes, needs N + 1 = {expected}")]
    TemplateNodes { template: usize, nodes: usize, expected: usize },
    #[error("{spectra}: the matched join needs the laid fibres' resampled nodes (`resampled_position`), which this spectra version does not hold (written by an older laydown, or idealised spectra); rerun it, or use `segment_join: curvature`")]
    MissingTemplateNodes { spectra: String },
    #[error(transparent)]
    Sde(#[from] sde::SdeError),
    #[error("generator lay_down_sde needs its two parameters (`sde_potential_length`, `sde_noise`) or an input spectra stage of laid fibres to calibrate them on")]
    SdeUnparametrised,
    #[error("lay_down_sde: give both `sde_potential_length` and `sde_noise`, or neither (both calibrated on the input)")]
    SdeHalfGiven,
    #[error("lay_down_sde: need a positive step and segment, got Δs = {spacing}, N = {points}")]
    SdeStep { spacing: f64, points: usize },
    #[error("lay_down_sde: the step Δs = {spacing:.3e} m exceeds the potential length b = {potential_length:.3e} m{}: the scheme cannot resolve the potential; allowed: Δs ≤ b (≤ b/{resolution} to be within 2 %): sample the input finer (the spectra stage's sample_spacing) or raise points_per_segment", if *.calibrated { " (calibrated)" } else { "" })]
    SdeStepBeyondPotential { spacing: f64, potential_length: f64, calibrated: bool, resolution: f64 },
}

#[cfg(test)]
mod tests;
