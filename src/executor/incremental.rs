//! Adding replicates without computing the stored ones again.
//!
//! A stage whose units of work are its replicates ([`Stage::units`] with one unit per
//! (point, replicate)) computes every replicate from its own random stream, so the rows
//! of replicates 0..R of a run with R' > R replicates are those of the run with R. When a
//! pipeline only raises `replicates`, the runner finds the stored version that matches in
//! everything else and [`run`] computes the new replicates' rows, reads the stored ones
//! back out of that version (each stored (point, replicate, …) variable sliced into the
//! row of its unit) and reduces all of them as one run would: the version written is
//! bit-identical to a full rerun (measured wall times aside).
//!
//! A stage whose stored output does not hold every row variable on (point, replicate, …)
//! (a grid that keeps only per-point corners, one with `store_density: false`, a laydown
//! drawing replicates in rounds towards a target) is computed in full: [`run`] says why.
use crate::archive::data::{Output, Values};
use crate::archive::gather::gather;
use crate::archive::{hdf, VersionInfo};
use crate::stages::{RunContext, Stage, UNIT_DIM};
use anyhow::Result;
use ndarray::{ArrayD, Axis, IxDyn};
use rayon::prelude::*;

/// The stage output of `ctx` (R' replicates) with replicates `stored..R'` computed and
/// `0..stored` read from `base`; `Err(why)` when the stage cannot be run this way.
pub fn run(stage: &dyn Stage, ctx: &RunContext, base: &VersionInfo, stored: usize) -> Result<Result<Output, String>> {
    let units = match stage.units(ctx)? {
        Some(u) if u.per_point == ctx.replicates && u.points == ctx.points.len() && stored < ctx.replicates => u,
        Some(u) if u.per_point == 1 => return Ok(Err(format!("its units are whole points{}", u.note.map(|n| format!(" ({n})")).unwrap_or_default()))),
        _ => return Ok(Err("its units of work are not its replicates".into())),
    };
    let reps = ctx.replicates;
    // The stored rows first: if they cannot be read back, only this unit was computed.
    let probe = stage.run_units(ctx, stored..stored + 1)?;
    let old = match stored_rows(base, &probe, units.points, stored) {
        Ok(Ok(rows)) => rows,
        Ok(Err(missing)) => return Ok(Err(format!("v{} does not hold {missing}", base.number))),
        Err(e) => return Ok(Err(format!("v{} could not be read back: {e:#}", base.number))),
    };
    // Point 0's replicate `stored` is the probe; every other new unit is computed here.
    let ranges: Vec<std::ops::Range<usize>> = (0..units.points).map(|p| p * reps + stored + usize::from(p == 0)..(p + 1) * reps).filter(|r| !r.is_empty()).collect();
    let parts: Vec<Output> = ranges.into_par_iter().map(|r| stage.run_units(ctx, r)).collect::<Result<_>>()?;
    let mut all = vec![old, probe];
    all.extend(parts);
    let rows = gather(&all, &[UNIT_DIM])?;
    drop(all);
    Ok(Ok(stage.reduce(ctx, rows)?))
}

/// The rows of replicates `0..replicates` of every point, read from the stored version:
/// every row variable of `template` (a row computed now) taken from the stored variable of
/// the same name on (point, replicate, rest…); `Err(which)` when one is missing or
/// shaped otherwise.
fn stored_rows(base: &VersionInfo, template: &Output, points: usize, replicates: usize) -> Result<Result<Output, String>> {
    let g = base.open()?;
    let dims = hdf::dimension_names(&g)?;
    let units: Vec<(usize, usize)> = (0..points).flat_map(|p| (0..replicates).map(move |r| (p, r))).collect();
    let mut rows = Output::new();
    for v in &template.variables {
        let values = match v.name.as_str() {
            "unit_point" => Values::I64(ArrayD::from_shape_vec(IxDyn(&[units.len()]), units.iter().map(|u| u.0 as i64).collect())?),
            "unit_replicate" => Values::I64(ArrayD::from_shape_vec(IxDyn(&[units.len()]), units.iter().map(|u| u.1 as i64).collect())?),
            name => {
                let Some(stored_dims) = dims.get(name) else { return Ok(Err(format!("`{name}`"))) };
                if v.dims.first().map(String::as_str) != Some(UNIT_DIM) || stored_dims.len() != v.dims.len() + 1 || stored_dims[0] != "point" {
                    return Ok(Err(format!("`{name}` per replicate")));
                }
                match &v.values {
                    Values::F64(_) => Values::F64(rows_of(&hdf::read_f64(&g, name)?, &units)?),
                    Values::I64(_) => Values::I64(rows_of(&hdf::read_i64(&g, name)?, &units)?),
                    Values::U8(_) => Values::U8(rows_of(&hdf::read_u8(&g, name)?, &units)?),
                    Values::Str(_) => Values::Str(rows_of(&hdf::read_strings_nd(&g, name)?, &units)?),
                }
            }
        };
        let dims: Vec<&str> = v.dims.iter().map(String::as_str).collect();
        let row = rows.push_values(&v.name, &dims, values, &v.units, &v.long_name);
        row.attrs = v.attrs.clone();
    }
    Ok(Ok(rows))
}

/// The (point, replicate) slices of a stored (point, replicate, rest…) array, stacked as
/// (unit, rest…) in the order of `units`.
fn rows_of<T: Clone>(stored: &ArrayD<T>, units: &[(usize, usize)]) -> Result<ArrayD<T>> {
    let shape = stored.shape();
    if units.iter().any(|&(p, r)| p >= shape[0] || r >= shape[1]) {
        anyhow::bail!("the stored version holds {} points × {} replicates, fewer than it claims", shape[0], shape[1]);
    }
    let slices: Vec<_> = units.iter().map(|&(p, r)| stored.index_axis(Axis(0), p).index_axis_move(Axis(0), r).insert_axis(Axis(0))).collect();
    Ok(ndarray::concatenate(Axis(0), &slices)?)
}
