//! Continuous feed: a fibre of any length fed through the laydown zone onto the belt,
//! integrating only its hanging part and its last landed stretch.
//!
//! The fibre starts as the paper's does (vertical, bottom node on the belt, every node
//! moving down at v_f, x/y imperfections), but only up to the feed height
//! z_f = z0 + `buffer_elements`·Δs: the nodes above z0 are held by the oscillator of
//! eq 7, so a short buffer there carries what the paper's long vertical fibre carries.
//! The top node is driven down at v_f; whenever it has descended one element a new
//! node is added above it at z_f (same x, y and velocity), so material enters at the
//! feed point at v_f for as long as the run lasts, or until `feed_stop`, when the fibre is
//! cut at the feed point and the rest of it falls.
//!
//! **Freezing.** A landed node that has settled (no more than `lift_tolerance` above
//! the belt, or resting on laid fibre with fibre contact, and crept less than `creep_tolerance`·Δs relative to it for `settle_time`;
//! the laid fibre slips in short bursts of ~10⁻⁴ m/s as tension waves from the hanging
//! part pass, so the friction state alone flickers), or that has been on the belt for
//! `age_limit`, or (laid at least `settle_time` ago) lies `front_margin` downstream of
//! the farthest touchdown point so far (of any fibre in a
//! [`ContactWorld`](super::contact_world::ContactWorld); the freezing front: no fibre
//! lands there, and a contact web's laid fibre creeps and may never settle; a single
//! fibre's node must lie on the belt), is frozen once a run of at
//! least `freeze_batch` such nodes has formed (in a world, any run, at each preparation)
//! (with fibre contact a span propped over a crossing counts as laid when the fibre
//! beyond it has landed, [`Simulator::laid_times`]; otherwise one such node, never laid
//! itself, held up every node after it)
//! at the start of the active rod: those nodes leave the simulation and are carried with the belt at
//! no cost (x ← x + v_b (t_end − t_freeze)); the two nodes after them are clamped to
//! the belt, so the bending of the next free node still sees the laid tangent. With
//! `freeze` off every node stays active (the reference the frozen runs are checked
//! against).
//!
//! ```no_run
//! use laydown::rod::{feed::{feed_fibre, FeedSettings}, LaydownParams, replicate_rng};
//! let mut p = LaydownParams::default();
//! let t_end = 0.5; // s: fed length v_f t_end = 2.5 m
//! p.length = p.fibre_speed * t_end;
//! p.elements = (p.length / 1e-3).round() as usize;
//! let fibre = feed_fibre(&p, 0.0, t_end, &FeedSettings::default(), &mut replicate_rng(1, 0));
//! println!("{} laid nodes, {} frozen, error {:?}", fibre.laid_nodes(), fibre.frozen_nodes, fibre.error);
//! ```

use super::contact_world::ContactBody;
use super::integrator::{Simulator, StepControl};
use super::state::NodeContact;
use super::recovery::Recovery;
use super::metrics::{bounce_reason, laid_polyline, shape_measures, BeltMotion, LaydownResult};
use super::lift_watch::LiftWatch;
use super::params::LaydownParams;
use crate::geometry::arc_length;
use super::scene::{build, CustomStart};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use std::time::Instant;

/// Settings of the continuous feed and of freezing.
#[derive(Clone, Debug, PartialEq)]
pub struct FeedSettings {
    /// Elements of the fibre above the laydown height z0 (held by the oscillator).
    pub buffer_elements: usize,
    /// Freeze stuck landed nodes (off: every node stays active).
    pub freeze: bool,
    /// Time a landed node must have stuck without interruption before it may freeze (s).
    pub settle_time: f64,
    /// Highest a settled node may be above the belt (m).
    pub lift_tolerance: f64,
    /// Largest creep relative to the belt during the settling time, in elements Δs.
    pub creep_tolerance: f64,
    /// Nodes frozen at once (the active rod is rebuilt each time) when freezing is
    /// checked after every step; a [`ContactWorld`](super::contact_world::ContactWorld)
    /// freezes at its preparations, any run.
    pub freeze_batch: usize,
    /// A node on the belt for this long is frozen even if it still creeps (s): slow
    /// creep of the fibre's start-up end would otherwise keep the whole laid fibre active.
    pub age_limit: f64,
    /// Soft start T_r (s): the oscillation amplitude grows smoothly from 0 to u0 over
    /// T_r (see [`super::forces::Oscillation::ramp_time`]). With 0, the stiff spring of
    /// eq 7 throws the top nodes from y = 0 to u0 sin φ at ~10 m/s in the first 0.1 ms:
    /// harmless for one fibre, but with fibre contact it throws neighbouring columns
    /// through one another.
    pub oscillation_ramp: f64,
    /// A node laid at least `settle_time` ago that lies this far (m) downstream of the
    /// farthest touchdown point reached so far (of any fibre, in a contact world) is
    /// frozen even if it still creeps (no fibre lands on it any more); without fibre
    /// contact only if it lies on the belt (within `lift_tolerance`); ∞: off.
    pub front_margin: f64,
    /// Time at which the feed stops (s): from the first step at or after it, no node is
    /// added and the top node is no longer driven, as if the fibre were cut at the feed
    /// point; the rest of it falls onto the belt (eq 7's spring still acts on it above z0,
    /// and the step limits stay those of the fed fibre). ∞ (default) or NaN: fed to the end
    /// of the run; 0 or less: never fed. With nothing left to drive it, a laid fibre (or
    /// web) must come to rest: the test of whether its motion is driven by the laydown or
    /// made by the integration (PHYSICAL_WEBS.md, "A contact web moves on after its feed
    /// stops"). Not a stage parameter: a laid web's length and density assume the full feed.
    pub feed_stop: f64,
}

impl FeedSettings {
    /// The default `front_margin` of the laid web (m): two elements of the Table 1 mesh.
    /// `start: fed` takes two of its own scene's, at most this ([`fed_settings`]). A laid
    /// node lying this far downstream of the farthest touchdown point so far, laid at least
    /// the settle time ago, freezes even if it still creeps. A contact web's laid fibre
    /// creeps, and a single fibre's start-up end (its first ~20 nodes at Table 1) slides
    /// for the whole run, up to 60 mm/s at its tip; freezing takes only a leading run, so
    /// without the front either held up the whole laid fibre behind it. The cost changes
    /// little from 0 to 5 mm at Table 1
    /// (`pipelines/studies/freezing_front.yaml`; PHYSICAL_WEBS.md, "A freezing front";
    /// FIBRE_SPEED.md, "A freezing front for the fed start").
    pub const FRONT_MARGIN: f64 = 0.002;
}

impl Default for FeedSettings {
    fn default() -> Self {
        FeedSettings { buffer_elements: 3, freeze: true, settle_time: 0.02, lift_tolerance: 1e-5, creep_tolerance: 0.01, freeze_batch: 32, age_limit: 0.2, oscillation_ramp: 0.0, front_margin: f64::INFINITY, feed_stop: f64::INFINITY }
    }
}

/// One continuously fed fibre at the end of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct FedFibre {
    /// Every node in fibre order at the end time, lab frame (x = 0 under the feed point;
    /// a laid node has been carried along +x by the belt). Never NaN: after a failure,
    /// the last good state.
    pub positions: Vec<[f64; 3]>,
    /// Time each node was laid (s): first touched the belt, or with fibre contact first
    /// came to rest on laid fibre or lies in a span between laid nodes
    /// ([`Simulator::laid_times`]); NaN: still hanging.
    pub landing_time: Vec<f64>,
    /// Nodes frozen during the run (a prefix of `positions`).
    pub frozen_nodes: usize,
    /// Highest landed, unfrozen node above the belt at the end time (m).
    pub final_lift_of_landed: f64,
    /// Index of that node.
    pub final_lift_node: usize,
    /// The lift watch at the end ([`Feeder::watch_lift`]; None: not watched).
    pub lift_watch: Option<LiftWatch>,
    /// Simulated time reached (s).
    pub end_time: f64,
    /// Element length Δs (m).
    pub element_length: f64,
    pub steps: u64,
    pub rejected_steps: u64,
    /// Times the run was rolled back to a checkpoint after a failed step and retaken
    /// ([`super::recovery`]).
    pub rollbacks: usize,
    /// Newton iterations of the length projection, summed over its calls.
    pub projection_iterations: u64,
    /// Largest allowed step (s) and the smallest step taken (s).
    pub time_step: f64,
    pub min_time_step: f64,
    /// Σ over steps of the active nodes: the work done, in node-steps.
    pub node_steps: u64,
    /// Most nodes active at once.
    pub max_active_nodes: usize,
    pub wall_seconds: f64,
    /// Opt-in twist ([`super::twist`]) at the end time: the span's twist rate (rad/m)
    /// and the twist laid down with the fibre (rad); 0 without twist.
    pub twist_rate: f64,
    pub laid_twist: f64,
    /// Set when the run could not be completed.
    pub error: Option<String>,
}

impl FedFibre {
    /// Nodes that have landed (finite landing time).
    pub fn laid_nodes(&self) -> usize {
        self.landing_time.iter().filter(|t| t.is_finite()).count()
    }

    /// The laid nodes in fibre order, raw and with the belt motion removed (by
    /// `p.belt_removal`), and their S and e (eqs 5-6): ((laid, removed), (S, e), (S, e) removed).
    #[allow(clippy::type_complexity)]
    pub fn shape(&self, p: &LaydownParams) -> ((Vec<[f64; 3]>, Vec<[f64; 3]>), (f64, f64), (f64, f64)) {
        let laid = laid_polyline(&self.positions, &self.landing_time, None);
        let motion = BeltMotion { belt_speed: p.belt_speed, fibre_speed: p.fibre_speed, end_time: self.end_time, element_length: self.element_length };
        let removed = laid_polyline(&self.positions, &self.landing_time, Some((p.belt_removal, motion)));
        let (raw, rm) = (shape_measures(&laid), shape_measures(&removed));
        ((laid, removed), raw, rm)
    }

    /// Why the fibre is not valid (None: valid): the run's error, a landed node above
    /// `bounce_tolerance` at the end (the paper's test) or, with `bounce_check:
    /// last_period`, for more than half the last oscillation period, or fewer than two
    /// laid nodes.
    pub fn invalid_reason(&self, p: &LaydownParams) -> Option<String> {
        if let Some(err) = &self.error {
            return Some(err.clone());
        }
        // no lift history: `bounce_check: transient` is refused for fed fibre
        bounce_reason(p, (self.final_lift_node, self.final_lift_of_landed), None, self.lift_watch.as_ref())
            .or_else(|| (self.laid_nodes() < 2).then(|| "fewer than two nodes landed".into()))
    }
}

/// Inertial coil scales ℓ_c = √(EI/(ρA))/v_f ([`LaydownParams::coil_scale`]) of fed
/// fibre over which a laid node must stay put before it may freeze: `start: fed` takes
/// the settle time as the time they take to feed, 28 ℓ_c/v_f ∝ 1/v_f² (20.3 ms at Table 1,
/// about the `laid_web` default; 1.3 ms at 20 m/s, 0.2 ms at 50 m/s; 6.6 ms for d = 16.2 µm at
/// 5 m/s). Against the front off it moves S and e by less than 0.5 % at 5-30 m/s; against
/// nothing frozen at 50 m/s, e by +1.9 ± 0.6 % (a node frozen 1 ms after landing keeps
/// curvature it would still lose). A fixed fed length (0.1 m, before 2026-12-05) froze next
/// to nothing at 10-20 m/s (`pipelines/studies/FIBRE_SPEED.md`, "The settle time in coil
/// scales" and "A tilted clamp stalled freezing").
const FED_SETTLE_COILS: f64 = 28.0;
/// Fed length after which a laid node freezes anyway (m): the age limit is the time it
/// takes to feed, 0.2 s at Table 1's 5 m/s (the `laid_web` default), 20 ms at 50 m/s.
const FED_AGE_LENGTH: f64 = 1.0;

/// The fed start's freezing front in elements of the scene's (coil-resolved) mesh: two,
/// at most [`FeedSettings::FRONT_MARGIN`] (2 mm, two of Table 1's 1 mm elements). So Table 1
/// keeps 2 mm, and so does the coarser mesh of its `mesh_error_estimate`; where the mesh
/// resolves the coil scale the front follows it (0.91 mm at 20 m/s, 0.36 mm at 50 m/s,
/// 1.18 mm for d = 16.2 µm at 5 m/s). At 50 m/s the fixed 2 mm kept about 1 ms of laid
/// fibre active past the touchdown; two elements save time there at the same S and e
/// (`pipelines/studies/FIBRE_SPEED.md`, "The fed start's freezing front in elements").
const FED_FRONT_ELEMENTS: f64 = 2.0;

/// The freezing settings of `start: fed` for the scene `p`: the settle time as the time
/// `FED_SETTLE_COILS` coil scales take to feed, the age limit as the time
/// `FED_AGE_LENGTH` takes, the front `FED_FRONT_ELEMENTS` elements of `p`'s mesh past the
/// farthest touchdown, at most [`FeedSettings::FRONT_MARGIN`].
pub fn fed_settings(p: &LaydownParams) -> FeedSettings {
    let settle_time = FED_SETTLE_COILS * p.coil_scale() / p.fibre_speed;
    let front_margin = (FED_FRONT_ELEMENTS * p.element_length()).min(FeedSettings::FRONT_MARGIN);
    FeedSettings { settle_time, age_limit: FED_AGE_LENGTH / p.fibre_speed, front_margin, ..FeedSettings::default() }
}

/// One replicate of the laydown scene with `start: fed` ([`fed_settings`]).
pub(crate) fn simulate_fed<R: Rng + ?Sized>(p: &LaydownParams, rng: &mut R) -> LaydownResult {
    simulate_fed_with(p, &fed_settings(p), rng)
}

/// The fibre [`feed_fibre`] feeds for the laydown scene `p` (`start: fed`): the length
/// fed in `p`'s end time, in elements of `p`'s (coil-resolved) element length.
pub fn fed_scene(p: &LaydownParams) -> LaydownParams {
    let element_length = p.element_length();
    let length = p.fibre_speed * p.end_time();
    LaydownParams {
        length,
        elements: (length / element_length).round().max(1.0) as usize,
        // the element length is the resolved one already
        coil_resolution: 0.0,
        duration: 0.0,
        ..p.clone()
    }
}

/// One replicate of the laydown scene fed continuously with the freezing `settings`:
/// the paper's element length (after `coil_resolution`) and end time, the fibre fed
/// into a short buffer above z0 instead of hanging from z = L, settled laid nodes
/// frozen; validated parameters ([`super::replicate::simulate`] validates). Errors are
/// reported in [`LaydownResult::error`]. The accuracy of a setting against another:
/// `examples/fed_freezing_accuracy.rs`.
pub fn simulate_fed_with<R: Rng + ?Sized>(p: &LaydownParams, settings: &FeedSettings, rng: &mut R) -> LaydownResult {
    let elements = p.resolved_elements();
    let t_end = p.end_time();
    let fed = feed_fibre(&fed_scene(p), 0.0, t_end, settings, rng);
    let ((laid, removed), (s, e), (sr, er)) = fed.shape(p);
    let invalid_reason = fed.invalid_reason(p);
    LaydownResult {
        landed_nodes: laid.len(),
        laid_length: arc_length(&laid),
        valid: invalid_reason.is_none(),
        invalid_reason,
        final_lift_of_landed: fed.final_lift_of_landed,
        lifted_fraction: fed.lift_watch.map_or(f64::NAN, |w| w.lifted_fraction()),
        // lifts are not kept for frozen nodes (bounce_check transient needs start: vertical)
        max_lift_after_landing: f64::NAN,
        lift: Vec::new(),
        lift_time: Vec::new(),
        radius_of_gyration: s,
        bending_energy: e,
        laid_belt_removed: removed,
        radius_of_gyration_belt_removed: sr,
        bending_energy_belt_removed: er,
        twist_rate: fed.twist_rate,
        laid_twist: fed.laid_twist,
        steps: fed.steps,
        time_step: fed.time_step,
        min_time_step: fed.min_time_step,
        rejected_steps: fed.rejected_steps,
        rollbacks: fed.rollbacks,
        projection_iterations: fed.projection_iterations,
        end_time: fed.end_time,
        elements,
        wall_seconds: fed.wall_seconds,
        warnings: p.resolution_warning(elements).into_iter().collect(),
        positions: fed.positions,
        landing_time: fed.landing_time,
        error: fed.error,
        ..LaydownResult::failed(String::new())
    }
}

/// Feed one fibre for `end_time` seconds. `p.length` is the fed length and
/// `p.length / p.resolved_elements()` the element length Δs; `phase` is the phase φ of
/// the oscillation u0 sin(ωt + φ). Imperfections are drawn from `rng` as in the paper's
/// scene. Never panics on bad input: errors are reported in [`FedFibre::error`].
pub fn feed_fibre<R: Rng + ?Sized>(p: &LaydownParams, phase: f64, end_time: f64, settings: &FeedSettings, rng: &mut R) -> FedFibre {
    let mut feeder = Feeder::new(p, p.element_length(), phase, settings, rng);
    if let Some(watch) = p.lift_watch_until(end_time) {
        feeder.watch_lift(watch);
    }
    feeder.advance_to(end_time);
    feeder.finish()
}

/// A fibre being fed, advanced in pieces ([`Feeder::advance_to`]) so that several can
/// be advanced together (fibre-fibre contact); [`feed_fibre`] runs one to the end.
pub struct Feeder {
    sim: Simulator,
    control: StepControl,
    settings: FeedSettings,
    belt_speed: f64,
    mass_per_length: f64,
    element_length: f64,
    feed_height: f64,
    /// Frozen nodes: position at freezing, freezing time, landing time.
    frozen: Vec<([f64; 3], f64, f64)>,
    /// Per-node settling and the touchdown reach.
    book: FeedBook,
    node_steps: u64,
    max_active: usize,
    error: Option<String>,
    last_good: Vec<[f64; 3]>,
    wall_seconds: f64,
    /// Advanced by a contact world ([`Feeder::join_contact_world`]): freeze only when
    /// asked ([`ContactBody::freeze`]), go back only when the world says.
    in_world: bool,
    /// Rollback after a failed step ([`super::recovery`]), with the feed's bookkeeping
    /// and the count of frozen nodes (they only grow, so the count is enough).
    recovery: Recovery<(usize, FeedBook)>,
}

/// The feed's bookkeeping a rollback restores with the simulator.
#[derive(Clone)]
struct FeedBook {
    /// Per node: since when it has stuck (s; NaN: not stuck).
    stuck_since: Vec<f64>,
    /// Belt-frame position of each node when its settling started.
    anchors: Vec<[f64; 2]>,
    /// The farthest downstream this fibre's touchdown point has been (m, lab frame), as
    /// noted at each preparation ([`ContactBody::landing_reach`]).
    landing_reach: f64,
    lift_watch: Option<LiftWatch>,
}

impl Feeder {
    /// The fibre at t = 0: vertical up to the feed height, moving down at v_f, fed in
    /// elements of `element_length` Δs (m; [`feed_fibre`] passes `p.element_length()`).
    pub fn new<R: Rng + ?Sized>(p: &LaydownParams, element_length: f64, phase: f64, settings: &FeedSettings, rng: &mut R) -> Self {
        let clock = Instant::now();
        let ds = element_length;
        let start_elements = ((p.laydown_height / ds).ceil() as usize + settings.buffer_elements).max(2);
        let feed_height = start_elements as f64 * ds;
        let mut positions: Vec<[f64; 3]> = (0..=start_elements).map(|i| [0.0, 0.0, i as f64 * ds]).collect();
        if p.effects.imperfections && p.imperfection_std > 0.0 {
            if let Ok(normal) = Normal::new(0.0, p.imperfection_std) {
                for x in positions.iter_mut() {
                    x[0] = normal.sample(rng);
                    x[1] = normal.sample(rng);
                }
            }
        }
        let start = CustomStart {
            velocities: vec![[0.0, 0.0, -p.fibre_speed]; start_elements + 1],
            positions,
            driven_top: true,
            clamped: 0,
            rest_length: Some(ds),
        };
        let mut sim = build(p, start);
        // a fed fibre records no energy diagnostics
        sim.stop_work_ledger();
        for term in sim.terms.iter_mut() {
            if let super::forces::Term::Oscillation(o) = term {
                o.phase = phase;
                o.ramp_time = settings.oscillation_ramp;
            }
        }
        let mpl = p.mass_per_length();
        let control = StepControl::new(sim.limits.chosen, mpl);
        let nodes = sim.rod.nodes();
        let last_good = sim.rod.x.clone();
        let book = FeedBook { stuck_since: vec![f64::NAN; nodes], anchors: vec![[0.0; 2]; nodes], landing_reach: f64::NEG_INFINITY, lift_watch: None };
        let recovery = Recovery::new(&mut sim, &control, p.rollbacks, (0, book.clone()));
        Feeder {
            control,
            settings: settings.clone(),
            belt_speed: p.belt_speed,
            mass_per_length: mpl,
            element_length: ds,
            feed_height,
            frozen: Vec::new(),
            book,
            node_steps: 0,
            max_active: nodes,
            error: None,
            last_good,
            wall_seconds: clock.elapsed().as_secs_f64(),
            in_world: false,
            sim,
            recovery,
        }
    }

    /// Watch the landed fibre's lift over `watch`'s window (`bounce_check: last_period`,
    /// [`super::lift_watch`]) through the run and its rollbacks; before the first step.
    /// [`feed_fibre`] watches the last period of the scene before its end time, a laid web
    /// the last period of its feed time.
    pub fn watch_lift(&mut self, watch: LiftWatch) {
        debug_assert_eq!(self.sim.steps, 0, "watch_lift after the run started");
        self.book.lift_watch = Some(watch);
        // the first checkpoint holds the watch too
        self.recovery.checkpoint_now(&mut self.sim, &self.control, (self.frozen.len(), self.book.clone()));
    }

    /// Advance as one fibre of a [`ContactWorld`](super::contact_world::ContactWorld):
    /// freeze only when asked ([`ContactBody::freeze`]), not after every step (the node
    /// indices other fibres refer to must not change between two preparations), and go
    /// back only with the fibres it can touch, to the checkpoint the world has it take at
    /// the start of each interval ([`ContactBody::checkpoint`], [`ContactBody::roll_back`]:
    /// the other fibres have seen its state).
    pub fn join_contact_world(&mut self) {
        self.in_world = true;
        self.recovery.checkpoint_on_demand();
    }

    /// After a step failed here (at `failed_at`, s) or in a fibre this one can touch:
    /// roll back ([`super::recovery`]) with the feed's bookkeeping and run again; false
    /// when no rollback is left.
    fn roll_back_from(&mut self, failed_at: f64) -> bool {
        match self.recovery.roll_back_from(&mut self.sim, &mut self.control, failed_at) {
            Some((frozen, book)) => {
                self.frozen.truncate(frozen);
                self.book = book;
                self.error = None;
                true
            }
            None => false,
        }
    }

    /// The simulated (hanging and not yet frozen) part.
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }
    pub fn simulator_mut(&mut self) -> &mut Simulator {
        &mut self.sim
    }
    /// Speed relative to the belt (m/s) of each laid node still simulated
    /// ([`Simulator::laid_time`]), in fibre order: 0 for laid fibre at rest on the belt.
    pub fn laid_speeds(&self) -> Vec<f64> {
        let sim = &self.sim;
        let vb = self.belt_speed;
        (0..sim.rod.nodes())
            .filter(|&i| sim.laid_time(i).is_finite())
            .map(|i| {
                let v = sim.rod.v[i];
                ((v[0] - vb).powi(2) + v[1] * v[1] + v[2] * v[2]).sqrt()
            })
            .collect()
    }
    /// Frozen nodes so far: position at freezing (lab frame), freezing time, landing time.
    pub fn frozen(&self) -> &[([f64; 3], f64, f64)] {
        &self.frozen
    }
    /// Advance to `until` (s); does nothing once the fibre has failed.
    pub fn advance_to(&mut self, until: f64) {
        self.advance_observed(until, |_| {});
    }

    /// [`Self::advance_to`], calling `observe` with the simulator after every accepted step
    /// (after its settling bookkeeping; a rollback then shows as a step back in time). A
    /// run observed so is bit-identical to one that is not, where sampling it by advancing
    /// in pieces cuts a step short at the end of each piece.
    pub fn advance_observed(&mut self, until: f64, mut observe: impl FnMut(&Simulator)) {
        if self.error.is_some() {
            return;
        }
        let clock = Instant::now();
        let ds = self.element_length;
        let belt = [self.belt_speed, 0.0, 0.0];
        let creep_tolerance2 = (self.settings.creep_tolerance * ds).powi(2);
        let tol = until * 1e-12;
        while self.sim.t < until - tol {
            self.feed_top();
            let line = if self.settings.front_margin.is_finite() && self.settings.freeze && !self.in_world {
                ContactBody::landing_reach(self) + self.settings.front_margin
            } else {
                f64::INFINITY
            };
            if self.settings.freeze && !self.in_world && freeze_stuck(&mut self.sim, &mut self.book.stuck_since, &mut self.frozen, &self.settings, belt, line, self.settings.freeze_batch) {
                self.book.anchors.drain(..self.book.anchors.len() - self.book.stuck_since.len());
            }
            self.node_steps += self.sim.rod.nodes() as u64;
            if let Err(f) = self.control.advance(&mut self.sim, until) {
                let failed_at = self.sim.t;
                if !self.in_world && self.roll_back_from(failed_at) {
                    continue;
                }
                self.error = Some(self.recovery.failure(&f));
                break;
            }
            let sim = &mut self.sim;
            if sim.steps.is_multiple_of(256) {
                self.last_good.clone_from(&sim.rod.x);
            }
            // settling bookkeeping: a node on the belt (or at rest on laid fibre) is
            // settled once it has crept less than creep_tolerance relative to the belt
            // for settle_time
            let t = sim.t;
            let on_web = sim.fibre_contact.as_ref().map_or(&[][..], |c| &c.on_web[..]);
            // laid: landed on the belt, or (with fibre contact) on the web ([`Simulator::laid_time`])
            let web_landing = sim.fibre_contact.as_ref().map_or(&[][..], |c| &c.web_landing_time[..]);
            for (i, (since, anchor)) in self.book.stuck_since.iter_mut().zip(self.book.anchors.iter_mut()).enumerate() {
                let x = sim.rod.x[i];
                let laid = sim.landing_time[i].is_finite() || web_landing.get(i).is_some_and(|t| t.is_finite());
                let on_belt = laid && (x[2] <= self.settings.lift_tolerance || on_web.get(i) == Some(&true));
                let here = [x[0] - self.belt_speed * t, x[1]];
                if !on_belt {
                    *since = f64::NAN;
                } else if since.is_nan() || (here[0] - anchor[0]).powi(2) + (here[1] - anchor[1]).powi(2) > creep_tolerance2 {
                    *since = t;
                    *anchor = here;
                }
            }
            sim.observe_lift(self.book.lift_watch.as_mut());
            // the step's bookkeeping is done: a checkpoint holds all of it
            let (frozen, book) = (&self.frozen, &self.book);
            self.recovery.after_step(&mut self.sim, &mut self.control, || (frozen.len(), book.clone()));
            observe(&self.sim);
        }
        self.wall_seconds += clock.elapsed().as_secs_f64();
    }

    /// Feed: a new top node whenever the driven one has descended an element; from
    /// `feed_stop` on, the top is released instead (at every step, so that a rollback to
    /// before the stop feeds again until it).
    fn feed_top(&mut self) {
        if self.sim.t >= self.settings.feed_stop {
            self.sim.driven_top = None;
            return;
        }
        let (sim, ds) = (&mut self.sim, self.element_length);
        let top = sim.rod.nodes() - 1;
        if sim.rod.x[top][2] <= self.feed_height - ds {
            let (x, v) = (sim.rod.x[top], sim.rod.v[top]);
            sim.push_top([x[0], x[1], x[2] + ds], v, ds, self.mass_per_length);
            self.book.stuck_since.push(f64::NAN);
            self.book.anchors.push([0.0; 2]);
            self.max_active = self.max_active.max(sim.rod.nodes());
        }
    }

    /// The fibre at the time reached: frozen nodes carried with the belt to it.
    pub fn finish(mut self) -> FedFibre {
        // a run that ends inside a retaken stretch reports the scene's scheme and step
        self.recovery.finish(&mut self.sim, &mut self.control);
        let sim = &mut self.sim;
        if self.error.is_some() && sim.rod.x.iter().any(|x| !(x[0].is_finite() && x[1].is_finite() && x[2].is_finite())) {
            sim.rod.x.clone_from(&self.last_good);
        }
        let t_end = sim.t;
        let vb = self.belt_speed;
        let frozen_nodes = self.frozen.len();
        let mut positions: Vec<[f64; 3]> = self.frozen.iter().map(|(x, tf, _)| [x[0] + vb * (t_end - tf), x[1], x[2]]).collect();
        let mut landing_time: Vec<f64> = self.frozen.iter().map(|f| f.2).collect();
        positions.extend_from_slice(&sim.rod.x);
        let mut laid = Vec::new();
        sim.laid_times(&mut laid);
        landing_time.extend(laid);
        let (final_lift_node, final_lift_of_landed) = sim.highest_laid_node().map_or((0, 0.0), |(i, h)| (frozen_nodes + i, h.max(0.0)));
        FedFibre {
            positions,
            landing_time,
            frozen_nodes,
            final_lift_of_landed,
            final_lift_node,
            lift_watch: self.book.lift_watch,
            end_time: t_end,
            element_length: self.element_length,
            steps: sim.steps,
            rejected_steps: self.control.rejected,
            rollbacks: self.recovery.rollbacks(),
            projection_iterations: sim.projection_iterations,
            time_step: self.control.dt_max,
            min_time_step: self.control.min_dt,
            node_steps: self.node_steps,
            max_active_nodes: self.max_active,
            wall_seconds: self.wall_seconds,
            twist_rate: sim.twist.as_ref().map_or(0.0, |t| t.twist_rate),
            laid_twist: sim.twist.as_ref().map_or(0.0, |t| t.laid_twist()),
            error: self.error,
        }
    }
}

impl ContactBody for Feeder {
    fn simulator(&self) -> &Simulator {
        &self.sim
    }
    fn simulator_mut(&mut self) -> &mut Simulator {
        &mut self.sim
    }
    fn next_step(&self) -> f64 {
        self.control.dt
    }
    fn advance_to(&mut self, until: f64) {
        Feeder::advance_to(self, until)
    }
    fn running(&self) -> bool {
        self.error.is_none()
    }
    fn before_step(&mut self) {
        self.feed_top();
    }
    fn checkpoint(&mut self) {
        self.recovery.checkpoint_now(&mut self.sim, &self.control, (self.frozen.len(), self.book.clone()));
    }
    fn can_roll_back(&self) -> bool {
        self.recovery.can_roll_back()
    }
    fn roll_back(&mut self, failed_at: f64) {
        let back = self.roll_back_from(failed_at);
        debug_assert!(back, "roll_back after can_roll_back");
    }
    fn landing_reach(&mut self) -> f64 {
        // the touchdown point: the last node along the fibre that has been laid (a span
        // settling far downstream is not a landing)
        if let Some(i) = (0..self.sim.rod.nodes()).rev().find(|&i| self.sim.laid_time(i).is_finite()) {
            self.book.landing_reach = self.book.landing_reach.max(self.sim.rod.x[i][0]);
        }
        self.book.landing_reach
    }
    fn freeze(&mut self, frozen: &mut Vec<[f64; 3]>, landing_front: f64) {
        if !self.settings.freeze || self.error.is_some() {
            return;
        }
        let before = self.frozen.len();
        let belt = [self.belt_speed, 0.0, 0.0];
        let line = landing_front + self.settings.front_margin;
        // once per preparation: any run is worth freezing (the batch spares rebuilding
        // the rod after every step, which does not happen here)
        if freeze_stuck(&mut self.sim, &mut self.book.stuck_since, &mut self.frozen, &self.settings, belt, line, 1) {
            self.book.anchors.drain(..self.book.anchors.len() - self.book.stuck_since.len());
        }
        let vb = self.belt_speed;
        frozen.extend(self.frozen[before..].iter().map(|(x, t, _)| [x[0] - vb * t, x[1], x[2]]));
    }
}

/// Nodes that stay clamped to the belt after a freeze (the next free node's bending
/// still sees the laid tangent).
const CLAMPED: usize = 2;

/// The laid times of `sim`'s nodes with the spans of a contact web
/// ([`Simulator::laid_times`]); None without fibre contact (node by node then).
fn laid_with_spans(sim: &Simulator) -> Option<Vec<f64>> {
    sim.fibre_contact.is_some().then(|| {
        let mut laid = Vec::new();
        sim.laid_times(&mut laid);
        laid
    })
}

/// Node `i`'s laid time: from `spans` ([`laid_with_spans`]) when given, else its own.
fn laid_time_of(sim: &Simulator, spans: Option<&[f64]>, i: usize) -> f64 {
    spans.map_or_else(|| sim.laid_time(i), |laid| laid[i])
}

/// The leading run of settled nodes, clamped ones included: stuck for the settling time,
/// or laid `age_limit` ago, or laid at least `settle_time` ago and downstream of `line`
/// (x ≥ line). Without fibre contact the run ends where its last [`CLAMPED`] nodes, the
/// clamped end after the freeze, touch the belt: a node that settled within
/// `lift_tolerance` may hover a few µm above it, and a clamp tilted up by it held the
/// next free node just above the tolerance for good, so that nothing after it froze
/// (`pipelines/studies/FIBRE_SPEED.md`, "A tilted clamp stalled freezing"). Zero when it
/// is too short to freeze (fewer than `batch` nodes, or not leaving the rod at least two
/// more).
pub(super) fn settled_run(sim: &Simulator, stuck_since: &[f64], s: &FeedSettings, line: f64, batch: usize, spans: Option<&[f64]>) -> usize {
    let t = sim.t;
    let clamped = sim.clamped.len();
    let settled = (clamped..stuck_since.len())
        .take_while(|&i| {
            let since = stuck_since[i];
            let age = t - laid_time_of(sim, spans, i);
            // past the front a node may still creep, but without fibre contact it must
            // lie on the belt: a lifted node frozen would hang in the air
            let past_front = age >= s.settle_time && sim.rod.x[i][0] >= line && (spans.is_some() || sim.rod.x[i][2] <= s.lift_tolerance);
            (since.is_finite() && t - since >= s.settle_time) || age >= s.age_limit || past_front
        })
        .count();
    // nodes clamped now are settled by construction
    let mut run = clamped + settled;
    if spans.is_none() {
        let touches = |i: usize| sim.ws.contact[i] != NodeContact::Free || sim.rod.x[i][2] <= 0.0;
        while run >= batch + CLAMPED && !(run - CLAMPED..run).all(touches) {
            run -= 1;
        }
    }
    if run < batch + CLAMPED || run + 2 >= sim.rod.nodes() {
        0
    } else {
        run
    }
}

/// Freeze the leading run of settled nodes ([`settled_run`], downstream of `line` with
/// fibre contact), once it is `batch` long; the two nodes after it become the clamped
/// (belt-carried) end.
fn freeze_stuck(sim: &mut Simulator, stuck_since: &mut Vec<f64>, frozen: &mut Vec<([f64; 3], f64, f64)>, s: &FeedSettings, belt: [f64; 3], line: f64, batch: usize) -> bool {
    // with fibre contact the spans laid over crossings count as laid (whole-rod pass);
    // without, node by node, as far as the run of settled nodes reaches
    let spans = laid_with_spans(sim);
    let run = settled_run(sim, stuck_since, s, line, batch, spans.as_deref());
    if run == 0 {
        return false;
    }
    let t = sim.t;
    let count = run - CLAMPED;
    for i in 0..count {
        frozen.push((sim.rod.x[i], t, laid_time_of(sim, spans.as_deref(), i)));
    }
    sim.drop_front(count, CLAMPED, belt);
    stuck_since.drain(..count);
    for since in stuck_since.iter_mut().take(CLAMPED) {
        *since = t;
    }
    true
}
