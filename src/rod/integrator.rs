//! Time stepping of the rod: all schemes share the force terms, the implicit
//! node-diagonal part, the contact/friction impulses and the bookkeeping.
//!
//! One step t → t + Δt:
//! 1. explicit forces F (elasticity, gravity) and implicit node matrices
//!    A_i = m I + Δt G_drag + Δt α_R m I + (Δt c + Δt² k) P_xy from the enabled [`Term`]s;
//! 2. v* = A_i⁻¹ (m v + Δt̄ F + r_i) per node (semi-implicit: symplectic Euler while the
//!    step is constant, the variable-step leapfrog where it changes); kinematic top node
//!    (v_z = −v_f) and clamped nodes imposed. v is the velocity of a step's interval
//!    (x' = x + Δt v'), so the explicit forces F(x) kick it over Δt̄ = ½(Δt_prev + Δt),
//!    from the middle of the last step to the middle of this one (Δt̄ = Δt while the
//!    step is constant, on the first step, on a retaken step and in `ImplicitBending`).
//!    With a kick of Δt, every change of step (a step cut short to meet a lock time, the
//!    step control's ramp and buckling limit) kicked each mode by ½(Δt_prev − Δt)ω²x: at
//!    0.8 of the bending limit (ωΔt ≈ 1.6) up to 0.8 of its velocity amplitude, which
//!    pumped the grid-scale modes ([`Simulator::kick_time`]);
//! 3. belt contact and Coulomb friction as velocity impulses (see [`super::contact`]);
//! 4. x ← x + Δt v;
//! 5. projection schemes only: segment lengths projected (XPBD form solved exactly).
//!    With P = EA (l_k − |e_k|)/l_k the spring force, the force applied over the step is
//!    λ_k/Δt² = θ P_new + (1 − θ) P_old, i.e. Newton on
//!    C_k = |e_k| − l_k + (l_k/(EA θ Δt²)) λ_k − ((1 − θ)/θ)(l_k/EA) P_old,k = 0:
//!    θ = ½ trapezoidal rule (`TrapezoidalAxial`, no numerical damping of the axial
//!    waves), θ = 1 backward Euler (`ImplicitAxial`), zero compliance (`Inextensible`).
//!    Each iteration is one symmetric tridiagonal solve (J W Jᵀ + α̃) Δλ = −C,
//!    W = A⁻¹ restricted by the contact state (a sticking node is fixed, a sliding one
//!    moves in plane only); runs of segments between stuck nodes are solved separately;
//!    nodes pushed below the belt join the contact set and the projection is repeated,
//!    continuing from the multipliers found (cleared once per step, so that the
//!    compliance term counts the step's whole impulse);
//!    then v ← v + (x − x_predicted)/Δt. The segment forces found are used, one step
//!    late, in the contact and stick tests, so that tension can lift or unstick a node.
//!
//! `ImplicitBending` adds, between steps 3 and 4, a coupled velocity solve with the
//! bending linearly implicit (`Simulator::solve_implicit_bending`); steps 2-3 then
//! serve as the contact predictor, with one Jacobi sweep of the implicit system instead
//! of the explicit bending kick.
//!
//! Stable step (ω_max of the lumped chain):
//! - axial ω_a = 2 c_0/Δs, c_0 = √(E/ρ): Δt_a = Δs/c_0 (0.69 µs at Δs = 1 mm);
//! - bending ω_b = 4/Δs² · √(EI/ρA): Δt_b = Δs²/2 · √(ρA/EI) (27.6 µs at 1 mm, d = 50 µm);
//!   factor 1.0 is measured to be unstable, 0.8 (default) and 0.5 give the same statistics;
//! - kinematic: Δt_k = Δs/(4 v_max), v_max the largest imposed speed (feed, belt, ωu0),
//!   so a node never moves more than a quarter element per step;
//! - coil time (opt-in, `coil_step` > 0): Δt_c = coil_step·ℓ_c/v_f, ℓ_c/v_f = √(EI/ρA)/v_f²,
//!   whatever the mesh (at two elements per ℓ_c the limits above allow 0.1 ℓ_c/v_f, where
//!   S and e are not converged in the step; [`super::scene::time_step_limits`] applies it);
//! - `Explicit`: fixed Δt = factor · min(2/√(ω_a² + ω_b²), Δt_k);
//! - projection schemes: adaptive Δt ≤ factor · min(Δt_b, Δt_k), starting at 1 % of it,
//!   growing by at most 25 % per step, and kept below ½/σ where σ = P/(2√(EI ρA)) is the
//!   growth rate of the fastest Euler-buckling mode under the largest compression P of
//!   the last step (the start-up impact compresses the column and needs ~µs steps for
//!   about a millisecond); a step that fails (projection not converging, blow-up) is
//!   retaken at Δt/4, and a run whose step fails even at the smallest is rolled back to a
//!   checkpoint and the stretch retaken ([`super::recovery`]).
//!
//! Work ([`Work`], the energy diagnostics). Over a step node i obeys
//! m(v' − v) = Δt̄ F + I(v') + G/Δt + R (v, v' its start- and end-of-step velocities,
//! I(v') = r − (A − m I)v' the implicit terms, G = Σ λ e the projection's, R the reaction
//! of whatever held it: belt, kinematic drive, clamp). The force terms are booked at v'
//! (Δt F·v': exact for gravity, x' − x = Δt v'; the elastic ones are ΔU). R is an
//! impulse (a landing stops a node within a step), booked at ½(v + v'): then
//! m(v' − v)·½(v + v') = ΔK exactly, and ΔK + ΔU − ΣW = −½(Δt̄ F + I + G/Δt)·(v' − v) +
//! (ΔU + the elastic impulses' work at v') + (Δt̄ − Δt) F·v' (at a change of step only) is
//! the scheme's own error, on the belt or off it (`explicit`: O(Δt²) a step). R is the
//! residual of the node's equation,
//! R = A v' − b − G/Δt (b = m v + Δt̄ F + r, step 2), so it includes what the step does
//! not apply: the projection's pull along the directions a held node cannot move, the
//! push-up of nodes it drove below the belt, the clip at z = 0. R_z → `contact` (≤ 0 on
//! landing, −½ m v_z² in total), R_xy → `friction`, R_z of the driven top → `feed`
//! (R_z·(−v_f)), R of clamped nodes → `clamp`. (R at v' misses most of a landing's loss;
//! step 3's m(v' − v*) at ½(v* + v'), v* before contact, books −|Δt F|²/2m a step that
//! ΔK never sees for a node resting on the belt under load.)

use super::contact::BeltContact;
use super::fibre_contact::FibreContact;
use super::forces::{axial_energy_at, axial_energy_of, bending_energy_at, bending_energy_of, Term};
use super::lift_watch::LiftWatch;
use super::params::Integrator;
use super::forces::sym_mul;
use super::state::{sym_inverse, sym_inverse_xy, NodeContact, Rod, Workspace};
use super::twist::Twist;

/// Components of the automatic time step (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeStepLimits {
    /// Δs/√(E/ρ).
    pub axial: f64,
    /// Δs²/2·√(ρA/EI).
    pub bending: f64,
    /// Δs/(4 v_max).
    pub kinematic: f64,
    /// `coil_step`·ℓ_c/v_f, the coil-time limit (∞ when off; set by
    /// [`super::scene::time_step_limits`]).
    pub coil: f64,
    /// The step used (after the safety factor, before rounding to the end time).
    pub chosen: f64,
}

/// Stable step for element length `ds` (see the module docs for the formulas).
#[allow(clippy::too_many_arguments)]
pub fn stable_time_step(
    integrator: Integrator,
    ds: f64,
    youngs_modulus: f64,
    density: f64,
    mass_per_length: f64,
    bending_stiffness: f64,
    max_speed: f64,
    factor: f64,
    elastic: bool,
) -> TimeStepLimits {
    let axial = ds / (youngs_modulus / density).sqrt();
    let bending = 0.5 * ds * ds * (mass_per_length / bending_stiffness).sqrt();
    let kinematic = if max_speed > 0.0 { 0.25 * ds / max_speed } else { f64::INFINITY };
    let elastic_limit = if !elastic {
        f64::INFINITY
    } else {
        match integrator {
            Integrator::Explicit => {
                let wa = 2.0 / axial;
                let wb = 2.0 / bending;
                2.0 / (wa * wa + wb * wb).sqrt()
            }
            Integrator::Inextensible | Integrator::ImplicitAxial | Integrator::TrapezoidalAxial => bending,
            // bending and axial springs implicit: no elastic limit (the caller sets the
            // step from the node motion, `implicit_step_travel`)
            Integrator::ImplicitBending => f64::INFINITY,
        }
    };
    let mut chosen = factor * elastic_limit.min(kinematic);
    if !chosen.is_finite() {
        chosen = factor * 0.25 * ds;
    }
    TimeStepLimits { axial, bending, kinematic, coil: f64::INFINITY, chosen }
}

/// Cumulative work done on the fibre (J), by source (booking: module docs, "Work"), so
/// that K + U − Σ (every field) stays constant up to the integrator's error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    pub gravity: f64,
    pub drag: f64,
    pub damping: f64,
    pub oscillation: f64,
    /// The belt's normal reaction (≤ 0 on an inelastic landing).
    pub contact: f64,
    /// The belt's tangential reaction (friction, stick included).
    pub friction: f64,
    /// The kinematic drive of the top node (its reaction R_z times v_z = −v_f).
    pub feed: f64,
    /// Continuous feed only: the clamps carrying the first nodes with the belt.
    pub clamp: f64,
    /// Continuous feed only: K + U carried in by nodes added at the feed point
    /// ([`Simulator::push_top`]) and out by frozen nodes ([`Simulator::drop_front`]).
    pub transport: f64,
}

/// One energy record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergySample {
    pub time: f64,
    pub kinetic: f64,
    /// Axial + bending + twist.
    pub elastic: f64,
    pub axial: f64,
    pub bending: f64,
    /// Twist energy of the span and of the laid fibre ([`Twist::energy`]; 0 without twist).
    pub twist: f64,
    pub work: Work,
}

/// Why a step could not be taken.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepFailure {
    #[error("unstable step at t = {t:.6e} s: node {node} has non-finite state or speed above {speed_limit:.3e} m/s")]
    Unstable { t: f64, node: usize, speed_limit: f64 },
    #[error("belt penetration {depth:.3e} m exceeds penetration_tolerance {tolerance:.3e} m at t = {t:.6e} s")]
    Penetration { depth: f64, tolerance: f64, t: f64 },
    #[error("singular top-node matrix")]
    SingularTopNode,
    #[error("singular node matrix at node {node}, t = {t:.6e} s")]
    SingularNode { node: usize, t: f64 },
    #[error("implicit bending system not positive definite at t = {t:.6e} s, dt = {dt:.3e} s (node {node}, pivot {pivot:.3e})")]
    BendingSystem { t: f64, dt: f64, node: usize, pivot: f64 },
    #[error("length projection did not converge at t = {t:.6e} s, dt = {dt:.3e} s (relative residual {residual:.3e} at segment {segment}: nodes {from} / {to})")]
    Projection { t: f64, dt: f64, residual: f64, segment: usize, from: String, to: String },
}

/// The time stepper of one replicate.
#[derive(Clone)]
pub struct Simulator {
    pub rod: Rod,
    pub ws: Workspace,
    pub terms: Vec<Term>,
    pub contact: Option<BeltContact>,
    pub integrator: Integrator,
    pub dt: f64,
    /// Step limits of this rod.
    pub limits: TimeStepLimits,
    pub t: f64,
    /// Top node driven at v_z = −speed (x, y free).
    pub driven_top: Option<f64>,
    /// Initial height of the driven top node (m).
    pub top_start_z: f64,
    /// Nodes moved kinematically at `clamp_velocity` (a cantilever clamp at rest, or the
    /// frozen end of a laid fibre carried by the belt); always the leading nodes.
    pub clamped: Vec<usize>,
    /// Positions of the clamped nodes at t = 0 (extrapolated back along `clamp_velocity`).
    pub clamp_positions: Vec<[f64; 3]>,
    pub clamp_velocity: [f64; 3],
    /// The work ledger, booked every step while `work_ledger` is on (NaN once it is off).
    pub work: Work,
    /// Book the work of the force terms and reactions every step (on by default; the
    /// energy diagnostics read it). [`Self::stop_work_ledger`] turns it off where no
    /// diagnostics are recorded.
    pub work_ledger: bool,
    /// Time each node first touched the belt (NaN = never).
    pub landing_time: Vec<f64>,
    /// Highest z of each node after its landing.
    pub max_lift: Vec<f64>,
    /// Time at which each node reached its `max_lift` (NaN: never rose).
    pub lift_time: Vec<f64>,
    /// Deepest belt penetration seen (m, ≥ 0).
    pub max_penetration: f64,
    pub penetration_tolerance: f64,
    /// A node faster than this is a blow-up (m/s).
    pub speed_limit: f64,
    pub steps: u64,
    pub projection_residual: f64,
    /// Axial compliance l-independent part 1/EA (1/N) of the projection; 0 = inextensible.
    pub compliance: f64,
    /// θ of the θ-method on the axial springs in the projection: 1 = backward Euler
    /// (`ImplicitAxial`), ½ = trapezoidal rule (`TrapezoidalAxial`, no numerical damping
    /// of the axial waves).
    pub axial_theta: f64,
    /// Compression P_k of each segment (N, < 0 = tension) found by the last projection;
    /// the friction test of the next step includes it (lagged), so that tension can
    /// unstick a laid node.
    pub segment_force: Vec<f64>,
    /// Largest compressive force of the last projection (N), from its multipliers.
    pub max_compression: f64,
    /// Newton iterations and projection calls so far (cost diagnostics).
    pub projection_iterations: u64,
    pub projection_calls: u64,
    /// Contact with other fibres (opt-in; see [`super::fibre_contact`]).
    pub fibre_contact: Option<FibreContact>,
    /// Rod twist (opt-in; see [`super::twist`]).
    pub twist: Option<Twist>,
    /// (t, Δt, nodes) of the forces in the workspace when [`Self::predict_velocities`]
    /// left them for the step that follows; None: the step evaluates them.
    pub(super) forces_for: Option<(f64, f64, usize)>,
    /// The last accepted step (s); None before the first, and after a step failed, until
    /// one is accepted. [`Self::kick_time`] reads it.
    pub previous_step: Option<f64>,
}

/// State needed to retake a rejected step.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    x: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
    landing_time: Vec<f64>,
    max_lift: Vec<f64>,
    lift_time: Vec<f64>,
    segment_force: Vec<f64>,
    t: f64,
    work: Work,
    max_penetration: f64,
    projection_residual: f64,
    steps: u64,
    fibre_penetration: f64,
}

/// Adaptive step control of the projection schemes: Δt ≤ the stable step Δt_max,
/// growing by at most 25 % per step from 1 % of it, kept below ½/σ (σ the compressive
/// buckling growth rate of the last step, [`Simulator::buckling_rate`]); a step that
/// fails is retaken at Δt/4, down to 10⁻⁴ Δt_max.
#[derive(Clone, Debug)]
pub struct StepControl {
    /// Step to try next (s).
    pub dt: f64,
    pub dt_max: f64,
    pub dt_min: f64,
    /// Steps rejected and retaken so far.
    pub rejected: u64,
    /// Smallest step taken (s).
    pub min_dt: f64,
    mass_per_length: f64,
    snapshot: Snapshot,
}

impl StepControl {
    pub fn new(dt_max: f64, mass_per_length: f64) -> Self {
        StepControl {
            dt: dt_max * 0.01,
            dt_max,
            dt_min: dt_max * 1e-4,
            rejected: 0,
            min_dt: f64::INFINITY,
            mass_per_length,
            snapshot: Snapshot::default(),
        }
    }

    /// A copy without the rejection snapshot (scratch between steps): what a checkpoint
    /// of [`super::recovery`] keeps.
    pub fn without_snapshot(&self) -> StepControl {
        StepControl { snapshot: Snapshot::default(), ..*self }
    }

    /// Take one accepted step of at most `until − t`, retaking failed ones with smaller
    /// steps. `Err` (the failure of the smallest step) leaves the state as before it.
    pub fn advance(&mut self, sim: &mut Simulator, until: f64) -> Result<(), StepFailure> {
        loop {
            let this = self.dt.min(until - sim.t);
            sim.dt = this;
            sim.save(&mut self.snapshot);
            match sim.step() {
                Ok(()) => {
                    self.min_dt = self.min_dt.min(this);
                    let sigma = sim.buckling_rate(self.mass_per_length);
                    let limit = if sigma > 0.0 { 0.5 / sigma } else { f64::INFINITY };
                    self.dt = (1.25 * this.max(self.dt)).min(self.dt_max).min(limit).max(self.dt_min);
                    return Ok(());
                }
                Err(f) => {
                    sim.restore(&self.snapshot);
                    // the retake restarts the leapfrog: its kick spans its own step
                    sim.previous_step = None;
                    self.rejected += 1;
                    if this <= self.dt_min {
                        return Err(f);
                    }
                    self.dt = (this * 0.25).max(self.dt_min);
                }
            }
        }
    }
}

const PROJECTION_TOL: f64 = 1e-8;
const PROJECTION_MAX_ITERS: usize = 12;

impl Simulator {
    pub fn save(&self, s: &mut Snapshot) {
        s.x.clone_from(&self.rod.x);
        s.v.clone_from(&self.rod.v);
        s.landing_time.clone_from(&self.landing_time);
        s.segment_force.clone_from(&self.segment_force);
        s.max_lift.clone_from(&self.max_lift);
        s.lift_time.clone_from(&self.lift_time);
        s.t = self.t;
        s.work = self.work;
        s.max_penetration = self.max_penetration;
        s.projection_residual = self.projection_residual;
        s.steps = self.steps;
        s.fibre_penetration = self.fibre_contact.as_ref().map_or(0.0, |c| c.max_penetration);
    }

    pub fn restore(&mut self, s: &Snapshot) {
        self.rod.x.copy_from_slice(&s.x);
        self.rod.v.copy_from_slice(&s.v);
        self.landing_time.copy_from_slice(&s.landing_time);
        self.segment_force.copy_from_slice(&s.segment_force);
        self.max_lift.copy_from_slice(&s.max_lift);
        self.lift_time.copy_from_slice(&s.lift_time);
        self.t = s.t;
        self.work = s.work;
        self.max_penetration = s.max_penetration;
        self.projection_residual = s.projection_residual;
        self.steps = s.steps;
        if let Some(c) = &mut self.fibre_contact {
            c.max_penetration = s.fibre_penetration;
        }
    }

    /// Set θ of the axial springs ([`Self::axial_theta`]) mid-run. Switching to the
    /// trapezoid (θ < 1) refreshes the segment forces to the end-of-step spring forces it
    /// carries as P_old ([`Self::segment_force`] holds the projection's forces under
    /// θ = 1, which are 0 on segments between held nodes).
    pub fn set_axial_theta(&mut self, theta: f64) {
        let to_trapezoid = theta < 1.0 && self.axial_theta >= 1.0 && self.compliance > 0.0;
        self.axial_theta = theta;
        if to_trapezoid {
            spring_forces(&self.rod, self.compliance, &mut self.segment_force);
        }
    }

    /// Stop booking work (it costs about 8 % of a step at 50 m/s): for runs that record
    /// no energy diagnostics. The ledger reads NaN from then on, so a diagnostic taken
    /// anyway cannot pass for a budget.
    pub fn stop_work_ledger(&mut self) {
        self.work_ledger = false;
        let nan = f64::NAN;
        self.work = Work { gravity: nan, drag: nan, damping: nan, oscillation: nan, contact: nan, friction: nan, feed: nan, clamp: nan, transport: nan };
    }

    /// When node `i` was laid (s): it first touched the belt ([`Simulator::landing_time`]),
    /// or, with fibre contact, first came to rest on laid fibre
    /// ([`FibreContact::web_landing_time`]); NaN: not laid. The laid fibre's bookkeeping
    /// (its polyline, freezing) uses this; the contact physics uses the belt landing.
    pub fn laid_time(&self, i: usize) -> f64 {
        let web = self.fibre_contact.as_ref().and_then(|c| c.web_landing_time.get(i)).copied().unwrap_or(f64::NAN);
        self.landing_time[i].min(web)
    }

    /// Show `watch` (`bounce_check: last_period`, [`super::lift_watch`]) the state just
    /// reached: the height of [`Self::highest_laid_node`], asked only inside its window.
    pub fn observe_lift(&self, watch: Option<&mut LiftWatch>) {
        if let Some(w) = watch {
            w.observe(self.t, || self.highest_laid_node().map(|n| n.1));
        }
    }

    /// The highest node laid so far and its height above the belt (m): the first of the
    /// highest; None when no node has been laid. Laid as in [`Self::laid_times`]: with
    /// fibre contact a node in a span propped over a crossing (followed by a laid node)
    /// counts. A non-finite height is passed over.
    pub fn highest_laid_node(&self) -> Option<(usize, f64)> {
        let spans = self.fibre_contact.is_some();
        let mut later_laid = false;
        let mut best: Option<(usize, f64)> = None;
        for i in (0..self.rod.nodes()).rev() {
            later_laid = (spans && later_laid) || self.laid_time(i).is_finite();
            let height = self.rod.x[i][2];
            if later_laid && height.is_finite() && best.is_none_or(|b| height >= b.1) {
                best = Some((i, height));
            }
        }
        best
    }

    /// [`Self::laid_time`] of every node into `out`, with the spans of a contact web: a
    /// node followed along the fibre by a laid node lies in a span the fibre has laid
    /// over a crossing (propped off the belt, resting on nothing that holds it) from the
    /// time the first of the later nodes was laid, so it counts as laid from the earlier
    /// of that time and its own (a span node that comes to rest on the web later does
    /// not start again). Without fibre contact every laid node has touched the belt, and
    /// this is `laid_time`.
    pub fn laid_times(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..self.rod.nodes()).map(|i| self.laid_time(i)));
        if self.fibre_contact.is_some() {
            let mut later = f64::NAN;
            // (min of NaN and a number is the number)
            for t in out.iter_mut().rev() {
                *t = t.min(later);
                later = *t;
            }
        }
    }

    /// Nodes free to move: all but the clamped leading ones and a driven top.
    pub fn free_nodes(&self) -> std::ops::Range<usize> {
        let n = self.rod.nodes();
        self.clamped.len()..if self.driven_top.is_some() { n - 1 } else { n }
    }

    /// Growth rate of the fastest compressive (Euler) buckling mode of the rod under
    /// the largest compression P of the last step, σ = P/(2√(EI ρA)) (1/s): for
    /// EI w_ssss + P w_ss + ρA w_tt = 0 the growth σ² = (P k² − EI k⁴)/ρA peaks at k² = P/2EI.
    pub fn buckling_rate(&self, mass_per_length: f64) -> f64 {
        if self.max_compression <= 0.0 || self.rod.bending_stiffness <= 0.0 {
            return 0.0;
        }
        self.max_compression / (2.0 * (self.rod.bending_stiffness * mass_per_length).sqrt())
    }

    /// Continuous feed: add a node at `x` with velocity `v` above the driven top node,
    /// joined by a segment of rest length `rest`; it becomes the driven top node
    /// (its height follows z = x_z − speed (t' − t)). The per-step workspace is
    /// resized (it holds nothing between steps but `bend_first`, reset as a new one is).
    pub fn push_top(&mut self, x: [f64; 3], v: [f64; 3], rest: f64, mass_per_length: f64) {
        let top = self.rod.nodes() - 1;
        let k_top = 0.5 * (self.rod.v[top][0].powi(2) + self.rod.v[top][1].powi(2) + self.rod.v[top][2].powi(2));
        self.rod.x.push(x);
        self.rod.v.push(v);
        self.rod.rest.push(rest);
        let half = 0.5 * mass_per_length * rest;
        self.rod.mass[top] += half;
        self.rod.mass.push(half);
        self.rod.inv_voronoi[top] = 2.0 / (self.rod.rest[top - 1] + rest);
        self.rod.inv_voronoi.push(0.0);
        self.rod.refresh_bounds();
        if let Some(twist) = &mut self.twist {
            let (p, q) = (self.rod.x[top], x);
            let e = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            twist.push_top([e[0] / l, e[1] / l, e[2] / l]);
        }
        // energy carried in: the added mass at its speed, the new segment's strain and
        // the bending at the old top (an end until now)
        let k_new = 0.5 * half * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        self.work.transport += half * k_top + k_new + axial_energy_at(&self.rod, top) + bending_energy_at(&self.rod, top);
        self.landing_time.push(f64::NAN);
        self.max_lift.push(0.0);
        self.lift_time.push(f64::NAN);
        self.segment_force.push(0.0);
        if let Some(speed) = self.driven_top {
            self.top_start_z = x[2] + speed * self.t;
        }
        self.ws.resize(self.rod.nodes());
    }

    /// Drop the first `count` nodes (they leave the simulation, e.g. frozen on the belt)
    /// and clamp the new first `clamp` nodes to move at `velocity` from their current
    /// positions.
    pub fn drop_front(&mut self, count: usize, clamp: usize, velocity: [f64; 3]) {
        let r = &mut self.rod;
        // the new first node becomes an end: it keeps only its half of the next element
        let share = r.rest[count] / (r.rest[count - 1] + r.rest[count]);
        // energy carried out: the dropped nodes' K, the share of node `count`'s mass it
        // loses, the dropped segments' strain and the bending up to node `count`
        let kin = |i: usize| 0.5 * r.mass[i] * (r.v[i][0].powi(2) + r.v[i][1].powi(2) + r.v[i][2].powi(2));
        let twist_out = self.twist.as_mut().map_or(0.0, |t| t.drop_front(r, count));
        let out = (0..count).map(|i| kin(i) + axial_energy_at(r, i) + bending_energy_at(r, i)).sum::<f64>()
            + (1.0 - share) * kin(count)
            + bending_energy_at(r, count)
            + twist_out;
        self.work.transport -= out;
        r.x.drain(..count);
        r.v.drain(..count);
        r.rest.drain(..count);
        r.mass.drain(..count);
        r.inv_voronoi.drain(..count);
        r.mass[0] *= share;
        r.inv_voronoi[0] = 0.0;
        r.refresh_bounds();
        self.landing_time.drain(..count);
        self.max_lift.drain(..count);
        self.lift_time.drain(..count);
        self.segment_force.drain(..count);
        if let Some(c) = &mut self.fibre_contact {
            c.drop_front(count);
        }
        let t = self.t;
        self.clamped = (0..clamp).collect();
        self.clamp_velocity = velocity;
        self.clamp_positions = (0..clamp)
            .map(|i| {
                let x = self.rod.x[i];
                [x[0] - velocity[0] * t, x[1] - velocity[1] * t, x[2] - velocity[2] * t]
            })
            .collect();
        self.ws.resize(self.rod.nodes());
    }

    /// Elastic energies at the current state (refreshes the segment geometry).
    pub fn energy_sample(&mut self) -> EnergySample {
        self.ws.update_geometry(&self.rod);
        let axial = axial_energy_of(&self.rod, &self.ws);
        let bending = bending_energy_of(&self.rod, &self.ws);
        let twist = self.twist.as_ref().map_or(0.0, |t| t.energy(&self.rod));
        EnergySample { time: self.t, kinetic: self.rod.kinetic_energy(), elastic: axial + bending + twist, axial, bending, twist, work: self.work }
    }

    /// Step 1 alone: segment geometry, explicit forces and implicit node matrices of
    /// every enabled term at the current state (the hot kernel, exposed for benches).
    pub fn evaluate_forces(&mut self) {
        let (dt, t, n) = (self.dt, self.t, self.rod.nodes());
        self.ws.update_geometry(&self.rod);
        for i in 0..n {
            self.ws.force[i] = [0.0; 3];
            let m = self.rod.mass[i];
            self.ws.amat[i] = [m, m, m, 0.0, 0.0, 0.0];
            self.ws.rhs[i] = [0.0; 3];
        }
        for term in &self.terms {
            term.accumulate(&self.rod, &mut self.ws, t, dt);
        }
        if let Some(twist) = &mut self.twist {
            // held: the clamped leading nodes and landed nodes lying on the belt
            let (clamped, landing, x) = (self.clamped.len(), &self.landing_time, &self.rod.x);
            let hold = twist.hold_height;
            let holds = |i: usize| i < clamped || (!landing[i].is_nan() && x[i][2] <= hold);
            twist.accumulate(&self.rod, &mut self.ws, self.driven_top.is_some(), holds);
        }
    }

    /// The velocities v* a step of `dt` from the current state reaches before fibre
    /// contact (forces, the node-wise implicit update and the belt, steps 1-3), into `out`; the state is
    /// unchanged, and the step of `dt` that follows reuses the forces. Fibres in contact
    /// see one another moving at v* (see [`super::contact_world`]). The belt's contact
    /// test leaves out the lagged axial force here: v* holds no axial force (the
    /// projection adds it), and a node the lag alone drew onto the belt was predicted at
    /// the friction impulse of that landing, over 100 m/s for a span propped 18 d above
    /// the belt in a dense web (the crossing holds it up in the step itself), which the
    /// fibres around it met and were thrown by (`pipelines/studies/PHYSICAL_WEBS.md`).
    /// With `before_belt`, also the velocities and inverse node matrices W before the belt.
    pub fn predict_velocities(&mut self, dt: f64, out: &mut Vec<[f64; 3]>, before_belt: Option<BeforeBelt>) -> Result<(), StepFailure> {
        let saved_dt = self.dt;
        self.dt = dt;
        self.evaluate_forces();
        out.clone_from(&self.rod.v);
        let solved = self.solve_velocities();
        if let Some((v, w)) = before_belt {
            v.clone_from(&self.rod.v);
            w.clone_from(&self.ws.winv);
        }
        if solved.is_ok() {
            // the belt holds what reaches it (fibre contact comes on top); without the
            // lagged axial force, which v* does not contain either
            self.belt_impulses(false);
        }
        std::mem::swap(out, &mut self.rod.v);
        self.dt = saved_dt;
        self.forces_for = solved.is_ok().then_some((self.t, dt, self.rod.nodes()));
        solved
    }

    /// Advance one step. On failure the state is left as it was after the failing step.
    pub fn step(&mut self) -> Result<(), StepFailure> {
        let dt = self.dt;
        let t = self.t;
        let n = self.rod.nodes();
        self.max_compression = 0.0;
        // 1.-2. forces (unless predicted for this step) and the node-wise implicit
        // velocity update
        if self.forces_for.take() != Some((t, dt, n)) {
            self.evaluate_forces();
        }
        let implicit_bending = self.integrator == Integrator::ImplicitBending;
        // the start-of-step velocities: read by the work ledger and the implicit bending
        if self.work_ledger || implicit_bending {
            self.ws.v_start.copy_from_slice(&self.rod.v);
        }
        self.solve_velocities()?;
        if implicit_bending {
            // the implicit system over the nodes not held at the last step (a margin of
            // four nodes that may come loose), and the contact predictor from it
            let first = self.ws.bend_first.saturating_sub(4);
            self.assemble_implicit_bending(first);
            self.predict_implicit_bending();
            self.ws.v_pred.clone_from(&self.rod.v);
        }
        let need_w = self.integrator != Integrator::Explicit;
        // the contacts shared ½ with other fibres, solved for both fibres before the step
        if let Some(c) = &self.fibre_contact {
            if c.air_at == Some(t) && c.air_change.len() == n {
                for (v, change) in self.rod.v.iter_mut().zip(&c.air_change) {
                    v[0] += change[0];
                    v[1] += change[1];
                    v[2] += change[2];
                }
            }
        }
        // 3. contact and friction: with other fibres first (a fibre lying on the belt
        // holds up a node that would otherwise reach the belt in this step), then the belt
        if self.fibre_contact.is_some() {
            let free = self.free_nodes();
            if let Some(c) = &mut self.fibre_contact {
                let winv = if need_w { Some(&mut self.ws.winv[..]) } else { None };
                c.apply_impulses(&mut self.rod, &self.landing_time, winv, t, dt, free);
            }
        }
        if self.contact.is_some() {
            self.belt_impulses(true);
        }
        if implicit_bending {
            self.solve_implicit_bending()?;
        }

        // 4./5. positions
        match self.integrator {
            Integrator::Explicit => {
                for (x, v) in self.rod.x.iter_mut().zip(&self.rod.v) {
                    x[0] += dt * v[0];
                    x[1] += dt * v[1];
                    x[2] += dt * v[2];
                }
            }
            Integrator::Inextensible | Integrator::ImplicitAxial | Integrator::TrapezoidalAxial | Integrator::ImplicitBending => {
                for (x, v) in self.rod.x.iter_mut().zip(&self.rod.v) {
                    x[0] += dt * v[0];
                    x[1] += dt * v[1];
                    x[2] += dt * v[2];
                }
                // predicted positions; the projection's displacement is added to v below
                self.ws.x_old.copy_from_slice(&self.rod.x);
                if self.work_ledger {
                    self.ws.lambda_e.fill([0.0; 3]);
                }
                // the step's multipliers: a repeated projection (below) continues from
                // them, so that the compliance term of each constraint counts the whole
                // impulse of the step
                self.ws.lambda_acc.fill(0.0);
                self.project()?;
                if self.contact.is_some() || self.fibre_contact.is_some() {
                    // nodes the projection pushed below the belt join the contact set
                    // (in-plane freedom only), fibres closer than d are pushed apart,
                    // and the projection is repeated
                    let free = self.free_nodes();
                    let mut fibre_penetration = 0.0;
                    for _round in 0..super::fibre_contact::POSITION_ROUNDS {
                        let mut pushed = 0;
                        if self.contact.is_some() {
                            for i in free.clone() {
                                if self.rod.x[i][2] < 0.0 {
                                    self.rod.x[i][2] = 0.0;
                                    if self.ws.contact[i] == NodeContact::Free {
                                        self.ws.contact[i] = NodeContact::Slide;
                                        self.ws.winv[i] = sym_inverse_xy(&self.ws.amat[i]).unwrap_or([0.0; 6]);
                                    }
                                    pushed += 1;
                                }
                            }
                        }
                        if let Some(c) = &mut self.fibre_contact {
                            let (corrected, deepest) = c.push_apart(&mut self.rod, Some(&self.ws.winv), t + dt, dt, free.clone());
                            pushed += corrected;
                            fibre_penetration = deepest;
                        }
                        if pushed == 0 {
                            break;
                        }
                        // the repeat continues from the step's λ, but against the P_old
                        // its first pass left (that pass's end-of-step spring forces), so
                        // a repeated step is nearer backward Euler than the trapezoid;
                        // with the step's own P_old the start-up impact of a 0.1 m fibre
                        // went unstable (FIBRE_SPEED.md, "A repeated length projection")
                        self.project()?;
                    }
                    if let Some(c) = &mut self.fibre_contact {
                        c.max_penetration = c.max_penetration.max(fibre_penetration);
                    }
                }
                let idt = 1.0 / dt;
                if let Some(c) = &self.fibre_contact {
                    // the position pass's corrections are not velocity
                    for (xo, s) in self.ws.x_old.iter_mut().zip(&c.shift) {
                        xo[0] += s[0];
                        xo[1] += s[1];
                        xo[2] += s[2];
                    }
                }
                for i in 0..n {
                    let (x, xo) = (self.rod.x[i], self.ws.x_old[i]);
                    let v = &mut self.rod.v[i];
                    v[0] += (x[0] - xo[0]) * idt;
                    v[1] += (x[1] - xo[1]) * idt;
                    v[2] += (x[2] - xo[2]) * idt;
                }
            }
        }
        let t_new = t + dt;
        if let Some(speed) = self.driven_top {
            // exact kinematic position of the top node (no round-off drift)
            self.rod.x[n - 1][2] = self.top_start_z - speed * t_new;
        }
        for (k, &i) in self.clamped.iter().enumerate() {
            let (x0, v) = (self.clamp_positions[k], self.clamp_velocity);
            self.rod.x[i] = [x0[0] + v[0] * t_new, x0[1] + v[1] * t_new, x0[2] + v[2] * t_new];
        }

        // 6. belt plane, landing, blow-up checks
        let contact_on = self.contact.is_some();
        let vmax2 = self.speed_limit * self.speed_limit;
        let mut bad: Option<usize> = None;
        for i in 0..n {
            let x = &mut self.rod.x[i];
            let v = &mut self.rod.v[i];
            let s2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            if !(s2 <= vmax2) || !x[0].is_finite() || !x[1].is_finite() || !x[2].is_finite() {
                bad = Some(i);
                break;
            }
            if contact_on {
                if x[2] < 0.0 {
                    self.max_penetration = self.max_penetration.max(-x[2]);
                    x[2] = 0.0;
                    if v[2] < 0.0 {
                        v[2] = 0.0;
                    }
                }
                let landed = self.ws.contact[i] != NodeContact::Free || x[2] <= 0.0;
                if self.landing_time[i].is_nan() {
                    if landed {
                        self.landing_time[i] = t_new;
                        self.max_lift[i] = 0.0;
                    }
                } else if x[2] > self.max_lift[i] {
                    self.max_lift[i] = x[2];
                    self.lift_time[i] = t_new;
                }
            }
        }
        if let Some(i) = bad {
            return Err(StepFailure::Unstable { t: t_new, node: i, speed_limit: self.speed_limit });
        }
        if self.max_penetration > self.penetration_tolerance {
            return Err(StepFailure::Penetration { depth: self.max_penetration, tolerance: self.penetration_tolerance, t: t_new });
        }

        if self.work_ledger {
            // work of the force terms at the end-of-step velocities, of the reactions at
            // the mean velocities
            self.book_reactions();
            for term in &self.terms {
                let p = term.power(&self.rod, &self.ws, t_new) * dt;
                match term {
                    Term::Gravity { .. } => self.work.gravity += p,
                    Term::Drag(_) => self.work.drag += p,
                    Term::Damping { .. } => self.work.damping += p,
                    Term::Oscillation(_) => self.work.oscillation += p,
                    Term::Axial | Term::Bending => {}
                }
            }
        }
        self.t = t_new;
        self.steps += 1;
        self.previous_step = Some(dt);
        Ok(())
    }

    /// The work of the reactions R = A v' − b − G/Δt over the step just taken, at
    /// ½(v + v') (module docs, "Work"): the belt's on the nodes in contact or at z ≤ 0
    /// (normal → `contact`, tangential → `friction`), the drive's on the top node
    /// (`feed`), the clamps' (`clamp`). A free node's R is round-off and is not booked.
    fn book_reactions(&mut self) {
        let (dt, n, kick) = (self.dt, self.rod.nodes(), self.kick_time());
        let projected = self.integrator != Integrator::Explicit;
        let implicit_bending = self.integrator == Integrator::ImplicitBending;
        let idt = 1.0 / dt;
        let free = self.free_nodes();
        let belt = self.contact.is_some();
        let (ws, rod) = (&self.ws, &self.rod);
        // R_i and the mean velocity ½(v + v')
        let reaction = |i: usize| {
            let (m, v, v0, f, r) = (rod.mass[i], rod.v[i], ws.v_start[i], ws.force[i], ws.rhs[i]);
            let mut av = sym_mul(&ws.amat[i], &v);
            if implicit_bending {
                // the implicit bending force −Δt² H v' is part of the node's equation
                let h = ws.bend_impl[i];
                av = [av[0] + h[0], av[1] + h[1], av[2] + h[2]];
            }
            let mut g = [0.0; 3];
            if projected {
                let (a, b) = (if i > 0 { ws.lambda_e[i - 1] } else { [0.0; 3] }, if i + 1 < n { ws.lambda_e[i] } else { [0.0; 3] });
                g = [(a[0] - b[0]) * idt, (a[1] - b[1]) * idt, (a[2] - b[2]) * idt];
            }
            let mut out = [[0.0; 3]; 2];
            for k in 0..3 {
                out[0][k] = av[k] - (m * v0[k] + kick * f[k] + r[k]) - g[k];
                out[1][k] = 0.5 * (v0[k] + v[k]);
            }
            out
        };
        let (mut normal, mut friction, mut feed, mut clamp) = (0.0, 0.0, 0.0, 0.0);
        if belt {
            for i in free.clone() {
                if ws.contact[i] == NodeContact::Free && rod.x[i][2] > 0.0 {
                    continue;
                }
                let [r, vm] = reaction(i);
                normal += r[2] * vm[2];
                friction += r[0] * vm[0] + r[1] * vm[1];
            }
        }
        if self.driven_top.is_some() {
            let [r, vm] = reaction(n - 1);
            feed += r[2] * vm[2];
        }
        for i in 0..free.start {
            let [r, vm] = reaction(i);
            clamp += r[0] * vm[0] + r[1] * vm[1] + r[2] * vm[2];
        }
        self.work.contact += normal;
        self.work.friction += friction;
        self.work.feed += feed;
        self.work.clamp += clamp;
    }

    /// Step 3, the belt: its normal and friction impulses on the nodes that reach it
    /// (the nodes held up by another fibre in this step left alone).
    fn belt_impulses(&mut self, lagged: bool) {
        let Some(c) = &self.contact else { return };
        let n = self.rod.nodes();
        let need_w = self.integrator != Integrator::Explicit;
        let skip_top = if self.driven_top.is_some() { n - 1 } else { n };
        // the lagged axial force of the projection schemes, node by node from the last
        // projection's segment forces (BeltContact::apply)
        let lag = (need_w && lagged).then_some(&self.segment_force[..]);
        let supported = self.fibre_contact.as_ref().map_or(&[][..], |f| &f.supported[..]);
        c.apply(&mut self.rod, &mut self.ws, self.dt, self.clamped.len()..skip_top, need_w, lag, supported)
    }

    /// The time Δt̄ over which the explicit forces F kick the velocities in this step
    /// (module docs, step 2): ½(Δt_prev + Δt), the variable-step leapfrog, so that a
    /// change of step does not kick the stiff modes; Δt on the first step, on a step
    /// retaken after a failure or a rollback (the smaller retake then also kicks less;
    /// `pipelines/studies/PHYSICAL_WEBS.md`, "Changes of step kicked the grid-scale
    /// modes") and in `ImplicitBending`, whose bending is backward Euler (F and its
    /// Hessian at the same Δt).
    pub fn kick_time(&self) -> f64 {
        match self.previous_step {
            Some(previous) if self.integrator != Integrator::ImplicitBending => 0.5 * (previous + self.dt),
            _ => self.dt,
        }
    }

    /// Step 2: the node-wise implicit velocity update from the forces and node matrices
    /// in the workspace, v = A⁻¹ (m v + Δt̄ f + r) (Δt̄ = [`Self::kick_time`]), with the
    /// driven top's v_z imposed and the clamped nodes carried; the projection schemes
    /// keep A⁻¹ as the nodes' inverse masses.
    fn solve_velocities(&mut self) -> Result<(), StepFailure> {
        let (t, n) = (self.t, self.rod.nodes());
        let kick = self.kick_time();
        let need_w = self.integrator != Integrator::Explicit;
        let driven = if self.driven_top.is_some() { n - 1 } else { usize::MAX };
        for i in 0..n {
            let m = self.rod.mass[i];
            let v = self.rod.v[i];
            let f = self.ws.force[i];
            let r = self.ws.rhs[i];
            let b = [m * v[0] + kick * f[0] + r[0], m * v[1] + kick * f[1] + r[1], m * v[2] + kick * f[2] + r[2]];
            let a = &self.ws.amat[i];
            self.ws.contact[i] = NodeContact::Free;
            if i == driven {
                // v_z imposed: A_xy v_xy = b_xy − A_{xy,z} v_z
                let vz = -self.driven_top.unwrap_or(0.0);
                let wi = sym_inverse_xy(a).ok_or(StepFailure::SingularTopNode)?;
                let (bx, by) = (b[0] - a[4] * vz, b[1] - a[5] * vz);
                self.rod.v[i] = [wi[0] * bx + wi[3] * by, wi[3] * bx + wi[1] * by, vz];
                if need_w {
                    self.ws.winv[i] = wi;
                }
                continue;
            }
            let ai = if a[3] == 0.0 && a[4] == 0.0 && a[5] == 0.0 {
                // no coupling term on this node (outside the drag zone): diagonal
                [1.0 / a[0], 1.0 / a[1], 1.0 / a[2], 0.0, 0.0, 0.0]
            } else {
                sym_inverse(a).ok_or(StepFailure::SingularNode { node: i, t })?
            };
            self.rod.v[i] = super::forces::sym_mul(&ai, &b);
            if need_w {
                self.ws.winv[i] = ai;
            }
        }
        for &i in &self.clamped {
            self.rod.v[i] = self.clamp_velocity;
            self.ws.winv[i] = [0.0; 6];
        }
        Ok(())
    }

    /// `implicit_bending`, after the node-wise predictor and the contact impulses (steps
    /// 2-3): the velocities again, with the bending linearly implicit (one backward-Euler
    /// Newton step, F_b(x') ≈ F_b(x) − H (x' − x), x' − x = Δt v'):
    /// (A + Δt² H) v' = m v + Δt F + r + J,
    /// H the Gauss-Newton bending Hessian ([`super::forces::add_bending_gauss_newton`]),
    /// A the node matrices (mass and the implicit node terms), J = A (v_c − v_p) the
    /// impulses steps 2-3 gave each node (v_p predicted, v_c after contact: friction of a
    /// sliding node, fibre contact). Held unknowns are Dirichlet rows: every component of
    /// a clamped or sticking node, v_z of the driven top and of a node on the belt. One
    /// banded Cholesky solve, half-bandwidth 8 (O(N)). The contact state is decided node by
    /// node on the predictor (explicit bending force), as in the other projection schemes;
    /// a node the implicit velocities take below the belt joins the contact set in the
    /// projection (step 5).
    fn solve_implicit_bending(&mut self) -> Result<(), StepFailure> {
        let (dt, n) = (self.dt, self.rod.nodes());
        let clamped = self.clamped.len();
        let held = |ws: &Workspace, i: usize| i < clamped || ws.contact[i] == NodeContact::Stick;
        // the nodes before the first free one are held: the system starts two before it
        // (those two held too, as Dirichlet rows carrying the bending coupling)
        let free_from = (0..n).find(|&i| !held(&self.ws, i)).unwrap_or(n);
        let first = free_from.saturating_sub(2);
        if first < self.ws.bend_first {
            // a node before the assembled window came loose in this step
            self.assemble_implicit_bending(first);
        }
        let first = self.ws.bend_first;
        let nd = 3 * (n - first);
        let ws = &mut self.ws;
        ws.bend_k.clone_from(&ws.bend_h);
        ws.bend_b.clear();
        ws.bend_b.resize(nd, 0.0);
        for i in first..n {
            let a = ws.amat[i];
            let k = 3 * (i - first);
            ws.bend_k.add(k, k, a[0]);
            ws.bend_k.add(k + 1, k + 1, a[1]);
            ws.bend_k.add(k + 2, k + 2, a[2]);
            ws.bend_k.add(k + 1, k, a[3]);
            ws.bend_k.add(k + 2, k, a[4]);
            ws.bend_k.add(k + 2, k + 1, a[5]);
            let (m, v0, f, r) = (self.rod.mass[i], ws.v_start[i], ws.force[i], ws.rhs[i]);
            let (vc, vp) = (self.rod.v[i], ws.v_pred[i]);
            let j = sym_mul(&a, &[vc[0] - vp[0], vc[1] - vp[1], vc[2] - vp[2]]);
            for c in 0..3 {
                ws.bend_b[k + c] = m * v0[c] + dt * f[c] + r[c] + j[c];
            }
        }
        // Dirichlet rows
        let driven = if self.driven_top.is_some() { n - 1 } else { usize::MAX };
        for i in first..n {
            let v = self.rod.v[i];
            let k = 3 * (i - first);
            let fixed: &[usize] = if i < clamped || ws.contact[i] == NodeContact::Stick {
                &[0, 1, 2]
            } else if i == driven || ws.contact[i] == NodeContact::Slide {
                &[2]
            } else {
                &[]
            };
            for &c in fixed {
                ws.bend_k.fix(k + c, v[c], &mut ws.bend_b);
            }
        }
        if let Err(e) = ws.bend_k.cholesky() {
            return Err(StepFailure::BendingSystem { t: self.t + dt, dt, node: first + e.row / 3, pivot: e.pivot });
        }
        ws.bend_k.solve_factored(&mut ws.bend_b);
        for i in first..n {
            let k = 3 * (i - first);
            self.rod.v[i] = [ws.bend_b[k], ws.bend_b[k + 1], ws.bend_b[k + 2]];
        }
        // Δt² H v' per node, for the reactions (zero before the window: held nodes moving
        // with the belt, a rigid translation that H does not see)
        ws.bend_h.mul(self.rod.v[first..].as_flattened(), &mut ws.bend_b);
        ws.bend_impl.clear();
        ws.bend_impl.resize(first, [0.0; 3]);
        ws.bend_impl.extend(ws.bend_b.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        ws.bend_first = free_from.saturating_sub(2);
        Ok(())
    }

    /// Δt² H of the nodes `first`.. into `ws.bend_h` (`Self::solve_implicit_bending`).
    fn assemble_implicit_bending(&mut self, first: usize) {
        use super::forces::{add_bending_gauss_newton, BENDING_BAND};
        let (dt, n) = (self.dt, self.rod.nodes());
        let first = first.min(n - 1);
        let ws = &mut self.ws;
        ws.bend_first = first;
        ws.bend_h.reset(3 * (n - first), BENDING_BAND);
        add_bending_gauss_newton(&self.rod, &ws.tangent, &ws.seg_len, first, dt * dt, &mut ws.bend_h);
    }

    /// The contact predictor of `implicit_bending`: one Jacobi sweep of the implicit
    /// system from the start-of-step velocities, node by node,
    /// (A_i + Δt² H_ii) v_i = m v + Δt F + r − Σ_{j≠i} Δt² H_ij v_j, over the assembled
    /// nodes (not the clamped ones and the driven top, whose velocities step 2 set). The
    /// node-wise explicit predictor would push a node by Δt F_b/m, far more than the
    /// implicit step moves it once Δt is beyond the bending limit, and the belt would
    /// then book a normal (and Coulomb friction) impulse that is not there.
    fn predict_implicit_bending(&mut self) {
        let (dt, n) = (self.dt, self.rod.nodes());
        let first = self.ws.bend_first;
        let last = if self.driven_top.is_some() { n - 1 } else { n };
        let ws = &self.ws;
        let h = &ws.bend_h;
        for i in first.max(self.clamped.len())..last {
            let li = 3 * (i - first);
            let (m, v0, f, r) = (self.rod.mass[i], ws.v_start[i], ws.force[i], ws.rhs[i]);
            let mut b = [m * v0[0] + dt * f[0] + r[0], m * v0[1] + dt * f[1] + r[1], m * v0[2] + dt * f[2] + r[2]];
            for j in i.saturating_sub(2).max(first)..(i + 3).min(n) {
                if j == i {
                    continue;
                }
                let (lj, vj) = (3 * (j - first), ws.v_start[j]);
                for (rr, br) in b.iter_mut().enumerate() {
                    *br -= h.get(li + rr, lj) * vj[0] + h.get(li + rr, lj + 1) * vj[1] + h.get(li + rr, lj + 2) * vj[2];
                }
            }
            let a = ws.amat[i];
            let k = [
                a[0] + h.get(li, li),
                a[1] + h.get(li + 1, li + 1),
                a[2] + h.get(li + 2, li + 2),
                a[3] + h.get(li + 1, li),
                a[4] + h.get(li + 2, li),
                a[5] + h.get(li + 2, li + 1),
            ];
            if let Some(ki) = sym_inverse(&k) {
                self.rod.v[i] = sym_mul(&ki, &b);
            }
        }
    }

    /// Constraint projection of the segment lengths, XPBD form solved exactly:
    /// C_k = |e_k| − l_k, compliance α̃_k = l_k/(EA Δt²) (`ImplicitAxial`, i.e. backward
    /// Euler on the axial springs) or 0 (`Inextensible`). Newton iterations
    /// (J W Jᵀ + α̃) Δλ = −C − α̃ λ, Δx_j = W_j (Δλ_{j−1} t_{j−1} − Δλ_j t_j), each one
    /// symmetric tridiagonal solve (Thomas algorithm, O(N)). Segments whose both ends
    /// are held (laid fibre stuck to the belt) cannot change and split the chain into
    /// independent runs, solved one by one.
    fn project(&mut self) -> Result<(), StepFailure> {
        self.projection_calls += 1;
        let ns = self.rod.rest.len();
        let held = |w: &[f64; 6]| w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0;
        let mut residual = 0.0f64;
        let mut worst = (0.0f64, 0usize);
        let mut k = 0;
        while k < ns {
            if held(&self.ws.winv[k]) && held(&self.ws.winv[k + 1]) {
                k += 1;
                continue;
            }
            let a = k;
            while k < ns && !(held(&self.ws.winv[k]) && held(&self.ws.winv[k + 1])) {
                k += 1;
            }
            let (r, iters, wk) = project_run(
                &mut self.rod,
                &mut self.ws,
                &self.segment_force,
                a,
                k,
                self.compliance,
                self.dt,
                self.axial_theta,
                self.work_ledger,
            );
            self.projection_iterations += iters;
            residual = residual.max(r);
            if r > worst.0 {
                worst = (r, wk);
            }
        }
        self.projection_residual = self.projection_residual.max(residual);
        // multiplier λ_k > 0 pushes the segment ends apart: compression P_k = λ_k/Δt²
        let idt2 = 1.0 / (self.dt * self.dt);
        let ws = &self.ws;
        let trapezoid = self.axial_theta < 1.0 && self.compliance > 0.0;
        if trapezoid {
            // end-of-step spring forces, the P_old of the next step
            spring_forces(&self.rod, self.compliance, &mut self.segment_force);
        } else {
            for k in 0..ns {
                self.segment_force[k] = ws.lambda_acc[k] * idt2;
            }
        }
        let mut pmax = 0.0f64;
        for k in 0..ns {
            // buckling needs a free span: segments touching the belt do not count
            if ws.contact[k] == NodeContact::Free && ws.contact[k + 1] == NodeContact::Free {
                pmax = pmax.max(self.segment_force[k]);
            }
        }
        self.max_compression = self.max_compression.max(pmax);
        if !(residual < 1e-4) {
            let wk = worst.1;
            let c = |i: usize| format!("{:?} z={:.2e}", ws.contact[i], self.rod.x[i][2]);
            return Err(StepFailure::Projection { t: self.t + self.dt, dt: self.dt, residual, segment: wk, from: c(wk), to: c(wk + 1) });
        }
        Ok(())
    }
}

/// Where [`Simulator::predict_velocities`] puts the velocities and the inverse node
/// matrices W of the step before the belt acts.
pub type BeforeBelt<'a> = (&'a mut Vec<[f64; 3]>, &'a mut Vec<[f64; 6]>);

/// The spring force P_k = EA (l0_k − l_k)/l0_k of every segment at the current positions
/// (`inv_ea` = 1/EA), [`SPRING_LANES`] segments at a time (their square roots and
/// divisions vectorise).
fn spring_forces(rod: &Rod, inv_ea: f64, p: &mut [f64]) {
    crate::simd::widest_isa!(
        generic: spring_forces_lanes(rod, inv_ea, p),
        avx2: spring_forces_avx2(rod, inv_ea, p),
        avx512: spring_forces_avx512(rod, inv_ea, p),
    )
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn spring_forces_avx512(rod: &Rod, inv_ea: f64, p: &mut [f64]) {
    spring_forces_lanes(rod, inv_ea, p)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn spring_forces_avx2(rod: &Rod, inv_ea: f64, p: &mut [f64]) {
    spring_forces_lanes(rod, inv_ea, p)
}

const SPRING_LANES: usize = 8;

#[inline(always)]
fn spring_forces_lanes(rod: &Rod, inv_ea: f64, p: &mut [f64]) {
    let ns = rod.rest.len();
    for first in (0..ns).step_by(SPRING_LANES) {
        let m = SPRING_LANES.min(ns - first);
        let (mut l2, mut l0) = ([0.0; SPRING_LANES], [1.0; SPRING_LANES]);
        for j in 0..m {
            let (x0, x1) = (rod.x[first + j], rod.x[first + j + 1]);
            l2[j] = (x1[0] - x0[0]).powi(2) + (x1[1] - x0[1]).powi(2) + (x1[2] - x0[2]).powi(2);
            l0[j] = rod.rest[first + j];
        }
        let mut f = [0.0; SPRING_LANES];
        for j in 0..SPRING_LANES {
            f[j] = (l0[j] - l2[j].sqrt()) / (l0[j] * inv_ea);
        }
        p[first..first + m].copy_from_slice(&f[..m]);
    }
}

/// The unit tangent t_k (`ws.seg_e`) and the constraint value −C_k (`ws.cons`, see
/// [`project_run`]) of segments k in `range`, [`SPRING_LANES`] segments at a time (their
/// square roots and divisions vectorise; the same IEEE operations as one at a time).
fn segment_constraints(rod: &Rod, ws: &mut Workspace, p_old: &[f64], range: std::ops::Range<usize>, compliance: f64, old_weight: f64) {
    crate::simd::widest_isa!(
        generic: segment_constraints_lanes(rod, ws, p_old, range, compliance, old_weight),
        avx2: segment_constraints_avx2(rod, ws, p_old, range, compliance, old_weight),
        avx512: segment_constraints_avx512(rod, ws, p_old, range, compliance, old_weight),
    )
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn segment_constraints_avx512(rod: &Rod, ws: &mut Workspace, p_old: &[f64], range: std::ops::Range<usize>, compliance: f64, old_weight: f64) {
    segment_constraints_lanes(rod, ws, p_old, range, compliance, old_weight)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn segment_constraints_avx2(rod: &Rod, ws: &mut Workspace, p_old: &[f64], range: std::ops::Range<usize>, compliance: f64, old_weight: f64) {
    segment_constraints_lanes(rod, ws, p_old, range, compliance, old_weight)
}

#[inline(always)]
fn segment_constraints_lanes(rod: &Rod, ws: &mut Workspace, p_old: &[f64], range: std::ops::Range<usize>, compliance: f64, old_weight: f64) {
    let end = range.end;
    for first in range.step_by(SPRING_LANES) {
        let m = SPRING_LANES.min(end - first);
        let (mut e, mut l2) = ([[0.0; 3]; SPRING_LANES], [1.0; SPRING_LANES]);
        for j in 0..m {
            let (p, q) = (rod.x[first + j], rod.x[first + j + 1]);
            e[j] = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            l2[j] = e[j][0] * e[j][0] + e[j][1] * e[j][1] + e[j][2] * e[j][2];
        }
        let (mut l, mut il) = ([0.0; SPRING_LANES], [0.0; SPRING_LANES]);
        for j in 0..SPRING_LANES {
            l[j] = l2[j].sqrt();
            il[j] = 1.0 / l[j];
        }
        for j in 0..m {
            let k = first + j;
            let l0 = rod.rest[k];
            ws.seg_e[k] = [e[j][0] * il[j], e[j][1] * il[j], e[j][2] * il[j]];
            ws.cons[k] = -(l[j] - l0 + compliance * l0 * ws.lambda_acc[k] - old_weight * l0 * p_old[k]);
        }
    }
}

/// Newton iterations of the length projection on segments a..b (nodes a..=b), which
/// are coupled to no other segment. Returns (relative residual, iterations, worst segment).
///
/// θ-method on the axial springs: the force applied over the step is λ/Δt² =
/// θ P_new + (1 − θ) P_old with P = EA (l0 − l)/l0, hence the constraint
/// l − l0 + (l0/(EA θ Δt²)) λ − (1 − θ)/θ · (l0/EA) P_old = 0.
/// `book_lambda_e`: add λ_k t_k to `ws.lambda_e` (the work ledger's reactions read it).
#[allow(clippy::too_many_arguments)]
fn project_run(
    rod: &mut Rod,
    ws: &mut Workspace,
    p_old: &[f64],
    a: usize,
    b: usize,
    inv_ea: f64,
    dt: f64,
    theta: f64,
    book_lambda_e: bool,
) -> (f64, u64, usize) {
    let compliance = inv_ea / (theta * dt * dt);
    let old_weight = inv_ea * (1.0 - theta) / theta;
    let wref = rod.max_inv_mass;
    let l0min = rod.min_rest;
    let drop_tol = 1e-12 * wref;
    let mut residual = 0.0f64;
    let mut worst = a;
    let mut iterations = 0;
    for iter in 0..=PROJECTION_MAX_ITERS {
        residual = 0.0;
        // bound = (1 − 4ε) residual: |C_k| ≤ bound l0_k cannot make |C_k|/l0_k exceed
        // the residual, so most segments skip the division
        let mut bound = 0.0;
        segment_constraints(rod, ws, p_old, a..b, compliance, old_weight);
        for k in a..b {
            let (c, l0) = (ws.cons[k], rod.rest[k]);
            if !(c.abs() <= bound * l0) {
                let r = c.abs() / l0;
                if r > residual {
                    residual = r;
                    worst = k;
                    bound = residual * (1.0 - 4.0 * f64::EPSILON);
                }
            }
        }
        if residual < PROJECTION_TOL || iter == PROJECTION_MAX_ITERS {
            break;
        }
        iterations += 1;
        // fused: W t products, tridiagonal entries and the Thomas forward sweep
        ws.we_next[a] = sym_mul(&ws.winv[a], &ws.seg_e[a]);
        let mut cprev = 0.0; // c'_{k-1}
        let mut lprev = 0.0; // d'_{k-1}
        let mut off_prev = 0.0; // off_{k-1}
        for k in a..b {
            let e = ws.seg_e[k];
            let wb = &ws.winv[k + 1];
            let bb = sym_mul(wb, &e);
            ws.we_prev[k + 1] = bb;
            let aa = ws.we_next[k];
            let mut d = e[0] * (aa[0] + bb[0]) + e[1] * (aa[1] + bb[1]) + e[2] * (aa[2] + bb[2]);
            let mut off = if k + 1 < b {
                let c = sym_mul(wb, &ws.seg_e[k + 1]);
                ws.we_next[k + 1] = c;
                -(e[0] * c[0] + e[1] * c[1] + e[2] * c[2])
            } else {
                0.0
            };
            let mut rhs = ws.cons[k];
            let mut lower = off_prev;
            if d <= drop_tol {
                // a segment that cannot change length (both ends fixed along it)
                d = 1.0;
                rhs = 0.0;
                off = 0.0;
                lower = 0.0;
            } else {
                d += compliance * rod.rest[k];
            }
            let inv = 1.0 / (d - lower * cprev);
            cprev = off * inv;
            lprev = (rhs - lower * lprev) * inv;
            ws.cprime[k] = cprev;
            ws.lambda[k] = lprev;
            off_prev = off;
        }
        // back substitution fused with the position update of node k + 1
        let mut lnext = 0.0; // λ_{k+1}
        let mut dmax2 = 0.0f64;
        for k in (a..b).rev() {
            let l = ws.lambda[k] - ws.cprime[k] * lnext;
            ws.lambda[k] = l;
            ws.lambda_acc[k] += l;
            if book_lambda_e {
                let (e, s) = (ws.seg_e[k], &mut ws.lambda_e[k]);
                s[0] += l * e[0];
                s[1] += l * e[1];
                s[2] += l * e[2];
            }
            // node k+1: Δx = W (λ_k t_k − λ_{k+1} t_{k+1})
            let wp = ws.we_prev[k + 1];
            let d = if k + 1 < b {
                let wn = ws.we_next[k + 1];
                [l * wp[0] - lnext * wn[0], l * wp[1] - lnext * wn[1], l * wp[2] - lnext * wn[2]]
            } else {
                [l * wp[0], l * wp[1], l * wp[2]]
            };
            let x = &mut rod.x[k + 1];
            x[0] += d[0];
            x[1] += d[1];
            x[2] += d[2];
            dmax2 = dmax2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            lnext = l;
        }
        let wn = ws.we_next[a];
        let d = [-lnext * wn[0], -lnext * wn[1], -lnext * wn[2]];
        let x = &mut rod.x[a];
        x[0] += d[0];
        x[1] += d[1];
        x[2] += d[2];
        dmax2 = dmax2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        // The constraints are linear in λ and the solve is exact, so what is left after
        // this update is the curvature of |e|: at most 2 max|Δx|²/l² (relative).
        let estimate = 2.0 * dmax2 / (l0min * l0min);
        if estimate < PROJECTION_TOL {
            residual = estimate;
            break;
        }
    }
    (residual, iterations, worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rod::scene::{prepared_simulator, replicate_rng};
    use crate::rod::LaydownParams;

    /// A step that repeats its length projection (nodes came out below the belt) applies
    /// its axial impulse once: the impulse the iterations applied to each segment, summed
    /// over every projection of the step (Σ Δλ t, which the work ledger books), is the
    /// step's multiplier λ_k along the segment, the impulse the compliance term of its
    /// constraint counts, on every segment off the belt (up to the turn of t over the
    /// iterations and projections: at most 1.6 % of the largest multiplier over these 50
    /// steps; 5 % allowed). When each repeat cleared λ, the repeat re-solved every
    /// compliant segment from λ = 0 and applied a second impulse that λ no longer held (the
    /// first repeat here then differed by as much as the largest multiplier).
    #[test]
    fn a_repeated_projection_applies_the_step_impulse_once() {
        let p = LaydownParams { length: 0.1, elements: 100, ..LaydownParams::default() };
        let mut sim = prepared_simulator(&p, &mut replicate_rng(1, 0), 0.0);
        assert!(sim.work_ledger && sim.integrator == Integrator::TrapezoidalAxial);
        let mut control = StepControl::new(sim.limits.chosen, p.mass_per_length());
        let mut repeats = 0;
        while repeats < 50 && sim.t < 0.05 {
            let (calls, rejected) = (sim.projection_calls, control.rejected);
            control.advance(&mut sim, f64::INFINITY).unwrap();
            if sim.projection_calls - calls < 2 || control.rejected != rejected {
                continue;
            }
            repeats += 1;
            let ws = &sim.ws;
            let (mut largest, mut unheld) = (0.0f64, 0.0f64);
            // segments off the belt (a node clipped between the projections turns its
            // segments by more than the iterations do)
            for k in (0..sim.rod.rest.len()).filter(|&k| ws.contact[k] == NodeContact::Free && ws.contact[k + 1] == NodeContact::Free) {
                let along = crate::geometry::dot(&ws.lambda_e[k], &ws.seg_e[k]);
                largest = largest.max(ws.lambda_acc[k].abs());
                unheld = unheld.max((along - ws.lambda_acc[k]).abs());
            }
            assert!(largest > 0.0 && unheld < 0.05 * largest, "t = {:.4e}: an applied impulse differs from the step's multiplier by {unheld:.3e}, the largest multiplier is {largest:.3e}", sim.t);
        }
        assert!(repeats >= 10, "only {repeats} steps repeated their projection");
    }
}
