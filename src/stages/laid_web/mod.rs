//! `kind: laid_web`: a web laid by the fibre physics itself. n_w fibres, one per
//! spinneret hole in a cross-direction row Δw apart, are fed continuously at v_f onto
//! the belt moving at v_b for a belt travel B (feed time T = B/v_b, fed length v_f T
//! per fibre), each with the physics of the `laydown` stage ([`crate::rod`]: drag
//! eqs 1-4, oscillation eq 7, gravity, belt contact and Coulomb friction, damping,
//! imperfections) and its continuous feed with freezing ([`crate::rod::feed`]).
//!
//! - **Turbulence.** Each fibre's oscillation u0 sin(ωt + φ) has its own phase φ drawn
//!   uniformly from the replicate's stream (`turbulence: independent`), optionally with
//!   relative frequency and amplitude jitter (normal, clipped at ±3σ); `coherent` gives
//!   every fibre of a replicate the same φ and jitter (a diffuser whose turbulence is
//!   coherent across the row).
//! - **Domain.** Cross direction periodic with period n_wΔw (no web edges): fibre j is
//!   fed at y_j = (j + ½)Δw − n_wΔw/2 and the grid folds y onto the period. In the
//!   machine direction the web runs from the touchdown (x ≈ 0 at the end of the run)
//!   to x ≈ B (the start-up); the stage reports the interior MD range free of both:
//!   [k·σ, v_b (T − t_s) − k·σ], σ the RMS belt-removed radius of gyration of the
//!   valid fibres, k = `edge_margin_spreads`, t_s = 2 z_f/v_f + 1/f the start-up time
//!   (the initial hanging column laid twice over, then one oscillation period).
//! - **Fibre-fibre contact** (opt-in, [`FibreContactSettings`]): without it fibres pass
//!   through one another and each fibre is simulated alone; with it the fibres of the
//!   web advance under one [`ContactWorld`], those that can touch in lock step
//!   ([`ContactWeb`]; centrelines at least d apart,
//!   Coulomb friction μ_ff, spatial hashing; [`crate::rod::fibre_contact`]), and a node
//!   that comes to rest on laid fibre has landed (on the web instead of the belt). A
//!   fibre whose step fails takes the fibres it can touch back with it to the start of
//!   the broad-phase interval, and they retake it with the recovery scheme (`rollbacks`;
//!   without contact each fibre goes back alone, [`crate::rod::recovery`]).
//! - **Freezing.** Besides the settle rule and the 0.2 s age limit a **freezing front**
//!   freezes laid fibre: a node laid at least `settle_time` ago that lies
//!   `freeze_front_margin` downstream of the farthest touchdown point reached so far,
//!   where no fibre lands, is frozen even if it still creeps. A contact web's laid fibre
//!   creeps (`pipelines/studies/PHYSICAL_WEBS.md`); without contact a fibre's start-up
//!   end keeps sliding and, since only a leading run of nodes freezes, held up the rest
//!   (`pipelines/studies/FIBRE_SPEED.md`). With contact the front is the web's (any
//!   fibre's touchdown); without, each fibre's own, and only nodes on the belt freeze by the front.
//! - **Random streams.** Fibre j of replicate r draws from stream (seed, r, j + 1)
//!   (phase, jitter, then imperfections); the coherent turbulence draws from (seed, r, 0).
//!   Without contact the fibres are independent and computed in parallel; with contact
//!   the clusters of fibres that can touch are, and the rods of a large cluster;
//!   identical for any thread count either way.
//!
//! Outputs are in belt coordinates at the end of the run, see [`stage`].
//!
//! ```no_run
//! use laydown::stages::laid_web::{lay_web, LaidWebParams};
//! let p = LaidWebParams { fibres_across: 4, belt_travel: 0.02, ..LaidWebParams::default() };
//! p.validate().unwrap();
//! let web = lay_web(&p, 42, 0, &indicatif::ProgressBar::hidden());
//! for f in &web.fibres {
//!     println!("S (belt removed) = {:.2} mm, valid = {}", 1e3 * f.radius_of_gyration_belt_removed, f.valid);
//! }
//! ```

// NaN-safe checks are written as negated comparisons on purpose (`!(x < limit)`).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod stage;

pub use stage::LaidWebStage;

use crate::error::InvalidParam;
use crate::rod::contact_world::{ContactStats, ContactWorld};
use crate::rod::feed::{FedFibre, FeedSettings, Feeder};
use crate::rod::fibre_contact::FibreContact;
use crate::rod::{BounceCheck, LaydownParams};
use crate::rng::stream_rng;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

crate::params::choice_enum! {
    /// How the oscillation phases of the fibres of one web relate.
    pub enum Turbulence {
        /// Each fibre its own phase (and jitter).
        #[default]
        Independent = "independent",
        /// One phase (and jitter) for every fibre of the web.
        Coherent = "coherent",
    }
}


/// Parameters of one laid web.
#[derive(Clone, Debug, PartialEq)]
pub struct LaidWebParams {
    /// The fibre physics, as for the `laydown` stage; `length`, `elements` and
    /// `duration` are set from the fields below.
    pub scene: LaydownParams,
    /// n_w, fibres across the row.
    pub fibres_across: usize,
    /// Δw, CD distance between the spinneret holes (m).
    pub fibre_spacing: f64,
    /// B, belt length laid (m): the run lasts T = B/v_b.
    pub belt_travel: f64,
    /// Δs, element length (m), refined by the scene's `coil_resolution`.
    pub element_length: f64,
    pub turbulence: Turbulence,
    /// Relative standard deviation of each fibre's oscillation frequency.
    pub frequency_jitter: f64,
    /// Relative standard deviation of each fibre's oscillation amplitude.
    pub amplitude_jitter: f64,
    /// k of the interior MD range, in belt-removed spreads.
    pub edge_margin_spreads: f64,
    pub feed: FeedSettings,
    /// Fibre-fibre contact; None: fibres pass through one another (no cost).
    pub fibre_contact: Option<FibreContactSettings>,
}

/// Fibre-fibre contact in a laid web.
#[derive(Clone, Debug, PartialEq)]
pub struct FibreContactSettings {
    /// μ_ff, Coulomb friction coefficient between fibres (0: frictionless).
    pub friction: f64,
    /// Δt_c, longest time between two broad-phase searches (s): the candidate pairs of an
    /// interval are those whose swept boxes (twice the motion their velocities predict)
    /// overlap at its start. Shortened for fast fibres
    /// ([`LaidWebParams::broad_phase_interval`]).
    pub interval: f64,
    /// Whether a fibre also collides with its own laid loops that are still simulated
    /// ([`ContactWorld::self_contact`]); its frozen stretch it always meets.
    pub self_contact: bool,
    /// Largest time step with contact, as a fraction of the stable step (the scene's
    /// `time_step_factor` where that is smaller; default
    /// [`CONTACT_STEP_FACTOR`](crate::rod::fibre_contact::CONTACT_STEP_FACTOR)).
    pub step_factor: f64,
}

impl FibreContactSettings {
    /// `scene` with its time step held to [`Self::step_factor`] of the stable step.
    pub fn stepped(&self, mut scene: LaydownParams) -> LaydownParams {
        scene.time_step_factor = scene.time_step_factor.min(self.step_factor);
        scene
    }
}

/// Length of the hanging fibre in feed heights, for the work estimate (the fibre swings
/// out by u0 and curls into the coil below z0).
pub const HANGING_LENGTH: f64 = 1.5;

/// How long a landed node slips before it settles (s), for the work estimate: without
/// fibre contact a laid node stays active for about this plus `settle_time` (measured:
/// 367 active nodes per fibre at Table 1, against 80 hanging and 132 settling).
pub const SETTLING_DELAY: f64 = 0.03;

/// CPU time of one node-step of a fed fibre without fibre contact (s): 1.13-1.33e-7
/// measured on one thread of the development machine (Table 1, Table 4 density, 50 m/s).
pub const CPU_SECONDS_PER_NODE_STEP: f64 = 1.2e-7;

/// With fibre contact a node-step costs 1 + a (ρ_L Δs)^0.6 times more, ρ_L = v_f/(v_b Δw)
/// the fibre length laid per belt area and Δs the element length (the other fibres'
/// segments within reach of one). a = 5 keeps the estimate below every contact web
/// measured (README, "Run time", where the fits are).
pub const CONTACT_COST_SCALE: f64 = 5.0;

/// Elements a node at the largest imposed speed may travel between two broad-phase
/// searches. A segment's box grows by twice its travel in the interval and the grid's
/// cell is an element, so this bounds the cells a fast segment fills: at v_f = 50 m/s
/// and the default interval of 0.2 ms a hanging segment's box grew by 20 mm, about 110
/// cells per side, and the search took 1538 s of a 1600 s web
/// (`pipelines/stability/laid_webs.yaml`, `fast_contact`).
pub const BROAD_PHASE_TRAVEL: f64 = 4.0;

impl Default for FibreContactSettings {
    fn default() -> Self {
        FibreContactSettings { friction: 0.3, interval: 2e-4, self_contact: false, step_factor: crate::rod::fibre_contact::CONTACT_STEP_FACTOR }
    }
}

impl Default for LaidWebParams {
    fn default() -> Self {
        LaidWebParams {
            scene: LaydownParams::default(),
            fibres_across: 8,
            fibre_spacing: 2e-3,
            belt_travel: 0.05,
            element_length: 1e-3,
            turbulence: Turbulence::Independent,
            frequency_jitter: 0.0,
            amplitude_jitter: 0.0,
            edge_margin_spreads: 3.0,
            feed: FeedSettings { front_margin: FeedSettings::FRONT_MARGIN, ..FeedSettings::default() },
            fibre_contact: None,
        }
    }
}

impl LaidWebParams {
    /// T = B/v_b (s).
    pub fn feed_time(&self) -> f64 {
        self.belt_travel / self.scene.belt_speed
    }
    /// v_f T, the length fed per fibre (m).
    pub fn fed_length(&self) -> f64 {
        self.scene.fibre_speed * self.feed_time()
    }
    /// CD period n_wΔw (m).
    pub fn cd_period(&self) -> f64 {
        self.fibres_across as f64 * self.fibre_spacing
    }
    /// y_j = (j + ½)Δw − n_wΔw/2, the feed point of fibre j (m).
    pub fn feed_cd(&self, j: usize) -> f64 {
        (j as f64 + 0.5) * self.fibre_spacing - 0.5 * self.cd_period()
    }
    /// c = v_b/v_f.
    pub fn belt_speed_ratio(&self) -> f64 {
        self.scene.belt_speed / self.scene.fibre_speed
    }
    /// ρ(πd²/4)/(Δw·c), the interior areal density mass conservation implies (kg/m²).
    pub fn interior_areal_density(&self) -> f64 {
        self.scene.mass_per_length() / (self.fibre_spacing * self.belt_speed_ratio())
    }
    /// The scene of one fibre: fed length L = v_f T, covered by whole elements of
    /// [`Self::resolved_element_length`] (`elements`; coil_resolution is then off, the
    /// refinement being made), oscillation frequency and amplitude scaled by the fibre's
    /// jitter. The fibre is fed in elements of exactly that Δs ([`web_feeder`]), not of
    /// L/elements, which would change with the belt travel.
    pub fn fibre_scene(&self, frequency_scale: f64, amplitude_scale: f64) -> LaydownParams {
        let mut s = self.scene.clone();
        s.length = self.fed_length();
        s.elements = (s.length / self.resolved_element_length()).ceil().max(1.0) as usize;
        s.coil_resolution = 0.0;
        s.duration = 0.0;
        s.oscillation_frequency *= frequency_scale;
        s.oscillation_amplitude *= amplitude_scale;
        s
    }
    /// Δt_c used with contact settings `c` (s): `c.interval`, shortened so that a node at
    /// the largest imposed speed (feed v_f, belt v_b, oscillation ω u0) travels at most
    /// [`BROAD_PHASE_TRAVEL`] elements between two searches.
    pub fn broad_phase_interval(&self, c: &FibreContactSettings) -> f64 {
        let s = &self.scene;
        let imposed_speed = s.fibre_speed.max(s.belt_speed).max(s.oscillation_speed());
        // no imposed motion: an infinite limit, and the user's interval
        c.interval.min(BROAD_PHASE_TRAVEL * self.resolved_element_length() / imposed_speed)
    }
    /// `scene` at the step the web's fibres take: with fibre contact, held to
    /// `contact_step_factor` ([`FibreContactSettings::stepped`]).
    pub fn stepped_scene(&self, scene: LaydownParams) -> LaydownParams {
        match &self.fibre_contact {
            Some(c) => c.stepped(scene),
            None => scene,
        }
    }
    /// Element length Δs actually used (m): `element_length`, or the coil scale over the
    /// scene's coil_resolution where that is shorter (the longest element the scene's
    /// `resolved_elements` allows). It does not depend on the belt travel, so a web laid
    /// over a longer travel begins exactly as the shorter one
    /// (`a_longer_web_begins_as_the_shorter_one`).
    pub fn resolved_element_length(&self) -> f64 {
        let s = &self.scene;
        let coil_resolved = s.coil_scale() / s.coil_resolution;
        if s.coil_resolution > 0.0 && coil_resolved.is_finite() && coil_resolved > 0.0 && coil_resolved < self.element_length {
            coil_resolved
        } else {
            self.element_length
        }
    }
    /// Feed height z_f = z0 + buffer (m), as [`feed_fibre`] places it.
    pub fn feed_height(&self) -> f64 {
        let ds = self.resolved_element_length();
        ((self.scene.laydown_height / ds).ceil() + self.feed.buffer_elements as f64).max(2.0) * ds
    }
    /// Start-up time t_s = 2 z_f/v_f + 1/f (s).
    pub fn startup_time(&self) -> f64 {
        let period = if self.scene.effects.oscillation && self.scene.oscillation_frequency > 0.0 { 1.0 / self.scene.oscillation_frequency } else { 0.0 };
        2.0 * self.feed_height() / self.scene.fibre_speed + period
    }
    /// Estimated work of one web in node-steps (Σ over a fibre's steps of its active
    /// nodes, summed over the fibres), from the parameters alone: each fibre steps at its
    /// scene's automatic step (with fibre contact, held to `contact_step_factor`) for the
    /// whole feed time, with the hanging fibre
    /// (`HANGING_LENGTH` times the feed height) and the laid nodes not yet frozen active.
    /// A laid node stays active for the settling time (or, with fibre contact, whose laid
    /// web does not come to rest, until the freezing front passes it, taken as u0 plus the
    /// margin downstream of the feed point, or the age limit), plus a batch; without
    /// freezing, until the end. Checked against the measured `node_steps` in the stage's
    /// tests.
    pub fn estimated_node_steps(&self) -> f64 {
        let ds = self.resolved_element_length();
        let scene = self.stepped_scene(self.fibre_scene(1.0, 1.0));
        let dt = crate::rod::scene::time_step_limits(&scene, ds, true).chosen;
        let t = self.feed_time();
        let steps = t / dt;
        let hanging = HANGING_LENGTH * self.feed_height() / ds;
        let laid_rate = self.scene.fibre_speed / ds;
        let keep = match (&self.fibre_contact, self.feed.freeze) {
            (_, false) => f64::INFINITY,
            (None, true) => self.feed.settle_time + SETTLING_DELAY,
            // until the freezing front passes (the touchdown zone reaches about u0
            // downstream of the feed point, a lower bound), or the age limit
            (Some(_), true) => {
                let front = (self.scene.oscillation_amplitude + self.feed.front_margin) / self.scene.belt_speed;
                self.feed.age_limit.min(front.max(self.feed.settle_time))
            }
        };
        // laid nodes active at time τ: min(laid_rate τ, laid_rate keep + batch), averaged over [0, T]
        let mean_laid = if keep >= t { 0.5 * laid_rate * t } else { laid_rate * (keep - 0.5 * keep * keep / t) + self.feed.freeze_batch as f64 };
        self.fibres_across as f64 * steps * (hanging + mean_laid)
    }

    /// Estimated CPU time of one web (s): [`Self::estimated_node_steps`] at the measured
    /// cost of a node-step ([`CPU_SECONDS_PER_NODE_STEP`]), with fibre contact times
    /// [`Self::contact_cost_factor`]. Good to a factor of about 2 (README, performance).
    pub fn estimated_cpu_seconds(&self) -> f64 {
        let factor = if self.fibre_contact.is_some() { self.contact_cost_factor() } else { 1.0 };
        self.estimated_node_steps() * CPU_SECONDS_PER_NODE_STEP * factor
    }

    /// How many times a node-step costs more with fibre contact: 1 + a (ρ_L Δs)^0.6
    /// ([`CONTACT_COST_SCALE`]).
    pub fn contact_cost_factor(&self) -> f64 {
        let laid_per_area = self.scene.fibre_speed / (self.scene.belt_speed * self.fibre_spacing);
        1.0 + CONTACT_COST_SCALE * (laid_per_area * self.resolved_element_length()).powf(0.6)
    }

    /// Nodes stored per web (laid nodes of every fibre, an upper bound).
    pub fn nodes_per_web(&self) -> f64 {
        self.fibres_across as f64 * (self.fed_length() / self.resolved_element_length() + 1.0)
    }

    /// Checks every parameter: `Err(InvalidParam::new(parameter, message))`.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if !(self.scene.belt_speed > 0.0) {
            return Err(InvalidParam::new("belt_speed".into(), "a laid web needs a moving belt (belt_speed > 0): its length is the belt travel".into()));
        }
        // the scene's own checks; its length and elements are the laid web's (fed
        // length, element length), checked below, and so is the lift watch, over the
        // feed time
        let s = LaydownParams { length: 1.0, elements: 1000, duration: 0.0, bounce_check: BounceCheck::Final, ..self.scene.clone() };
        s.validate().map_err(|e| {
            let name = match &e {
                crate::rod::ParamError::Range(r) => r.name.to_string(),
                _ => "belt_travel".to_string(),
            };
            InvalidParam::new(name, e.to_string())
        })?;
        if self.scene.bounce_check == BounceCheck::Transient {
            return Err(InvalidParam::new(
                "bounce_check".into(),
                "bounce_check transient needs every landed node's lift history, which a laid web does not keep for frozen fibre; use final or last_period".into(),
            ));
        }
        self.scene.check_lift_watch(self.feed_time(), "belt_travel").map_err(|e| InvalidParam::new("bounce_check".into(), e.to_string()))?;
        if self.fed_length() <= 2.0 * self.scene.laydown_height {
            return Err(InvalidParam::new("belt_travel".into(), format!(
                "belt_travel {} m feeds only {:.4} m of fibre at v_f/v_b = {:.1}, less than twice the laydown height {} m: nothing would be laid",
                self.belt_travel,
                self.fed_length(),
                1.0 / self.belt_speed_ratio(),
                self.scene.laydown_height
            )));
        }
        let nodes = self.fed_length() / self.resolved_element_length();
        if !(nodes <= 1e9) {
            return Err(InvalidParam::new("belt_travel".into(), format!(
                "belt_travel {} m feeds {:.3e} m of fibre per hole in {:.3e} elements of {:.3e} m: more than 10⁹ elements per fibre",
                self.belt_travel,
                self.fed_length(),
                nodes,
                self.resolved_element_length()
            )));
        }
        if let Some(c) = &self.fibre_contact {
            if !(c.interval > 0.0 && c.interval <= self.feed_time()) {
                return Err(InvalidParam::new("contact_interval".into(), format!("contact_interval {} s must be positive and at most the feed time {:.4} s", c.interval, self.feed_time())));
            }
            if !(c.friction >= 0.0 && c.friction.is_finite()) {
                return Err(InvalidParam::new("fibre_friction".into(), format!("fibre_friction {} must be finite and ≥ 0", c.friction)));
            }
            if !(c.step_factor > 0.0 && c.step_factor <= 1.0) {
                return Err(InvalidParam::new("contact_step_factor".into(), format!("contact_step_factor {} must lie in (0, 1] (a fraction of the stable step)", c.step_factor)));
            }
            if !(self.feed.oscillation_ramp > 0.0) {
                return Err(InvalidParam::new("oscillation_ramp".into(), "fibre_contact needs oscillation_ramp > 0 (e.g. 0.01 s): starting at full amplitude, eq 7's spring throws the top of each fibre sideways at ~10 m/s in the first 0.1 ms, through its neighbours".into()));
            }
        }
        if !(self.frequency_jitter < 1.0 / 3.0) || !(self.amplitude_jitter < 1.0) {
            return Err(InvalidParam::new("frequency_jitter".into(), "frequency_jitter must be below 1/3 (a fibre's frequency stays positive within ±3σ) and amplitude_jitter below 1".into()));
        }
        Ok(())
    }
}

/// One laid fibre of a web.
#[derive(Clone, Debug, PartialEq)]
pub struct LaidFibre {
    pub fed: FedFibre,
    /// y of the fibre's feed point (m).
    pub feed_cd: f64,
    /// Oscillation phase φ (rad), frequency and amplitude scales of the fibre.
    pub phase: f64,
    pub frequency_scale: f64,
    pub amplitude_scale: f64,
    /// S (eq 5) and e (eq 6) of the laid fibre as it lies on the belt, and with the belt
    /// motion removed (by the scene's `belt_removal`).
    pub radius_of_gyration: f64,
    pub bending_energy: f64,
    pub radius_of_gyration_belt_removed: f64,
    pub bending_energy_belt_removed: f64,
    /// x of each laid node with the belt motion removed (y is unchanged), in fibre order.
    pub x_belt_removed: Vec<f64>,
    /// Completed, and no landed node above `bounce_tolerance` at the end (the paper's rule).
    pub valid: bool,
    pub invalid_reason: Option<String>,
    /// With fibre contact: velocity impulses and position corrections against other
    /// fibres, and pair-steps found crossed (closer than d/2) and left alone; 0 without.
    pub contact_impulses: u64,
    pub contact_corrections: u64,
    pub crossed_pair_steps: u64,
}

/// One laid web.
#[derive(Clone, Debug, PartialEq)]
pub struct LaidWeb {
    pub fibres: Vec<LaidFibre>,
    /// Interior MD range [min, max] (m), see the module docs; min > max when the web is
    /// too short to have an interior.
    pub interior_md: [f64; 2],
    /// σ: RMS belt-removed S of the valid fibres (m).
    pub spread: f64,
    /// Cost of the fibre contact (None: off).
    pub contact: Option<ContactStats>,
    /// Wall time of the whole web (s).
    pub wall_seconds: f64,
}

/// Fibre j's oscillation of one web: phase φ (rad), frequency and amplitude scales.
pub type FibreTurbulence = (f64, f64, f64);

/// Fibre j of replicate `replicate`: its random stream (after the turbulence draws, for
/// the imperfections), its turbulence and its scene (see the module docs, random streams).
pub fn fibre_setup(p: &LaidWebParams, seed: u64, replicate: usize, j: usize) -> (rand_chacha::ChaCha8Rng, FibreTurbulence, LaydownParams) {
    let mut rng = stream_rng(seed, replicate as u64, j as u64 + 1);
    let turbulence = match p.turbulence {
        Turbulence::Independent => draw_turbulence(p, &mut rng),
        Turbulence::Coherent => draw_turbulence(p, &mut stream_rng(seed, replicate as u64, 0)),
    };
    let scene = p.fibre_scene(turbulence.1, turbulence.2);
    (rng, turbulence, scene)
}

/// Fibre j's feeder at t = 0 ([`fibre_setup`]'s scene and phase), watching with
/// `bounce_check: last_period` the last period of the web's nominal oscillation before
/// the end of the feed, whatever the fibre's frequency jitter (the period `validate`
/// checks).
pub fn web_feeder<R: rand::Rng + ?Sized>(p: &LaidWebParams, scene: &LaydownParams, phase: f64, rng: &mut R) -> Feeder {
    let mut feeder = Feeder::new(scene, p.resolved_element_length(), phase, &p.feed, rng);
    if let Some(watch) = p.scene.lift_watch_until(p.feed_time()) {
        feeder.watch_lift(watch);
    }
    feeder
}

/// Lay replicate `replicate` of the web (fibres in parallel on the current rayon pool;
/// identical for any thread count). `bar` counts fibres done.
pub fn lay_web(p: &LaidWebParams, seed: u64, replicate: usize, bar: &indicatif::ProgressBar) -> LaidWeb {
    let clock = std::time::Instant::now();
    let t_end = p.feed_time();
    let (fibres, contact) = match &p.fibre_contact {
        None => {
            let fibres = crate::progress::par_map(bar, 0..p.fibres_across, |j| {
                let (mut rng, turbulence, scene) = fibre_setup(p, seed, replicate, j);
                let mut feeder = web_feeder(p, &scene, turbulence.0, &mut rng);
                feeder.advance_to(t_end);
                let fed = feeder.finish();
                finish_fibre(p, &scene, j, fed, turbulence, [0; 3])
            });
            (fibres, None)
        }
        Some(c) => {
            let mut web = ContactWeb::new(p, c, seed, replicate);
            let label = bar.message();
            for k in 0..web.intervals() {
                let (_, t1) = web.run_interval(k);
                bar.set_message(format!("{label} t {:.0} %", 100.0 * t1 / t_end));
            }
            bar.set_message(label);
            let stats = web.stats;
            let fibres = web
                .into_fibres()
                .into_iter()
                .enumerate()
                .map(|(j, (feeder, scene, turbulence))| {
                    let counts = feeder.simulator().fibre_contact.as_ref().map_or([0; 3], |c| [c.impulses, c.corrections, c.crossed]);
                    let fibre = finish_fibre(p, &scene, j, feeder.finish(), turbulence, counts);
                    bar.inc(1);
                    fibre
                })
                .collect();
            (fibres, Some(stats))
        }
    };
    let valid: Vec<f64> = fibres.iter().filter(|f| f.valid).map(|f| f.radius_of_gyration_belt_removed).collect();
    let spread = if valid.is_empty() { f64::NAN } else { (valid.iter().map(|s| s * s).sum::<f64>() / valid.len() as f64).sqrt() };
    let margin = p.edge_margin_spreads * spread;
    let interior_md = [margin, p.scene.belt_speed * (t_end - p.startup_time()) - margin];
    LaidWeb { fibres, interior_md, spread, contact, wall_seconds: clock.elapsed().as_secs_f64() }
}

/// A web being laid with fibre contact: the feeder of every fibre and the
/// [`ContactWorld`] they share, advanced one broad-phase interval at a time (the stage
/// runs them all; a tool can look at the fibres in between).
///
/// ```no_run
/// use laydown::stages::laid_web::{ContactWeb, FibreContactSettings, LaidWebParams};
/// let p = LaidWebParams { fibres_across: 4, belt_travel: 0.01, fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
/// let mut web = ContactWeb::new(&p, p.fibre_contact.as_ref().unwrap(), 7, 0);
/// for k in 0..web.intervals() {
///     let (_, t1) = web.run_interval(k);
///     let lowest_top = web.feeders.iter().map(|f| f.simulator().rod.x.last().unwrap()[2]).fold(f64::INFINITY, f64::min);
///     println!("t = {t1:.4} s: lowest fed top node {lowest_top:.4} m");
/// }
/// println!("{} lock steps", web.stats.lock_steps);
/// ```
pub struct ContactWeb {
    /// Fibre j's feeder, in its own frame (CD offset `world.cd_offsets[j]`).
    pub feeders: Vec<Feeder>,
    pub world: ContactWorld,
    pub stats: ContactStats,
    /// Fibre j's scene and turbulence.
    pub scenes: Vec<(LaydownParams, FibreTurbulence)>,
    interval: f64,
    feed_time: f64,
}

impl ContactWeb {
    /// Replicate `replicate` of web `p` with contact settings `c`, at t = 0.
    pub fn new(p: &LaidWebParams, c: &FibreContactSettings, seed: u64, replicate: usize) -> Self {
        let d = p.scene.diameter;
        let friction = (c.friction > 0.0).then_some(c.friction);
        let mut scenes = Vec::with_capacity(p.fibres_across);
        let feeders: Vec<Feeder> = (0..p.fibres_across)
            .map(|j| {
                let (mut rng, turbulence, scene) = fibre_setup(p, seed, replicate, j);
                let scene = c.stepped(scene);
                let mut feeder = web_feeder(p, &scene, turbulence.0, &mut rng);
                feeder.join_contact_world();
                let mut contact = FibreContact::new(d, friction);
                contact.web_top = scene.bounce_tolerance;
                feeder.simulator_mut().fibre_contact = Some(contact);
                scenes.push((scene, turbulence));
                feeder
            })
            .collect();
        let mut world = ContactWorld::new(p.fibres_across, d, friction, p.scene.belt_speed, Some(p.cd_period()), p.resolved_element_length());
        world.contact_top = p.scene.laydown_height;
        world.self_contact = c.self_contact;
        for (j, offset) in world.cd_offsets.iter_mut().enumerate() {
            *offset = p.feed_cd(j);
        }
        ContactWeb { feeders, world, stats: ContactStats::default(), scenes, interval: p.broad_phase_interval(c), feed_time: p.feed_time() }
    }

    /// Broad-phase intervals in the feed time.
    pub fn intervals(&self) -> usize {
        (self.feed_time / self.interval).ceil() as usize
    }

    /// Run interval k (in order, from 0); returns its start and end time (s).
    pub fn run_interval(&mut self, k: usize) -> (f64, f64) {
        let (t0, t1) = (k as f64 * self.interval, ((k + 1) as f64 * self.interval).min(self.feed_time));
        self.world.run_interval(&mut self.feeders, t0, t1, &mut self.stats);
        (t0, t1)
    }

    /// Each fibre's feeder, scene and turbulence.
    pub fn into_fibres(self) -> Vec<(Feeder, LaydownParams, FibreTurbulence)> {
        self.feeders.into_iter().zip(self.scenes).map(|(f, (s, t))| (f, s, t)).collect()
    }
}

/// Phase φ ~ U[0, 2π), then the frequency and amplitude scales 1 + σ ξ (ξ standard
/// normal clipped at ±3).
fn draw_turbulence<R: Rng + ?Sized>(p: &LaidWebParams, rng: &mut R) -> FibreTurbulence {
    let phase = 2.0 * PI * rng.random::<f64>();
    let mut scale = |sigma: f64| {
        if sigma > 0.0 {
            let xi: f64 = StandardNormal.sample(rng);
            1.0 + sigma * xi.clamp(-3.0, 3.0)
        } else {
            1.0
        }
    };
    let fs = scale(p.frequency_jitter);
    let fa = scale(p.amplitude_jitter);
    (phase, fs, fa)
}

/// The laid fibre from its fed state; `contact` the fibre's contact impulses,
/// corrections and crossed pair-steps.
fn finish_fibre(p: &LaidWebParams, scene: &LaydownParams, j: usize, fed: FedFibre, turbulence: FibreTurbulence, contact: [u64; 3]) -> LaidFibre {
    let ((_, removed), (s, e), (sr, er)) = fed.shape(scene);
    let invalid_reason = fed.invalid_reason(scene);
    LaidFibre {
        feed_cd: p.feed_cd(j),
        phase: turbulence.0,
        frequency_scale: turbulence.1,
        amplitude_scale: turbulence.2,
        radius_of_gyration: s,
        bending_energy: e,
        radius_of_gyration_belt_removed: sr,
        bending_energy_belt_removed: er,
        x_belt_removed: removed.iter().map(|q| q[0]).collect(),
        valid: invalid_reason.is_none(),
        invalid_reason,
        contact_impulses: contact[0],
        contact_corrections: contact[1],
        crossed_pair_steps: contact[2],
        fed,
    }
}

#[cfg(test)]
mod tests;
