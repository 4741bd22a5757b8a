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
use super::params::{BounceCheck, Effects, Integrator, LaydownParams, ParamKind as LKind, PARAMETERS};
use super::{laid_polyline, simulate, LaydownResult};
use crate::archive::data::Output;
use crate::params::{ParamKind, ParamSet, ParamSpec, ParamValue};
use crate::stages::{InputRule, RunContext, Stage};
use anyhow::Result;
use ndarray::{Array1, Array2, Array3, Array4};
use rayon::prelude::*;

/// Stage-level parameters (not scene parameters): the valid-replicate target and its cap.
const TARGET: &str = "valid_replicates_target";
const CAP: &str = "max_replicates";

pub struct LaydownStage;

/// The scene of one sweep point, from its resolved parameters (names are the fields of
/// [`LaydownParams`]; `effects.X` are the [`Effects`] flags).
pub fn scene(p: &ParamSet) -> Result<LaydownParams, String> {
    let mut root = serde_json::Map::new();
    let mut effects = serde_json::Map::new();
    for (name, value) in &p.0 {
        let v = match value {
            ParamValue::Float(f) => serde_json::json!(f),
            ParamValue::Int(i) => serde_json::json!(i),
            ParamValue::Bool(b) => serde_json::json!(b),
            ParamValue::Text(s) => serde_json::json!(s),
            ParamValue::List(v) => serde_json::json!(v),
            ParamValue::Auto => serde_json::Value::Null,
        };
        if name == TARGET || name == CAP {
            continue;
        }
        match name.strip_prefix("effects.") {
            Some(flag) => effects.insert(flag.to_string(), v),
            None => root.insert(name.clone(), v),
        };
    }
    root.insert("effects".into(), serde_json::Value::Object(effects));
    serde_json::from_value(serde_json::Value::Object(root)).map_err(|e| e.to_string())
}

impl Stage for LaydownStage {
    fn kind(&self) -> &'static str {
        "laydown"
    }
    fn summary(&self) -> &'static str {
        "one fibre fed onto a moving belt: geometrically nonlinear rod with drag, oscillation, contact and friction (paper §2)"
    }
    fn cache_version(&self) -> u32 {
        2
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &[], min: 0, max: 0 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v: Vec<ParamSpec> = PARAMETERS
            .iter()
            .map(|p| ParamSpec {
                name: p.name,
                unit: p.unit,
                kind: match p.kind {
                    LKind::Real => ParamKind::Float { min: p.min, max: p.max },
                    LKind::Integer => ParamKind::Int { min: p.min as i64, max: p.max as i64 },
                },
                default: match p.kind {
                    LKind::Real => ParamValue::Float(p.default),
                    LKind::Integer => ParamValue::Int(p.default as i64),
                },
                auto: false,
                doc: p.doc,
            })
            .collect();
        v.push(ParamSpec::choice(
            "integrator",
            &Integrator::NAMES,
            Integrator::default().name(),
            "time integration: explicit (reference), implicit_axial (fast), inextensible",
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
        v.push(ParamSpec::choice(
            "bounce_check",
            &BounceCheck::NAMES,
            BounceCheck::default().name(),
            "final: a landed node above bounce_tolerance in the final profile invalidates the replicate (the paper's test); transient: at any time after landing",
        ));
        let defaults = Effects::default();
        let on = serde_json::to_value(defaults).unwrap();
        for (flag, doc) in Effects::FLAGS {
            let name: &'static str = Box::leak(format!("effects.{flag}").into_boxed_str());
            v.push(ParamSpec::flag(name, on[flag].as_bool().unwrap_or(true), doc));
        }
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), (String, String)> {
        let (target, cap) = (p.int(TARGET), p.int(CAP));
        if target > 0 && cap < target {
            return Err((CAP.to_string(), format!("max_replicates ({cap}) must be at least valid_replicates_target ({target})")));
        }
        let scene = scene(p).map_err(|e| ("integrator".to_string(), e))?;
        scene.validate().map_err(|e| {
            let name = match &e {
                super::ParamError::OutOfRange { name, .. } | super::ParamError::NotFinite { name, .. } => name.to_string(),
                _ => "laydown_height".to_string(),
            };
            (name, e.to_string())
        })
    }

    fn run(&self, ctx: &RunContext) -> Result<Output> {
        let scenes: Vec<LaydownParams> = ctx.points.iter().map(|p| scene(p).expect("checked")).collect();
        let targets: Vec<(usize, usize)> = ctx.points.iter().map(|p| (p.usize(TARGET), p.usize(CAP))).collect();
        let results = run_until_valid(&scenes, &targets, ctx.replicates, ctx.progress, &ctx.stage_name, |p, r| {
            simulate(&scenes[p], &mut ctx.rng(r, 0))
        });
        Ok(assemble(&scenes, &results, &targets))
    }
    /// Points are independent (every replicate's random stream is keyed by seed and
    /// replicate only, not by the point), and `assemble` stacks them along `point` and
    /// `run` (point * replicates + replicate), padding ragged node counts with NaN.
    fn point_dims(&self) -> &'static [&'static str] {
        &["point", "run"]
    }
}

/// Replicates per point: first 0..`replicates` for every point, then, for each point
/// with a target (T, cap) not yet met, further rounds of replicate indices continuing
/// from the last one attempted. The size of a round is (T − valid)/(valid fraction so
/// far, at least ¼), capped; it depends only on earlier results, so the set of runs and
/// the output are independent of the number of threads. `sim(point, replicate)` must be
/// a pure function of its arguments.
pub(crate) fn run_until_valid(
    scenes: &[LaydownParams],
    targets: &[(usize, usize)],
    replicates: usize,
    progress: bool,
    stage_name: &str,
    sim: impl Fn(usize, usize) -> LaydownResult + Sync + Send,
) -> Vec<Vec<LaydownResult>> {
    let npoints = scenes.len();
    let mut results: Vec<Vec<LaydownResult>> = vec![Vec::new(); npoints];
    let mut jobs: Vec<(usize, usize)> = (0..npoints).flat_map(|p| (0..replicates).map(move |r| (p, r))).collect();
    let mut round = 0;
    while !jobs.is_empty() {
        let label = if round == 0 { format!("{stage_name} units") } else { format!("{stage_name} extra {round}") };
        let bar = crate::progress::bar(progress, jobs.len() as u64, &label);
        let out: Vec<LaydownResult> = jobs
            .par_iter()
            .map(|&(p, r)| {
                let res = sim(p, r);
                bar.inc(1);
                res
            })
            .collect();
        bar.finish_and_clear();
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
            let valid = results[p].iter().filter(|r| r.valid && r.error.is_none()).count();
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

fn assemble(scenes: &[LaydownParams], results: &[Vec<LaydownResult>], targets: &[(usize, usize)]) -> Output {
    let nan = f64::NAN;
    let npoints = results.len();
    let nreps = results.iter().map(|r| r.len()).max().unwrap_or(0);
    let nodes = results.iter().flatten().map(|r| r.positions.len()).max().unwrap_or(0);
    let ndiag = results.iter().flatten().map(|r| r.diagnostics.len()).max().unwrap_or(0);
    let mut positions = Array4::from_elem((npoints, nreps, nodes, 3), nan);
    let mut laid = positions.clone();
    let mut laid_removed = positions.clone();
    let mut landing = Array3::from_elem((npoints, nreps, nodes), nan);
    let mut valid = Array2::from_elem((npoints, nreps), false);
    let per_rep = |f: &dyn Fn(&LaydownResult) -> f64| {
        Array2::from_shape_fn((npoints, nreps), |(p, r)| results[p].get(r).map_or(nan, f))
    };
    let ok = |r: &LaydownResult, v: f64| if r.error.is_none() { v } else { f64::NAN };
    let s = per_rep(&|r| ok(r, r.radius_of_gyration));
    let e = per_rep(&|r| ok(r, r.bending_energy));
    let s_b = per_rep(&|r| ok(r, r.radius_of_gyration_belt_removed));
    let e_b = per_rep(&|r| ok(r, r.bending_energy_belt_removed));
    let steps = per_rep(&|r| r.steps as f64);
    let wall = per_rep(&|r| r.wall_seconds);
    let dt = per_rep(&|r| r.time_step);
    let lift = per_rep(&|r| r.max_lift_after_landing);
    let final_lift = per_rep(&|r| r.final_lift_of_landed);
    let laid_length = per_rep(&|r| r.laid_length);
    let elements = per_rep(&|r| r.elements as f64);
    let mut diag = Array4::from_elem((npoints, nreps, ndiag, 8), nan);
    let mut reasons = vec![];
    let mut errors = vec![];
    let mut used = Array2::from_elem((npoints, nreps), false);
    let mut attempted = vec![];
    let mut shortfall = vec![];
    for p in 0..npoints {
        attempted.push(results[p].len() as i64);
        let target = if targets[p].0 > 0 { targets[p].0 } else { usize::MAX };
        let mut n_used = 0;
        for r in 0..nreps {
            let Some(res) = results[p].get(r) else {
                reasons.push("not attempted".to_string());
                errors.push(String::new());
                continue;
            };
            valid[[p, r]] = res.valid && res.error.is_none();
            if valid[[p, r]] && n_used < target {
                used[[p, r]] = true;
                n_used += 1;
            }
            reasons.push(res.invalid_reason.clone().unwrap_or_default());
            errors.push(res.error.clone().unwrap_or_default());
            for (i, x) in res.positions.iter().enumerate() {
                for k in 0..3 {
                    positions[[p, r, i, k]] = x[k];
                }
                landing[[p, r, i]] = res.landing_time[i];
            }
            let t_end = res.end_time;
            for (i, x) in laid_polyline(&res.positions, &res.landing_time, None).iter().enumerate() {
                for k in 0..3 {
                    laid[[p, r, i, k]] = x[k];
                }
            }
            let removed = laid_polyline(&res.positions, &res.landing_time, Some((scenes[p].belt_speed, t_end)));
            for (i, x) in removed.iter().enumerate() {
                for k in 0..3 {
                    laid_removed[[p, r, i, k]] = x[k];
                }
            }
            for (i, d) in res.diagnostics.iter().enumerate() {
                let w = &d.work;
                let row = [d.time, d.kinetic, d.elastic, w.drag, w.friction, w.gravity, w.oscillation, w.damping];
                for (k, v) in row.iter().enumerate() {
                    diag[[p, r, i, k]] = *v;
                }
            }
        }
        shortfall.push(if targets[p].0 > 0 { targets[p].0.saturating_sub(n_used) as i64 } else { 0 });
    }
    let mut out = Output::new();
    out.strings("xyz", "xyz", vec!["x".into(), "y".into(), "z".into()], "axis: x machine direction (belt motion), y cross direction, z up");
    out.f64("positions", &["point", "replicate", "node", "xyz"], positions, "m", "final node positions");
    out.f64("laid_positions", &["point", "replicate", "laid_node", "xyz"], laid, "m", "landed nodes in fibre order, projected on the belt plane (z = 0)");
    out.f64("laid_positions_belt_removed", &["point", "replicate", "laid_node", "xyz"], laid_removed, "m", "landed nodes with the belt motion removed: x - v_belt (t_end - landing_time)");
    out.f64("landing_time", &["point", "replicate", "node"], landing, "s", "time each node first touched the belt (NaN: never)");
    out.flags("valid", &["point", "replicate"], valid.clone(), "replicate valid: completed and no landed node above bounce_tolerance (see bounce_check)");
    out.flags("used", &["point", "replicate"], used.clone(), "replicate enters the per-point statistics: the first valid_replicates_target valid ones (all valid ones without a target)");
    out.i64("attempted_replicates", &["point"], Array1::from(attempted), "1", "replicates simulated per point (the rest of the replicate axis is padding)");
    out.i64("valid_shortfall", &["point"], Array1::from(shortfall), "1", "valid_replicates_target minus the valid replicates found within max_replicates (0: target met or no target)");
    out.strings("invalid_reason", "run", reasons, "why a replicate is invalid, per run = point * replicates + replicate (empty: valid)");
    out.strings("error", "run", errors, "numerical failure of a replicate, per run = point * replicates + replicate (empty: none)");
    let metrics = [
        ("radius_of_gyration", &s, "m", "S of the laid fibre (eq 5)"),
        ("bending_energy", &e, "1", "e = V_b L / EI of the laid fibre (eq 6)"),
        ("radius_of_gyration_belt_removed", &s_b, "m", "S with the belt motion removed (Fig 5 dashed)"),
        ("bending_energy_belt_removed", &e_b, "1", "e with the belt motion removed (Fig 6 dashed)"),
    ];
    for (name, values, unit, long) in metrics {
        out.f64(name, &["point", "replicate"], values.clone(), unit, long);
        let (mut means, mut stds, mut counts) = (vec![], vec![], vec![]);
        for p in 0..npoints {
            let (m, sd, n) = mean_std((0..nreps).filter(|&r| used[[p, r]]).map(|r| values[[p, r]]));
            means.push(m);
            stds.push(sd);
            counts.push(n as i64);
        }
        out.f64(&format!("{name}_mean"), &["point"], Array1::from(means), unit, &format!("mean over the used (valid) replicates of {long}"));
        out.f64(&format!("{name}_std"), &["point"], Array1::from(stds), unit, &format!("sample standard deviation over the used (valid) replicates of {long}"));
        if name == "radius_of_gyration" {
            out.i64("valid_replicates", &["point"], Array1::from(counts), "1", "number of valid replicates entering the statistics per point (the `used` ones)");
        }
    }
    out.f64("steps", &["point", "replicate"], steps, "1", "time steps taken");
    out.f64("time_step", &["point", "replicate"], dt, "s", "time step used (largest allowed for adaptive schemes)");
    out.f64("wall_seconds", &["point", "replicate"], wall, "s", "wall time of the replicate");
    out.f64("max_lift_after_landing", &["point", "replicate"], lift, "m", "highest rise of a landed node above the belt at any time after its landing (bounce_check = transient)");
    out.f64("final_lift_of_landed", &["point", "replicate"], final_lift, "m", "highest landed node above the belt in the final profile (bounce_check = final)");
    out.f64("laid_length", &["point", "replicate"], laid_length, "m", "arc length of the laid fibre");
    out.f64("elements", &["point", "replicate"], elements, "1", "rod elements used (after coil_resolution)");
    out.strings(
        "diagnostic",
        "diagnostic",
        ["time", "kinetic", "elastic", "work_drag", "work_friction", "work_gravity", "work_oscillation", "work_damping"].iter().map(|s| s.to_string()).collect(),
        "energy diagnostic: time (s), energies and cumulative work (J)",
    );
    out.f64("energy_diagnostics", &["point", "replicate", "record", "diagnostic"], diag, "J", "energy diagnostics every diagnostic_stride steps (the `time` column is in s)");
    out
}
