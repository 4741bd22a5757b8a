//! Partial results of a distributed stage: one small HDF5 file per array task holding
//! the task's `Output` (every variable with its dimension names, units, long name and
//! attributes, in order) plus the task's own provenance as root attributes. The driver
//! stacks them with [`crate::archive::gather::gather`] into the rows the local executor
//! would have produced.
//!
//! A partial is written to `<name>.tmp` and renamed, so a file that exists is complete.
use crate::archive::data::{Attr, Output, Values, Variable};
use crate::archive::hdf;
use anyhow::{anyhow, bail, Context, Result};
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

/// Read a partial written by [`write()`]: its output and its provenance attributes.
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
            "str" => Values::Str(hdf::read_strings_nd(&vars, &name)?),
            other => bail!("{}: `{name}` has unknown type {other}", path.display()),
        };
        indexed.push((index, Variable { name, dims, values, units, long_name, attrs: a }));
    }
    indexed.sort_by_key(|(i, _)| *i);
    out.variables = indexed.into_iter().map(|(_, v)| v).collect();
    Ok((out, attrs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::archive::gather::tests::part;

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
