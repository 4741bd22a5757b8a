//! `kind: web` — the pipeline stage around the web numerics (§3.1 eqs 11-15, §3.2).
//!
//! A web is *defined*, not stored: per sweep point the stage records its resolved
//! parameters, the exact curvature spectrum coefficients it uses and the random seed.
//! With [`web_from_input`] a downstream stage rebuilds the same [`Web`] from those
//! datasets and regenerates any fibre of any realisation bit for bit (the fibre's
//! random stream is fixed by (seed, realisation, fibre), see [`super::fibre_rng`]).
//!
//! **Generators** (`generator`, see [`super::Generator`]): `random_phase` (the paper's,
//! the default) needs a spectrum; `laid_segments` follows the laid fibres of the input
//! spectra stage (their resampled nodes, `resampled_position`, and curvature samples);
//! `lay_down_sde` is calibrated on those fibres' mean S and e ([`super::sde::calibrate`])
//! unless `sde_potential_length` and `sde_noise` are both given. Per point the stage
//! records the input's and the generated segments' mean S and e (measured alike by
//! [`super::sde::window_shape`]), the SDE's parameters and calibration, the laid templates
//! (so that a grid regenerates a `laid_segments` web from the archive alone) and one input
//! fibre for the `shape` figure.
//!
//! **Spectrum source** (random_phase). Either `input: <spectra stage>` (the spectrum of one of its
//! points, chosen with `input_point`; `spectrum_selection: single` uses that point's
//! energy-averaged mean spectrum, `per_segment` keeps every valid fibre's spectrum and
//! each segment draws one uniformly, the draw being part of the fibre's random stream),
//! or `preset: spectrum1|2|3` (the paper's idealised square waves, N = `points_per_segment`).
//!
//! **Physical parameters.** `fibre_diameter`, `fibre_density` and `belt_speed_ratio` left
//! `auto` are those of the input's laid fibres (the spectra stage records them per point),
//! else the paper's web values; `inherited_parameters` and stderr say what was taken
//! ([`physical_parameters`]).
//!
//! **Seed.** Every point uses the stage's seed (pipeline `seed`, or the stage's own):
//! sweep points share their fibres' random phases (common random numbers), as the other
//! stages do. Realisation k of a web is fibre streams (seed, k, ·).
//!
//! **Stored fibres.** For each replicate k (`replicates:`, realisation k) the stage
//! stores all fibres when n_w·(n_l·N + 1) ≤ `store_all_max_points`, otherwise
//! `sample_fibres` fibres evenly spread across the web: fibre indices
//! ⌊(2i + 1)·n_w / (2k)⌋, i = 0..k (centred strips, away from the edges).
//!
//! **Memory** ([`Stage::estimate_memory`]): the stored fibres' nodes, generated and
//! placed (32 B each), every thread's fibre buffers ([`SCRATCH_BYTES_PER_NODE`] per node
//! of a fibre being generated) and the spectrum set (read and prepared, 48 B per bin).
use super::sde::{calibrate, window_shape, Calibration, LayDownSde, ShapeTarget, RESOLUTION};
use super::{Generator, SegmentJoin, SpectrumSelection, Web, WebError, WebParams, WEB_PARAMS};
use crate::archive::data::Output;
use crate::memory::Estimate;
use crate::params::{ParamSet, ParamSpec};
use crate::stages::spectra::{declared_spectra, integrate_curvature, CurvatureSpectrum, SquareWaveParams};
use crate::stages::{concurrent, BadInput, Declared, Input, InputRule, RunContext, Stage};
use anyhow::{anyhow, Result};
use ndarray::{Array1, Array2, Array3, Axis};
use num_complex::Complex64;
use rayon::prelude::*;

pub struct WebStage;

const PRESETS: &[&str] = &["none", "spectrum1", "spectrum2", "spectrum3"];

/// A web point's parameters as the pipeline gives them ([`ParamSet::to_typed`] of the
/// stage's table): [`WebParams`] but for the seed (the pipeline's) and the physical
/// parameters that may be `auto`, and the stage's own rows.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WebStageParams {
    pub preset: String,
    pub points_per_segment: usize,
    pub input_point: Option<usize>,
    pub fibres_across: usize,
    pub segments_per_fibre: usize,
    pub fibre_spacing: f64,
    pub belt_speed_ratio: Option<f64>,
    pub fibre_diameter: Option<f64>,
    pub fibre_density: Option<f64>,
    pub spectrum_selection: SpectrumSelection,
    pub generator: Generator,
    pub mirror: bool,
    pub segment_join: SegmentJoin,
    pub sde_potential_length: Option<f64>,
    pub sde_noise: Option<f64>,
    pub segment_length: f64,
    pub store_all_max_points: u64,
    pub sample_fibres: usize,
}

impl WebStageParams {
    /// A point's typed parameters (its rows were checked against the table).
    pub fn of(p: &ParamSet) -> Self {
        p.to_typed().expect("the web table and WebStageParams agree (tested)")
    }
}

/// Bytes per node of a fibre being generated: κ, θ, sin θ, cos θ (8 B each) and the
/// nodes (x, y).
pub const SCRATCH_BYTES_PER_NODE: f64 = 48.0;
/// The same for a `lay_down_sde` web, whose workers integrate up to 16 fibres in lockstep
/// and hold all their nodes (16 × 16 B; measured: the paper-size web's peak RSS rose by
/// 25 MB, 2 workers, from 8 to 16 fibres of 1e5 nodes).
pub const SDE_SCRATCH_BYTES_PER_NODE: f64 = 256.0;
/// Bytes per stored fibre node: generated, then placed in the (padded) output, x and y each.
const STORED_BYTES_PER_NODE: f64 = 32.0;

/// One point of a declared web stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeclaredWeb {
    /// n_w.
    pub fibres_across: f64,
    /// n_l·N + 1.
    pub nodes_per_fibre: f64,
    /// Fibres stored per realisation.
    pub stored_fibres: f64,
    /// Spectra (or laid templates) in the set and their N.
    pub spectra: f64,
    pub points_per_segment: f64,
    /// Bytes a worker holds per node of a fibre it generates.
    pub scratch_bytes_per_node: f64,
}

/// The webs of a declared web stage, per point (N of an input spectra stage: the
/// largest of its points).
pub fn declared_webs(stage: &Declared) -> Vec<DeclaredWeb> {
    let input = stage.inputs.first().map(declared_spectra);
    stage
        .points
        .iter()
        .map(|p| {
            let p = WebStageParams::of(p);
            let (count, n) = match &input {
                Some(s) => s.iter().fold((0.0, 0.0), |a, b| (f64::max(a.0, b.0), f64::max(a.1, b.1))),
                None => (1.0, p.points_per_segment as f64),
            };
            let spectra = if p.spectrum_selection == SpectrumSelection::PerSegment || p.generator == Generator::LaidSegments { count } else { 1.0 };
            let n_w = p.fibres_across as f64;
            let nodes = p.segments_per_fibre as f64 * n + 1.0;
            let stored = if n_w * nodes <= p.store_all_max_points as f64 { n_w } else { (p.sample_fibres as f64).min(n_w) };
            let scratch_bytes_per_node = if p.generator == Generator::LayDownSde { SDE_SCRATCH_BYTES_PER_NODE } else { SCRATCH_BYTES_PER_NODE };
            DeclaredWeb { fibres_across: n_w, nodes_per_fibre: nodes, stored_fibres: stored, spectra, points_per_segment: n, scratch_bytes_per_node }
        })
        .collect()
}

/// Bytes of a declared web's stored fibres (`fibre_positions`), as a reader gets them.
pub fn stored_bytes(stage: &Declared) -> f64 {
    declared_webs(stage).iter().map(|w| stage.replicates as f64 * w.stored_fibres * w.nodes_per_fibre * 16.0).sum()
}

/// One sweep point's web with where its spectrum came from.
struct PointWeb {
    web: Web,
    /// The spectra a `random_phase` web uses (empty for the other generators).
    spectra: Vec<CurvatureSpectrum>,
    source: String,
    sample: Vec<usize>,
    /// Mean S and e of the input's laid fibres (None without laid fibres).
    input_shape: Option<ShapeTarget>,
    /// Mean S and e of the generated fibres' segment windows (belt removed).
    generated_shape: ShapeTarget,
    /// How the SDE's parameters were set.
    calibration: Option<Calibration>,
    /// The input's first laid fibre, belt removed, rebuilt by eq 13 about its centroid
    /// (for the figure beside a generated segment).
    example_input_fibre: Option<Vec<[f64; 2]>>,
    /// Physical parameters taken from the input's laid fibres ([`physical_parameters`]).
    inherited: Option<String>,
    /// The point of the input spectra stage used (None without an input).
    input_point: Option<usize>,
}

/// Fibres of realisation 0 whose segment windows give a point's generated S and e.
const SHAPE_FIBRES: usize = 8;

impl Stage for WebStage {
    fn kind(&self) -> &'static str {
        "web"
    }
    fn summary(&self) -> &'static str {
        "stochastic fibres laid with belt drift (eqs 14-15), n_w across, n_l segments long: random phases of a curvature spectrum (eqs 11-13), laid fibres joined, or the ITWM lay-down SDE"
    }
    fn cache_version(&self) -> u32 {
        1
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["spectra"], min: 0, max: 1 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v = vec![
            ParamSpec::choice("preset", PRESETS, "none", "idealised spectrum instead of an input: the paper's Fig 10 square waves (L = 1 m)"),
            ParamSpec::int("points_per_segment", "1", 1000, 4, 1_000_000, "N, samples per segment of a preset spectrum or of a lay_down_sde given without an input (Δs = L/N); ignored with an input"),
            ParamSpec::int("input_point", "1", 0, 0, i64::MAX, "which point of the input spectra stage to use (auto: its only point)").auto_default(),
        ];
        for p in WEB_PARAMS {
            if let Some(&(_, doc)) = INHERITED_DOCS.iter().find(|(name, _)| *name == p.name) {
                v.push(p.auto_default().with_doc(doc));
            } else if p.name != "seed" {
                v.push(*p);
            }
        }
        v.push(ParamSpec::float("sde_potential_length", "m", 5e-3, 1e-9, 10.0, "lay_down_sde: b of the potential V = |η|²/(2b²) (auto: calibrated so the input's laid fibres' S is met)").auto_default());
        v.push(ParamSpec::float("sde_noise", "m^-1/2", 1.0, 0.0, 1e6, "lay_down_sde: A, the Brownian noise on the tangent angle (auto: calibrated so the input's e is met)").auto_default());
        v.push(ParamSpec::float("segment_length", "m", 1.0, 1e-6, 1e3, "lay_down_sde without an input: L of a segment (Δs = L/points_per_segment)"));
        v.push(ParamSpec::int("store_all_max_points", "1", 2_000_000, 0, i64::MAX, "store every fibre when the web has at most this many nodes; otherwise a sample"));
        v.push(ParamSpec::int("sample_fibres", "1", 8, 1, 1_000_000, "fibres stored for a larger web, evenly spread across it"));
        v
    }

    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let webs = declared_webs(stage);
        let reps = stage.replicates as f64;
        // generated fibres, then the output padded to the most stored fibres and the longest
        let generated: f64 = webs.iter().map(|w| reps * w.stored_fibres * w.nodes_per_fibre * 16.0).sum();
        let most = webs.iter().map(|w| w.stored_fibres).fold(0.0, f64::max);
        let longest_stored = webs.iter().map(|w| w.nodes_per_fibre).fold(0.0, f64::max);
        let stored = generated + webs.len() as f64 * reps * most * longest_stored * 16.0;
        let jobs: f64 = webs.iter().map(|w| reps * w.stored_fibres).sum();
        let longest = webs.iter().map(|w| w.nodes_per_fibre).fold(0.0, f64::max);
        let per_node = webs.iter().map(|w| w.scratch_bytes_per_node).fold(0.0, f64::max);
        let scratch = concurrent(jobs) * longest * per_node;
        let spectra: f64 = webs.iter().map(|w| w.spectra * w.points_per_segment * 48.0).sum();
        // N is the preset's points_per_segment, or the input spectra stage's.
        let n_param = match stage.inputs.first() {
            Some(i) => (i.name.clone(), "points_per_segment".to_string()),
            None => (stage.name.clone(), "points_per_segment".to_string()),
        };
        let own = |p: &str| (stage.name.clone(), p.to_string());
        let (what, params) = if stored > scratch {
            (format!("{jobs} stored fibres of up to {longest} nodes, {STORED_BYTES_PER_NODE} B each"), vec![own("segments_per_fibre"), n_param, own("store_all_max_points"), own("sample_fibres")])
        } else {
            (format!("fibres of n_l·N + 1 = {longest} nodes generated by {} threads at once, {per_node} B per node", concurrent(jobs)), vec![own("segments_per_fibre"), n_param])
        };
        Some(Estimate { bytes: stored + scratch + spectra, what, params, inverse: vec![] })
    }

    fn run(&self, ctx: &RunContext) -> Result<Output> {
        let webs: Vec<PointWeb> = ctx.points.iter().enumerate().map(|(i, p)| point_web(ctx, i, p)).collect::<Result<_>>()?;
        let reps = ctx.replicates;
        // Generate the stored fibres in parallel; positions are per (point, realisation, sample).
        let jobs: Vec<(usize, usize, usize)> = webs
            .iter()
            .enumerate()
            .flat_map(|(p, w)| (0..reps).flat_map(move |r| (0..w.sample.len()).map(move |i| (p, r, i))))
            .collect();
        let fibres: Vec<Vec<[f64; 2]>> = jobs.par_iter().map(|&(p, r, i)| webs[p].web.generate_fibre(r as u32, webs[p].sample[i])).collect();
        assemble(&webs, reps, &jobs, &fibres)
    }
}

fn point_web(ctx: &RunContext, index: usize, p: &ParamSet) -> Result<PointWeb> {
    let p = &WebStageParams::of(p);
    let bad = |e: &dyn std::fmt::Display| BadInput(format!("point {index}: {e}"));
    let (selection, generator) = (p.spectrum_selection, p.generator);
    // The point of the input spectra stage this web reads (read once, used below).
    let input_point = if ctx.inputs.is_empty() { None } else { Some(input_point(ctx, p)?) };
    let physical = physical_parameters(ctx, p, input_point)?;
    if let Some(note) = &physical.inherited {
        crate::info!("{}: point {index}: {note}", ctx.stage_name);
    }
    let [belt_speed_ratio, fibre_diameter, fibre_density] = physical.values;
    let params = WebParams {
        fibres_across: p.fibres_across,
        segments_per_fibre: p.segments_per_fibre,
        fibre_spacing: p.fibre_spacing,
        belt_speed_ratio,
        fibre_diameter,
        fibre_density,
        spectrum_selection: selection,
        generator,
        mirror: p.mirror,
        segment_join: p.segment_join,
        seed: ctx.seed,
    };
    if generator != Generator::RandomPhase && p.preset != "none" {
        return Err(BadInput(format!("`preset` gives a spectrum for generator random_phase; generator {} does not use one", generator.name())).into());
    }
    let laid = input_point.map(|point| laid_fibres(ctx, point)).transpose()?;
    let input_shape = laid.as_ref().and_then(|l| l.shape());
    let example = laid.as_ref().map(|l| match l.positions.first() {
        Some(nodes) => nodes.clone(),
        None => integrate_curvature(&l.curvature[0], l.spacing, 0.0, [0.0, 0.0], 0.0),
    });
    let (web, spectra, source, calibration) = match generator {
        Generator::RandomPhase => {
            let (spectra, source) = spectra_for(ctx, p, selection, input_point)?;
            let web = Web::new(params, spectra.clone()).map_err(|e| bad(&e))?;
            (web, spectra, source, None)
        }
        Generator::LaidSegments => {
            let laid = laid.ok_or_else(|| BadInput("generator laid_segments joins laid fibres: give `input: <spectra stage>` computed from a laydown or laid_web stage".into()))?;
            let (web, source) = laid_segments_web(params, laid).map_err(|e| bad(&e))?;
            (web, vec![], source, None)
        }
        Generator::LayDownSde => {
            let (web, source, calibration) = sde_web(ctx, p, params, laid.as_ref(), input_shape).map_err(|e| bad(&e))?;
            if let Some(remark) = sde_remark(&web, calibration.as_ref()) {
                eprintln!("{}: warning: point {index}: {remark}", ctx.stage_name);
            }
            (web, vec![], source, calibration)
        }
    };
    let n_w = params.fibres_across;
    let total = n_w as u128 * web.nodes_per_fibre() as u128;
    let sample = if total <= p.store_all_max_points as u128 {
        (0..n_w).collect()
    } else {
        let k = p.sample_fibres.min(n_w);
        (0..k).map(|i| (2 * i + 1) * n_w / (2 * k)).collect()
    };
    let generated_shape = generated_shape(&web);
    let example_input_fibre = example.map(|nodes| crate::geometry::centred(&nodes));
    Ok(PointWeb { web, spectra, source, sample, input_shape, generated_shape, calibration, example_input_fibre, inherited: physical.inherited, input_point })
}

/// The physical parameters a web takes from the laid fibres of its input spectra stage
/// when the pipeline leaves them `auto`: c = v_b/v_f, d, ρ, in this order.
const INHERITED: [&str; 3] = ["belt_speed_ratio", "fibre_diameter", "fibre_density"];

/// Their documentation, with what `auto` means.
const INHERITED_DOCS: [(&str, &str); 3] = [
    ("belt_speed_ratio", "c = v_b/v_f, belt drift per unit fibre length (eqs 14-15); auto: the laid fibres' c (0 if their spectra keep the belt motion), without laid fibres 0.04 = Table 1"),
    ("fibre_diameter", "d, fibre diameter (point mass ρπd²/4·Δs); auto: the laid fibres' d, without laid fibres 20 µm (§3.2)"),
    ("fibre_density", "ρ, fibre material density; auto: the laid fibres' ρ, without laid fibres 950 kg/m³"),
];

/// A point's physical parameters: as given; else (`auto`) the laid fibres' (the spectra
/// stage records them per point), with c = 0 for fibres analysed with the belt motion
/// in them (their curve already drifts, eq 14 would add it twice); else the table's
/// defaults (the paper's web, §3.3).
struct Physical {
    values: [f64; 3],
    /// What was taken from the input, for the archive and the log (None: nothing).
    inherited: Option<String>,
}

fn physical_parameters(ctx: &RunContext, p: &WebStageParams, input_point: Option<usize>) -> Result<Physical> {
    let laid = match (ctx.inputs.first(), input_point) {
        (Some(input), Some(point)) if input.has("fibre_diameter") => Some((input, point)),
        _ => None,
    };
    let (mut values, mut taken) = ([0.0; 3], vec![]);
    let given = [p.belt_speed_ratio, p.fibre_diameter, p.fibre_density];
    for ((value, name), given) in values.iter_mut().zip(INHERITED).zip(given) {
        let row = ParamSpec::find(WEB_PARAMS, name);
        *value = match (given, laid) {
            (Some(given), _) => given,
            (None, Some((input, point))) => {
                let belt_kept = name == "belt_speed_ratio" && input.has("belt_removed") && input.read_u8("belt_removed")?.iter().all(|&b| b == 0);
                let laid_value = if belt_kept { 0.0 } else { input.read_f64(name)?[[point]] };
                taken.push(format!("{name} = {laid_value:e} {}{}", row.unit, if belt_kept { " (the laid curves keep the belt drift)" } else { "" }));
                laid_value
            }
            (None, None) => row.default.number().expect("inherited parameters are numbers"),
        };
    }
    let inherited = laid.filter(|_| !taken.is_empty()).map(|(input, point)| format!("from the laid fibres of {} point {point}: {}", input.version.group_path(), taken.join(", ")));
    Ok(Physical { values, inherited })
}

/// A `laid_segments` web of the input's laid fibres, and where they came from.
fn laid_segments_web(params: WebParams, laid: LaidFibres) -> Result<(Web, String), WebError> {
    let source = format!(
        "{}: {} laid fibres (belt removed) joined ({} join){}",
        laid.source,
        laid.curvature.len(),
        params.segment_join.name(),
        if params.mirror { ", mirrored at random" } else { "" }
    );
    if params.segment_join == SegmentJoin::Matched && laid.positions.is_empty() {
        return Err(WebError::MissingTemplateNodes { spectra: laid.source });
    }
    let web = Web::laid_segments(params, laid.curvature, laid.positions, laid.spacing)?;
    Ok((web, source))
}

/// A `lay_down_sde` web: b and A as given, or calibrated on the laid fibres' mean shape at
/// their Δs and length; without an input, Δs = segment_length / points_per_segment.
fn sde_web(ctx: &RunContext, p: &WebStageParams, params: WebParams, laid: Option<&LaidFibres>, target: Option<ShapeTarget>) -> Result<(Web, String, Option<Calibration>), WebError> {
    let given = (p.sde_potential_length, p.sde_noise);
    let (spacing, points) = match laid {
        Some(l) => (l.spacing, l.curvature[0].len()),
        None => (p.segment_length / p.points_per_segment as f64, p.points_per_segment),
    };
    let (model, calibration, source) = match (given, target, laid) {
        ((Some(b), Some(a)), _, _) => (LayDownSde { potential_length: b, noise: a }, None, "lay_down_sde: parameters given".to_string()),
        ((None, None), Some(target), Some(l)) => {
            let fit = calibrate(target, spacing, points, ctx.seed)?;
            (fit.model, Some(fit), format!("lay_down_sde calibrated on {}: {} laid fibres", l.source, l.curvature.len()))
        }
        ((None, None), _, _) => return Err(WebError::SdeUnparametrised),
        _ => return Err(WebError::SdeHalfGiven),
    };
    if spacing > model.potential_length {
        // Measured: the stationary spread is 27 % off already at Δs = b/2; beyond b the
        // scheme turns the fibre by more than a radian per step and the web is noise.
        return Err(WebError::SdeStepBeyondPotential { spacing, potential_length: model.potential_length, calibrated: calibration.is_some(), resolution: RESOLUTION });
    }
    let web = Web::lay_down_sde(params, model, spacing, points)?;
    Ok((web, source, calibration))
}

/// What a researcher must know about a lay-down SDE web's numerics, if anything: a step
/// coarser than b/[`RESOLUTION`] or a calibration that did not converge.
fn sde_remark(web: &Web, calibration: Option<&Calibration>) -> Option<String> {
    let model = web.sde_model()?;
    let mut remarks = vec![];
    if web.spacing() * RESOLUTION > model.potential_length {
        remarks.push(format!(
            "the SDE step Δs = {:.3e} m is coarser than b/{RESOLUTION} = {:.3e} m: the scheme's stationary spread is biased (27 % at b/2); sample the input finer",
            web.spacing(),
            model.potential_length / RESOLUTION
        ));
    }
    if let Some(c) = calibration.filter(|c| !c.converged) {
        remarks.push(format!(
            "calibration did not converge: S {:.4e} m for {:.4e} m, e {:.4e} for {:.4e}",
            c.achieved.radius_of_gyration, c.target.radius_of_gyration, c.achieved.bending_energy, c.target.bending_energy
        ));
    }
    (!remarks.is_empty()).then(|| remarks.join("; "))
}

/// Mean S and e over the segment windows of up to [`SHAPE_FIBRES`] fibres of realisation 0.
fn generated_shape(web: &Web) -> ShapeTarget {
    let n_w = web.params().fibres_across;
    let k = SHAPE_FIBRES.min(n_w);
    let shapes: Vec<(f64, f64)> = (0..k).into_par_iter().flat_map_iter(|i| web.segment_shapes(0, (2 * i + 1) * n_w / (2 * k))).collect();
    let n = shapes.len() as f64;
    ShapeTarget { radius_of_gyration: shapes.iter().map(|s| s.0).sum::<f64>() / n, bending_energy: shapes.iter().map(|s| s.1).sum::<f64>() / n }
}


/// The laid fibres of one point of an input spectra stage: their curvature samples.
struct LaidFibres {
    curvature: Vec<Vec<f64>>,
    /// Resampled belt-removed nodes of each (N + 1), when the spectra version holds them.
    positions: Vec<Vec<[f64; 2]>>,
    spacing: f64,
    source: String,
}

impl LaidFibres {
    /// Mean S and e of the fibres, measured by [`window_shape`] (S of their resampled
    /// nodes when the spectra version holds them).
    fn shape(&self) -> Option<ShapeTarget> {
        let shapes: Vec<(f64, f64)> = self.curvature.iter().enumerate().map(|(i, k)| window_shape(self.positions.get(i).map(|q| q.as_slice()), k, self.spacing)).collect();
        let n = shapes.len() as f64;
        (n > 0.0).then(|| ShapeTarget { radius_of_gyration: shapes.iter().map(|s| s.0).sum::<f64>() / n, bending_energy: shapes.iter().map(|s| s.1).sum::<f64>() / n })
    }
}

/// Which point of the input spectra stage a web uses (`input_point`, or its only point).
fn input_point(ctx: &RunContext, p: &WebStageParams) -> Result<usize> {
    let input = ctx.input(0);
    let npoints = input.read_f64("segment_length")?.len();
    let point = match p.input_point {
        Some(i) => i,
        _ if npoints == 1 => 0,
        _ => {
            return Err(BadInput(format!(
                "input {} has {npoints} points; choose one with `input_point: 0..{}` (one web stage per spectrum)",
                input.version.group_path(),
                npoints - 1
            ))
            .into())
        }
    };
    if point >= npoints {
        return Err(BadInput(format!("input_point {point} is beyond the {npoints} points of {}", input.version.group_path())).into());
    }
    Ok(point)
}

/// The valid fibres' curvature rows (`curvature`, N samples at `sample_spacing`) of the
/// input spectra stage's point: the laid fibres, belt removed, as the spectra stage sampled them.
fn laid_fibres(ctx: &RunContext, point: usize) -> Result<LaidFibres> {
    let input = ctx.input(0);
    let kappa = input.read_f64("curvature")?; // (point, fibre, sample)
    let valid = input.read_u8("valid")?;
    let spacing = input.read_f64("sample_spacing")?[[point]];
    let resampled = if input.has("resampled_position") { Some(input.read_f64("resampled_position")?) } else { None }; // (point, fibre, node, xy)
    let kappa = kappa.index_axis(Axis(0), point);
    let (mut curvature, mut positions) = (vec![], vec![]);
    for f in 0..kappa.shape()[0] {
        if valid[[point, f]] == 0 {
            continue;
        }
        if let Some(r) = &resampled {
            let nodes = r.index_axis(Axis(0), point).index_axis(Axis(0), f).outer_iter().map(|q| [q[0], q[1]]).take_while(|q| q[0].is_finite()).collect();
            positions.push(nodes);
        }
        curvature.push(kappa.index_axis(Axis(0), f).iter().copied().take_while(|k| k.is_finite()).collect::<Vec<f64>>());
    }
    if curvature.is_empty() {
        return Err(BadInput(format!("{} point {point} has no valid fibre", input.version.group_path())).into());
    }
    Ok(LaidFibres { curvature, positions, spacing, source: format!("{} point {point}", input.version.group_path()) })
}

fn spectra_for(ctx: &RunContext, p: &WebStageParams, selection: SpectrumSelection, input_point: Option<usize>) -> Result<(Vec<CurvatureSpectrum>, String)> {
    let preset = p.preset.as_str();
    if ctx.inputs.is_empty() {
        if preset == "none" {
            return Err(BadInput("a web needs a spectrum: give `input: <spectra stage>` or `preset: spectrum1|spectrum2|spectrum3`".into()).into());
        }
        let sq = SquareWaveParams { points_per_segment: p.points_per_segment, ..SquareWaveParams::preset(preset).ok_or_else(|| anyhow!("unknown preset {preset}"))? };
        let s = sq.spectrum().map_err(|e| BadInput(format!("preset {preset}: {e}")))?;
        return Ok((vec![s], format!("preset {preset}, N = {}", sq.points_per_segment)));
    }
    if preset != "none" {
        return Err(BadInput(format!("give either an input spectra stage or `preset`, not both (preset: {preset})")).into());
    }
    let (input, point) = (ctx.input(0), input_point.expect("an input has its point"));
    let length = input.read_f64("segment_length")?[[point]];
    let row = |re: &ndarray::ArrayViewD<f64>, im: &ndarray::ArrayViewD<f64>| -> Vec<Complex64> {
        re.iter().zip(im.iter()).take_while(|(a, b)| a.is_finite() && b.is_finite()).map(|(a, b)| Complex64::new(*a, *b)).collect()
    };
    let bad = |e: crate::stages::spectra::SpectraError| BadInput(format!("{} point {point}: {e}", input.version.group_path()));
    match selection {
        SpectrumSelection::Single => {
            let re = input.read_f64("mean_curvature_spectrum_real")?;
            let im = input.read_f64("mean_curvature_spectrum_imag")?;
            let c = row(&re.index_axis(Axis(0), point), &im.index_axis(Axis(0), point));
            let s = CurvatureSpectrum::new(length, c).map_err(bad)?;
            Ok((vec![s], format!("{} point {point}: mean spectrum", input.version.group_path())))
        }
        SpectrumSelection::PerSegment => {
            let re = input.read_f64("curvature_spectrum_real")?;
            let im = input.read_f64("curvature_spectrum_imag")?;
            let valid = input.read_u8("valid")?;
            let (re, im) = (re.index_axis(Axis(0), point), im.index_axis(Axis(0), point));
            let mut out = vec![];
            let mut which = vec![];
            for f in 0..re.shape()[0] {
                if valid[[point, f]] == 0 {
                    continue;
                }
                let c = row(&re.index_axis(Axis(0), f), &im.index_axis(Axis(0), f));
                out.push(CurvatureSpectrum::new(length, c).map_err(bad)?);
                which.push(f.to_string());
            }
            if out.is_empty() {
                return Err(BadInput(format!("{} point {point} has no valid spectrum", input.version.group_path())).into());
            }
            Ok((out, format!("{} point {point}: fibre spectra {} drawn per segment", input.version.group_path(), which.join(","))))
        }
    }
}

fn assemble(webs: &[PointWeb], reps: usize, jobs: &[(usize, usize, usize)], fibres: &[Vec<[f64; 2]>]) -> Result<Output> {
    let np = webs.len();
    let nan = f64::NAN;
    let nspec = webs.iter().map(|w| w.spectra.len()).max().unwrap_or(0).max(1);
    let nbins = webs.iter().map(|w| w.web.points_per_segment()).max().unwrap_or(0);
    let nsample = webs.iter().map(|w| w.sample.len()).max().unwrap_or(0);
    let nnodes = webs.iter().map(|w| w.web.nodes_per_fibre()).max().unwrap_or(0);
    let mut re = Array3::from_elem((np, nspec, nbins), nan);
    let mut im = re.clone();
    let mut index = Array2::from_elem((np, nsample), -1i64);
    for (p, w) in webs.iter().enumerate() {
        for (s, spec) in w.spectra.iter().enumerate() {
            for (r, c) in spec.coefficients().iter().enumerate() {
                re[[p, s, r]] = c.re;
                im[[p, s, r]] = c.im;
            }
        }
        for (i, &j) in w.sample.iter().enumerate() {
            index[[p, i]] = j as i64;
        }
    }
    let mut positions = crate::memory::try_array((np, reps, nsample, nnodes, 2), nan, "the stored fibres' positions")?;
    for (&(p, r, i), nodes) in jobs.iter().zip(fibres) {
        for (k, n) in nodes.iter().enumerate() {
            positions[[p, r, i, k, 0]] = n[0];
            positions[[p, r, i, k, 1]] = n[1];
        }
    }
    let per = |f: &dyn Fn(&Web) -> f64| Array1::from_iter(webs.iter().map(|w| f(&w.web)));
    let per_i = |f: &dyn Fn(&Web) -> i64| Array1::from_iter(webs.iter().map(|w| f(&w.web)));
    let mut out = Output::new();
    out.i64("fibres_across", &["point"], per_i(&|w| w.params().fibres_across as i64), "1", "n_w, fibres started across the machine");
    out.i64("segments_per_fibre", &["point"], per_i(&|w| w.params().segments_per_fibre as i64), "1", "n_l, random segments per fibre");
    out.f64("fibre_spacing", &["point"], per(&|w| w.params().fibre_spacing), "m", "Δw, CD spacing of the fibres' starting points");
    out.f64("belt_speed_ratio", &["point"], per(&|w| w.params().belt_speed_ratio), "1", "c = v_b/v_f (eqs 14-15)");
    out.f64("fibre_diameter", &["point"], per(&|w| w.params().fibre_diameter), "m", "d, fibre diameter");
    out.f64("fibre_density", &["point"], per(&|w| w.params().fibre_density), "kg m-3", "ρ, fibre material density");
    out.strings("spectrum_selection", "point", webs.iter().map(|w| w.web.params().spectrum_selection.name().to_string()).collect(), "spectrum selection").describe("single: first spectrum for every segment; per_segment: each segment draws one of the set");
    out.strings("rng_seed", "point", webs.iter().map(|w| w.web.params().seed.to_string()).collect(), "master seed").describe("master seed of the fibre streams (decimal u64): fibre j of realisation k uses ChaCha8 stream k·2^32 + j");
    out.strings("spectrum_source", "point", webs.iter().map(|w| w.source.clone()).collect(), "where the spectrum came from");
    if webs.iter().all(|w| w.input_point.is_some()) {
        out.i64("input_point", &["point"], Array1::from_iter(webs.iter().map(|w| w.input_point.unwrap_or(0) as i64)), "1", "point of the input spectra stage used");
    }
    out.strings("inherited_parameters", "point", webs.iter().map(|w| w.inherited.clone().unwrap_or_default()).collect(), "inherited physical parameters").describe("physical parameters left auto and taken from the input's laid fibres, with their values (empty: none)");
    out.i64("points_per_segment", &["point"], per_i(&|w| w.points_per_segment() as i64), "1", "N, samples per segment");
    out.f64("segment_length", &["point"], per(&|w| w.segment_length()), "m", "L, segment length");
    out.f64("node_spacing", &["point"], per(&|w| w.spacing()), "m", "Δs = L/N, arc length between nodes");
    out.i64("nodes_per_fibre", &["point"], per_i(&|w| w.nodes_per_fibre() as i64), "1", "n_l·N + 1 nodes per fibre");
    out.f64("point_mass", &["point"], per(&|w| w.point_mass()), "kg", "point mass Δm").describe("Δm = ρ(πd²/4)Δs carried by every node but the last");
    out.f64("drift_length", &["point"], per(&|w| w.drift_length()), "m", "c·n_l·L, nominal MD extent of the web");
    out.f64("interior_areal_density", &["point"], per(&|w| w.params().interior_areal_density() * 1e3), "g m-2", "expected interior areal density").describe("ρ(πd²/4)/(Δw·c), areal density far from edges and drift ends");
    out.i64("spectrum_count", &["point"], Array1::from_iter(webs.iter().map(|w| w.spectra.len() as i64)), "1", "spectra in the set").describe("spectra in the set (entries beyond are NaN padding)");
    out.f64("spectrum_real", &["point", "spectrum", "bin"], re, "m-1", "spectrum K_r used, real part").describe("real part of the K_r the fibres use (magnitudes kept, phases randomised; eq 11)");
    out.f64("spectrum_imag", &["point", "spectrum", "bin"], im, "m-1", "imaginary part of the K_r the fibres use");
    out.i64("sample_fibre_index", &["point", "sample_fibre"], index, "1", "index j of each stored fibre (-1: padding)");
    out.strings("xy", "xy", vec!["x".into(), "y".into()], "axis").describe("axis: x machine direction (belt motion), y cross direction");
    out.f64("fibre_positions", &["point", "realisation", "sample_fibre", "node", "xy"], positions, "m", "stored fibre nodes").describe("nodes of the stored fibres (realisation = replicate), s = node·Δs; NaN padding");
    out.strings("generator", "point", webs.iter().map(|w| w.web.params().generator.name().to_string()).collect(), "generator").describe("how the fibres are made: random_phase (eqs 11-13), laid_segments (laid fibres joined), lay_down_sde (ITWM stochastic lay-down model)");
    out.strings("segment_join", "point", webs.iter().map(|w| w.web.params().segment_join.name().to_string()).collect(), "segment join").describe("laid_segments: matched (laid fibres kept about their feed axis, entered where they continue the previous one) or curvature (curvature integrated across joins)");
    out.flags("mirror", &["point"], Array1::from_iter(webs.iter().map(|w| w.web.params().mirror)), "laid_segments: templates mirrored at random");
    let shape = |f: &dyn Fn(&PointWeb) -> Option<f64>| Array1::from_iter(webs.iter().map(|w| f(w).unwrap_or(nan)));
    out.f64("input_radius_of_gyration", &["point"], shape(&|w| w.input_shape.map(|s| s.radius_of_gyration)), "m", "mean S of the input's laid fibres").describe("mean S (eq 5) of the input's laid fibres, belt removed, as the spectra stage sampled them (NaN: no laid input)");
    out.f64("input_bending_energy", &["point"], shape(&|w| w.input_shape.map(|s| s.bending_energy)), "1", "mean e of the input's laid fibres").describe("mean e (eq 6) of the input's laid fibres at their Δs");
    out.f64("generated_radius_of_gyration", &["point"], shape(&|w| Some(w.generated_shape.radius_of_gyration)), "m", "mean S of the generated segments").describe("mean S of segment-long windows of the generated fibres, belt drift removed (8 fibres of realisation 0)");
    out.f64("generated_bending_energy", &["point"], shape(&|w| Some(w.generated_shape.bending_energy)), "1", "mean e of the same windows");
    out.f64("sde_potential_length", &["point"], shape(&|w| w.web.sde_model().map(|m| m.potential_length)), "m", "SDE potential length b").describe("lay_down_sde: b of V = |η|²/(2b²) (NaN: other generator)");
    out.f64("sde_noise", &["point"], shape(&|w| w.web.sde_model().map(|m| m.noise)), "m-1/2", "lay_down_sde: A, noise on the tangent angle");
    out.strings(
        "sde_calibration",
        "point",
        webs.iter()
            .map(|w| match (&w.calibration, w.web.sde_model()) {
                (Some(c), _) => format!(
                    "calibrated on the input's laid fibres (seed {}): target S = {:.6e} m, e = {:.6e}; achieved S = {:.6e} m, e = {:.6e} over {} segments after {} iterations; {}",
                    w.web.params().seed, c.target.radius_of_gyration, c.target.bending_energy, c.achieved.radius_of_gyration, c.achieved.bending_energy, c.segments, c.iterations,
                    if c.converged { "converged (S 0.5 %, e 1 %)" } else { "NOT converged" }
                ),
                (None, Some(_)) => "given".to_string(),
                (None, None) => String::new(),
            } + &sde_remark(&w.web, w.calibration.as_ref()).map(|r| format!("; WARNING: {r}")).unwrap_or_default())
            .collect(),
        "SDE calibration",
    )
    .describe("lay_down_sde: how b and A were set (calibration target, fit and iterations)");
    if let Some(longest) = webs.iter().filter_map(|w| w.example_input_fibre.as_ref()).map(|f| f.len()).max() {
        let mut example = Array3::from_elem((np, longest, 2), nan);
        for (p, w) in webs.iter().enumerate() {
            for (k, q) in w.example_input_fibre.iter().flatten().enumerate() {
                example[[p, k, 0]] = q[0];
                example[[p, k, 1]] = q[1];
            }
        }
        out.f64("example_input_fibre", &["point", "example_node", "xy"], example, "m", "example input fibre").describe("the input's first laid fibre, belt removed, about its centroid (its resampled nodes, or the curve its curvature samples rebuild by eq 13); NaN padding");
    }
    if let Some(longest) = webs.iter().filter_map(|w| w.web.templates()).map(|t| t.len()).max() {
        let mut curvature = crate::memory::try_array((np, longest, nbins), nan, "the laid templates")?;
        for (p, w) in webs.iter().enumerate() {
            for (t, row) in w.web.templates().unwrap_or_default().iter().enumerate() {
                for (m, k) in row.iter().enumerate() {
                    curvature[[p, t, m]] = *k;
                }
            }
        }
        if webs.iter().any(|w| w.web.template_positions().is_some()) {
            let mut nodes = crate::memory::try_array((np, longest, nbins + 1, 2), nan, "the laid templates' nodes")?;
            for (p, w) in webs.iter().enumerate() {
                for (t, row) in w.web.template_positions().unwrap_or_default().iter().enumerate() {
                    for (m, q) in row.iter().enumerate() {
                        nodes[[p, t, m, 0]] = q[0];
                        nodes[[p, t, m, 1]] = q[1];
                    }
                }
            }
            out.f64("template_position", &["point", "template", "template_node", "xy"], nodes, "m", "template nodes").describe("laid_segments (matched join): each laid fibre's resampled belt-removed nodes, N + 1 (NaN: curvature join or padding)");
        }
        out.i64("template_count", &["point"], Array1::from_iter(webs.iter().map(|w| w.web.templates().map_or(0, |t| t.len() as i64))), "1", "template count").describe("laid_segments: templates (laid fibres) the segments are drawn from");
        out.f64("template_curvature", &["point", "template", "template_sample"], curvature, "m-1", "template curvature κ_m").describe("laid_segments: curvature samples κ_m of each template at Δs = node_spacing (NaN padding)");
    }
    out.attrs.insert(
        "fibre_sample_rule".into(),
        "all fibres when n_w·(n_l·N+1) <= store_all_max_points, else sample_fibres fibres j_i = floor((2i+1)·n_w/(2k))".into(),
    );
    Ok(out)
}

/// The webs of a web stage version, one per point, rebuilt bit-exactly from its
/// stored parameters, seed and spectrum coefficients.
pub fn web_from_input(input: &Input) -> Result<Vec<Web>> {
    let g = input.version.open()?;
    let f = |n: &str| crate::archive::hdf::read_f64(&g, n);
    let i = |n: &str| crate::archive::hdf::read_i64(&g, n);
    let (n_w, n_l, nn, count) = (i("fibres_across")?, i("segments_per_fibre")?, i("points_per_segment")?, i("spectrum_count")?);
    let (dw, c, d, rho, length) = (f("fibre_spacing")?, f("belt_speed_ratio")?, f("fibre_diameter")?, f("fibre_density")?, f("segment_length")?);
    let (re, im) = (f("spectrum_real")?, f("spectrum_imag")?);
    let selection = crate::archive::hdf::read_strings(&g, "spectrum_selection")?;
    let seeds = crate::archive::hdf::read_strings(&g, "rng_seed")?;
    let spacing = f("node_spacing")?;
    // Archives written before the generators existed hold random-phase webs only, without
    // the datasets below; each is read once for every point.
    let joins = if g.link_exists("segment_join") { Some(crate::archive::hdf::read_strings(&g, "segment_join")?) } else { None };
    let mirror = if g.link_exists("mirror") { Some(crate::archive::hdf::read_u8(&g, "mirror")?) } else { None };
    let generators = if g.link_exists("generator") { crate::archive::hdf::read_strings(&g, "generator")? } else { vec!["random_phase".to_string(); n_w.len()] };
    let uses = |kind: Generator| generators.iter().any(|n| n == kind.name());
    let (template_count, template_curvature) = if uses(Generator::LaidSegments) { (Some(i("template_count")?), Some(f("template_curvature")?)) } else { (None, None) };
    let template_position = if g.link_exists("template_position") { Some(f("template_position")?) } else { None };
    let sde = if uses(Generator::LayDownSde) { Some((f("sde_potential_length")?, f("sde_noise")?)) } else { None };
    (0..n_w.len())
        .map(|p| {
            let params = WebParams {
                fibres_across: n_w[[p]] as usize,
                segments_per_fibre: n_l[[p]] as usize,
                fibre_spacing: dw[[p]],
                belt_speed_ratio: c[[p]],
                fibre_diameter: d[[p]],
                fibre_density: rho[[p]],
                spectrum_selection: SpectrumSelection::from_name(&selection[p])?,
                generator: Generator::from_name(&generators[p])?,
                mirror: mirror.as_ref().is_some_and(|m| m[[p]] != 0),
                segment_join: match &joins {
                    Some(j) => SegmentJoin::from_name(&j[p])?,
                    None => SegmentJoin::Curvature,
                },
                seed: seeds[p].parse()?,
            };
            let spacing = spacing[[p]];
            match params.generator {
                Generator::RandomPhase => {
                    let spectra = (0..count[[p]] as usize)
                        .map(|s| {
                            let coeffs = (0..nn[[p]] as usize).map(|r| Complex64::new(re[[p, s, r]], im[[p, s, r]])).collect();
                            CurvatureSpectrum::new(length[[p]], coeffs)
                        })
                        .collect::<Result<Vec<_>, _>>()?;
                    Ok(Web::new(params, spectra)?)
                }
                Generator::LaidSegments => {
                    let (Some(count), Some(kappa)) = (&template_count, &template_curvature) else { unreachable!("read above for laid_segments points") };
                    let templates = count[[p]] as usize;
                    let rows = (0..templates).map(|t| (0..nn[[p]] as usize).map(|m| kappa[[p, t, m]]).collect()).collect();
                    let positions = match params.segment_join {
                        SegmentJoin::Matched => {
                            let q = template_position.as_ref().ok_or_else(|| anyhow!("{}: no template_position for a matched join", input.version.group_path()))?;
                            (0..templates).map(|t| (0..=nn[[p]] as usize).map(|m| [q[[p, t, m, 0]], q[[p, t, m, 1]]]).collect()).collect()
                        }
                        SegmentJoin::Curvature => vec![],
                    };
                    Ok(Web::laid_segments(params, rows, positions, spacing)?)
                }
                Generator::LayDownSde => {
                    let Some((b, a)) = &sde else { unreachable!("read above for lay_down_sde points") };
                    let model = LayDownSde { potential_length: b[[p]], noise: a[[p]] };
                    Ok(Web::lay_down_sde(params, model, spacing, nn[[p]] as usize)?)
                }
            }
        })
        .collect()
}
