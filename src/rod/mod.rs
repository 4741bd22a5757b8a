//! Rod physics shared by the stages that lay fibres (`laydown`, `laid_web`): a
//! discrete elastic rod fed onto a moving belt, after Battocchio & Sutcliffe,
//! "Modelling fibre laydown and web uniformity in nonwoven fabric", §2 (eqs 1-8,
//! Table 1). Pure library: no I/O, no pipeline.
//!
//! Layout: [`state`] (nodes, masses, workspace), [`forces`] (one opt-in [`forces::Term`]
//! per effect: elasticity, gravity, drag, oscillation, damping), [`contact`] (belt
//! plane, Coulomb friction), [`integrator`] (time steppers and their step control),
//! [`recovery`] (a run whose step failed rolled back to a checkpoint and retaken),
//! [`params`] (the scene's parameter table), [`replicate`] (one replicate by either start, batches of them), [`air`] (the opt-in air field near the belt), [`scene`] (the paper's single-fibre scene),
//! [`feed`] (continuous feed: a fibre of any length fed through the laydown zone, the
//! stuck part frozen), [`twist`] (opt-in rod twist), [`fibre_contact`] and [`contact_world`] (opt-in contact between
//! fibres: narrow and broad phase), [`metrics`] (S and e of the laid fibre).
//!
//! # Conventions
//! SI units. x = machine direction (the belt moves along +x at `belt_speed`),
//! y = cross direction (the imposed oscillation u0 sin ωt is along y), z up, belt
//! plane z = 0. (The paper's belt moves along its y axis.)
//!
//! # Model
//! A rod of length L and N = `elements` segments starts vertical with its bottom node
//! on the belt, every node moving down at `fibre_speed`; the top node is driven
//! kinematically at v_z = −v_f (x, y free) and the run ends when it reaches z0 =
//! `laydown_height` (0.19 s for Table 1). Effects are opt-in ([`Effects`]); each enabled
//! one is a separate term built once:
//! - elasticity: discrete elastic rod, axial springs EA (explicit scheme) and bending EI
//!   with the curvature-binormal energy (2EI/V_i)(1 − cos φ)/(1 + cos φ) at interior nodes
//!   (geometrically exact, large rotations);
//! - twist (opt-in, [`twist`]): quasistatic discrete-elastic-rod twist, GJ = EI/(1 + ν).
//!   With a feed free to spin it vanishes (the paper's model, and the default); with
//!   `feed_end: clamped` the coiling twists the hanging fibre between the spinneret and
//!   the laid fibre, and the twist acts back on the centreline;
//! - gravity;
//! - drag in 0 ≤ z ≤ z0 with air moving down at `air_speed`: tangential eqs 1-2
//!   (C_t = β Re^-0.61, β = 0.37 after Matsui 1976, C_f = 0.37 Re^-0.61) and normal
//!   eqs 3-4 (C_n = 6.96 Re^-0.44 (d/78 µm)^0.404) applied along the normal relative
//!   velocity (frame invariant for a round fibre; see [`forces::Drag`]). The air is
//!   uniform by default; `air_field` = `impinging` / `impinging_slot` turns the part of
//!   it the belt does not pass (1 − `belt_permeability`) sideways near the belt over
//!   `stagnation_height` (stagnation-point flow of a round or slot jet, [`air`]), the
//!   drag then taking the air velocity at each element's midpoint;
//! - oscillation: eq 7 spring-damper (k, c per node) from every node above z0 to the
//!   dummy point (0, u0 sin ωt), implicit so c/m ≈ 5·10⁵ 1/s never limits the step;
//! - contact with the belt plane and Coulomb friction (stick and slip) as velocity
//!   impulses ([`contact`]);
//! - Rayleigh mass damping α_R; initial x/y imperfections N(0, σ) drawn from the
//!   caller's RNG.
//!
//! # Start ([`Start`])
//! `vertical` (default) is the scene above. `fed` lays the same replicate as a
//! continuous feed (`feed::simulate_fed`): the fibre enters a short buffer above z0 at
//! v_f, and laid nodes that stayed put while 0.1 m was fed are frozen. The element
//! length, end time and laid length are the same. S and e agree with the vertical
//! start's within statistical error, at 0.55× its cost at the baseline and 0.26× at
//! 50 m/s (`pipelines/studies/FIBRE_SPEED.md`, which also records where validity differs).
//!
//! # Integrators ([`Integrator`], formulas in [`integrator`])
//! - `explicit` (reference): extensible rod, symplectic Euler, fixed
//!   Δt = factor·2/√(ω_a² + ω_b²) with ω_a = 2√(E/ρ)/Δs, ω_b = (4/Δs²)√(EI/ρA):
//!   ≈ factor × 0.69 µs at Δs = 1 mm.
//! - `trapezoidal_axial` (default, fast): axial springs by the trapezoidal rule through
//!   a compliant length projection (XPBD form solved exactly, one O(N) tridiagonal solve
//!   per Newton iteration); bending explicit; adaptive
//!   Δt ≤ factor·(Δs²/2)√(ρA/EI) ≈ factor × 27.6 µs at Δs = 1 mm, d = 50 µm, reduced
//!   while a compressed free span could buckle faster than the step.
//! - `implicit_axial`: the same with backward Euler on the axial springs (damps the
//!   axial waves: e about 6 % above the reference).
//! - `inextensible`: the same with zero compliance.
//! - `implicit_bending` (opt-in, issue 15): bending linearly implicit, one backward-Euler
//!   Newton step with the Gauss-Newton bending Hessian per step ((A + Δt² H) v' = b, a
//!   banded Cholesky solve of 3(N + 1) unknowns, half-bandwidth 8, [`banded`]), axial
//!   springs by backward Euler in the projection; held nodes (sticking, on the belt,
//!   driven top, clamps) are Dirichlet rows. No elastic step limit:
//!   Δt ≤ factor·`implicit_step_travel`·Δs/v_max and the buckling limit. Dissipative
//!   (backward Euler): e reads low at large steps (see `pipelines/paper/LAYDOWN_MEASUREMENTS.md`).
//!
//! All keep Δt ≤ factor·Δs/(4 v_max) (v_max: feed, belt, ωu0). `coil_resolution` raises N when the inertial
//! coil scale √(EI/ρA v_f²) (3.6 mm at the baseline, ten times smaller at 50 m/s) would
//! be resolved by fewer than that many elements. `coil_step` (opt-in) bounds Δt by
//! factor·`coil_step`·ℓ_c/v_f: at the coil-resolved mesh the limits above allow 0.1 ℓ_c/v_f,
//! where S and e are not converged in the step (0.04 leaves Table 1 unchanged;
//! `pipelines/studies/FIBRE_SPEED.md`, "Where the step error comes from").
//!
//! # Validity and failures
//! The paper rejects about 10 % of its runs because "portions of fibre were out of
//! plane" in the final profile after impacts. By default (`bounce_check` = `final`) a
//! replicate is invalid when a landed node is more than `bounce_tolerance` (1 mm = 20 d
//! = one element at the baseline) above the belt in the final profile, the one S and e
//! are measured on. `bounce_check` = `transient` applies the tolerance to the highest
//! rise of a landed node at any time after its landing
//! ([`LaydownResult::max_lift_after_landing`]; per node in [`LaydownResult::lift`] and
//! [`LaydownResult::lift_time`]). `bounce_check` = `last_period` applies the paper's test
//! after every step of the last oscillation period and invalidates the replicate when it
//! fails for more than half of that time ([`LaydownResult::lifted_fraction`];
//! [`lift_watch`]): at 50 m/s arches behind the touchdown rise and settle in step with the
//! sweep, so the final profile reads the sweep's phase at the end.
//!
//! Why the final profile, measured: `pipelines/paper/LAYDOWN_MEASUREMENTS.md` ("Which
//! bounce test"). A step that cannot be taken (non-finite state, node faster than
//! 50 v_ref + 10 m/s, belt penetration beyond `penetration_tolerance`, explicit strain
//! above 50 %, projection not converging even at 10⁻⁴ of the step) ends the replicate with
//! [`LaydownResult::error`] set; positions are then the last good state, never NaN.
//!
//! # Metrics
//! S (eq 5) and e (eq 6, via [`crate::geometry`]) are computed on the laid nodes (finite
//! landing time) projected on the belt plane, in fibre order, and again with the belt
//! motion removed as `belt_removal` says ([`metrics::BeltRemoval`]): the travel since
//! each node landed (the paper's reading, default; its e grows with refinement) or
//! since it was fed (converges with the mesh).
//!
//! # Use
//! ```no_run
//! use laydown::rod::{simulate, replicate_rng, run_jobs, LaydownJob, LaydownParams};
//! let p = LaydownParams::default(); // Table 1 baseline, all effects, trapezoidal_axial
//! p.validate().unwrap();
//! let r = simulate(&p, &mut replicate_rng(2024, 0));
//! println!("S = {} m, e = {}, valid = {}", r.radius_of_gyration, r.bending_energy, r.valid);
//! let jobs: Vec<_> = (0..10).map(|k| LaydownJob { params: p.clone(), seed: 2024, replicate: k }).collect();
//! let results = run_jobs(&jobs); // rayon; identical for any thread count
//! ```
//!

// NaN-safe checks are written as negated comparisons on purpose (`!(x < limit)`).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod air;
pub mod banded;
pub mod contact;
pub mod contact_world;
pub mod feed;
pub mod fibre_contact;
pub mod forces;
pub mod integrator;
pub mod lift_watch;
pub mod metrics;
pub mod params;
pub mod recovery;
pub mod replicate;
pub mod scene;
pub mod state;
pub mod twist;

#[cfg(test)]
mod energy_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
pub(crate) mod test_support;

pub use lift_watch::LiftWatch;
pub use integrator::{stable_time_step, EnergySample, Simulator, Snapshot, StepControl, TimeStepLimits, Work};
pub use metrics::{laid_polyline, shape_measures, BeltMotion, BeltRemoval, LaydownResult};
pub use params::{parameter_table_markdown, AirField, BounceCheck, Effects, FeedEnd, Integrator, LaydownParams, ParamError, Start, PARAMETERS};
pub use replicate::{run_jobs, simulate, LaydownJob};
pub use scene::{prepared_simulator, replicate_rng};
