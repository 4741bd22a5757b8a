//! `kind: grid` — the pipeline stage around the grid numerics (§3.3 eq 16).
//!
//! `input: <web stage>`. The web version's stored parameters, seed and spectrum
//! coefficients rebuild each point's web ([`crate::stages::web::web_from_input`]); every
//! realisation regenerates its fibres on the fly and deposits them, so no web is held.
//!
//! - **Realisations** are the stage's `replicates:` (the paper: 10). Grid realisation k
//!   is web realisation k (fibre streams (seed, k, ·)), so realisation 0 is the one whose
//!   fibres the web stage stored.
//! - **Points.** A web with several points gives one grid point per web point (the web's
//!   sweep coordinates are copied); the grid may then not sweep itself. A one-point web
//!   may be evaluated at the grid's own sweep points. `cell_size`, `window_side` and the
//!   zone-size parameters must be the same at every point (the maps share `md`, `cd`
//!   and `zone_size` coordinates).
//! - **Check.** Before gridding, the stage regenerates the web's stored fibres of
//!   realisation 0 and requires them to equal the stored ones bit for bit.
//! - `compare_with: table4` adds the paper's measured Table 4 as `reference_*` datasets.
use super::{grid_realisation, Boundary, Deposit, GridParams, GridResult, GRID_PARAMS};
use crate::archive::data::{Attr, Output};
use crate::params::{ParamSet, ParamSpec};
use crate::stages::web::{web_from_input, Web};
use crate::stages::{BadInput, InputRule, RunContext, Stage};
use anyhow::{anyhow, Result};
use ndarray::{Array1, Array2, Array3, Array4, ArrayD, Axis, IxDyn};
use std::time::Instant;

pub struct GridStage;

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
    /// Points are independent (one web point each): an executor may split them.
    fn point_dims(&self) -> &'static [&'static str] {
        &["point"]
    }
    fn point_count(&self, ctx: &RunContext) -> Result<usize> {
        let web_points = ctx.input(0).read_f64("point")?.len();
        Ok(if web_points > 1 { web_points } else { ctx.points.len() })
    }
    fn cache_version(&self) -> u32 {
        1
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["web"], min: 1, max: 1 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v: Vec<ParamSpec> = GRID_PARAMS.iter().map(|p| p.into()).collect();
        v.push(ParamSpec::flag("store_density", true, "store the density maps (point, realisation, md, cd); false keeps only the statistics"));
        v.push(ParamSpec::choice("compare_with", &["none", "table4"], "none", "table4: store the paper's measured Table 4 values as reference_* datasets"));
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), (String, String)> {
        grid_params(p).validate().map(|_| ()).map_err(|e| {
            let name = match &e {
                super::GridError::Param(pe) => pe.name.to_string(),
                super::GridError::ZoneRange { .. } => "zone_size_min".into(),
                _ => "cell_size".into(),
            };
            (name, e.to_string())
        })
    }

    fn run(&self, ctx: &RunContext) -> Result<Output> {
        let input = ctx.input(0);
        let webs = web_from_input(input)?;
        let nw = webs.len();
        if nw > 1 && !ctx.sweep.is_empty() {
            return Err(BadInput(format!(
                "the input web {} has {nw} points; a grid reading it takes the web's points and cannot have a sweep of its own (use one grid stage per setting)",
                input.version.group_path()
            ))
            .into());
        }
        // One point per web point (a swept web), or per own sweep point of one web. An
        // executor may ask for a share of the web's points (`point_range`); the grid's own
        // points arrive already cut to the share.
        let units: Vec<(usize, GridParams)> = if nw > 1 {
            let (lo, hi) = ctx.point_range.unwrap_or((0, nw));
            (lo..hi).map(|i| (i, grid_params(&ctx.points[0]))).collect()
        } else {
            ctx.points.iter().map(|p| (0, grid_params(p))).collect()
        };
        let npoints = units.len();
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
        let regen = check_regeneration(input, &webs)?;

        let reps = ctx.replicates;
        let bar = crate::progress::bar(ctx.progress, (npoints * reps) as u64, &format!("{} realisations", ctx.stage_name));
        let mut results: Vec<(GridResult, f64)> = Vec::with_capacity(npoints * reps);
        for (i, (w, g)) in units.iter().enumerate() {
            for r in 0..reps {
                let t = Instant::now();
                let res = grid_realisation(&webs[*w], g, r as u32).map_err(|e| BadInput(format!("point {i} (web point {w}), realisation {r}: {e}")))?;
                results.push((res, t.elapsed().as_secs_f64()));
                bar.inc(1);
            }
        }
        bar.finish_and_clear();
        let mut out = assemble(&units, &webs, &results, reps, ctx.points[0].bool("store_density"));
        if nw > 1 {
            let web_points: Vec<usize> = units.iter().map(|u| u.0).collect();
            copy_web_sweep(input, &mut out, &web_points)?;
        }
        if ctx.points[0].text("compare_with") == "table4" {
            add_table4(&mut out);
        }
        out.attrs.insert("regeneration_check".into(), Attr::Str(regen));
        Ok(out)
    }
}

pub fn grid_params(p: &ParamSet) -> GridParams {
    GridParams {
        cell_size: p.f64("cell_size"),
        window_side: p.f64("window_side"),
        window_offset_md: p.f64("window_offset_md"),
        window_offset_cd: p.f64("window_offset_cd"),
        edge_margin_spreads: p.f64("edge_margin_spreads"),
        deposit: Deposit::from_name(p.text("deposit")).expect("validated choice"),
        boundary: Boundary::from_name(p.text("boundary")).expect("validated choice"),
        zone_size_min: p.f64("zone_size_min"),
        zone_size_max: p.f64("zone_size_max"),
        zones_per_octave: p.usize("zones_per_octave"),
    }
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

fn assemble(units: &[(usize, GridParams)], webs: &[Web], results: &[(GridResult, f64)], reps: usize, store_density: bool) -> Output {
    let np = units.len();
    let g0 = units[0].1;
    let cells = g0.validate().expect("validated");
    let h = g0.cell_size;
    let at = |p: usize, r: usize| &results[p * reps + r].0;
    let per_rep = |f: &dyn Fn(&GridResult) -> f64| Array2::from_shape_fn((np, reps), |(p, r)| f(at(p, r)));
    let nz = results.first().map(|r| r.0.zone_curve.len()).unwrap_or(0);
    let zone = |f: &dyn Fn(&super::ZonePoint) -> f64| Array3::from_shape_fn((np, reps, nz), |(p, r, z)| f(&at(p, r).zone_curve[z]));
    let mut out = Output::new();
    let centres = Array1::from_iter((0..cells).map(|k| (k as f64 + 0.5) * h));
    out.f64("md", &["md"], centres.clone(), "m", "machine-direction cell centre, measured from the window's lower MD edge window_corner_md");
    out.f64("cd", &["cd"], centres, "m", "cross-direction cell centre, measured from the window's lower CD edge window_corner_cd");
    out.f64("cell_size", &[], ndarray::arr0(h), "m", "Δh, grid cell side");
    out.f64("window_side", &[], ndarray::arr0(g0.window_side), "m", "H, window side");
    if store_density && reps > 0 {
        let mut density = Array4::zeros((np, reps, cells, cells));
        for p in 0..np {
            for r in 0..reps {
                density.index_axis_mut(Axis(0), p).index_axis_mut(Axis(0), r).assign(&(&at(p, r).density * 1e3));
            }
        }
        out.f64("density", &["point", "realisation", "md", "cd"], density, "g m-2", "areal density of each Δh × Δh cell");
    }
    let corner = |c: usize| Array1::from_iter((0..np).map(|p| results[p * reps].0.window_corner[c]));
    if reps > 0 {
        out.f64("window_corner_md", &["point"], corner(0), "m", "MD position of the window's lower edge in web coordinates (fibres start at x = 0)");
        out.f64("window_corner_cd", &["point"], corner(1), "m", "CD position of the window's lower edge (web centre line y = 0)");
    }
    out.i64("web_point", &["point"], Array1::from_iter(units.iter().map(|u| u.0 as i64)), "1", "point of the input web evaluated");
    out.f64("expected_interior_density", &["point"], Array1::from_iter(units.iter().map(|u| webs[u.0].params().interior_areal_density() * 1e3)), "g m-2", "ρ(πd²/4)/(Δw·c), the interior areal density mass conservation implies");
    let rho = per_rep(&|g| g.mean_areal_density_gsm);
    let cv = per_rep(&|g| g.cv);
    for (name, values, unit, long) in [
        ("mean_areal_density", &rho, "g m-2", "ρ_av = Σ m_k / H² over the window (eq 16)"),
        ("cv", &cv, "1", "coefficient of variation of the cell densities"),
    ] {
        out.f64(name, &["point", "realisation"], values.clone(), unit, long);
        let (m, s) = mean_std(values);
        out.f64(&format!("{name}_mean"), &["point"], m, unit, &format!("mean over realisations of {long}"));
        out.f64(&format!("{name}_std"), &["point"], s, unit, &format!("sample standard deviation over realisations of {long}"));
    }
    out.f64("fibre_length_per_area", &["point", "realisation"], per_rep(&|g| g.fibre_length_per_area), "m-1", "L_A = ρ_av/(ρπd²/4), fibre length per window area");
    out.f64("spread_cd", &["point", "realisation"], per_rep(&|g| g.spreads.cross_direction), "m", "σ_CD, RMS CD displacement of the fibres where the drift reaches the window's far edge");
    out.f64("spread_md", &["point", "realisation"], per_rep(&|g| g.spreads.machine_direction), "m", "σ_MD, RMS MD displacement of the fibre ends from c·n_l·L");
    out.f64("nodes_generated", &["point", "realisation"], per_rep(&|g| g.nodes_generated as f64), "1", "fibre nodes generated for the realisation");
    out.f64("wall_seconds", &["point", "realisation"], Array2::from_shape_fn((np, reps), |(p, r)| results[p * reps + r].1), "s", "wall time of generating and gridding the realisation");
    if nz > 0 {
        let z0 = &results[0].0.zone_curve;
        out.f64("zone_size", &["zone_size"], Array1::from_iter(z0.iter().map(|z| z.zone_size)), "m", "zone side x = cells·Δh (log-spaced from zone_size_min, sizes below Δh skipped)");
        out.i64("zone_cells", &["zone_size"], Array1::from_iter(z0.iter().map(|z| z.cells_per_side as i64)), "1", "cells per zone side");
        out.i64("zone_count", &["zone_size"], Array1::from_iter(z0.iter().map(|z| z.zones as i64)), "1", "zones the CV is taken over");
        let cvz = zone(&|z| z.cv);
        let nf = zone(&|z| z.formation_number);
        out.f64("cv_zone", &["point", "realisation", "zone_size"], cvz.clone(), "1", "CV of the zone densities at zone size x");
        out.f64("random_line_cv", &["point", "realisation", "zone_size"], zone(&|z| z.random_line_cv), "1", "CV of a Poisson network of straight lines with the same L_A: sqrt(E1/(π L_A x)) (REFERENCE.md §2)");
        out.f64("formation_number", &["point", "realisation", "zone_size"], nf.clone(), "1", "n_f(x) = CV²/CV²_random-line");
        out.f64("cv_zone_mean", &["point", "zone_size"], cvz.mean_axis(Axis(1)).unwrap(), "1", "mean over realisations of cv_zone");
        out.f64("formation_number_mean", &["point", "zone_size"], nf.mean_axis(Axis(1)).unwrap(), "1", "mean over realisations of formation_number");
    }
    out
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

/// Copies the web's sweep coordinates (variables carrying a `parameter` attribute).
fn copy_web_sweep(input: &crate::stages::Input, out: &mut Output, web_points: &[usize]) -> Result<()> {
    let g = input.version.open()?;
    let mut names = vec![];
    for name in g.member_names()? {
        let Ok(ds) = g.dataset(&name) else { continue };
        let attrs = crate::archive::hdf::read_attrs(&ds)?;
        let Some(Attr::Str(param)) = attrs.get("parameter") else { continue };
        let long = format!("swept parameter {param} of the input web");
        let var = if let Ok(v) = crate::archive::hdf::read_f64(&g, &name) {
            let unit = match attrs.get("units") {
                Some(Attr::Str(u)) => u.clone(),
                _ => "1".into(),
            };
            let picked: Vec<f64> = web_points.iter().map(|&w| v[[w]]).collect();
            out.f64(&name, &["point"], ArrayD::from_shape_vec(IxDyn(&[picked.len()]), picked)?, &unit, &long)
        } else {
            let all = crate::archive::hdf::read_strings(&g, &name)?;
            out.strings(&name, "point", web_points.iter().map(|&w| all[w].clone()).collect(), &long)
        };
        var.attrs.insert("parameter".into(), Attr::Str(param.clone()));
        names.push(name);
    }
    let coords = names.join(" ");
    if !coords.is_empty() {
        for v in out.variables.iter_mut() {
            if v.dims.iter().any(|d| d == "point") && !names.contains(&v.name) {
                v.attrs.insert("coordinates".into(), Attr::Str(coords.clone()));
            }
        }
    }
    Ok(())
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
