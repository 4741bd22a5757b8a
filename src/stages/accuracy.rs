//! `kind: accuracy` — what accuracy costs in time.
//!
//! The first input is the reference (a converged run with one sweep point); every
//! further input is a set of candidates (each of its sweep points is one candidate,
//! e.g. an element-count sweep of the fast scheme). With `references: k` the first k
//! inputs (one sweep point each, of one kind) are pooled as the reference: its value is
//! the mean over all their units (Σ n_j m_j / Σ n_j of their means), so that runs of a
//! reference on several seeds, or at two steps that agree, measure it more closely than
//! one; its wall time is the first's. A candidate is never paired with a pooled
//! reference. For each candidate and metric the
//! stage records the value, its relative error against the reference, and the wall
//! time per unit of work (replicate or realisation), so a researcher can pick a
//! resolution with both numbers in view. It writes a markdown table beside the
//! archive (`accuracy_cost.md` in the stage's figure directory) and prints it.
//!
//! Metrics are per-point datasets `<metric>_mean` of the inputs (laydown:
//! `radius_of_gyration`, `bending_energy`, ...; grid: `mean_areal_density`, `cv`;
//! image, with one condition: `cv_corr`, `cv_corr_plain`); the time is the
//! input's `wall_seconds` averaged over everything but the point (per replicate,
//! realisation or image), or the version's wall time divided by its points when a stage
//! records none per unit.
//! Errors of means over a few random replicates include their sampling error, so each
//! error comes with the standard error of the difference (`relative_error_standard_error`,
//! "± … %" in the table) from the inputs' per-unit values (`<metric>` with the point
//! first; units not in the mean, by `used` or `valid`, left out; a laid web's fibres
//! averaged per web). When the reference and the candidate are of one kind and the same
//! units enter both means, unit i of one is paired with unit i of the other
//! (`paired_units`): with the same seed the pairs share their random draws and the
//! paired error is far smaller than either's scatter (with different seeds it is as
//! large as the unpaired one, and still right). Otherwise it is √(s_r²/n_r + s_c²/n_c).
//! An error within its standard error times Student's t is not resolved by the
//! replicates: read it as "converged" or add replicates. With n pairs t has n − 1
//! degrees of freedom: 12.7 for 2 pairs, 3.2 for 4, 2.4 for 8, 2.1 for 16 (95 %).
//! It reads only per-point values, so it makes no memory estimate
//! ([`Stage::estimate_memory`]).
use crate::error::InvalidParam;
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
    /// Per metric: the standard error of the difference from the reference (in the
    /// metric's units; NaN without per-unit values) and the pairs it used (0: unpaired).
    standard_errors: Vec<(f64, usize)>,
    wall_seconds: f64,
}

fn bad(msg: String) -> anyhow::Error {
    anyhow::Error::new(BadInput(msg))
}

/// Number of sweep points of an input version (1 without a `point` dimension).
fn points_of(input: &Input) -> Result<usize> {
    let g = input.version.open()?;
    Ok(match g.dataset("point") {
        Ok(ds) => ds.size(),
        Err(_) => 1,
    })
}

/// Per-point values of `metric` in an input version: `<metric>_mean` must hold one
/// value per sweep point (dimensions (point) or (point, 1), or a single value).
fn metric(input: &Input, metric: &str, points: usize) -> Result<Vec<f64>> {
    let name = format!("{metric}_mean");
    if !input.has(&name) {
        return Err(bad(format!(
            "input `{}` (kind {}) has no per-point `{name}`; choose metrics it records (e.g. laydown: radius_of_gyration, bending_energy; grid: mean_areal_density, cv; image: cv_corr, cv_corr_plain)",
            input.name, input.kind
        )));
    }
    let values = input.read_f64(&name)?;
    if values.len() != points {
        return Err(bad(format!(
            "`{name}` of input `{}` has shape {:?}, not one value per sweep point ({points}); an image stage compared here must have one condition (e.g. one grid point)",
            input.name,
            values.shape()
        )));
    }
    Ok(values.iter().copied().collect())
}

/// Per-unit values of a metric at each sweep point ([`units`]).
struct Units {
    /// One row per point: a value per unit, NaN where the unit is not in the mean.
    rows: Vec<Vec<f64>>,
    /// Values that enter `<metric>_mean` at each point (a laid web's fibres, not its webs).
    counts: Vec<usize>,
}

/// Per-unit values of `metric` in an input version of `points` points, one row per point:
/// the dataset `<metric>` with the point first (replicates or realisations after it), NaN
/// where a unit does not enter `<metric>_mean` (`used`, else `valid`). A laid web's fibres
/// are averaged per web (fibres of one web can be correlated: fibre contact, coherent
/// turbulence), so its units are webs. None when the input records no such dataset, or
/// when it has axes its flags do not cover (not one value per unit).
fn units(input: &Input, metric: &str, points: usize) -> Result<Option<Units>> {
    if !input.has(metric) {
        return Ok(None);
    }
    let mut values = input.read_f64(metric)?;
    if values.ndim() < 2 || values.shape()[0] != points {
        return Ok(None);
    }
    let flagged: Vec<&str> = ["used", "valid"].into_iter().filter(|m| input.has(m)).collect();
    if !flagged.is_empty() {
        let mut mask = None;
        for name in flagged {
            let flags = input.read_u8(name)?;
            if flags.shape() == values.shape() {
                mask = Some(flags);
                break;
            }
        }
        let Some(mask) = mask else { return Ok(None) };
        values.zip_mut_with(&mask, |x, keep| {
            if *keep == 0 {
                *x = f64::NAN;
            }
        });
    }
    let per_web = input.kind == "laid_web" && values.ndim() == 3;
    let finite = |v: ndarray::ArrayViewD<f64>| v.iter().copied().filter(|x| x.is_finite()).collect::<Vec<_>>();
    Ok(Some(Units {
        counts: values.outer_iter().map(|row| row.iter().filter(|x| x.is_finite()).count()).collect(),
        rows: values
            .outer_iter()
            .map(|row| if per_web { row.outer_iter().map(|web| crate::stages::mean_std(&finite(web)).0).collect() } else { row.iter().copied().collect() })
            .collect(),
    }))
}

/// The reference: the first `references` inputs pooled, each one sweep point of one kind.
struct Reference {
    stages: Vec<String>,
    /// Per metric: the mean over every unit of the pooled inputs (with one input, its
    /// `<metric>_mean`), and the pooled per-unit values (None where an input records none).
    values: Vec<f64>,
    units: Vec<Option<Vec<f64>>>,
    /// Wall time per unit of the first input (pooled inputs may differ in cost, e.g. a
    /// run at half the step).
    wall_seconds: f64,
}

/// Pool `inputs` (the first `references` of a stage) as the reference for
/// `reference_metrics`. Each value is Σ n_j m_j / Σ n_j over the inputs' recorded means
/// m_j of n_j units, so one input gives its own mean exactly; pooling several needs
/// their per-unit values.
fn pooled_reference(inputs: &[Input], reference_metrics: &[String]) -> Result<Reference> {
    let first = &inputs[0];
    for input in inputs {
        let points = points_of(input)?;
        if points != 1 {
            return Err(bad(format!(
                "the reference `{}` has {points} sweep points; it must be one converged run (each of the first `references` inputs)",
                input.name
            )));
        }
        if input.kind != first.kind {
            return Err(bad(format!(
                "the pooled references must be of one kind: `{}` is {}, `{}` is {}",
                first.name, first.kind, input.name, input.kind
            )));
        }
    }
    let mut values = vec![];
    let mut pooled_units = vec![];
    for m in reference_metrics {
        let means: Vec<f64> = inputs.iter().map(|i| Ok(metric(i, m, 1)?[0])).collect::<Result<_>>()?;
        let units: Vec<Option<Units>> = inputs.iter().map(|i| units(i, m, 1)).collect::<Result<_>>()?;
        if inputs.len() == 1 {
            values.push(means[0]);
            pooled_units.push(units.into_iter().next().flatten().map(|mut u| u.rows.remove(0)));
            continue;
        }
        let (mut sum, mut count, mut all) = (0.0, 0usize, vec![]);
        for ((input, mean), u) in inputs.iter().zip(&means).zip(units) {
            let Some(mut u) = u else {
                return Err(bad(format!(
                    "input `{}` records no per-unit `{m}` (one value per replicate or realisation); pooled references need them to weigh each input's mean",
                    input.name
                )));
            };
            if u.counts[0] > 0 {
                sum += u.counts[0] as f64 * mean;
                count += u.counts[0];
            }
            all.append(&mut u.rows[0]);
        }
        values.push(sum / count as f64);
        pooled_units.push(Some(all));
    }
    Ok(Reference { stages: inputs.iter().map(|i| i.name.clone()).collect(), values, units: pooled_units, wall_seconds: wall_per_point(first, 1)?[0] })
}

/// Standard error of the candidate's mean minus the reference's, from their per-unit
/// values (NaN: unit left out), and the pairs it used. Paired (`pair`, and the same units
/// present in both, so that the error of the means is the mean of the differences): the
/// standard error of the mean difference. Otherwise (0 pairs) √(s_r²/n_r + s_c²/n_c). NaN
/// with fewer than two units (pairs) on a side.
fn difference_standard_error(reference: &[f64], candidate: &[f64], pair: bool) -> (f64, usize) {
    fn variance_of_mean(v: impl Iterator<Item = f64>) -> (f64, usize) {
        let v: Vec<f64> = v.collect();
        if v.len() < 2 {
            return (f64::NAN, v.len());
        }
        let (_, sd) = super::mean_std(&v);
        (sd * sd / v.len() as f64, v.len())
    }
    let same_units = reference.len() == candidate.len() && reference.iter().zip(candidate).all(|(a, b)| a.is_finite() == b.is_finite());
    if pair && same_units {
        let (var, n) = variance_of_mean(reference.iter().zip(candidate).filter(|(a, b)| a.is_finite() && b.is_finite()).map(|(a, b)| b - a));
        return (var.sqrt(), n);
    }
    let (var_r, _) = variance_of_mean(reference.iter().copied().filter(|x| x.is_finite()));
    let (var_c, _) = variance_of_mean(candidate.iter().copied().filter(|x| x.is_finite()));
    ((var_r + var_c).sqrt(), 0)
}

/// Mean wall time per unit of work at each of `points` points: `wall_seconds` averaged
/// over everything but the point (over everything for a single point), or the
/// version's wall time shared out over the points when a stage records none.
fn wall_per_point(input: &Input, points: usize) -> Result<Vec<f64>> {
    let mean = |v: &mut dyn Iterator<Item = f64>| {
        let finite: Vec<f64> = v.filter(|v| v.is_finite()).collect();
        finite.iter().sum::<f64>() / finite.len().max(1) as f64
    };
    if input.has("wall_seconds") {
        let w = input.read_f64("wall_seconds")?;
        if points == 1 {
            return Ok(vec![mean(&mut w.iter().copied())]);
        }
        if w.ndim() >= 1 && w.shape()[0] == points {
            return Ok(w.outer_iter().map(|row| mean(&mut row.iter().copied())).collect());
        }
    }
    let total = input.version.attr_f64("wall_seconds").unwrap_or(f64::NAN);
    Ok(vec![total / points as f64; points])
}

/// `name = value, ...` of the resolved parameters in which `input` differs from
/// `reference` (both from their versions' `params_yaml`; dotted names for nested ones).
fn differing_params(reference: &Input, input: &Input) -> String {
    fn flatten(prefix: &str, v: &serde_yaml_ng::Value, out: &mut Vec<(String, String)>) {
        match v {
            serde_yaml_ng::Value::Mapping(m) => {
                for (k, v) in m {
                    let key = k.as_str().unwrap_or("?");
                    flatten(&if prefix.is_empty() { key.to_string() } else { format!("{prefix}.{key}") }, v, out);
                }
            }
            other => out.push((prefix.to_string(), serde_yaml_ng::to_string(other).unwrap_or_default().trim().to_string())),
        }
    }
    let params = |i: &Input| {
        let mut out = vec![];
        if let Some(y) = i.version.attr_str("params_yaml").and_then(|t| serde_yaml_ng::from_str::<serde_yaml_ng::Value>(t).ok()) {
            flatten("", &y, &mut out);
        }
        out
    };
    let base = params(reference);
    params(input)
        .into_iter()
        .filter(|(k, v)| base.iter().find(|(b, _)| b == k).map(|(_, w)| w) != Some(v))
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn default_metrics(kind: &str) -> Vec<String> {
    match kind {
        "laydown" => vec!["radius_of_gyration".into(), "bending_energy".into()],
        "grid" => vec!["mean_areal_density".into(), "cv".into()],
        "image" => vec!["cv_corr".into(), "cv_corr_plain".into()],
        _ => vec![],
    }
}

/// The markdown table of a run; `against[i]` is what metric `i` is compared with in
/// the reference. An error reads "± its standard error" where there is one.
fn table(metrics: &[String], against: &[String], reference: &[f64], reference_wall: f64, cands: &[Candidate], reference_name: &str) -> String {
    let mut t = String::from("| candidate | setting | wall per unit (s) | speed-up |");
    for (m, r) in metrics.iter().zip(against) {
        if m == r {
            t += &format!(" {m} | error |");
        } else {
            t += &format!(" {m} | error against {r} |");
        }
    }
    t += "\n|---|---|---:|---:|";
    for _ in metrics {
        t += "---:|---:|";
    }
    t += &format!("\n| reference | {reference_name} | {reference_wall:.3} | 1 |");
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
        for ((v, r), (se, _)) in c.values.iter().zip(reference).zip(&c.standard_errors) {
            let se = 100.0 * se / r.abs();
            let error = 100.0 * (v - r) / r.abs();
            t += &if se.is_finite() { format!(" {} | {error:+.2} ± {se:.2} % |", sig(*v)) } else { format!(" {} | {error:+.2} % |", sig(*v)) };
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

/// The accuracy stage's rows.
const PARAMS: &[ParamSpec] = &[
    ParamSpec::text_list(
        "metrics",
        "per-point quantities to compare (`<name>_mean` in every input); empty: laydown radius_of_gyration, bending_energy; grid mean_areal_density, cv; image cv_corr, cv_corr_plain",
    ),
    ParamSpec::text_list(
        "reference_metrics",
        "what each metric is compared with in the reference (`<name>_mean`; same length as metrics), e.g. an image stage's cv_web, the known truth of its rendered webs; empty: the metrics themselves",
    ),
    ParamSpec::int(
        "references",
        "1",
        1,
        1,
        63,
        "the first `references` inputs (one sweep point each, one kind: e.g. converged runs on several seeds or steps) pooled as the reference, its value the mean over all their units; the rest are candidates",
    ),
];

/// The accuracy stage's parameters ([`ParamSet::to_typed`] of [`PARAMS`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct AccuracyParams {
    metrics: Vec<String>,
    reference_metrics: Vec<String>,
    references: usize,
}

impl AccuracyParams {
    fn of(p: &ParamSet) -> Self {
        p.to_typed().expect("the accuracy table and AccuracyParams agree (tested)")
    }
}

impl Stage for AccuracyStage {
    fn kind(&self) -> &'static str {
        "accuracy"
    }
    fn summary(&self) -> &'static str {
        "what accuracy costs in time: each candidate's error against a reference input, next to its wall time per unit"
    }
    fn cache_version(&self) -> u32 {
        2
    }
    fn params(&self) -> Vec<ParamSpec> {
        PARAMS.to_vec()
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["laydown", "laid_web", "grid", "spectra", "web", "image"], min: 2, max: 64 }
    }
    fn check(&self, p: &ParamSet) -> std::result::Result<(), InvalidParam> {
        let AccuracyParams { metrics: m, reference_metrics: r, .. } = AccuracyParams::of(p);
        if !r.is_empty() && r.len() != m.len() {
            return Err(InvalidParam::new(
                "reference_metrics".into(),
                format!("{} reference metrics for {} metrics; allowed: one per metric (list the metrics too), or none", r.len(), m.len()),
            ));
        }
        Ok(())
    }
    fn run(&self, ctx: &RunContext) -> Result<Output> {
        if ctx.points.len() != 1 || ctx.replicates != 1 {
            return Err(bad("an accuracy stage compares its inputs; it takes no sweep and no replicates".into()));
        }
        let AccuracyParams { mut metrics, reference_metrics: given, references } = AccuracyParams::of(&ctx.points[0]);
        if references >= ctx.inputs.len() {
            return Err(bad(format!(
                "references = {references} pools every one of the {} inputs and leaves no candidate; allowed: 1 to {}",
                ctx.inputs.len(),
                ctx.inputs.len() - 1
            )));
        }
        let reference = ctx.input(0);
        if metrics.is_empty() {
            metrics = default_metrics(&reference.kind);
        }
        if metrics.is_empty() {
            return Err(bad(format!("give `metrics`: there is no default for a reference of kind {}", reference.kind)));
        }
        let reference_metrics: Vec<String> = if given.is_empty() { metrics.clone() } else { given };
        let pooled = pooled_reference(&ctx.inputs[..references], &reference_metrics)?;
        let (reference_values, reference_wall) = (&pooled.values, pooled.wall_seconds);

        let mut cands = vec![];
        for input in &ctx.inputs[references..] {
            let points = points_of(input)?;
            let values: Vec<Vec<f64>> = metrics.iter().map(|m| metric(input, m, points)).collect::<Result<_>>()?;
            let wall = wall_per_point(input, points)?;
            let swept = hdf::swept_coordinates(&input.version.open()?);
            // An unswept candidate is named by the parameters it changes from the reference.
            let unswept = if swept.is_empty() { differing_params(reference, input) } else { String::new() };
            // units pair one to one only between inputs of the same kind (the same
            // replicates, realisations or webs), never with a pooled reference
            let pair = input.kind == reference.kind && references == 1;
            let candidate_units: Vec<Option<Units>> = metrics.iter().map(|m| units(input, m, points)).collect::<Result<_>>()?;
            for p in 0..points {
                let standard_errors = (0..metrics.len())
                    .map(|m| match (&pooled.units[m], &candidate_units[m]) {
                        (Some(r), Some(c)) => difference_standard_error(r, &c.rows[p], pair),
                        _ => (f64::NAN, 0),
                    })
                    .collect();
                cands.push(Candidate {
                    stage: input.name.clone(),
                    point: p,
                    label: if swept.is_empty() { unswept.clone() } else { hdf::point_label(&swept, p) },
                    values: values.iter().map(|v| v[p]).collect(),
                    standard_errors,
                    wall_seconds: wall[p],
                });
            }
        }

        let n = cands.len();
        let mut out = Output::new();
        out.strings("metric", "metric", metrics.clone(), "compared quantity").describe("compared quantity (`<metric>_mean` of the inputs)");
        out.strings("reference_metric", "metric", reference_metrics.clone(), "reference quantity").describe("what the metric is compared with in the reference (`<name>_mean`)");
        out.strings("candidate_stage", "candidate", cands.iter().map(|c| c.stage.clone()).collect(), "input stage of the candidate");
        out.i64("candidate_point", &["candidate"], Array1::from_iter(cands.iter().map(|c| c.point as i64)), "1", "sweep point of the candidate in its stage");
        out.strings("candidate_label", "candidate", cands.iter().map(|c| c.label.clone()).collect(), "swept parameters of the candidate");
        out.strings("reference_stage", "reference", pooled.stages.clone(), "input stage pooled as the reference")
            .describe("the input stages pooled as the reference (the first `references` inputs); the first names unswept candidates and gives the wall time");
        out.f64("reference_value", &["metric"], Array1::from(reference_values.clone()), "", "value of the reference")
            .describe("value of the reference: its `<metric>_mean`, or over pooled references the mean over all their units");
        out.i64("reference_units", &["metric"], Array1::from_iter(pooled.units.iter().map(|u| u.as_ref().map_or(0, |u| u.iter().filter(|x| x.is_finite()).count()) as i64)), "1", "units of the reference in its standard error")
            .describe("units of the (pooled) reference that enter the standard errors (replicates, realisations, webs); 0: it records no per-unit values");
        out.f64("reference_wall_seconds", &[], ndarray::arr0(reference_wall), "s", "wall time per unit of the reference");
        let value = Array2::from_shape_fn((n, metrics.len()), |(c, m)| cands[c].values[m]);
        let error = Array2::from_shape_fn((n, metrics.len()), |(c, m)| (cands[c].values[m] - reference_values[m]) / reference_values[m].abs());
        out.f64("value", &["candidate", "metric"], value, "", "candidate's value (units of the metric)");
        out.f64("relative_error", &["candidate", "metric"], error, "1", "(candidate - reference) / |reference|");
        let standard_error = Array2::from_shape_fn((n, metrics.len()), |(c, m)| cands[c].standard_errors[m].0 / reference_values[m].abs());
        out.f64("relative_error_standard_error", &["candidate", "metric"], standard_error, "1", "standard error of relative_error")
            .describe("standard error of relative_error from the per-unit values (a laid web's fibres averaged per web): of the paired differences when paired_units > 0, else of the two means' difference; NaN without per-unit values or with fewer than two units");
        out.i64("paired_units", &["candidate", "metric"], Array2::from_shape_fn((n, metrics.len()), |(c, m)| cands[c].standard_errors[m].1 as i64), "1", "units paired for the standard error")
            .describe("units (replicates, realisations, webs) paired one to one with the reference's for the standard error (inputs of one kind, the same units in both means); 0: unpaired");
        out.f64("wall_seconds", &["candidate"], Array1::from_iter(cands.iter().map(|c| c.wall_seconds)), "s", "wall time per unit of work").describe("wall time per unit of work (replicate, realisation)");
        out.f64("speedup", &["candidate"], Array1::from_iter(cands.iter().map(|c| reference_wall / c.wall_seconds)), "1", "reference wall time / candidate wall time");

        let reference_name = pooled.stages.join(" + ");
        let md = table(&metrics, &reference_metrics, reference_values, reference_wall, &cands, &reference_name);
        for line in md.lines() {
            crate::info!("{}: {line}", ctx.stage_name);
        }
        out.file("accuracy_cost.md", format!("# What accuracy costs: `{}` against `{}`\n\n{md}", ctx.stage_name, pooled.stages.join("` + `")).into_bytes());
        out.set_attr("table_markdown", md);
        out.set_attr("reference", reference_name);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_its_typed_parameters() {
        crate::params::assert_table_matches(PARAMS, &AccuracyParams { metrics: vec![], reference_metrics: vec![], references: 1 });
    }

    #[test]
    fn table_has_errors_and_speedups() {
        let c = Candidate { stage: "fast".into(), point: 0, label: "elements = 250".into(), values: vec![1.1, 2.0], standard_errors: vec![(0.05, 4), (f64::NAN, 0)], wall_seconds: 0.5 };
        let names = ["s".to_string(), "e".to_string()];
        let t = table(&names, &names, &[1.0, 2.0], 5.0, &[c], "exact");
        assert!(t.contains("| fast | elements = 250 | 0.500 | 10.0 | 1.100 | +10.00 ± 5.00 % | 2.000 | +0.00 % |"), "{t}");
        assert!(t.contains("| reference | exact | 5.000 | 1 |"), "{t}");
    }

    /// Paired (the same units present in both): the standard error of the mean difference
    /// (a shared offset cancels); otherwise √(s_r²/n_r + s_c²/n_c); too few units: NaN.
    #[test]
    fn standard_error_of_the_difference() {
        let reference = [1.0, 2.0, 3.0, 4.0, f64::NAN];
        // the candidate is the reference + 0.5 with ±0.1 jitter; unit 4 is left out in
        // the reference, unit 0 in the candidate
        let candidate = [f64::NAN, 2.6, 3.4, 4.6, 9.0];
        let shared = [f64::NAN, 2.6, 3.4, 4.6, f64::NAN];
        let (se, pairs) = difference_standard_error(&[f64::NAN, 2.0, 3.0, 4.0, f64::NAN], &shared, true);
        // differences 0.6, 0.4, 0.6: sd = 0.11547, se = sd/√3
        assert_eq!(pairs, 3);
        assert!((se - 0.115_470_053_8 / 3f64.sqrt()).abs() < 1e-9, "{se}");
        // the units present differ (and so do the means'): unpaired, s_r² over 4 units
        // (1, 2, 3, 4) and s_c² over 4 (2.6, 3.4, 4.6, 9)
        let (se, pairs) = difference_standard_error(&reference, &candidate, true);
        let (_, s_c) = crate::stages::mean_std(&[2.6, 3.4, 4.6, 9.0]);
        assert_eq!(pairs, 0);
        assert!((se - (5.0 / 3.0 / 4.0 + s_c * s_c / 4.0).sqrt()).abs() < 1e-12, "{se}");
        // different lengths, or inputs of different kinds: unpaired
        let (se, pairs) = difference_standard_error(&reference[..4], &[2.0, 3.0, 4.0], true);
        assert_eq!(pairs, 0);
        assert!((se - (5.0 / 3.0 / 4.0 + 1.0 / 3.0f64).sqrt()).abs() < 1e-12, "{se}");
        assert_eq!(difference_standard_error(&shared, &shared, false).1, 0);
        // identical ensembles: exactly 0
        assert_eq!(difference_standard_error(&reference, &reference, true), (0.0, 4));
        assert!(difference_standard_error(&[1.0, f64::NAN], &[2.0, f64::NAN], true).0.is_nan());
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(0.015432), "0.01543");
        assert_eq!(sig(11397.2), "11397");
        assert_eq!(sig(1.5), "1.500");
    }
}
