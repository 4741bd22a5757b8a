//! Building a replicate from the parameters, running it, and batches of replicates.

use super::air::{AirField, ImpingingAir, JetShape};
use super::contact::BeltContact;
use super::forces::{Drag, DragLaw, Oscillation, Term};
use super::integrator::{stable_time_step, Simulator, StepControl, Work};
use super::recovery::Recovery;
use super::metrics::{bounce_reason, laid_polyline, shape_measures, BeltMotion, LaydownResult};
use super::params::{FeedEnd, Integrator, LaydownParams, CONVERGED_COIL_STEP};
use crate::params::ParamCaution;
use super::twist::Twist;
use super::state::{Rod, Workspace};
use crate::geometry::arc_length;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::time::Instant;

/// Initial configuration other than the paper's falling vertical fibre (used by the
/// verification tests: cantilever, falling fibres).
#[derive(Clone, Debug)]
pub(crate) struct CustomStart {
    pub positions: Vec<[f64; 3]>,
    pub velocities: Vec<[f64; 3]>,
    /// Drive the top (last) node at v_z = −fibre_speed.
    pub driven_top: bool,
    /// Number of leading nodes held fixed (2 = clamped end).
    pub clamped: usize,
    /// Rest length of every segment; `None`: the paper's L/N with a driven top, else
    /// the distances between the given positions.
    pub rest_length: Option<f64>,
}

/// The paper's start: vertical fibre, bottom node on the belt, top at z = L, every node
/// moving down at v_f, x/y imperfections drawn node by node (x then y) from `rng`.
pub(crate) fn paper_start<R: Rng + ?Sized>(p: &LaydownParams, elements: usize, rng: &mut R) -> CustomStart {
    let ds = p.length / elements as f64;
    let mut positions: Vec<[f64; 3]> = (0..=elements).map(|i| [0.0, 0.0, i as f64 * ds]).collect();
    if p.effects.imperfections && p.imperfection_std > 0.0 {
        let normal = Normal::new(0.0, p.imperfection_std).expect("validated std");
        for x in positions.iter_mut() {
            x[0] = normal.sample(rng);
            x[1] = normal.sample(rng);
        }
    }
    positions[elements][2] = p.length;
    CustomStart { velocities: vec![[0.0, 0.0, -p.fibre_speed]; elements + 1], positions, driven_top: true, clamped: 0, rest_length: None }
}

/// The automatic time step of `p`'s scene for elements of `ds` (with `driven_top`, the
/// top node fed at v_f): the stable step of its integrator, limited by the largest
/// imposed speed (feed, belt, oscillation ω u0) and, with `coil_step`, by the coil time
/// ℓ_c/v_f. Shared by the scene's build and the
/// run-time estimates.
pub fn time_step_limits(p: &LaydownParams, ds: f64, driven_top: bool) -> super::integrator::TimeStepLimits {
    let e = &p.effects;
    let osc_speed = if e.oscillation { p.oscillation_speed() } else { 0.0 };
    let feed = if driven_top { p.fibre_speed } else { 0.0 };
    let belt = if e.contact { p.belt_speed } else { 0.0 };
    let max_speed = feed.max(belt).max(osc_speed);
    let mut limits = stable_time_step(
        p.integrator,
        ds,
        p.youngs_modulus,
        p.density,
        p.mass_per_length(),
        p.bending_stiffness(),
        max_speed,
        p.time_step_factor,
        e.elasticity,
    );
    if p.integrator == Integrator::ImplicitBending && e.elasticity && max_speed > 0.0 {
        // no elastic limit: a node at the largest imposed speed travels at most
        // implicit_step_travel elements a step
        limits.chosen = p.time_step_factor * p.implicit_step_travel * ds / max_speed;
    }
    if p.coil_step > 0.0 {
        // the coil-time limit: the step in units of the time one coil scale takes to feed
        limits.coil = p.coil_step * p.coil_time();
        limits.chosen = limits.chosen.min(p.time_step_factor * limits.coil);
    }
    limits
}

/// Step of the default scheme, as a fraction of the coil time ℓ_c/v_f, above which S and
/// e were measured off their step-converged values: 0.8 × [`CONVERGED_COIL_STEP`]. The
/// Table 1 baseline steps at 0.0305 and is converged.
pub const COARSE_COIL_STEP: f64 = 0.8 * CONVERGED_COIL_STEP;

/// The warning a scene of the default integrator draws when its time step at element
/// length `element_length` (fed at v_f) is coarser than [`COARSE_COIL_STEP`] of the coil
/// time ℓ_c/v_f: at the coil-resolved mesh (two elements per ℓ_c, 10 m/s and up, or thin
/// fibres) the step is 0.1 ℓ_c/v_f. Keyed at the fibre speed above 5 m/s, or at the
/// diameter below Table 1's 50 µm, where it was measured; a mesh chosen coarse at Table 1's
/// speed and diameter draws none (its step coarsens with it, and `mesh_error_estimate`
/// states the two together). None for the other integrators, or with `coil_step` at or
/// below the recommended [`CONVERGED_COIL_STEP`].
pub fn step_caution(p: &LaydownParams, element_length: f64) -> Option<ParamCaution> {
    let e = &p.effects;
    if p.integrator != Integrator::TrapezoidalAxial || !e.elasticity || !(p.fibre_speed > 0.0) {
        return None;
    }
    if p.coil_step > 0.0 && p.coil_step <= CONVERGED_COIL_STEP {
        return None;
    }
    let coil_time = p.coil_time();
    let fraction = time_step_limits(p, element_length, true).chosen / coil_time;
    if !(fraction > COARSE_COIL_STEP * (1.0 + 1e-9)) {
        return None;
    }
    let (key, written) = if p.fibre_speed > 5.0 {
        ("fibre_speed", format!("{} m/s", p.fibre_speed))
    } else if p.diameter < 50e-6 {
        ("diameter", format!("{} m", p.diameter))
    } else {
        return None;
    };
    Some(ParamCaution {
        key: key.into(),
        message: format!(
            "{written}: the time step of integrator trapezoidal_axial (the default) is {fraction:.3} of the inertial coil time l_c/v_f = {coil_time:.3e} s, \
             coarser than the {COARSE_COIL_STEP} at which S and e were measured converged (Table 1 steps at 0.031); at 0.1 (two elements per coil scale) e read \
             6-11 % low (5 m/s at d = 16.2 and 20 um, 10 m/s) and S 2-2.5 % high (30-50 m/s), while S at 5 m/s moved by less than 0.5 %; set coil_step: {CONVERGED_COIL_STEP} \
             (about three times the steps there) (pipelines/studies/FIBRE_SPEED.md, \"Where the step error comes from\")"
        ),
    })
}

/// Every caution of scene `p` laid in elements of `element_length`: the parameter
/// cautions ([`LaydownParams::cautions`]) and the step caution ([`step_caution`]). What the
/// laydown and laid_web stages report.
pub fn cautions(p: &LaydownParams, element_length: f64) -> Vec<ParamCaution> {
    let mut out = p.cautions();
    out.extend(step_caution(p, element_length));
    out
}

/// Assemble the simulator: only the enabled effects become terms.
pub(crate) fn build(p: &LaydownParams, start: CustomStart) -> Simulator {
    let n = start.positions.len();
    let rest: Vec<f64> = start.positions.windows(2).map(|w| crate::geometry::distance(&w[0], &w[1])).collect();
    // The paper's rest length is L/N; the 1 µm imperfections change it by ~1e-9 relative.
    let rest = match start.rest_length {
        Some(l) => vec![l; n - 1],
        None if start.driven_top => vec![p.length / (n - 1) as f64; n - 1],
        None => rest,
    };
    let ds = rest.iter().cloned().fold(f64::INFINITY, f64::min);
    let e = &p.effects;
    let mut terms = Vec::new();
    if e.elasticity {
        if p.integrator == Integrator::Explicit {
            terms.push(Term::Axial);
        }
        terms.push(Term::Bending);
    }
    if e.gravity && p.gravity > 0.0 {
        terms.push(Term::Gravity { g: p.gravity });
    }
    if e.drag {
        let jet = |shape| Some(ImpingingAir { air_speed: p.air_speed, permeability: p.belt_permeability, stagnation_height: p.stagnation_height, shape });
        let field = match p.air_field {
            AirField::Uniform => None,
            // φ = 1: the belt passes all the air, the uniform field (and its code)
            _ if p.belt_permeability >= 1.0 => None,
            AirField::Impinging => jet(JetShape::Round),
            AirField::ImpingingSlot => jet(JetShape::Slot),
        };
        terms.push(Term::Drag(Drag {
            law: DragLaw::new(p.diameter, p.air_density, p.air_kinematic_viscosity, p.tangential_drag_beta),
            air_velocity: [0.0, 0.0, -p.air_speed],
            field,
            zone_top: p.laydown_height,
        }));
    }
    if e.oscillation {
        terms.push(Term::Oscillation(Oscillation {
            amplitude: p.oscillation_amplitude,
            angular_frequency: p.angular_frequency(),
            phase: 0.0,
            stiffness: p.oscillation_stiffness,
            damping: p.oscillation_damping,
            zone_top: p.laydown_height,
            ramp_time: 0.0,
        }));
    }
    if e.damping && p.rayleigh_damping > 0.0 {
        terms.push(Term::Damping { alpha: p.rayleigh_damping });
    }
    let contact = e.contact.then(|| BeltContact {
        belt_speed: p.belt_speed,
        friction: e.friction.then_some(p.friction_coefficient),
    });
    let osc_speed = if e.oscillation { p.oscillation_speed() } else { 0.0 };
    let limits = time_step_limits(p, ds, start.driven_top);
    let v_ref = p.fibre_speed.max(p.air_speed).max(p.belt_speed).max(osc_speed).max(1.0);
    let top_start_z = start.positions[n - 1][2];
    let clamp_positions = start.positions[..start.clamped].to_vec();
    let rod = Rod::new(start.positions, start.velocities, rest, p.mass_per_length(), p.axial_stiffness(), p.bending_stiffness());
    // a feed free to spin leaves the hanging span a free end: no twist (super::twist)
    let twist = (e.twist && e.elasticity && p.feed_end == FeedEnd::Clamped).then(|| Twist::new(&rod, p.twist_stiffness(), p.diameter));
    Simulator {
        ws: Workspace::new(n),
        rod,
        terms,
        contact,
        integrator: p.integrator,
        dt: limits.chosen,
        limits,
        t: 0.0,
        driven_top: start.driven_top.then_some(p.fibre_speed),
        top_start_z,
        clamped: (0..start.clamped).collect(),
        clamp_positions,
        clamp_velocity: [0.0; 3],
        work: Work::default(),
        work_ledger: true,
        landing_time: vec![f64::NAN; n],
        max_lift: vec![0.0; n],
        lift_time: vec![f64::NAN; n],
        max_penetration: 0.0,
        penetration_tolerance: p.penetration_tolerance,
        speed_limit: 50.0 * v_ref + 10.0,
        steps: 0,
        projection_residual: 0.0,
        max_compression: 0.0,
        segment_force: vec![0.0; n - 1],
        projection_iterations: 0,
        projection_calls: 0,
        fibre_contact: None,
        twist,
        forces_for: None,
        previous_step: None,
        compliance: match p.integrator {
            Integrator::ImplicitAxial | Integrator::TrapezoidalAxial | Integrator::ImplicitBending => 1.0 / p.axial_stiffness(),
            _ => 0.0,
        },
        // implicit_bending: backward Euler on the axial springs too. With θ = ½ the axial
        // force rings from step to step at ω_aΔt ≫ 1 and its spurious compressions hold
        // the buckling step limit down (measured on the Table 1 baseline: 5 900 steps
        // against 1 500 with θ = 1)
        axial_theta: if p.integrator == Integrator::TrapezoidalAxial { 0.5 } else { 1.0 },
    }
}

/// Run one replicate of the paper's scene (`start: vertical`) with validated
/// parameters ([`super::replicate::simulate`] validates and chooses by the start).
/// Imperfections are drawn from `rng` (in practice a `ChaCha8Rng` per replicate, see
/// [`replicate_rng`]). Errors are reported in [`LaydownResult::error`].
pub(crate) fn simulate_vertical<R: Rng + ?Sized>(params: &LaydownParams, rng: &mut R) -> LaydownResult {
    let elements = params.resolved_elements();
    let start = paper_start(params, elements, rng);
    let mut sim = build(params, start);
    let mut result = run(&mut sim, params, params.end_time());
    result.warnings.extend(params.resolution_warning(elements));
    result
}

/// A simulator of the paper's scene advanced (adaptive stepping) to time `t`, with its
/// step reset to the largest allowed one: the state a bench times single steps on.
pub fn prepared_simulator<R: Rng + ?Sized>(params: &LaydownParams, rng: &mut R, t: f64) -> Simulator {
    let start = paper_start(params, params.resolved_elements(), rng);
    let mut sim = build(params, start);
    if t > 0.0 {
        let _ = run(&mut sim, params, t);
    }
    sim.dt = sim.limits.chosen;
    sim
}

/// Integrate `sim` up to `end_time` and assemble the result.
pub(crate) fn run(sim: &mut Simulator, p: &LaydownParams, end_time: f64) -> LaydownResult {
    let clock = Instant::now();
    let limits = sim.limits;
    let stride = p.diagnostic_stride.max(1) as u64;
    let mut diagnostics = vec![sim.energy_sample()];
    let mut watch = p.lift_watch_until(end_time);
    let mut last_good = sim.rod.x.clone();
    let mut error = None;
    let mut rejected = 0u64;
    let mut rollbacks = 0;
    let min_dt;
    if p.integrator == Integrator::Explicit {
        // fixed step, rounded so that the run ends exactly at end_time
        let steps = (end_time / sim.dt).ceil().max(1.0) as u64;
        sim.dt = end_time / steps as f64;
        min_dt = sim.dt;
        for s in 1..=steps {
            if let Err(f) = sim.step() {
                error = Some(f.to_string());
                break;
            }
            sim.observe_lift(watch.as_mut());
            if s % stride == 0 || s == steps {
                let sample = sim.energy_sample();
                let worst = sim
                    .rod
                    .rest
                    .iter()
                    .zip(&sim.ws.seg_len)
                    .map(|(l0, l)| ((l - l0) / l0).abs())
                    .fold(0.0, f64::max);
                if !(worst < 0.5) {
                    error = Some(format!("axial strain {worst:.3e} at t = {:.6e} s: the explicit step blew up", sim.t));
                    break;
                }
                diagnostics.push(sample);
                last_good.copy_from_slice(&sim.rod.x);
            }
        }
    } else {
        // adaptive step (see StepControl): dt <= dt_stable, growth <= 25 % per step,
        // dt <= 0.5/sigma, a failed step retaken at dt/4.
        // A step that fails even at the smallest size rolls the run back to a
        // checkpoint (with the energy samples recorded by then) and retakes the stretch
        // with the recovery scheme (super::recovery).
        let mut control = StepControl::new(limits.chosen, p.mass_per_length());
        let mut recovery = Recovery::new(sim, &control, p.rollbacks, (diagnostics.len(), watch));
        let tol = end_time * 1e-12;
        while sim.t < end_time - tol {
            if let Err(f) = control.advance(sim, end_time) {
                if let Some((samples, watched)) = recovery.roll_back(sim, &mut control) {
                    diagnostics.truncate(samples);
                    watch = watched;
                    continue;
                }
                error = Some(recovery.failure(&f));
                break;
            }
            if sim.steps.is_multiple_of(stride) || sim.t >= end_time - tol {
                diagnostics.push(sim.energy_sample());
                last_good.copy_from_slice(&sim.rod.x);
            }
            sim.observe_lift(watch.as_mut());
            let samples = (diagnostics.len(), watch);
            recovery.after_step(sim, &mut control, || samples);
        }
        recovery.finish(sim, &mut control);
        rollbacks = recovery.rollbacks();
        rejected = control.rejected;
        min_dt = control.min_dt;
        sim.dt = limits.chosen;
    }
    if error.is_some() && sim.rod.x.iter().any(|x| !(x[0].is_finite() && x[1].is_finite() && x[2].is_finite())) {
        sim.rod.x.copy_from_slice(&last_good);
    }
    let t_end = sim.t;
    let laid = laid_polyline(&sim.rod.x, &sim.landing_time, None);
    let motion = BeltMotion { belt_speed: p.belt_speed, fibre_speed: p.fibre_speed, end_time: t_end, element_length: sim.rod.rest.iter().sum::<f64>() / sim.rod.rest.len() as f64 };
    let laid_removed = laid_polyline(&sim.rod.x, &sim.landing_time, Some((p.belt_removal, motion)));
    let (s, e) = shape_measures(&laid);
    let (sr, er) = shape_measures(&laid_removed);
    let mut invalid_reason = error.clone();
    let worst = sim
            .max_lift
            .iter()
            .zip(&sim.landing_time)
            .enumerate()
            .filter(|(_, (_, t))| t.is_finite())
            .map(|(i, (h, _))| (i, *h))
            .fold((0usize, 0.0f64), |a, b| if b.1 > a.1 { b } else { a });
    let final_worst = sim.highest_laid_node().map_or((0, 0.0), |(i, h)| (i, h.max(0.0)));
    if invalid_reason.is_none() {
        invalid_reason = bounce_reason(p, final_worst, Some(worst), watch.as_ref());
    }
    LaydownResult {
        max_lift_after_landing: worst.1,
        final_lift_of_landed: final_worst.1,
        lifted_fraction: watch.map_or(f64::NAN, |w| w.lifted_fraction()),
        lift: sim.max_lift.iter().zip(&sim.landing_time).map(|(h, t)| if t.is_finite() { *h } else { 0.0 }).collect(),
        lift_time: sim.lift_time.clone(),
        landed_nodes: laid.len(),
        laid_length: arc_length(&laid),
        positions: sim.rod.x.clone(),
        landing_time: sim.landing_time.clone(),
        valid: invalid_reason.is_none(),
        invalid_reason,
        radius_of_gyration: s,
        bending_energy: e,
        radius_of_gyration_belt_removed: sr,
        laid_belt_removed: laid_removed,
        bending_energy_belt_removed: er,
        twist_rate: sim.twist.as_ref().map_or(0.0, |t| t.twist_rate),
        laid_twist: sim.twist.as_ref().map_or(0.0, |t| t.laid_twist()),
        diagnostics,
        steps: sim.steps,
        time_step: sim.dt,
        min_time_step: min_dt,
        rejected_steps: rejected,
        rollbacks,
        projection_iterations: sim.projection_iterations,
        time_step_limits: Some(super::integrator::TimeStepLimits { chosen: sim.dt, ..limits }),
        end_time: t_end,
        elements: sim.rod.rest.len(),
        max_penetration: sim.max_penetration,
        max_constraint_error: sim.projection_residual,
        wall_seconds: clock.elapsed().as_secs_f64(),
        error,
        warnings: Vec::new(),
    }
}

/// The random stream of replicate `replicate` of a laydown seeded with `seed`: item 0 of
/// the crate's one scheme ([`crate::rng::stream_rng`]`(seed, replicate, 0)`), the stream
/// the laydown stage gives that replicate, so `simulate(&p, &mut replicate_rng(seed, r))`
/// is replicate r of a laydown stage with seed `seed` and the same scene. Independent of
/// thread count and order of execution.
pub fn replicate_rng(seed: u64, replicate: u64) -> ChaCha8Rng {
    crate::rng::stream_rng(seed, replicate, 0)
}


#[cfg(test)]
mod tests {
    use super::*;

    fn step_in_coil_times(p: &LaydownParams) -> f64 {
        time_step_limits(p, p.element_length(), true).chosen / p.coil_time()
    }

    /// `coil_step` 0.04 leaves the Table 1 baseline's step as it is, to the bit (there the
    /// bending limit, 0.0305 ℓ_c/v_f, is below it), and holds the coil-resolved scenes
    /// of 10-50 m/s and thin fibres, which otherwise step at 0.1 ℓ_c/v_f, to
    /// time_step_factor · 0.04 ℓ_c/v_f.
    #[test]
    fn coil_step_leaves_table_1_alone_and_bounds_the_step_in_coil_times() {
        let table1 = LaydownParams::default();
        assert_eq!(table1.coil_step, 0.0, "opt-in");
        let ruled = LaydownParams { coil_step: CONVERGED_COIL_STEP, ..table1.clone() };
        let ds = table1.element_length();
        assert_eq!(time_step_limits(&ruled, ds, true).chosen.to_bits(), time_step_limits(&table1, ds, true).chosen.to_bits());
        let baseline = step_in_coil_times(&table1);
        assert!((baseline - 0.0305).abs() < 5e-4, "Table 1 steps at {baseline} coil times");
        for (fibre_speed, diameter) in [(10.0, 50e-6), (50.0, 50e-6), (5.0, 16.2e-6)] {
            let p = LaydownParams { fibre_speed, diameter, air_speed: 3.0 * fibre_speed, ..table1.clone() };
            let coarse = step_in_coil_times(&p);
            assert!((coarse - 0.1).abs() < 3e-3, "{fibre_speed} m/s, d {diameter}: {coarse} coil times without the rule");
            let with = step_in_coil_times(&LaydownParams { coil_step: CONVERGED_COIL_STEP, ..p.clone() });
            assert!((with - p.time_step_factor * CONVERGED_COIL_STEP).abs() < 1e-12, "{fibre_speed} m/s: {with}");
            let limits = time_step_limits(&LaydownParams { coil_step: CONVERGED_COIL_STEP, ..p.clone() }, p.element_length(), true);
            assert!((limits.coil - CONVERGED_COIL_STEP * p.coil_time()).abs() < 1e-18, "the limit is reported");
        }
    }

    /// The step caution: none at Table 1, with the rule, at a small enough
    /// time_step_factor, under another integrator or for a mesh chosen coarse at Table 1;
    /// at 50 m/s keyed at the fibre speed, for a thin fibre at the diameter.
    #[test]
    fn a_step_coarse_in_coil_times_is_cautioned_where_it_comes_from() {
        let table1 = LaydownParams::default();
        let ds = |p: &LaydownParams| p.element_length();
        assert!(step_caution(&table1, ds(&table1)).is_none());
        let fast = LaydownParams { fibre_speed: 50.0, air_speed: 150.0, ..table1.clone() };
        let c = step_caution(&fast, ds(&fast)).expect("50 m/s at the default step");
        assert_eq!(c.key, "fibre_speed");
        assert!(c.message.contains("0.100 of the inertial coil time") && c.message.contains("coil_step: 0.04"), "{}", c.message);
        for quiet in [
            LaydownParams { coil_step: CONVERGED_COIL_STEP, ..fast.clone() },
            LaydownParams { time_step_factor: 0.25, ..fast.clone() },
            LaydownParams { integrator: Integrator::ImplicitAxial, ..fast.clone() },
        ] {
            assert!(step_caution(&quiet, ds(&quiet)).is_none(), "{quiet:?}");
        }
        let thin = LaydownParams { diameter: 16.2e-6, ..table1.clone() };
        assert_eq!(step_caution(&thin, ds(&thin)).map(|c| c.key), Some("diameter".to_string()));
        let coarse = LaydownParams { elements: 250, ..table1.clone() };
        assert!(step_caution(&coarse, ds(&coarse)).is_none(), "a coarse mesh at Table 1: its error is the mesh estimate's");
    }
}
