//! `kind: grid` — the pipeline stage around the grid numerics (§3.3 eq 16).
//!
//! `input: <web stage>`. The web version's stored parameters, seed and spectrum
//! coefficients rebuild each point's web ([`crate::stages::web::web_from_input`]); every
//! realisation regenerates its fibres on the fly and deposits them, so no web is held.
//! `input: <laid_web stage>`: the stored laid fibres of replicate k are realisation k
//! (window and mass as in [`super::laid`]).
//!
//! - **Realisations** are the stage's `replicates:` (the paper: 10). Grid realisation k
//!   is web realisation k (fibre streams (seed, k, ·)), so realisation 0 is the one whose
//!   fibres the web stage stored.
//! - **Points.** A web with several points gives one grid point per web point (the web's
//!   sweep coordinates are copied); the grid may then not sweep itself. A one-point web
//!   may be evaluated at the grid's own sweep points. `cell_size`, `window_side` and the
//!   zone-size parameters must be the same at every point (the maps share `md`, `cd`
//!   and `zone_size` coordinates).
//! - **Check.** Before its output is made, the stage regenerates the web's stored fibres of
//!   realisation 0 and requires them to equal the stored ones bit for bit.
//! - `compare_with: table4` adds the paper's measured Table 4 as `reference_*` datasets.
//! - **Units.** An executor may compute every (point, realisation) apart
//!   ([`Stage::run_units`]); [`Stage::reduce`] places them and takes the means and
//!   standard deviations over realisations, for the local run and a gathered Slurm array
//!   alike. The regeneration check runs in the reduce.
//! - **Memory** ([`Stage::estimate_memory`]): every realisation's density map is kept
//!   until the output is written (three copies with `store_density`, 8 B per cell each),
//!   plus one realisation's working set: the deposit grid and two maps, 16 B per fibre
//!   across the web (its displacements) and each thread's fibre buffers
//!   ([`crate::stages::web::SCRATCH_BYTES_PER_NODE`] per node, [`crate::stages::web::SDE_SCRATCH_BYTES_PER_NODE`]
//!   for a lay-down SDE web); and what is read of the
//!   input: the web's stored fibres (regeneration check) or the laid web's nodes
//!   ([`LAID_BYTES_PER_NODE`]).
use crate::error::InvalidParam;
use super::laid::{read_laid_web, LaidPoint};
use super::{grid_realisation, GridParams, GridResult, GRID_PARAMS};
use crate::archive::data::{Attr, Output};
use crate::memory::Estimate;
use crate::params::{ParamSet, ParamSpec};
use crate::stages::web::{declared_webs, stored_bytes, web_from_input, Web};
use crate::stages::{concurrent, BadInput, Declared, InputRule, RunContext, Stage, Units};
use anyhow::{anyhow, bail, Result};
use ndarray::{Array1, Array2, ArrayD, Axis, IxDyn};
use std::time::Instant;

pub struct GridStage;

/// Bytes per node of a laid web read as input: its stored positions and the fibres
/// copied out of them.
const LAID_BYTES_PER_NODE: f64 = 48.0;

/// The paper's measured webs (Table 4: 8 scans each of 4 thermally bonded spunbond
/// nonwovens): v_b/v_f, d (µm), areal density (g/m²), CV raw (%), CV_corr (%).
pub const TABLE4: [[f64; 5]; 4] = [
    [0.020, 16.3, 40.0, 20.2, 11.0],
    [0.028, 16.2, 30.0, 19.6, 13.6],
    [0.050, 16.2, 17.0, 20.4, 17.9],
    [0.070, 16.2, 12.0, 21.5, 19.9],
];
pub const TABLE4_SOURCE: &str = "paper (seed 000_d7960bf99d7620d0), §3.4 Table 4: experimental web data, average over 8 measurements";

impl Stage for GridStage {
    fn kind(&self) -> &'static str {
        "grid"
    }
    fn summary(&self) -> &'static str {
        "areal density of a web on a Δh grid over an H×H window: ρ_av (eq 16), CV, CV by zone size and formation number"
    }
    fn cache_version(&self) -> u32 {
        1
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["web", "laid_web"], min: 1, max: 1 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v: Vec<ParamSpec> = GRID_PARAMS.to_vec();
        v.extend_from_slice(STAGE_PARAMS);
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), InvalidParam> {
        grid_params(p).validate().map(|_| ()).map_err(|e| {
            let name = match &e {
                super::GridError::Param(pe) => pe.name.to_string(),
                super::GridError::ZoneRange { .. } => "zone_size_min".into(),
                _ => "cell_size".into(),
            };
            InvalidParam::new(name, e.to_string())
        })
    }

    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let input = stage.inputs.first()?;
        let p = &stage.points[0];
        let g = grid_params(p);
        let cells = (g.window_side / g.cell_size).round();
        let map = cells * cells * 8.0;
        let input_param = |name: &str| (input.name.clone(), name.to_string());
        // (web points, one realisation's fibre working set, bytes read of the input, its drivers)
        let (web_points, fibres, read, web_what, web_params) = if input.kind == "laid_web" {
            let laid = crate::stages::laid_web::stage::declared_fibres(input);
            let nodes: f64 = laid.iter().map(|f| f.count * f.nodes).sum();
            let what = format!("{nodes:.3e} laid nodes of input `{}` read, {LAID_BYTES_PER_NODE} B each", input.name);
            (laid.len(), 0.0, nodes * LAID_BYTES_PER_NODE, what, vec![input_param("fibres_across"), input_param("belt_travel")])
        } else {
            let webs = declared_webs(input);
            let n_w = webs.iter().map(|w| w.fibres_across).fold(0.0, f64::max);
            let nodes = webs.iter().map(|w| w.nodes_per_fibre).fold(0.0, f64::max);
            let per_node = webs.iter().map(|w| w.scratch_bytes_per_node).fold(0.0, f64::max);
            let (displacements, generated) = (n_w * 16.0, concurrent(n_w) * nodes * per_node);
            let (what, params) = if displacements >= generated {
                (format!("the displacements of the n_w = {n_w} fibres across input web `{}`, 16 B each", input.name), vec![input_param("fibres_across")])
            } else {
                let what = format!("fibres of {nodes} nodes of input web `{}` generated by {} threads at once, {per_node} B per node", input.name, concurrent(n_w));
                (what, vec![input_param("segments_per_fibre"), input_param("points_per_segment")])
            };
            (webs.len(), displacements + generated, stored_bytes(input), what, params)
        };
        let points = if web_points > 1 { web_points } else { stage.points.len() };
        let copies = if stage_params(p).store_density { 3.0 } else { 1.0 };
        let maps = (points * stage.replicates) as f64 * map * copies + 3.0 * map;
        let bytes = maps + fibres + read;
        Some(if maps >= fibres + read {
            let held = if copies > 1.0 { "three copies each (store_density)" } else { "one copy each" };
            let what = format!("{} density maps of {cells} × {cells} cells, 8 B per cell, {held}", points * stage.replicates);
            Estimate::new(bytes, what, &stage.name, &["window_side", "replicates"]).falling_with(&stage.name, &["cell_size"])
        } else {
            Estimate { bytes, what: web_what, params: web_params, inverse: vec![] }
        })
    }

    /// All units, then the reduce, on one read of the input web (the trait's
    /// [`Stage::run_units`] and [`Stage::reduce`] read it for themselves, as an array task
    /// and the gathering driver must).
    fn run(&self, ctx: &RunContext) -> Result<Output> {
        let (points, source) = grid_units(ctx)?;
        let rows = grid_rows(ctx, &points, &source, 0..points.len() * ctx.replicates)?;
        grid_output(ctx, &points, &source, rows)
    }
    /// A unit is one (point, realisation): realisation k of a web is keyed by the web
    /// and k only, so any share of the units grids what the whole run grids.
    fn units(&self, ctx: &RunContext) -> Result<Option<Units>> {
        let (points, _) = grid_units(ctx)?;
        Ok(Some(Units { points: points.len(), per_point: ctx.replicates, note: None }))
    }
    fn run_units(&self, ctx: &RunContext, range: std::ops::Range<usize>) -> Result<Output> {
        let (points, source) = grid_units(ctx)?;
        grid_rows(ctx, &points, &source, range)
    }
    fn reduce(&self, ctx: &RunContext, rows: Output) -> Result<Output> {
        let (points, source) = grid_units(ctx)?;
        grid_output(ctx, &points, &source, rows)
    }
}

/// The per-realisation rows of the units `range` ([`Stage::run_units`]).
fn grid_rows(ctx: &RunContext, points: &Points, source: &Source, range: std::ops::Range<usize>) -> Result<Output> {
    let reps = ctx.replicates;
    let bar = crate::progress::bar(ctx.progress, range.len() as u64, &format!("{} realisations", ctx.stage_name));
    let mut results: Vec<Row> = Vec::with_capacity(range.len());
    for u in range {
        let (i, r) = (u / reps, u % reps);
        let (w, g) = &points[i];
        let t = Instant::now();
        let res = source.realisation(*w, g, r, ctx.replicates).map_err(|e| {
            let at = format!("point {i} (web point {w}), realisation {r}");
            // memory that could not be had is a runtime failure; anything else is the input's
            match e.downcast::<super::GridError>() {
                Ok(super::GridError::Alloc(a)) => anyhow::Error::new(a).context(at),
                Ok(e) => BadInput(format!("{at}: {e}")).into(),
                Err(e) => BadInput(format!("{at}: {e}")).into(),
            }
        })?;
        results.push((i, r, res, t.elapsed().as_secs_f64()));
        bar.inc(1);
    }
    bar.finish_and_clear();
    unit_rows(&results, stage_params(&ctx.points[0]).store_density)
}

/// The stage output from the rows of every unit ([`Stage::reduce`]), with the
/// regeneration check and the optional Table 4 (the runner copies the web's sweep
/// coordinates along `input_point`, see [`crate::coordinates`]).
fn grid_output(ctx: &RunContext, points: &Points, source: &Source, rows: Output) -> Result<Output> {
    let input = ctx.input(0);
    let regen = match source {
        Source::Web(webs) => check_regeneration(input, webs)?,
        Source::Laid(_) => "laid web: fibres read as stored, nothing to regenerate".to_string(),
    };
    let expected: Vec<f64> = (0..source.len()).map(|w| source.expected_interior_density(w)).collect();
    let own = stage_params(&ctx.points[0]);
    let mut out = assemble(points, &expected, &rows, ctx.replicates, own.store_density)?;
    if own.compare_with == CompareWith::Table4 {
        add_table4(&mut out);
    }
    out.attrs.insert("regeneration_check".into(), Attr::Str(regen));
    Ok(out)
}

/// The grid's points as (web point, grid parameters).
type Points = Vec<(usize, GridParams)>;

/// What a grid reads: a stochastic web (regenerated per realisation) or a web laid by
/// the physics (stored fibres, one replicate per realisation).
enum Source {
    Web(Vec<Web>),
    Laid(Vec<LaidPoint>),
}

impl Source {
    fn read(input: &crate::stages::Input) -> Result<Self> {
        Ok(match input.kind.as_str() {
            "laid_web" => Source::Laid(read_laid_web(input)?),
            _ => Source::Web(web_from_input(input)?),
        })
    }
    fn len(&self) -> usize {
        match self {
            Source::Web(w) => w.len(),
            Source::Laid(l) => l.len(),
        }
    }
    /// ρA/(Δw·c) of web point `w` (kg/m²).
    fn expected_interior_density(&self, w: usize) -> f64 {
        match self {
            Source::Web(webs) => webs[w].params().interior_areal_density(),
            Source::Laid(points) => points[w].expected_interior_density,
        }
    }
    fn realisation(&self, w: usize, g: &GridParams, r: usize, replicates: usize) -> Result<GridResult> {
        match self {
            Source::Web(webs) => Ok(grid_realisation(&webs[w], g, r as u32)?),
            Source::Laid(points) => {
                let corner = points[w].window_corner(g, replicates)?;
                Ok(points[w].grid(g, r, corner)?)
            }
        }
    }
}

/// The grid's points — one per web point of a swept web, else one per own sweep point
/// of a one-point web — and the webs.
fn grid_units(ctx: &RunContext) -> Result<(Points, Source)> {
    let input = ctx.input(0);
    let webs = Source::read(input)?;
    let nw = webs.len();
    if nw > 1 && !ctx.sweep.is_empty() {
        return Err(BadInput(format!(
            "the input web {} has {nw} points; a grid reading it takes the web's points and cannot have a sweep of its own (use one grid stage per setting)",
            input.version.group_path()
        ))
        .into());
    }
    let units: Vec<(usize, GridParams)> = if nw > 1 {
        (0..nw).map(|i| (i, grid_params(&ctx.points[0]))).collect()
    } else {
        ctx.points.iter().map(|p| (0, grid_params(p))).collect()
    };
    let first = units[0].1;
    for (i, (_, g)) in units.iter().enumerate() {
        let same = g.cell_size == first.cell_size
            && g.window_side == first.window_side
            && g.zone_size_min == first.zone_size_min
            && g.zone_size_max == first.zone_size_max
            && g.zones_per_octave == first.zones_per_octave;
        if !same {
            return Err(BadInput(format!("point {i}: cell_size, window_side and the zone-size parameters must be the same at every point (the maps share md, cd and zone_size); use one grid stage per setting")).into());
        }
    }
    Ok((units, webs))
}

/// The grid stage's own rows, beside [`GRID_PARAMS`].
const STAGE_PARAMS: &[ParamSpec] = &[
    ParamSpec::flag("store_density", true, "store the density maps (point, realisation, md, cd); false keeps only the statistics"),
    ParamSpec::choice("compare_with", CompareWith::NAMES, "none", "table4: store the paper's measured Table 4 values as reference_* datasets"),
];

crate::params::choice_enum! {
    /// Measured values stored beside the grid's (`compare_with`).
    pub enum CompareWith {
        #[default]
        None = "none",
        /// The paper's Table 4.
        Table4 = "table4",
    }
}

/// A grid point's parameters: the grid's and the stage's own rows.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GridStageParams {
    #[serde(flatten)]
    pub grid: GridParams,
    pub store_density: bool,
    pub compare_with: CompareWith,
}

/// A point's typed parameters (its rows were checked against the table).
pub fn stage_params(p: &ParamSet) -> GridStageParams {
    p.to_typed().expect("the grid table and GridStageParams agree (tested)")
}

/// A point's grid parameters.
pub fn grid_params(p: &ParamSet) -> GridParams {
    stage_params(p).grid
}

/// Regenerates the web's stored fibres of realisation 0 and compares them bit for bit.
fn check_regeneration(input: &crate::stages::Input, webs: &[Web]) -> Result<String> {
    let positions = input.read_f64("fibre_positions")?; // (point, realisation, sample, node, xy)
    let index = input.read_i64("sample_fibre_index")?; // (point, sample)
    if positions.shape()[1] == 0 {
        return Ok("web stored no realisation; nothing compared".into());
    }
    let mut compared = 0;
    for (p, web) in webs.iter().enumerate() {
        for (i, &j) in index.index_axis(Axis(0), p).iter().enumerate() {
            if j < 0 {
                continue;
            }
            let nodes = web.generate_fibre(0, j as usize);
            let stored = positions.index_axis(Axis(0), p).index_axis(Axis(0), 0).index_axis(Axis(0), i).to_owned();
            let equal = nodes.iter().enumerate().all(|(k, n)| {
                n[0].to_bits() == stored[[k, 0]].to_bits() && n[1].to_bits() == stored[[k, 1]].to_bits()
            });
            if !equal {
                return Err(anyhow!("web {} point {p} fibre {j}: regenerated nodes differ from the stored ones", input.version.group_path()));
            }
            compared += 1;
        }
    }
    Ok(format!("{compared} stored fibres of realisation 0 regenerated bit-identically"))
}

/// One computed realisation: (point, realisation, result, wall seconds).
type Row = (usize, usize, GridResult, f64);

/// The per-realisation rows of `results`: everything of a realisation that the stage
/// output holds.
fn unit_rows(results: &[Row], store_density: bool) -> Result<Output> {
    let unit = crate::stages::UNIT_DIM;
    let n = results.len();
    let col = |f: &dyn Fn(&GridResult) -> f64| Array1::from_iter(results.iter().map(|r| f(&r.2)));
    let nz = results.first().map(|r| r.2.zone_curve.len()).unwrap_or(0);
    let zone = |f: &dyn Fn(&super::ZonePoint) -> f64| Array2::from_shape_fn((n, nz), |(u, z)| f(&results[u].2.zone_curve[z]));
    let zone_i = |f: &dyn Fn(&super::ZonePoint) -> usize| Array2::from_shape_fn((n, nz), |(u, z)| f(&results[u].2.zone_curve[z]) as i64);
    let mut out = Output::new();
    out.i64("unit_point", &[unit], Array1::from_iter(results.iter().map(|r| r.0 as i64)), "1", "point of the row");
    out.i64("unit_replicate", &[unit], Array1::from_iter(results.iter().map(|r| r.1 as i64)), "1", "realisation of the row");
    if store_density && n > 0 {
        let cells = results[0].2.density.shape().to_vec();
        let mut density = crate::memory::try_array((n, cells[0], cells[1]), 0.0, "the density maps")?;
        for (u, r) in results.iter().enumerate() {
            density.index_axis_mut(Axis(0), u).assign(&(&r.2.density * 1e3));
        }
        out.f64("density", &[unit, "md", "cd"], density, "g m-2", "");
    }
    out.f64("window_corner_md", &[unit], col(&|g| g.window_corner[0]), "m", "");
    out.f64("window_corner_cd", &[unit], col(&|g| g.window_corner[1]), "m", "");
    out.f64("mean_areal_density", &[unit], col(&|g| g.mean_areal_density_gsm), "g m-2", "");
    out.f64("cv", &[unit], col(&|g| g.cv), "1", "");
    out.f64("fibre_length_per_area", &[unit], col(&|g| g.fibre_length_per_area), "m-1", "");
    out.f64("spread_cd", &[unit], col(&|g| g.spreads.cross_direction), "m", "");
    out.f64("spread_md", &[unit], col(&|g| g.spreads.machine_direction), "m", "");
    out.f64("nodes_generated", &[unit], col(&|g| g.nodes_generated as f64), "1", "");
    out.f64("wall_seconds", &[unit], Array1::from_iter(results.iter().map(|r| r.3)), "s", "");
    out.f64("zone_size", &[unit, "zone_size"], zone(&|z| z.zone_size), "m", "");
    out.i64("zone_cells", &[unit, "zone_size"], zone_i(&|z| z.cells_per_side), "1", "");
    out.i64("zone_count", &[unit, "zone_size"], zone_i(&|z| z.zones), "1", "");
    out.f64("cv_zone", &[unit, "zone_size"], zone(&|z| z.cv), "1", "");
    out.f64("random_line_cv", &[unit, "zone_size"], zone(&|z| z.random_line_cv), "1", "");
    out.f64("formation_number", &[unit, "zone_size"], zone(&|z| z.formation_number), "1", "");
    Ok(out)
}

/// The stage output from the rows of every (point, realisation) ([`unit_rows`], whole or
/// gathered from the parts of a job array): the maps and per-realisation values on the
/// (point, realisation) axes and the means and standard deviations over realisations.
fn assemble(units: &[(usize, GridParams)], expected_density: &[f64], rows: &Output, reps: usize, store_density: bool) -> Result<Output> {
    use crate::stages::rows as get;
    let np = units.len();
    let index = get::index(rows)?;
    let expected: Vec<(usize, usize)> = (0..np).flat_map(|p| (0..reps).map(move |r| (p, r))).collect();
    if index != expected {
        bail!("the per-realisation rows are not every (point, realisation) of {np} points × {reps} realisations in order");
    }
    // Rows (point * reps + realisation, rest…) as (point, realisation, rest…).
    let by_rep = |a: &ArrayD<f64>| -> Result<ArrayD<f64>> {
        let mut shape = vec![np, reps];
        shape.extend_from_slice(&a.shape()[1..]);
        Ok(ArrayD::from_shape_vec(IxDyn(&shape), a.iter().copied().collect())?)
    };
    let row_f = |name: &str| get::f64(rows, name);
    let per_rep = |name: &str| -> Result<Array2<f64>> { Ok(by_rep(row_f(name)?)?.into_dimensionality()?) };
    let g0 = units[0].1;
    let cells = g0.validate().expect("validated");
    let h = g0.cell_size;
    let nz = row_f("zone_size")?.shape()[1];
    let mut out = Output::new();
    let centres = Array1::from_iter((0..cells).map(|k| (k as f64 + 0.5) * h));
    out.f64("md", &["md"], centres.clone(), "m", "MD cell centre").describe("machine-direction cell centre, measured from the window's lower MD edge window_corner_md");
    out.f64("cd", &["cd"], centres, "m", "CD cell centre").describe("cross-direction cell centre, measured from the window's lower CD edge window_corner_cd");
    out.f64("cell_size", &[], ndarray::arr0(h), "m", "Δh, grid cell side");
    out.f64("window_side", &[], ndarray::arr0(g0.window_side), "m", "H, window side");
    if store_density && reps > 0 {
        out.f64("density", &["point", "realisation", "md", "cd"], by_rep(row_f("density")?)?, "g m-2", "areal density of each Δh × Δh cell");
    }
    // Realisation 0's window (the window is placed the same for every realisation).
    let corner = |name: &str| -> Result<Array1<f64>> {
        let a = row_f(name)?;
        Ok(Array1::from_iter((0..np).map(|p| a[[p * reps]])))
    };
    if reps > 0 {
        out.f64("window_corner_md", &["point"], corner("window_corner_md")?, "m", "window MD edge").describe("MD position of the window's lower edge in web coordinates (fibres start at x = 0)");
        out.f64("window_corner_cd", &["point"], corner("window_corner_cd")?, "m", "window CD edge").describe("CD position of the window's lower edge (web centre line y = 0)");
    }
    out.i64("input_point", &["point"], Array1::from_iter(units.iter().map(|u| u.0 as i64)), "1", "point of the input web (or laid web) gridded");
    out.f64("expected_interior_density", &["point"], Array1::from_iter(units.iter().map(|u| expected_density[u.0] * 1e3)), "g m-2", "expected interior areal density").describe("ρ(πd²/4)/(Δw·c), the interior areal density mass conservation implies");
    let rho = per_rep("mean_areal_density")?;
    let cv = per_rep("cv")?;
    for (name, values, unit, label, long) in [
        ("mean_areal_density", &rho, "g m-2", "areal density ρ_av", "ρ_av = Σ m_k / H² over the window (eq 16)"),
        ("cv", &cv, "1", "CV", "coefficient of variation of the cell densities"),
    ] {
        out.f64(name, &["point", "realisation"], values.clone(), unit, label).describe(long);
        let (m, s) = mean_std(values);
        out.f64(&format!("{name}_mean"), &["point"], m, unit, &format!("mean {label}")).describe(format!("mean over realisations of {long}"));
        out.f64(&format!("{name}_std"), &["point"], s, unit, &format!("std of {label}")).describe(format!("sample standard deviation over realisations of {long}"));
    }
    out.f64("fibre_length_per_area", &["point", "realisation"], per_rep("fibre_length_per_area")?, "m-1", "fibre length per area").describe("L_A = ρ_av/(ρπd²/4), fibre length per window area");
    out.f64("spread_cd", &["point", "realisation"], per_rep("spread_cd")?, "m", "RMS CD fibre displacement").describe("σ_CD, RMS CD displacement of the fibres where the drift reaches the window's far edge");
    out.f64("spread_md", &["point", "realisation"], per_rep("spread_md")?, "m", "RMS MD fibre-end displacement").describe("σ_MD, RMS MD displacement of the fibre ends from c·n_l·L");
    out.f64("nodes_generated", &["point", "realisation"], per_rep("nodes_generated")?, "1", "fibre nodes generated for the realisation");
    out.f64("wall_seconds", &["point", "realisation"], per_rep("wall_seconds")?, "s", "wall time of the realisation").describe("wall time of generating and gridding the realisation");
    if nz > 0 {
        // The zone sizes of the first realisation (they depend only on the parameters).
        out.f64("zone_size", &["zone_size"], row_f("zone_size")?.index_axis(Axis(0), 0).to_owned(), "m", "zone size").describe("zone side x = cells·Δh (log-spaced from zone_size_min, sizes below Δh skipped)");
        out.i64("zone_cells", &["zone_size"], get::i64(rows, "zone_cells")?.index_axis(Axis(0), 0).to_owned(), "1", "cells per zone side");
        out.i64("zone_count", &["zone_size"], get::i64(rows, "zone_count")?.index_axis(Axis(0), 0).to_owned(), "1", "zones the CV is taken over");
        let cvz = by_rep(row_f("cv_zone")?)?;
        let nf = by_rep(row_f("formation_number")?)?;
        out.f64("cv_zone", &["point", "realisation", "zone_size"], cvz.clone(), "1", "CV of the zone densities at zone size x");
        out.f64("random_line_cv", &["point", "realisation", "zone_size"], by_rep(row_f("random_line_cv")?)?, "1", "CV of a random line network").describe("CV of a Poisson network of straight lines with the same L_A: sqrt(E1/(π L_A x)) (REFERENCE.md §2)");
        out.f64("formation_number", &["point", "realisation", "zone_size"], nf.clone(), "1", "n_f(x) = CV²/CV²_random-line");
        out.f64("cv_zone_mean", &["point", "zone_size"], cvz.mean_axis(Axis(1)).unwrap(), "1", "mean over realisations of cv_zone");
        out.f64("formation_number_mean", &["point", "zone_size"], nf.mean_axis(Axis(1)).unwrap(), "1", "mean over realisations of formation_number");
    }
    Ok(out)
}

fn mean_std(v: &Array2<f64>) -> (Array1<f64>, Array1<f64>) {
    let n = v.shape()[1];
    let m = Array1::from_iter(v.outer_iter().map(|row| if n == 0 { f64::NAN } else { row.sum() / n as f64 }));
    let s = Array1::from_iter(v.outer_iter().zip(m.iter()).map(|(row, &m)| {
        // The sample standard deviation of one value is undefined: NaN, not 0.
        if n < 2 {
            f64::NAN
        } else {
            (row.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        }
    }));
    (m, s)
}

fn add_table4(out: &mut Output) {
    let col = |c: usize| Array1::from_iter(TABLE4.iter().map(|r| r[c]));
    let src = Attr::Str(TABLE4_SOURCE.into());
    let rows = [
        ("reference_belt_speed_ratio", 0, "1", "measured v_b/v_f"),
        ("reference_fibre_diameter", 1, "um", "measured fibre diameter d"),
        ("reference_areal_density", 2, "g m-2", "measured areal density"),
        ("reference_cv_raw", 3, "%", "CV of the grey levels of the raw images"),
        ("reference_cv_corr", 4, "%", "CV after removing the bond pattern (CV_corr), the one to compare with simulated CV"),
    ];
    for (name, c, unit, long) in rows {
        out.f64(name, &["reference_row"], col(c), unit, long).attrs.insert("source".into(), src.clone());
    }
    out.attrs.insert("reference_source".into(), src);
}
