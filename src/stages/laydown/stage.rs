//! `kind: laydown` — the pipeline stage around the rod physics: every (sweep point,
//! replicate) is one simulated fibre, run in parallel; results are stacked along
//! `point` and `replicate`, with per-point mean and standard deviation over the valid
//! replicates (Figs 5-6).
//!
//! With `valid_replicates_target` = T > 0 (the paper: ten valid simulations per point),
//! a point whose first `replicates` runs give fewer than T valid ones draws more
//! replicates `replicates`, `replicates` + 1, … (each with its own random stream, the
//! same one it would get with a larger `replicates`) in rounds, until T are valid or
//! `max_replicates` were attempted. Rounds depend only on the results of earlier
//! rounds, never on timing, so the output is identical for any thread count. All
//! attempted replicates are stored (the `replicate` axis is padded to the largest count
//! with NaN and `valid` = false, `invalid_reason` = "not attempted"); `used` marks the
//! first T valid ones in replicate order, over which the means and standard deviations
//! are taken; `valid_shortfall` = T − used (0 when the target was met).
//!
//! Executors ([`crate::executor`]): a unit of work is one (point, replicate), or a whole
//! point when it has a target (its rounds depend on earlier results). The replicates are
//! computed as per-replicate rows ([`Stage::run_units`]) and placed on the (point,
//! replicate) axes with the statistics by [`Stage::reduce`], for the local run and for a
//! gathered Slurm array alike.
//!
//! **Discretisation error** (`mesh_error_estimate`, on by default): every replicate is
//! also simulated at half its elements (its own random stream, a quarter of its cost at
//! 1000 elements), and per point the relative error of the mean S and e (raw and belt
//! removed) is estimated by Richardson extrapolation, (m_N − m_{N/2}) / ((2^p − 1) m_N)
//! with p = [`MESH_ORDER`],
//! with its standard error from the replicate scatter ([`mesh_error`]); points whose e
//! is more than [`MESH_ERROR_WARNING`] off are counted in one warning on stderr, and
//! points with `belt_removal: landing` whose belt-removed e is, in another (that
//! definition does not converge; `feed` does).
//!
//! **Step error** (`step_error_estimate`, opt-in): every replicate is simulated again at
//! half its time step (`time_step_factor` halved, which halves every step limit of every
//! integrator) on the *same* random stream: the same imperfections and oscillation phase
//! (where the laydown is chaotic the two paths still part: at 10 m/s a pair differed as
//! much as two fibres do). Per point, the relative change of each mean,
//! (m_{Δt/2} − m_{Δt}) / m_{Δt}, with its standard error from the scatter of the paired
//! differences ([`step_change`]); points whose S or e changes by more than
//! [`STEP_CHANGE_WARNING`] (and twice its standard error) are counted in a warning. It is
//! the measured change, not an extrapolation: against much smaller steps the error at
//! 10-50 m/s was 1.4 to 3 times this change, no one order of convergence (FIBRE_SPEED.md,
//! "The order of the step error"). The half-step runs are estimated at twice the replicates'
//! cost and took 1.05-1.7 times it over the fibre-speed sweep (invalid replicates are not
//! run again).
//!
//! **Memory** ([`Stage::estimate_memory`]): every replicate's nodes are kept until the
//! output is written (result, per-replicate row, placed copy: [`KEPT_BYTES_PER_NODE`]),
//! and each thread simulates one rod ([`SIM_BYTES_PER_NODE`]); the energy diagnostics
//! (one record per `diagnostic_stride` steps) are not counted.
use crate::error::InvalidParam;
use super::params::{AirField, BounceCheck, Effects, FeedEnd, Integrator, LaydownParams, Start, PARAMETERS};
use super::metrics::ENERGY_COLUMNS;
use super::{laid_polyline, simulate, LaydownResult};
use crate::archive::data::Output;
use crate::memory::Estimate;
use crate::params::{ParamCaution, ParamSet, ParamSpec};
use crate::stages::rows::place;
use crate::stages::{concurrent, Declared, DeclaredFibres, InputRule, RunContext, Stage, Units};
use anyhow::{bail, Result};
use ndarray::{Array1, Array2, Array3};

/// Stage-level parameters (not scene parameters): the valid-replicate target and its cap.
const TARGET: &str = "valid_replicates_target";
const CAP: &str = "max_replicates";
const MESH: &str = "mesh_error_estimate";
const STEP: &str = "step_error_estimate";
/// Order p of the Richardson estimate. The scheme is second order for smooth curves, but
/// the laid curve's e converged at orders 0.7-1.8 in the measurements (within their noise,
/// pipelines/paper/LAYDOWN_MEASUREMENTS.md); first order lies between, where second order
/// would make the estimate a third as large, too small in both.
const MESH_ORDER: f64 = 1.0;
/// Points whose S or e changes by more than this when the step is halved (and by more than
/// twice its standard error) are counted in a warning: the error against much smaller steps
/// was 1.4-3 times the change, so 1 % flags errors of about 2 % and more.
pub const STEP_CHANGE_WARNING: f64 = 0.01;
/// Points whose estimated error of e exceeds this are counted in a warning on stderr.
pub const MESH_ERROR_WARNING: f64 = 0.02;
/// The laid-fibre measures (whose discretisation errors are estimated) and their short labels.
const LAID_MEASURES: [(&str, &str); 4] = [
    ("radius_of_gyration", "S"),
    ("bending_energy", "e"),
    ("radius_of_gyration_belt_removed", "S, belt removed"),
    ("bending_energy_belt_removed", "e, belt removed"),
];

pub struct LaydownStage;

/// Bytes per node of a rod being simulated: state, workspace (forces, drag and
/// constraint matrices, contact) and the step-rejection snapshot, about 75 f64, and the
/// two checkpoints of the recovery (`rollbacks`, state only: about 105 B each). One
/// replicate of 100001 nodes peaked at 71 MB resident before the checkpoints, estimated
/// at 90 MB; the checkpoints took 20001 nodes from 27.2 to 31.3 MB.
pub const SIM_BYTES_PER_NODE: f64 = 850.0;
/// Bytes per node of a finished replicate until the output is written: its positions,
/// velocities, landing times and belt-removed laid nodes, its row (positions, laid,
/// belt-removed, landing) and the copy placed on (point, replicate).
pub const KEPT_BYTES_PER_NODE: f64 = 280.0;

/// Replicates a point may attempt: `replicates`, or `max_replicates` with a target.
fn attempts(p: &ParamSet, replicates: usize) -> usize {
    let p = LaydownStageParams::of(p);
    if p.valid_replicates_target > 0 {
        replicates.max(p.max_replicates)
    } else {
        replicates
    }
}

/// The fibres of a declared laydown stage, per point: one per attempted replicate.
pub fn declared_fibres(stage: &Declared) -> Vec<DeclaredFibres> {
    stage
        .points
        .iter()
        .map(|p| {
            let s = scene(p);
            let (nodes, length) = (s.resolved_elements() as f64 + 1.0, s.length);
            DeclaredFibres { count: attempts(p, stage.replicates) as f64, nodes, length }
        })
        .collect()
}

/// A laydown point's parameters ([`ParamSet::to_typed`] of the stage's table): the
/// scene (rows named after the fields of [`LaydownParams`], `effects.X` the [`Effects`]
/// flags) and how the stage runs replicates of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LaydownStageParams {
    #[serde(flatten)]
    pub scene: LaydownParams,
    pub valid_replicates_target: usize,
    pub max_replicates: usize,
    pub mesh_error_estimate: bool,
    pub step_error_estimate: bool,
}

impl LaydownStageParams {
    /// A point's typed parameters (its rows were checked against the table).
    pub fn of(p: &ParamSet) -> Self {
        p.to_typed().expect("the laydown table and LaydownStageParams agree (tested)")
    }
}

/// The scene of one sweep point.
pub fn scene(p: &ParamSet) -> LaydownParams {
    LaydownStageParams::of(p).scene
}

/// CPU time of one node-step of the vertical start on one thread (s), by integrator:
/// wall time over steps × nodes of the replicates of `scheme_offset.yaml` and
/// `converged_mesh_accuracy.yaml` (Table 1, 1000 and 2000 elements, one replicate per
/// core on the 2-core development machine): explicit 4.4-5.3e-8, the projection schemes
/// 6.5-9.8e-8 (1.4e-7 on a busy host), implicit_bending (a banded solve a step) 3.7e-7.
/// The host's speed varies by some 40 % from day to day.
fn cpu_seconds_per_node_step(integrator: Integrator) -> f64 {
    match integrator {
        Integrator::Explicit => 4.8e-8,
        Integrator::ImplicitBending => 3.7e-7,
        Integrator::Inextensible | Integrator::ImplicitAxial | Integrator::TrapezoidalAxial => 8.0e-8,
    }
}

/// Node-steps of one simulation of `scene` with the vertical start: every node at every
/// step of the chosen time step ([`crate::rod::scene::time_step_limits`]; the adaptive
/// schemes take more, for their short steps at the start-up impact: 2 % at Table 1, 14 %
/// on a fibre of 0.15 m). The opt-in twist's extra work per node is not counted. The fed start integrates
/// fewer nodes: with its freezing front its wall time is 0.31 of the vertical start's at
/// Table 1 (README, "Performance").
pub fn estimated_node_steps(scene: &LaydownParams) -> f64 {
    let elements = scene.resolved_elements();
    let ds = scene.length / elements as f64;
    let dt = crate::rod::scene::time_step_limits(scene, ds, true).chosen;
    (scene.end_time() / dt).ceil() * (elements + 1) as f64
}

/// What lowers the cost of a point, for the refusal above `--max-cpu-time`: only the
/// settings it can still change.
fn cost_advice(p: &LaydownStageParams) -> String {
    let scene = &p.scene;
    let mut lower = vec!["elements"];
    if scene.coil_resolution > 0.0 {
        lower.push("coil_resolution");
    }
    lower.push("replicates");
    let mut advice = format!("lower {} or {}", lower[..lower.len() - 1].join(", "), lower[lower.len() - 1]);
    if p.mesh_error_estimate {
        advice += ", set mesh_error_estimate: false (its half-mesh run)";
    }
    if p.step_error_estimate {
        advice += ", set step_error_estimate: false (its half-step run)";
    }
    if scene.integrator == Integrator::Explicit {
        advice += ", use a projection integrator (the default trapezoidal_axial)";
    } else if scene.start == Start::Vertical {
        advice += ", use start: fed";
    }
    advice
}

/// Estimated CPU time of one replicate of a point (s): [`estimated_node_steps`] at the
/// integrator's cost per node-step, plus the half-mesh run of `mesh_error_estimate` and
/// the half-step run of `step_error_estimate`.
pub fn estimated_cpu_seconds(p: &LaydownStageParams) -> f64 {
    let scene = &p.scene;
    let mut node_steps = estimated_node_steps(scene);
    if p.mesh_error_estimate {
        node_steps += estimated_node_steps(&half_mesh_scene(scene, scene.resolved_elements()));
    }
    if p.step_error_estimate {
        node_steps += estimated_node_steps(&half_step_scene(scene));
    }
    node_steps * cpu_seconds_per_node_step(scene.integrator)
}

impl Stage for LaydownStage {
    fn kind(&self) -> &'static str {
        "laydown"
    }
    fn summary(&self) -> &'static str {
        "one fibre fed onto a moving belt: geometrically nonlinear rod with drag, oscillation, contact and friction (paper §2)"
    }
    fn cache_version(&self) -> u32 {
        3
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &[], min: 0, max: 0 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v: Vec<ParamSpec> = PARAMETERS.to_vec();
        v.push(ParamSpec::choice(
            "air_field",
            AirField::NAMES,
            AirField::default().name(),
            "uniform: air (0, 0, -air_speed) everywhere, a belt passing all of it (the paper); impinging / impinging_slot: a round / slot jet whose part not passing the belt (1 - belt_permeability) turns sideways over stagnation_height (src/rod/air.rs)",
        ));
        v.push(ParamSpec::choice(
            "integrator",
            Integrator::NAMES,
            Integrator::default().name(),
            "time integration: explicit (reference), implicit_axial (fast), inextensible, implicit_bending (opt-in: bending implicit, step set by node travel, implicit_step_travel; dissipative)",
        ));
        v.push(ParamSpec::int(
            TARGET,
            "1",
            0,
            0,
            10_000,
            "draw replicates beyond `replicates` until this many per point are valid (paper: 10); 0 = off; statistics over the first that many valid",
        ));
        v.push(ParamSpec::int(
            CAP,
            "1",
            40,
            1,
            100_000,
            "with valid_replicates_target: most replicates attempted per point (shortfall recorded in valid_shortfall)",
        ));
        v.push(ParamSpec::flag(
            MESH,
            true,
            "also simulate every replicate at half its elements (a quarter of the cost at 1000 elements) and estimate the discretisation error of the mean S and e by Richardson extrapolation (first order), per point (`*_mesh_error`); points whose e is off by more than 2 % are counted in a warning",
        ));
        v.push(ParamSpec::flag(
            STEP,
            false,
            "also simulate every valid replicate at half its time step (time_step_factor halved; about twice its cost) on the same random stream (the same imperfections and oscillation phase), and report the relative change of the mean S and e with its paired standard error, per point (`*_step_change`; the error against much smaller steps was 1.4-3 times this change at 10-50 m/s, pipelines/studies/FIBRE_SPEED.md); points whose S or e changes by more than 1 % (and twice its standard error) are counted in a warning",
        ));
        v.push(ParamSpec::choice(
            "bounce_check",
            BounceCheck::NAMES,
            BounceCheck::default().name(),
            "final: a landed node above bounce_tolerance in the final profile invalidates the replicate (the paper's test); transient: at any time after landing; last_period: for more than half of the run's last oscillation period (the paper's test at every step of it; at 50 m/s arches rise and settle with the sweep, and the final profile reads where the sweep ends: pipelines/studies/FIBRE_SPEED.md, \"A validity that does not depend on the end instant\")",
        ));
        v.push(ParamSpec::choice(
            "belt_removal",
            crate::rod::BeltRemoval::NAMES,
            crate::rod::BeltRemoval::default().name(),
            "belt-removed S and e (Figs 5-6 dashed): landing takes off the belt travel since each node landed, x − v_b(t_end − t_land) (the paper's reading; e grows with the mesh); feed since it was fed, x + (v_b/v_f)s (converges)",
        ));
        v.push(ParamSpec::choice(
            "start",
            Start::NAMES,
            Start::default().name(),
            "vertical: the paper's start, a vertical fibre of length L all simulated; fed: fibre fed continuously into a short buffer above laydown_height, settled laid nodes frozen (src/rod/feed.rs, as laid_web lays a fibre): the same element length, end time and laid length, statistically the same replicate (paired with it, 96 replicates at Table 1 and 64 at 50 m/s: S within 0.7 % and e within 2 %), 3.3x faster at Table 1, 8x at 50 m/s; with bounce_check final or last_period",
        ));
        v.push(ParamSpec::choice(
            "feed_end",
            FeedEnd::NAMES,
            FeedEnd::default().name(),
            "with effects.twist: clamped, the spinneret holds the fibre against spinning, so the twist coiling puts into the hanging fibre stays and acts on it; free, it relaxes through the feed (no twist, nothing built)",
        ));
        let defaults = Effects::default();
        let on = serde_json::to_value(defaults).unwrap();
        for (flag, doc) in Effects::FLAGS {
            let name: &'static str = Box::leak(format!("effects.{flag}").into_boxed_str());
            v.push(ParamSpec::flag(name, on[flag].as_bool().unwrap_or(true), doc));
        }
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), InvalidParam> {
        let LaydownStageParams { scene, valid_replicates_target: target, max_replicates: cap, step_error_estimate: step, .. } = LaydownStageParams::of(p);
        if target > 0 && cap < target {
            return Err(InvalidParam::new(CAP.to_string(), format!("max_replicates ({cap}) must be at least valid_replicates_target ({target})")));
        }
        if step && scene.validate().is_ok() && half_step_scene(&scene).validate().is_err() {
            let smallest = PARAMETERS.iter().find(|s| s.name == "time_step_factor").map_or(f64::NAN, |s| match s.kind {
                crate::params::ParamKind::Float { min, .. } => min,
                _ => f64::NAN,
            });
            return Err(InvalidParam::new(
                "time_step_factor".to_string(),
                format!(
                    "{} is too small for step_error_estimate, which runs every replicate again at half of it: allowed at least {} (twice the smallest time_step_factor, {smallest})",
                    scene.time_step_factor,
                    2.0 * smallest
                ),
            ));
        }
        scene.validate().map_err(|e| {
            let name = match &e {
                super::ParamError::Range(r) => r.name.to_string(),
                _ => "laydown_height".to_string(),
            };
            InvalidParam::new(name, e.to_string())
        })
    }

    fn cautions(&self, p: &ParamSet) -> Vec<ParamCaution> {
        let own = LaydownStageParams::of(p);
        let mut cautions = own.scene.cautions();
        cautions.extend(crate::rod::scene::step_caution(&own.scene, own.scene.element_length()).map(|mut c| {
            if !own.step_error_estimate {
                c.message += "; or measure the change at half the step: step_error_estimate: true";
            }
            c
        }));
        cautions
    }

    /// `estimated_cpu_seconds`: about, for the vertical start; at most, for the fed
    /// start (frozen laid fibre costs nothing); at least, with a `valid_replicates_target`
    /// (invalid replicates are redrawn), unless the start is fed too (then about).
    fn estimate_cpu_time(&self, p: &ParamSet) -> Option<crate::stages::CpuTime> {
        use crate::stages::Bound;
        let own = LaydownStageParams::of(p);
        let bound = match (own.valid_replicates_target > 0, own.scene.start) {
            (true, Start::Fed) => Bound::About,
            (true, Start::Vertical) => Bound::AtLeast,
            (false, Start::Fed) => Bound::AtMost,
            (false, Start::Vertical) => Bound::About,
        };
        Some(crate::stages::CpuTime { seconds: estimated_cpu_seconds(&own), bound, advice: cost_advice(&own) })
    }

    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let fibres = declared_fibres(stage);
        let kept: f64 = fibres.iter().map(|f| f.count * f.nodes * KEPT_BYTES_PER_NODE).sum();
        let units: f64 = fibres.iter().map(|f| f.count).sum();
        let nodes = fibres.iter().map(|f| f.nodes).fold(0.0, f64::max);
        let simulated = concurrent(units) * nodes * SIM_BYTES_PER_NODE;
        let mut params = vec!["elements", "coil_resolution"];
        if fibres.iter().any(|f| f.count > stage.replicates as f64) {
            params.push(CAP);
        }
        params.push("replicates");
        let what = format!("{units} replicates of up to {nodes} nodes kept, {KEPT_BYTES_PER_NODE} B each, and {} rods simulated at once", concurrent(units));
        Some(Estimate::new(kept + simulated, what, &stage.name, &params))
    }
    fn run(&self, ctx: &RunContext) -> Result<Output> {
        crate::stages::run_by_units(self, ctx)
    }
    /// A unit is one (point, replicate): every replicate's random stream is keyed by seed
    /// and replicate only ([`RunContext::rng`]), so any share of the units computes what
    /// the whole run computes. With a `valid_replicates_target` at some point, the
    /// extra replicates are drawn in rounds that depend on how many earlier ones were
    /// valid (`run_until_valid`); then a unit is a whole point with its rounds.
    fn units(&self, ctx: &RunContext) -> Result<Option<Units>> {
        let own: Vec<LaydownStageParams> = ctx.points.iter().map(LaydownStageParams::of).collect();
        let rounds = own.iter().any(|p| p.valid_replicates_target > 0);
        Ok(Some(if rounds {
            Units {
                points: ctx.points.len(),
                per_point: 1,
                note: Some("valid_replicates_target draws extra replicates in rounds that depend on earlier results: a unit is a whole point"),
            }
        } else {
            Units { points: ctx.points.len(), per_point: ctx.replicates, note: None }
        }))
    }
    fn run_units(&self, ctx: &RunContext, range: std::ops::Range<usize>) -> Result<Output> {
        let units = self.units(ctx)?.expect("laydown has units");
        let own: Vec<LaydownStageParams> = ctx.points.iter().map(LaydownStageParams::of).collect();
        let sim = |p: usize, r: usize| {
            let fine = simulate(&own[p].scene, &mut ctx.rng(r, 0));
            let half = own[p].mesh_error_estimate.then(|| half_mesh(&own[p].scene, &fine, &mut ctx.rng(r, 1))).flatten();
            // the fine run's stream: the same imperfections and phase, at half the step
            let half_step = own[p].step_error_estimate.then(|| half_step(&own[p].scene, &fine, &mut ctx.rng(r, 0))).flatten();
            Replicate { fine, half, half_step }
        };
        let rows: Vec<(usize, usize, Replicate)> = if units.per_point == 1 {
            // Whole points, with their rounds of extra replicates.
            let (a, b) = (range.start, range.end);
            let targets: Vec<(usize, usize)> = own[a..b].iter().map(|p| (p.valid_replicates_target, p.max_replicates)).collect();
            let results = run_until_valid(&targets, ctx.replicates, ctx.progress, &ctx.stage_name, |p, r| sim(a + p, r), |rep| rep.fine.valid && rep.fine.error.is_none());
            results.into_iter().enumerate().flat_map(|(p, rs)| rs.into_iter().enumerate().map(move |(r, res)| (a + p, r, res))).collect()
        } else {
            ctx.par_units(range, |p, r| (p, r, sim(p, r)))
        };
        unit_rows(&rows, Estimates::of(&own))
    }
    fn reduce(&self, ctx: &RunContext, rows: Output) -> Result<Output> {
        let own: Vec<LaydownStageParams> = ctx.points.iter().map(LaydownStageParams::of).collect();
        let targets: Vec<(usize, usize)> = own.iter().map(|p| (p.valid_replicates_target, p.max_replicates)).collect();
        let by_landing: Vec<bool> = own.iter().map(|p| p.scene.belt_removal == crate::rod::BeltRemoval::Landing).collect();
        assemble(&rows, &targets, &ctx.stage_name, Estimates::of(&own), &by_landing)
    }
}

/// One replicate: the fibre at the scene's mesh and, with `mesh_error_estimate`, the
/// measures of the same scene at half the elements; with `step_error_estimate`, those at
/// half the step on the same random stream.
#[derive(Clone)]
struct Replicate {
    fine: LaydownResult,
    half: Option<Measures>,
    half_step: Option<Measures>,
}

/// S and e (raw, belt removed) of a replicate simulated again at half the elements or
/// half the step, and the wall time of that run.
#[derive(Clone, Copy)]
struct Measures {
    measures: [f64; 4],
    wall_seconds: f64,
}

impl Measures {
    /// The measures of a run that completed and is valid.
    fn of(r: &LaydownResult) -> Option<Self> {
        (r.valid && r.error.is_none()).then_some(Measures {
            measures: [r.radius_of_gyration, r.bending_energy, r.radius_of_gyration_belt_removed, r.bending_energy_belt_removed],
            wall_seconds: r.wall_seconds,
        })
    }
}

/// Which discretisation-error estimates a stage made (any point asked for them).
#[derive(Clone, Copy)]
struct Estimates {
    mesh: bool,
    step: bool,
}

impl Estimates {
    /// The estimates any of a stage's points asks for: every part of a job array writes
    /// the same columns, and `reduce` reads them.
    fn of(points: &[LaydownStageParams]) -> Self {
        Estimates { mesh: points.iter().any(|p| p.mesh_error_estimate), step: points.iter().any(|p| p.step_error_estimate) }
    }
}

/// `scene` at half its time step: `time_step_factor` halved, which halves every limit of
/// [`crate::rod::scene::time_step_limits`] for every integrator (the coil-time limit too).
fn half_step_scene(scene: &LaydownParams) -> LaydownParams {
    LaydownParams { time_step_factor: 0.5 * scene.time_step_factor, ..scene.clone() }
}

/// [`half_step_scene`] simulated on the fine run's stream (its imperfections and phase); None when the
/// fine run failed or is invalid (it never enters the statistics, so it is not run), or the
/// half-step run failed or is invalid.
fn half_step(scene: &LaydownParams, fine: &LaydownResult, rng: &mut rand_chacha::ChaCha8Rng) -> Option<Measures> {
    if fine.error.is_some() || !fine.valid {
        return None;
    }
    Measures::of(&simulate(&half_step_scene(scene), rng))
}

/// `scene` at half of `elements` (the fine run's), with coil_resolution off so the
/// halving holds: the run of `mesh_error_estimate`, and its cost estimate.
fn half_mesh_scene(scene: &LaydownParams, elements: usize) -> LaydownParams {
    LaydownParams { elements: elements / 2, coil_resolution: 0.0, ..scene.clone() }
}

/// [`half_mesh_scene`] of the fine run, simulated on its own stream; None when the fine
/// run failed, the coarse one failed or bounced, or the mesh is too coarse to halve
/// (under 8 elements).
fn half_mesh(scene: &LaydownParams, fine: &LaydownResult, rng: &mut rand_chacha::ChaCha8Rng) -> Option<Measures> {
    if fine.error.is_some() || fine.elements < 8 {
        return None;
    }
    Measures::of(&simulate(&half_mesh_scene(scene, fine.elements), rng))
}

/// The short label of a laid-fibre measure (a `long_name`).
fn metric_label(name: &str) -> &'static str {
    LAID_MEASURES.iter().find(|m| m.0 == name).map_or("measure", |m| m.1)
}

/// Richardson estimate of the relative discretisation error of a mean over replicates,
/// (m_N − m_{N/2}) / ((2^p − 1) m_N): the converged value is about m_N (1 + error). With
/// its standard error from the two samples' scatter. NaN with fewer than two of either.
pub fn mesh_error(fine: &[f64], half: &[f64]) -> (f64, f64) {
    let (mf, sf, nf) = mean_std(fine.iter().copied());
    let (mh, sh, nh) = mean_std(half.iter().copied());
    if nf < 2 || nh < 2 || mf == 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let scale = (2f64.powf(MESH_ORDER) - 1.0) * mf;
    ((mf - mh) / scale, (sf * sf / nf as f64 + sh * sh / nh as f64).sqrt() / scale.abs())
}

/// Relative change of a mean over replicates when the time step is halved, from paired
/// runs of the same fibres at the scene's step (`fine`) and at half of it (`half_step`):
/// (m_{Δt/2} − m_{Δt}) / m_{Δt}, with its standard error from the scatter of the paired
/// differences. Pairs where either value is not finite are left out; NaN with fewer than
/// two pairs or a zero mean.
pub fn step_change(fine: &[f64], half_step: &[f64]) -> (f64, f64) {
    let (f, d): (Vec<f64>, Vec<f64>) = fine.iter().zip(half_step).filter(|(a, b)| a.is_finite() && b.is_finite()).map(|(&a, &b)| (a, b - a)).unzip();
    let (mf, _, n) = mean_std(f.into_iter());
    let (md, sd, _) = mean_std(d.into_iter());
    if n < 2 || mf == 0.0 {
        return (f64::NAN, f64::NAN);
    }
    (md / mf, sd / (n as f64).sqrt() / mf.abs())
}

/// Replicates per point: first 0..`replicates` for every point, then, for each point
/// with a target (T, cap) not yet met, further rounds of replicate indices continuing
/// from the last one attempted. The size of a round is (T − valid)/(valid fraction so
/// far, at least ¼), capped; it depends only on earlier results, so the set of runs and
/// the output are independent of the number of threads. `sim(point, replicate)` must be
/// a pure function of its arguments.
pub(crate) fn run_until_valid<T: Send + Clone>(
    targets: &[(usize, usize)],
    replicates: usize,
    progress: bool,
    stage_name: &str,
    sim: impl Fn(usize, usize) -> T + Sync + Send,
    is_valid: impl Fn(&T) -> bool,
) -> Vec<Vec<T>> {
    let npoints = targets.len();
    let mut results: Vec<Vec<T>> = vec![Vec::new(); npoints];
    let mut jobs: Vec<(usize, usize)> = (0..npoints).flat_map(|p| (0..replicates).map(move |r| (p, r))).collect();
    let mut round = 0;
    while !jobs.is_empty() {
        let label = if round == 0 { format!("{stage_name} units") } else { format!("{stage_name} extra {round}") };
        let out: Vec<T> = crate::progress::par_map_shown(progress, &label, &jobs, |&(p, r)| sim(p, r));
        for (&(p, _), res) in jobs.iter().zip(out) {
            results[p].push(res);
        }
        jobs.clear();
        round += 1;
        for (p, &(target, cap)) in targets.iter().enumerate() {
            if target == 0 {
                continue;
            }
            let attempted = results[p].len();
            let valid = results[p].iter().filter(|r| is_valid(r)).count();
            if valid >= target || attempted >= cap {
                continue;
            }
            let rate = if attempted > 0 { (valid as f64 / attempted as f64).max(0.25) } else { 1.0 };
            let batch = (((target - valid) as f64 / rate).ceil() as usize).clamp(1, cap - attempted);
            jobs.extend((attempted..attempted + batch).map(|r| (p, r)));
        }
    }
    results
}

fn mean_std(values: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    let n = v.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, 0);
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    // The sample standard deviation of a single value is undefined: NaN, not 0.
    let var = if n > 1 { v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64 } else { f64::NAN };
    (mean, var.sqrt(), n)
}

/// The per-replicate rows of `results` ((point, replicate, result), in any order):
/// everything of a replicate that the stage output holds, with the laid polylines
/// computed here. Node, laid-node and record axes are padded with NaN to the longest
/// replicate (the laid axis to the node count, as the output's is).
fn unit_rows(replicates: &[(usize, usize, Replicate)], estimates: Estimates) -> Result<Output> {
    let results: Vec<(usize, usize, &LaydownResult)> = replicates.iter().map(|(p, r, rep)| (*p, *r, &rep.fine)).collect();
    let nan = f64::NAN;
    let n = results.len();
    let nodes = results.iter().map(|r| r.2.positions.len()).max().unwrap_or(0);
    let ndiag = results.iter().map(|r| r.2.diagnostics.len()).max().unwrap_or(0);
    let what = "the replicates' rows";
    let mut positions = crate::memory::try_array((n, nodes, 3), nan, what)?;
    let mut laid = crate::memory::try_array((n, nodes, 3), nan, what)?;
    let mut laid_removed = crate::memory::try_array((n, nodes, 3), nan, what)?;
    let mut landing = crate::memory::try_array((n, nodes), nan, what)?;
    let mut diag = Array3::from_elem((n, ndiag, ENERGY_COLUMNS.len()), nan);
    let column = |f: &dyn Fn(&LaydownResult) -> f64| Array1::from_iter(results.iter().map(|r| f(r.2)));
    let ok = |r: &LaydownResult, v: f64| if r.error.is_none() { v } else { f64::NAN };
    // Row u of an (unit, node, xyz) array from a polyline (the rest stays NaN).
    let put = |a: &mut Array3<f64>, u: usize, nodes: &[[f64; 3]]| {
        for (i, x) in nodes.iter().enumerate() {
            a.slice_mut(ndarray::s![u, i, ..]).assign(&ndarray::aview1(x));
        }
    };
    for (u, (_, _, res)) in results.iter().enumerate() {
        put(&mut positions, u, &res.positions);
        for (i, &t) in res.landing_time.iter().enumerate() {
            landing[[u, i]] = t;
        }
        put(&mut laid, u, &laid_polyline(&res.positions, &res.landing_time, None));
        put(&mut laid_removed, u, &res.laid_belt_removed);
        for (i, d) in res.diagnostics.iter().enumerate() {
            for (k, (_, value)) in ENERGY_COLUMNS.iter().enumerate() {
                diag[[u, i, k]] = value(d);
            }
        }
    }
    let unit = crate::stages::UNIT_DIM;
    let mut out = Output::new();
    out.i64("unit_point", &[unit], Array1::from_iter(results.iter().map(|r| r.0 as i64)), "1", "point of the row");
    out.i64("unit_replicate", &[unit], Array1::from_iter(results.iter().map(|r| r.1 as i64)), "1", "replicate of the row");
    out.f64("positions", &[unit, "node", "xyz"], positions, "m", "");
    out.f64("laid_positions", &[unit, "node", "xyz"], laid, "m", "");
    out.f64("laid_positions_belt_removed", &[unit, "node", "xyz"], laid_removed, "m", "");
    out.f64("landing_time", &[unit, "node"], landing, "s", "");
    out.flags("valid", &[unit], Array1::from_iter(results.iter().map(|r| r.2.valid && r.2.error.is_none())), "");
    out.strings("invalid_reason", unit, results.iter().map(|r| r.2.invalid_reason.clone().unwrap_or_default()).collect(), "");
    out.strings("error", unit, results.iter().map(|r| r.2.error.clone().unwrap_or_default()).collect(), "");
    out.f64("radius_of_gyration", &[unit], column(&|r| ok(r, r.radius_of_gyration)), "m", "");
    out.f64("bending_energy", &[unit], column(&|r| ok(r, r.bending_energy)), "1", "");
    out.f64("radius_of_gyration_belt_removed", &[unit], column(&|r| ok(r, r.radius_of_gyration_belt_removed)), "m", "");
    out.f64("bending_energy_belt_removed", &[unit], column(&|r| ok(r, r.bending_energy_belt_removed)), "1", "");
    out.f64("steps", &[unit], column(&|r| r.steps as f64), "1", "");
    out.f64("rollbacks", &[unit], column(&|r| r.rollbacks as f64), "1", "");
    out.f64("time_step", &[unit], column(&|r| r.time_step), "s", "");
    out.f64("wall_seconds", &[unit], column(&|r| r.wall_seconds), "s", "");
    out.f64("max_lift_after_landing", &[unit], column(&|r| r.max_lift_after_landing), "m", "");
    out.f64("final_lift_of_landed", &[unit], column(&|r| r.final_lift_of_landed), "m", "");
    out.f64("lifted_fraction", &[unit], column(&|r| r.lifted_fraction), "1", "");
    out.f64("laid_length", &[unit], column(&|r| r.laid_length), "m", "");
    out.f64("twist_rate", &[unit], column(&|r| r.twist_rate), "rad/m", "");
    out.f64("laid_twist", &[unit], column(&|r| r.laid_twist), "rad", "");
    out.f64("elements", &[unit], column(&|r| r.elements as f64), "1", "");
    out.f64("energy_diagnostics", &[unit, "record", "diagnostic"], diag, "J", "");
    let extra = |out: &mut Output, suffix: &str, of: &dyn Fn(&Replicate) -> Option<&Measures>| {
        let column = |f: &dyn Fn(&Measures) -> f64| Array1::from_iter(replicates.iter().map(|r| of(&r.2).map_or(f64::NAN, f)));
        for (k, (name, _)) in LAID_MEASURES.iter().enumerate() {
            out.f64(&format!("{name}_{suffix}"), &[unit], column(&|h| h.measures[k]), "", "");
        }
        out.f64(&format!("wall_seconds_{suffix}"), &[unit], column(&|h| h.wall_seconds), "s", "");
    };
    if estimates.mesh {
        extra(&mut out, ErrorEstimate::mesh().run, &|r| r.half.as_ref());
    }
    if estimates.step {
        extra(&mut out, ErrorEstimate::step().run, &|r| r.half_step.as_ref());
    }
    Ok(out)
}

/// One of the two discretisation-error estimates: what its extra run changed, the names
/// of its datasets, how it is computed and when it warns.
struct ErrorEstimate {
    /// Suffix of the extra run's datasets (`half_mesh`, `half_step`).
    run: &'static str,
    /// The extra run, for the long name of its wall time.
    run_name: &'static str,
    /// What the extra run changed, for the long names of its values.
    what: &'static str,
    /// Suffix of the estimate's datasets (`mesh_error`, `step_change`).
    error: &'static str,
    /// The estimate and its standard error from the fine and the extra run's values.
    estimate: fn(&[f64], &[f64]) -> (f64, f64),
    /// The description of the estimate of a measure (its dataset name given).
    describe: fn(&str) -> String,
    /// The measures warned about (by their dataset names).
    warned: &'static [&'static str],
    /// Relative size above which a warned measure is counted in the warning.
    threshold: f64,
    /// Warn only where the estimate is more than twice its standard error (the step change
    /// is a small difference of noisy means; the mesh error is warned as it stands).
    significant_only: bool,
    /// What the warning says of a measure beyond `threshold` (given in %).
    beyond: fn(f64) -> String,
    /// Where the warning sends the reader, after the dataset name.
    advice: &'static str,
    /// Also warn where the belt-removed e of a point with `belt_removal: landing` is beyond
    /// [`MESH_ERROR_WARNING`] (that definition does not converge with the mesh).
    landing_warning: bool,
}

impl ErrorEstimate {
    fn mesh() -> Self {
        ErrorEstimate {
            run: "half_mesh",
            run_name: "half-mesh run",
            what: "half the elements",
            error: "mesh_error",
            estimate: mesh_error,
            describe: |name| {
                format!(
                    "estimated relative error of {name}_mean from the mesh: converged ≈ mean·(1 + error); Richardson of order {MESH_ORDER}, (m_N − m_N/2)/((2^{MESH_ORDER} − 1) m_N), over the used replicates with a valid half-mesh run"
                )
            },
            warned: &["bending_energy"],
            threshold: MESH_ERROR_WARNING,
            significant_only: false,
            beyond: |percent| format!("is estimated more than {percent:.0} % off its converged value"),
            advice: "; Richardson from N and N/2 elements, which overstates it where N/2 has fewer than 2 elements per coil scale: at 10 m/s 13 % against about 8 % from N, 2N and 4N, \
                     pipelines/studies/FIBRE_SPEED.md); raise elements or coil_resolution",
            landing_warning: true,
        }
    }
    fn step() -> Self {
        ErrorEstimate {
            run: "half_step",
            run_name: "half-step run",
            what: "half the time step",
            error: "step_change",
            estimate: step_change,
            describe: |name| {
                format!(
                    "relative change of the mean of {name} when the time step is halved, over the used replicates with a valid half-step run on the same random stream \
                     ({name}_step_change_pairs of them): (m_dt/2 − m_dt)/m_dt, s.e. from the paired differences; a measured change, not an extrapolation: the error against \
                     much smaller steps was 1.4-3 times it at 10-50 m/s (pipelines/studies/FIBRE_SPEED.md, \"The order of the step error\")"
                )
            },
            warned: &["radius_of_gyration", "bending_energy"],
            threshold: STEP_CHANGE_WARNING,
            significant_only: true,
            beyond: |percent| format!("changes by more than {percent:.0} % when the time step is halved"),
            advice: ": not converged in the step, pipelines/studies/FIBRE_SPEED.md, \"The order of the step error\"); set coil_step: 0.04 if it is off, or lower time_step_factor",
            landing_warning: false,
        }
    }
}

/// Per point, the estimate `kind` of the discretisation error of each mean measure over
/// the used replicates whose extra run is valid (and how many those are), beside the extra
/// run's values and their cost. Warns where the measures `kind` names are beyond its
/// threshold, and with `landing_warning` where the belt-removed e of a point whose
/// `belt_removal` is `landing` (`by_landing[p]`) is: that definition grows with
/// refinement, `feed` converges.
fn add_error_estimate(out: &mut Output, kind: &ErrorEstimate, per_rep: &dyn Fn(&str) -> Result<Array2<f64>>, used: &Array2<bool>, fine: [&Array2<f64>; 4], stage_name: &str, by_landing: &[bool]) -> Result<()> {
    let (npoints, nreps) = used.dim();
    let (run, suffix) = (kind.run, kind.error);
    for (k, &(name, label)) in LAID_MEASURES.iter().enumerate() {
        let extra = per_rep(&format!("{name}_{run}"))?;
        let (mut error, mut error_std, mut pairs) = (vec![], vec![], vec![]);
        for p in 0..npoints {
            // Replicates with both runs valid, so the two means are over the same imperfections.
            let paired: Vec<usize> = (0..nreps).filter(|&r| used[[p, r]] && extra[[p, r]].is_finite() && fine[k][[p, r]].is_finite()).collect();
            let pick = |a: &Array2<f64>| paired.iter().map(|&r| a[[p, r]]).collect::<Vec<f64>>();
            let (err, sd) = (kind.estimate)(&pick(fine[k]), &pick(&extra));
            error.push(err);
            error_std.push(sd);
            pairs.push(paired.len() as i64);
        }
        // Points beyond `threshold`, counted in one warning.
        let warn = |flagged: &dyn Fn(usize) -> bool, threshold: f64, significant_only: bool, what: &str, beyond: String, advice: &str| {
            let beyond_at = |p: usize| error[p].abs() > threshold && (!significant_only || error[p].abs() > 2.0 * error_std[p]);
            let off: Vec<usize> = (0..npoints).filter(|&p| flagged(p) && beyond_at(p)).collect();
            if let Some(&worst) = off.iter().max_by(|&&a, &&b| error[a].abs().total_cmp(&error[b].abs())) {
                eprintln!(
                    "{stage_name}: warning: {what} {beyond} at {} of {npoints} point(s), most at point {worst}: {:+.1} ± {:.1} % ({name}_{suffix}{advice}",
                    off.len(),
                    100.0 * error[worst],
                    100.0 * error_std[worst]
                );
            }
        };
        if kind.warned.contains(&name) {
            warn(&|_| true, kind.threshold, kind.significant_only, label, (kind.beyond)(100.0 * kind.threshold), kind.advice);
        } else if kind.landing_warning && name == "bending_energy_belt_removed" {
            warn(
                &|p| by_landing.get(p) == Some(&true),
                MESH_ERROR_WARNING,
                false,
                "e with the belt removed by landing time",
                (kind.beyond)(100.0 * MESH_ERROR_WARNING),
                "). That definition adds a node-scale jitter v_b·δt_land that refinement sharpens, so it does not converge; belt_removal: feed does (pipelines/paper/LAYDOWN_MEASUREMENTS.md)",
            );
        }
        let unit = if name.starts_with("radius") { "m" } else { "1" };
        let words = suffix.replace('_', " ");
        out.f64(&format!("{name}_{run}"), &["point", "replicate"], extra, unit, &format!("{label} at {}", kind.what));
        out.f64(&format!("{name}_{suffix}"), &["point"], Array1::from(error), "1", &format!("{words} of mean {label}")).describe((kind.describe)(name));
        out.f64(&format!("{name}_{suffix}_std"), &["point"], Array1::from(error_std), "1", &format!("s.e. of the {words} of {label}"));
        out.i64(&format!("{name}_{suffix}_pairs"), &["point"], Array1::from(pairs), "1", &format!("pairs in the {words} of {label}"))
            .describe(format!("used replicates whose {} is valid too: the {name}_{suffix} and its s.e. are over these", kind.run_name));
    }
    out.f64(&format!("wall_seconds_{run}"), &["point", "replicate"], per_rep(&format!("wall_seconds_{run}"))?, "s", &format!("wall time of the {}", kind.run_name));
    Ok(())
}

/// The stage output from the per-replicate rows of every point ([`unit_rows`], whole or
/// gathered from the parts of a job array): the replicates placed on the (point,
/// replicate) axes, `used` (the first T valid in replicate order), the shortfall, and the
/// per-point means and standard deviations over the used replicates.
fn assemble(rows: &Output, targets: &[(usize, usize)], stage_name: &str, estimates: Estimates, by_landing: &[bool]) -> Result<Output> {
    use crate::stages::rows as get;
    let nan = f64::NAN;
    let index = get::index(rows)?;
    let npoints = targets.len();
    if let Some(&(p, r)) = index.iter().find(|(p, _)| *p >= npoints) {
        bail!("per-replicate row of point {p} replicate {r}, but the stage has {npoints} points");
    }
    let nreps = index.iter().map(|&(_, r)| r + 1).max().unwrap_or(0);
    let mut attempted = vec![0i64; npoints];
    let mut row_of = Array2::from_elem((npoints, nreps), usize::MAX);
    for (row, &(p, r)) in index.iter().enumerate() {
        if row_of[[p, r]] != usize::MAX {
            bail!("point {p} replicate {r} appears twice in the per-replicate rows");
        }
        row_of[[p, r]] = row;
        attempted[p] += 1;
    }
    for p in 0..npoints {
        if (0..attempted[p] as usize).any(|r| row_of[[p, r]] == usize::MAX) {
            bail!("point {p}: the replicates computed are not 0..{}", attempted[p]);
        }
    }
    let f = |name: &str| -> Result<ndarray::ArrayD<f64>> { Ok(place(get::f64(rows, name)?, &index, npoints, nreps, nan)) };
    let per_rep = |name: &str| -> Result<Array2<f64>> { Ok(f(name)?.into_dimensionality()?) };
    let positions = f("positions")?;
    let laid = f("laid_positions")?;
    let laid_removed = f("laid_positions_belt_removed")?;
    let landing = f("landing_time")?;
    let diag = f("energy_diagnostics")?;
    let valid: Array2<bool> = place(get::u8(rows, "valid")?, &index, npoints, nreps, 0).mapv(|v| v != 0).into_dimensionality()?;
    let (row_reasons, row_errors) = (get::strings(rows, "invalid_reason")?, get::strings(rows, "error")?);
    let s = per_rep("radius_of_gyration")?;
    let e = per_rep("bending_energy")?;
    let s_b = per_rep("radius_of_gyration_belt_removed")?;
    let e_b = per_rep("bending_energy_belt_removed")?;
    let steps = per_rep("steps")?;
    let rollbacks = per_rep("rollbacks")?;
    let wall = per_rep("wall_seconds")?;
    let dt = per_rep("time_step")?;
    let lift = per_rep("max_lift_after_landing")?;
    let final_lift = per_rep("final_lift_of_landed")?;
    let lifted_fraction = per_rep("lifted_fraction")?;
    let laid_length = per_rep("laid_length")?;
    let twist_rate = per_rep("twist_rate")?;
    let laid_twist = per_rep("laid_twist")?;
    let elements = per_rep("elements")?;
    let mut reasons = vec![];
    let mut errors = vec![];
    let mut used = Array2::from_elem((npoints, nreps), false);
    let mut shortfall = vec![];
    for p in 0..npoints {
        let target = if targets[p].0 > 0 { targets[p].0 } else { usize::MAX };
        let mut n_used = 0;
        for r in 0..nreps {
            let row = row_of[[p, r]];
            if row == usize::MAX {
                reasons.push("not attempted".to_string());
                errors.push(String::new());
                continue;
            }
            if valid[[p, r]] && n_used < target {
                used[[p, r]] = true;
                n_used += 1;
            }
            reasons.push(row_reasons[row].clone());
            errors.push(row_errors[row].clone());
        }
        shortfall.push(if targets[p].0 > 0 { targets[p].0.saturating_sub(n_used) as i64 } else { 0 });
    }
    let mut out = Output::new();
    out.strings("xyz", "xyz", vec!["x".into(), "y".into(), "z".into()], "axis").describe("axis: x machine direction (belt motion), y cross direction, z up");
    out.f64("positions", &["point", "replicate", "node", "xyz"], positions, "m", "final node positions");
    out.f64("laid_positions", &["point", "replicate", "laid_node", "xyz"], laid, "m", "laid nodes").describe("landed nodes in fibre order, projected on the belt plane (z = 0)");
    out.f64("laid_positions_belt_removed", &["point", "replicate", "laid_node", "xyz"], laid_removed, "m", "laid nodes, belt removed").describe("landed nodes with the belt motion removed (by belt_removal: landing, x − v_b(t_end − t_land); feed, x + (v_b/v_f)s)");
    out.f64("landing_time", &["point", "replicate", "node"], landing, "s", "landing time").describe("time each node first touched the belt (NaN: never)");
    out.flags("valid", &["point", "replicate"], valid.clone(), "replicate valid").describe("replicate valid: completed and no landed node above bounce_tolerance (see bounce_check)");
    out.flags("used", &["point", "replicate"], used.clone(), "replicate used in the statistics").describe("replicate enters the per-point statistics: the first valid_replicates_target valid ones (all valid ones without a target)");
    out.i64("attempted_replicates", &["point"], Array1::from(attempted), "1", "replicates simulated").describe("replicates simulated per point (the rest of the replicate axis is padding)");
    out.i64("valid_shortfall", &["point"], Array1::from(shortfall), "1", "valid replicates short of the target").describe("valid_replicates_target minus the valid replicates found within max_replicates (0: target met or no target)");
    out.strings_nd("invalid_reason", &["point", "replicate"], Array2::from_shape_vec((npoints, nreps), reasons)?, "why the replicate is invalid (empty: valid)");
    out.strings_nd("error", &["point", "replicate"], Array2::from_shape_vec((npoints, nreps), errors)?, "numerical failure of the replicate (empty: none)");
    let metrics = [
        ("radius_of_gyration", &s, "m", "S of the laid fibre (eq 5)"),
        ("bending_energy", &e, "1", "e = V_b L / EI of the laid fibre (eq 6)"),
        ("radius_of_gyration_belt_removed", &s_b, "m", "S with the belt motion removed (Fig 5 dashed)"),
        ("bending_energy_belt_removed", &e_b, "1", "e with the belt motion removed (Fig 6 dashed)"),
    ];
    for (name, values, unit, long) in metrics {
        let label = metric_label(name);
        out.f64(name, &["point", "replicate"], values.clone(), unit, label).describe(long);
        let (mut means, mut stds, mut counts) = (vec![], vec![], vec![]);
        for p in 0..npoints {
            let (m, sd, n) = mean_std((0..nreps).filter(|&r| used[[p, r]]).map(|r| values[[p, r]]));
            means.push(m);
            stds.push(sd);
            counts.push(n as i64);
        }
        out.f64(&format!("{name}_mean"), &["point"], Array1::from(means), unit, &format!("mean {label}")).describe(format!("mean over the used (valid) replicates of {long}"));
        out.f64(&format!("{name}_std"), &["point"], Array1::from(stds), unit, &format!("std of {label}")).describe(format!("sample standard deviation over the used (valid) replicates of {long}"));
        if name == "radius_of_gyration" {
            out.i64("valid_replicates", &["point"], Array1::from(counts), "1", "valid replicates used").describe("number of valid replicates entering the statistics per point (the `used` ones)");
        }
    }
    if estimates.mesh {
        add_error_estimate(&mut out, &ErrorEstimate::mesh(), &per_rep, &used, [&s, &e, &s_b, &e_b], stage_name, by_landing)?;
    }
    if estimates.step {
        add_error_estimate(&mut out, &ErrorEstimate::step(), &per_rep, &used, [&s, &e, &s_b, &e_b], stage_name, by_landing)?;
    }
    out.f64("steps", &["point", "replicate"], steps, "1", "time steps taken");
    out.f64("rollbacks", &["point", "replicate"], rollbacks, "1", "rollbacks after failed steps").describe("times the run went back to a checkpoint after a step failed even at the smallest size and retook the stretch with the recovery scheme (parameter rollbacks, src/rod/recovery.rs); 0: no step failed");
    out.f64("time_step", &["point", "replicate"], dt, "s", "time step").describe("time step used (largest allowed for adaptive schemes)");
    out.f64("wall_seconds", &["point", "replicate"], wall, "s", "wall time of the replicate");
    out.f64("max_lift_after_landing", &["point", "replicate"], lift, "m", "highest rise after landing").describe("highest rise of a landed node above the belt at any time after its landing (bounce_check = transient)");
    out.f64("final_lift_of_landed", &["point", "replicate"], final_lift, "m", "highest landed node at the end").describe("highest landed node above the belt in the final profile (bounce_check = final)");
    out.f64("lifted_fraction", &["point", "replicate"], lifted_fraction, "1", "lifted share of the last period").describe("share of the last oscillation period in which a landed node stood above bounce_tolerance (bounce_check = last_period invalidates above 0.5; NaN with the other checks)");
    out.f64("laid_length", &["point", "replicate"], laid_length, "m", "arc length of the laid fibre");
    out.f64("twist_rate", &["point", "replicate"], twist_rate, "rad/m", "twist rate of the hanging fibre at the end").describe("effects.twist: twist rate Ω of the span between the clamped feed and the laid fibre at the end of the run (src/rod/twist.rs); 0 without twist");
    out.f64("laid_twist", &["point", "replicate"], laid_twist, "rad", "twist laid with the fibre").describe("effects.twist: total twist Σ τ the landings laid down with the fibre (rad; 2π is one turn); 0 without twist");
    out.f64("elements", &["point", "replicate"], elements, "1", "rod elements used (after coil_resolution)");
    out.strings(
        "diagnostic",
        "diagnostic",
        ENERGY_COLUMNS.iter().map(|c| c.0.to_string()).collect(),
        "energy diagnostic",
    )
    .describe("energy diagnostic: time (s), energies and cumulative work (J)");
    out.f64("energy_diagnostics", &["point", "replicate", "record", "diagnostic"], diag, "J", "energy diagnostics").describe("energy diagnostics every diagnostic_stride steps (the `time` column is in s)");
    Ok(out)
}
