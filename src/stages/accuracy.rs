//! `kind: accuracy` — what accuracy costs in time.
//!
//! The first input is the reference (a converged run with one sweep point); every
//! further input is a set of candidates (each of its sweep points is one candidate,
//! e.g. an element-count sweep of the fast scheme). For each candidate and metric the
//! stage records the value, its relative error against the reference, and the wall
//! time per unit of work (replicate or realisation), so a researcher can pick a
//! resolution with both numbers in view. It writes a markdown table beside the
//! archive (`accuracy_cost.md` in the stage's figure directory) and prints it.
//!
//! Metrics are per-point datasets `<metric>_mean` of the inputs (laydown:
//! `radius_of_gyration`, `bending_energy`, ...; grid: `mean_areal_density`, `cv`); the
//! time is the input's `wall_seconds` averaged over everything but the point, or the
//! version's wall time divided by its points when a stage records none per unit.
//! Errors of means over a few random replicates include their sampling error: compare
//! candidates against a reference with the same seed and replicates, and read errors
//! below the replicate scatter (`<metric>_std / sqrt(n)`) as "converged".
use super::{BadInput, Input, InputRule, RunContext, Stage};
use crate::archive::data::Output;
use crate::archive::hdf;
use crate::params::{ParamSet, ParamSpec};
use anyhow::Result;
use ndarray::{Array1, Array2};

pub struct AccuracyStage;

/// One candidate: a sweep point of a candidate input.
struct Candidate {
    stage: String,
    point: usize,
    label: String,
    values: Vec<f64>,
    wall_seconds: f64,
}

fn bad(msg: String) -> anyhow::Error {
    anyhow::Error::new(BadInput(msg))
}

/// Per-point values of `metric` in an input version.
fn metric(input: &Input, metric: &str) -> Result<Vec<f64>> {
    let name = format!("{metric}_mean");
    if !input.has(&name) {
        return Err(bad(format!(
            "input `{}` (kind {}) has no per-point `{name}`; choose metrics it records (e.g. laydown: radius_of_gyration, bending_energy; grid: mean_areal_density, cv)",
            input.name, input.kind
        )));
    }
    Ok(input.read_f64(&name)?.iter().copied().collect())
}

/// Mean wall time per unit of work at each of `points` points.
fn wall_per_point(input: &Input, points: usize) -> Result<Vec<f64>> {
    if input.has("wall_seconds") {
        let w = input.read_f64("wall_seconds")?;
        if w.ndim() >= 1 && w.shape()[0] == points {
            return Ok(w
                .outer_iter()
                .map(|row| {
                    let finite: Vec<f64> = row.iter().copied().filter(|v| v.is_finite()).collect();
                    finite.iter().sum::<f64>() / finite.len().max(1) as f64
                })
                .collect());
        }
    }
    let total = input.version.attr_f64("wall_seconds").unwrap_or(f64::NAN);
    Ok(vec![total / points as f64; points])
}

fn default_metrics(kind: &str) -> Vec<String> {
    match kind {
        "laydown" => vec!["radius_of_gyration".into(), "bending_energy".into()],
        "grid" => vec!["mean_areal_density".into(), "cv".into()],
        _ => vec![],
    }
}

/// The markdown table of a run.
fn table(metrics: &[String], reference: &[f64], reference_wall: f64, cands: &[Candidate]) -> String {
    let mut t = String::from("| candidate | setting | wall per unit (s) | speed-up |");
    for m in metrics {
        t += &format!(" {m} | error |");
    }
    t += "\n|---|---|---:|---:|";
    for _ in metrics {
        t += "---:|---:|";
    }
    t += &format!("\n| reference | | {reference_wall:.3} | 1 |");
    for r in reference {
        t += &format!(" {} | |", sig(*r));
    }
    for c in cands {
        t += &format!(
            "\n| {} | {} | {:.3} | {:.1} |",
            c.stage,
            if c.label.is_empty() { format!("point {}", c.point) } else { c.label.clone() },
            c.wall_seconds,
            reference_wall / c.wall_seconds
        );
        for (v, r) in c.values.iter().zip(reference) {
            t += &format!(" {} | {:+.2} % |", sig(*v), 100.0 * (v - r) / r.abs());
        }
    }
    t + "\n"
}

/// Four significant digits.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

impl Stage for AccuracyStage {
    fn kind(&self) -> &'static str {
        "accuracy"
    }
    fn summary(&self) -> &'static str {
        "what accuracy costs in time: each candidate's error against a reference input, next to its wall time per unit"
    }
    fn cache_version(&self) -> u32 {
        1
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::text_list(
            "metrics",
            "per-point quantities to compare (`<name>_mean` in every input); empty: laydown radius_of_gyration, bending_energy; grid mean_areal_density, cv",
        )]
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["laydown", "grid", "spectra", "web", "image"], min: 2, max: 64 }
    }
    fn check(&self, _p: &ParamSet) -> std::result::Result<(), (String, String)> {
        Ok(())
    }
    fn run(&self, ctx: &RunContext) -> Result<Output> {
        if ctx.points.len() != 1 || ctx.replicates != 1 {
            return Err(bad("an accuracy stage compares its inputs; it takes no sweep and no replicates".into()));
        }
        let reference = ctx.input(0);
        let mut metrics: Vec<String> = ctx.points[0].text_list("metrics").to_vec();
        if metrics.is_empty() {
            metrics = default_metrics(&reference.kind);
        }
        if metrics.is_empty() {
            return Err(bad(format!("give `metrics`: there is no default for a reference of kind {}", reference.kind)));
        }
        let ref_values: Vec<Vec<f64>> = metrics.iter().map(|m| metric(reference, m)).collect::<Result<_>>()?;
        if ref_values[0].len() != 1 {
            return Err(bad(format!(
                "the reference `{}` has {} sweep points; it must be one converged run (the first input)",
                reference.name,
                ref_values[0].len()
            )));
        }
        let reference_values: Vec<f64> = ref_values.iter().map(|v| v[0]).collect();
        let reference_wall = wall_per_point(reference, 1)?[0];

        let mut cands = vec![];
        for input in &ctx.inputs[1..] {
            let values: Vec<Vec<f64>> = metrics.iter().map(|m| metric(input, m)).collect::<Result<_>>()?;
            let points = values[0].len();
            let wall = wall_per_point(input, points)?;
            let swept = hdf::swept_coordinates(&input.version.open()?);
            for p in 0..points {
                cands.push(Candidate {
                    stage: input.name.clone(),
                    point: p,
                    label: hdf::point_label(&swept, p),
                    values: values.iter().map(|v| v[p]).collect(),
                    wall_seconds: wall[p],
                });
            }
        }

        let n = cands.len();
        let mut out = Output::new();
        out.strings("metric", "metric", metrics.clone(), "compared quantity (`<metric>_mean` of the inputs)");
        out.strings("candidate_stage", "candidate", cands.iter().map(|c| c.stage.clone()).collect(), "input stage of the candidate");
        out.i64("candidate_point", &["candidate"], Array1::from_iter(cands.iter().map(|c| c.point as i64)), "1", "sweep point of the candidate in its stage");
        out.strings("candidate_label", "candidate", cands.iter().map(|c| c.label.clone()).collect(), "swept parameters of the candidate");
        out.f64("reference_value", &["metric"], Array1::from(reference_values.clone()), "", "value of the reference");
        out.f64("reference_wall_seconds", &[], ndarray::arr0(reference_wall), "s", "wall time per unit of the reference");
        let value = Array2::from_shape_fn((n, metrics.len()), |(c, m)| cands[c].values[m]);
        let error = Array2::from_shape_fn((n, metrics.len()), |(c, m)| (cands[c].values[m] - reference_values[m]) / reference_values[m].abs());
        out.f64("value", &["candidate", "metric"], value, "", "candidate's value (units of the metric)");
        out.f64("relative_error", &["candidate", "metric"], error, "1", "(candidate - reference) / |reference|");
        out.f64("wall_seconds", &["candidate"], Array1::from_iter(cands.iter().map(|c| c.wall_seconds)), "s", "wall time per unit of work (replicate, realisation)");
        out.f64("speedup", &["candidate"], Array1::from_iter(cands.iter().map(|c| reference_wall / c.wall_seconds)), "1", "reference wall time / candidate wall time");

        let md = table(&metrics, &reference_values, reference_wall, &cands);
        eprint!("{}", md.lines().map(|l| format!("{}: {l}\n", ctx.stage_name)).collect::<String>());
        std::fs::create_dir_all(&ctx.figure_dir)?;
        let path = ctx.figure_dir.join("accuracy_cost.md");
        std::fs::write(&path, format!("# What accuracy costs: `{}` against `{}`\n\n{md}", ctx.stage_name, reference.name))?;
        eprintln!("{}: table {}", ctx.stage_name, path.display());
        out.set_attr("table_markdown", md);
        out.set_attr("reference", reference.name.clone());
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_has_errors_and_speedups() {
        let c = Candidate { stage: "fast".into(), point: 0, label: "elements = 250".into(), values: vec![1.1, 2.0], wall_seconds: 0.5 };
        let t = table(&["s".into(), "e".into()], &[1.0, 2.0], 5.0, &[c]);
        assert!(t.contains("| fast | elements = 250 | 0.500 | 10.0 | 1.100 | +10.00 % | 2.000 | +0.00 % |"), "{t}");
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(0.015432), "0.01543");
        assert_eq!(sig(11397.2), "11397");
        assert_eq!(sig(1.5), "1.500");
    }
}
