//! Stacking outputs computed apart: the per-replicate rows of the units of a stage that
//! were computed in separate Slurm array tasks, or the per-point outputs of an image
//! sweep, concatenated along their leading dimension into the output one computation of
//! everything would have produced (ragged trailing dimensions padded with NaN, as the
//! stages pad them).
use super::data::{Output, Values, Variable};
use anyhow::{anyhow, bail, Result};
use ndarray::{ArrayD, Axis, IxDyn, Slice};

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
                Values::Str(_) => Values::Str(concat(&vs, |v| match &v.values {
                    Values::Str(a) => Some(a),
                    _ => None,
                }, Some(String::new()), &v0.name)?),
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
pub(crate) mod tests {
    use super::*;
    use ndarray::arr1;

    /// An output of ragged rows along `point`, a shared `axis` and per-`run` labels.
    pub(crate) fn part(rows: &[&[f64]], label: &str) -> Output {
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
        b.variables[0].values = Values::Str(ndarray::arr1(&["y".to_string()]).into_dyn());
        assert!(gather(&[part(&[&[1.0]], "a"), b], &["point", "run"]).is_err());
    }
}
