//! Partial results of a distributed stage: one small HDF5 file per array task holding
//! the task's `Output` (every variable with its dimension names, units, long name and
//! attributes, in order) plus the task's own provenance as root attributes; and the
//! gathering of the partials into the output the local executor would have produced.
//!
//! A partial is written to `<name>.tmp` and renamed, so a file that exists is complete.
use crate::archive::data::{Attr, Output, Values, Variable};
use crate::archive::hdf;
use anyhow::{anyhow, bail, Context, Result};
use ndarray::{ArrayD, Axis, IxDyn, Slice};
use std::collections::BTreeMap;
use std::path::Path;

const META: &str = "_laydown_";

/// Write `out` and the task's provenance `attrs` to `path` (atomically).
pub fn write(path: &Path, out: &Output, attrs: &BTreeMap<String, Attr>) -> Result<()> {
    let tmp = path.with_extension("h5.tmp");
    {
        let file = hdf5::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        for (k, a) in attrs {
            hdf::write_attr(&file, k, a)?;
        }
        let vars = file.create_group("variables")?;
        for (k, a) in &out.attrs {
            hdf::write_attr(&vars, k, a)?;
        }
        for (i, v) in out.variables.iter().enumerate() {
            let ds = hdf::write_values(&vars, &v.name, &v.values)?;
            hdf::write_attr(&ds, &format!("{META}index"), &Attr::I64(i as i64))?;
            hdf::write_attr(&ds, &format!("{META}type"), &Attr::Str(v.values.type_name().into()))?;
            hdf::write_attr(&ds, &format!("{META}dims"), &Attr::Str(v.dims.join(" ")))?;
            hdf::write_attr(&ds, &format!("{META}units"), &Attr::Str(v.units.clone()))?;
            hdf::write_attr(&ds, &format!("{META}long_name"), &Attr::Str(v.long_name.clone()))?;
            for (k, a) in &v.attrs {
                hdf::write_attr(&ds, k, a)?;
            }
        }
        file.flush()?;
    }
    std::fs::File::open(&tmp)?.sync_all()?;
    std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))?;
    Ok(())
}

/// Read a partial written by [`write`]: its output and its provenance attributes.
pub fn read(path: &Path) -> Result<(Output, BTreeMap<String, Attr>)> {
    let file = hdf5::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let attrs = hdf::read_attrs(&file)?;
    let vars = file.group("variables")?;
    let mut out = Output::new();
    out.attrs = hdf::read_attrs(&vars)?;
    let mut indexed = vec![];
    for name in vars.member_names()? {
        let ds = vars.dataset(&name)?;
        let mut a = hdf::read_attrs(&ds)?;
        let mut take = |k: &str| a.remove(&format!("{META}{k}")).ok_or_else(|| anyhow!("{}: `{name}` lacks {META}{k}", path.display()));
        let index = match take("index")? {
            Attr::I64(i) => i,
            _ => bail!("{}: bad index of `{name}`", path.display()),
        };
        let text = |x: Attr| match x {
            Attr::Str(s) => s,
            other => format!("{other:?}"),
        };
        let ty = text(take("type")?);
        let dims: Vec<String> = text(take("dims")?).split(' ').filter(|s| !s.is_empty()).map(String::from).collect();
        let units = text(take("units")?);
        let long_name = text(take("long_name")?);
        let values = match ty.as_str() {
            "f64" => Values::F64(hdf::read_f64(&vars, &name)?),
            "i64" => Values::I64(hdf::read_i64(&vars, &name)?),
            "u8" => Values::U8(hdf::read_u8(&vars, &name)?),
            "str" => Values::Str(hdf::read_strings(&vars, &name)?),
            other => bail!("{}: `{name}` has unknown type {other}", path.display()),
        };
        indexed.push((index, Variable { name, dims, values, units, long_name, attrs: a }));
    }
    indexed.sort_by_key(|(i, _)| *i);
    out.variables = indexed.into_iter().map(|(_, v)| v).collect();
    Ok((out, attrs))
}

/// Concatenate `parts` (in unit order) along the leading dimension of every variable
/// whose first dimension is one of `stack_dims` (the executors pass
/// [`crate::stages::UNIT_DIM`], the per-replicate rows); every other variable must be
/// identical in all parts. Trailing dimensions that differ between parts (a stage pads
/// ragged data to the longest unit, with NaN) are padded to the longest with NaN, as
/// the stage does when it computes all points at once.
pub fn gather(parts: &[Output], stack_dims: &[&str]) -> Result<Output> {
    /// Equal values, NaN equal to NaN (a NaN marks a missing value the same way in every part).
    fn same_values(a: &Values, b: &Values) -> bool {
        match (a, b) {
            (Values::F64(x), Values::F64(y)) => x.shape() == y.shape() && x.iter().zip(y.iter()).all(|(p, q)| p == q || p.is_nan() && q.is_nan()),
            _ => a == b,
        }
    }
    let first = parts.first().ok_or_else(|| anyhow!("no partial results to gather"))?;
    for (t, p) in parts.iter().enumerate() {
        let names: Vec<&str> = p.variables.iter().map(|v| v.name.as_str()).collect();
        let want: Vec<&str> = first.variables.iter().map(|v| v.name.as_str()).collect();
        if names != want {
            bail!("partial {t} has variables {names:?}, partial 0 has {want:?}");
        }
        if p.attrs != first.attrs {
            bail!("partial {t} has different output attributes from partial 0");
        }
    }
    let mut out = Output::new();
    out.attrs = first.attrs.clone();
    for (i, v0) in first.variables.iter().enumerate() {
        let vs: Vec<&Variable> = parts.iter().map(|p| &p.variables[i]).collect();
        for (t, v) in vs.iter().enumerate() {
            if v.dims != v0.dims || v.units != v0.units || v.long_name != v0.long_name || v.attrs != v0.attrs {
                bail!("variable `{}` of partial {t} has different dimensions or metadata from partial 0", v0.name);
            }
        }
        let stacked = v0.dims.first().is_some_and(|d| stack_dims.contains(&d.as_str()));
        let values = if !stacked {
            if let Some(t) = vs.iter().position(|v| !same_values(&v.values, &v0.values)) {
                bail!("variable `{}` is not stacked but differs between partial 0 and partial {t}", v0.name);
            }
            v0.values.clone()
        } else {
            match &v0.values {
                Values::F64(_) => Values::F64(concat(&vs, |v| match &v.values {
                    Values::F64(a) => Some(a),
                    _ => None,
                }, Some(f64::NAN), &v0.name)?),
                Values::I64(_) => Values::I64(concat(&vs, |v| match &v.values {
                    Values::I64(a) => Some(a),
                    _ => None,
                }, None, &v0.name)?),
                Values::U8(_) => Values::U8(concat(&vs, |v| match &v.values {
                    Values::U8(a) => Some(a),
                    _ => None,
                }, None, &v0.name)?),
                Values::Str(_) => Values::Str(
                    vs.iter()
                        .flat_map(|v| match &v.values {
                            Values::Str(s) => s.clone(),
                            _ => vec![],
                        })
                        .collect(),
                ),
            }
        };
        out.variables.push(Variable { values, ..(*v0).clone() });
    }
    out.dimensions().map_err(|e| anyhow!("gathered output: {e}"))?;
    Ok(out)
}

fn concat<T: Clone>(
    vs: &[&Variable],
    get: impl Fn(&Variable) -> Option<&ArrayD<T>>,
    pad: Option<T>,
    name: &str,
) -> Result<ArrayD<T>> {
    let arrays: Vec<&ArrayD<T>> = vs.iter().map(|v| get(v).ok_or_else(|| anyhow!("`{name}` changes type between partials"))).collect::<Result<_>>()?;
    let ndim = arrays[0].ndim();
    if arrays.iter().any(|a| a.ndim() != ndim) {
        bail!("`{name}` has a different number of dimensions in different partials");
    }
    let mut shape = arrays[0].shape().to_vec();
    shape[0] = arrays.iter().map(|a| a.shape()[0]).sum();
    for k in 1..ndim {
        shape[k] = arrays.iter().map(|a| a.shape()[k]).max().unwrap_or(0);
    }
    let ragged = arrays.iter().any(|a| a.shape()[1..] != shape[1..]);
    if !ragged {
        let views: Vec<_> = arrays.iter().map(|a| a.view()).collect();
        return Ok(ndarray::concatenate(Axis(0), &views)?);
    }
    let Some(fill) = pad else {
        bail!("`{name}` has different trailing dimensions in different partials and cannot be padded");
    };
    let mut out = ArrayD::from_elem(IxDyn(&shape), fill);
    let mut at = 0;
    for a in arrays {
        let n = a.shape()[0];
        let mut view = out.slice_axis_mut(Axis(0), Slice::from(at..at + n));
        for (k, &len) in a.shape().iter().enumerate().skip(1) {
            view = view.slice_axis_move(Axis(k), Slice::from(0..len));
        }
        view.assign(a);
        at += n;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::arr1;

    fn part(rows: &[&[f64]], label: &str) -> Output {
        let w = rows.iter().map(|r| r.len()).max().unwrap();
        let mut a = ndarray::Array2::from_elem((rows.len(), w), f64::NAN);
        for (i, r) in rows.iter().enumerate() {
            for (j, x) in r.iter().enumerate() {
                a[[i, j]] = *x;
            }
        }
        let mut o = Output::new();
        o.strings("axis", "axis", vec!["x".into()], "shared");
        o.f64("data", &["point", "node"], a, "m", "ragged");
        o.i64("count", &["point"], arr1(&vec![1i64; rows.len()]), "1", "counts");
        o.strings("label", "run", vec![label.to_string(); rows.len()], "labels");
        o
    }

    #[test]
    fn gather_pads_with_nan_and_stacks_points() {
        let all = part(&[&[1.0, 2.0], &[3.0], &[4.0, 5.0, 6.0]], "a");
        let g = gather(&[part(&[&[1.0, 2.0], &[3.0]], "a"), part(&[&[4.0, 5.0, 6.0]], "a")], &["point", "run"]).unwrap();
        assert_eq!(crate::archive::hdf::content_hash(&g), crate::archive::hdf::content_hash(&all));
    }

    #[test]
    fn gather_refuses_differing_shared_variables() {
        let mut b = part(&[&[1.0]], "a");
        b.variables[0].values = Values::Str(vec!["y".into()]);
        assert!(gather(&[part(&[&[1.0]], "a"), b], &["point", "run"]).is_err());
    }

    #[test]
    fn partial_files_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("task-0.h5");
        let mut o = part(&[&[1.0, f64::NAN], &[3.0]], "x");
        o.variables[1].attrs.insert("coordinates".into(), Attr::Str("a b".into()));
        o.set_attr("note", "hi");
        let mut attrs = BTreeMap::new();
        attrs.insert("slurm_job_id".into(), Attr::Str("12".into()));
        write(&p, &o, &attrs).unwrap();
        let (back, a) = read(&p).unwrap();
        assert_eq!(a, attrs);
        assert_eq!(crate::archive::hdf::content_hash(&back), crate::archive::hdf::content_hash(&o));
        assert_eq!(back.variables[1].attrs, o.variables[1].attrs);
        assert_eq!(back.attrs, o.attrs);
    }
}
