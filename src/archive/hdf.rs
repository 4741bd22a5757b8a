//! Low-level HDF5 writing and reading of `Output`s: datasets with units, long names,
//! chunking and compression, and HDF5 dimension scales (through libhdf5_hl) so that
//! netCDF readers (h5netcdf, xarray) see named dimensions.
use super::data::{Attr, Output, Values, Variable};
use anyhow::{anyhow, Context, Result};
use hdf5::types::VarLenUnicode;
use ndarray::{ArrayD, IxDyn};
use std::collections::BTreeMap;
use std::ffi::CString;
use std::str::FromStr;

#[allow(non_snake_case)]
mod ds {
    use hdf5_sys::h5::herr_t;
    use hdf5_sys::h5i::hid_t;
    use std::os::raw::{c_char, c_uint};
    #[link(name = "hdf5_hl")]
    extern "C" {
        pub fn H5DSset_scale(dsid: hid_t, dimname: *const c_char) -> herr_t;
        pub fn H5DSattach_scale(did: hid_t, dsid: hid_t, idx: c_uint) -> herr_t;
        pub fn H5DSis_attached(did: hid_t, dsid: hid_t, idx: c_uint) -> hdf5_sys::h5::htri_t;
        pub fn H5DSis_scale(did: hid_t) -> hdf5_sys::h5::htri_t;
    }
}

/// Arrays with at least this many elements are chunked and deflate-compressed.
const COMPRESS_FROM: usize = 4096;

pub fn write_str_attr(loc: &hdf5::Location, name: &str, value: &str) -> Result<()> {
    let v = VarLenUnicode::from_str(value).map_err(|e| anyhow!("attribute {name}: {e}"))?;
    loc.new_attr::<VarLenUnicode>().create(name)?.write_scalar(&v)?;
    Ok(())
}

pub fn write_attr(loc: &hdf5::Location, name: &str, value: &Attr) -> Result<()> {
    match value {
        Attr::Str(s) => write_str_attr(loc, name, s),
        Attr::F64(v) => Ok(loc.new_attr::<f64>().create(name)?.write_scalar(v)?),
        Attr::I64(v) => Ok(loc.new_attr::<i64>().create(name)?.write_scalar(v)?),
    }
}

pub fn read_attrs(loc: &hdf5::Location) -> Result<BTreeMap<String, Attr>> {
    let mut out = BTreeMap::new();
    for name in loc.attr_names()? {
        let a = loc.attr(&name)?;
        // Dispatch on the stored type: HDF5 would happily convert a float attribute
        // to an integer (truncating it) if asked for i64 first.
        use hdf5::types::TypeDescriptor as T;
        let value = match a.dtype().and_then(|t| t.to_descriptor()) {
            Ok(T::Float(_)) => match a.read_scalar::<f64>() {
                Ok(v) => Attr::F64(v),
                Err(_) => continue,
            },
            Ok(T::Integer(_) | T::Unsigned(_)) => match a.read_scalar::<i64>() {
                Ok(v) => Attr::I64(v),
                Err(_) => continue,
            },
            _ => match a.read_scalar::<VarLenUnicode>() {
                Ok(s) => Attr::Str(s.as_str().to_string()),
                Err(_) => continue,
            },
        };
        out.insert(name, value);
    }
    Ok(out)
}

fn chunk_shape(shape: &[usize]) -> Vec<usize> {
    // Aim for chunks of ~64k elements, cutting the leading dimensions first.
    let mut chunk = shape.iter().map(|&n| n.max(1)).collect::<Vec<_>>();
    let mut total: usize = chunk.iter().product();
    let mut i = 0;
    while total > 65536 && i < chunk.len() {
        while total > 65536 && chunk[i] > 1 {
            chunk[i] = chunk[i].div_ceil(2);
            total = chunk.iter().product();
        }
        i += 1;
    }
    chunk
}

fn write_array<T: hdf5::H5Type>(group: &hdf5::Group, name: &str, data: &ArrayD<T>) -> Result<hdf5::Dataset> {
    let mut builder = group.new_dataset_builder().with_data(data.view());
    if data.len() >= COMPRESS_FROM {
        builder = builder.chunk(chunk_shape(data.shape())).shuffle().deflate(4);
    }
    Ok(builder.create(name)?)
}

/// Write one dataset of `values` (compressed when large; strings as variable-length UTF-8).
pub fn write_values(group: &hdf5::Group, name: &str, values: &Values) -> Result<hdf5::Dataset> {
    match values {
        Values::F64(a) => write_array(group, name, a),
        Values::I64(a) => write_array(group, name, a),
        Values::U8(a) => write_array(group, name, a),
        Values::Str(items) => {
            let vs = items
                .iter()
                .map(|s| VarLenUnicode::from_str(s).map_err(|e| anyhow!("{name}: {e}")))
                .collect::<Result<Vec<_>>>()?;
            let arr = ArrayD::from_shape_vec(IxDyn(items.shape()), vs)?;
            Ok(group.new_dataset_builder().with_data(arr.view()).create(name)?)
        }
    }
}

fn write_variable(group: &hdf5::Group, v: &Variable) -> Result<hdf5::Dataset> {
    let ds = write_values(group, &v.name, &v.values)?;
    if !v.units.is_empty() {
        write_str_attr(&ds, "units", &v.units)?;
    }
    write_str_attr(&ds, "long_name", &v.long_name)?;
    for (k, a) in &v.attrs {
        write_attr(&ds, k, a)?;
    }
    Ok(ds)
}

/// Write all variables of `out` into `group`, with a dimension scale for every dimension.
/// Dimensions without a coordinate variable get an integer index coordinate.
pub fn write_output(group: &hdf5::Group, out: &Output) -> Result<()> {
    let dims = out.dimensions().map_err(|e| anyhow!(e))?;
    let mut scales: BTreeMap<String, hdf5::Dataset> = BTreeMap::new();
    for (dim, &n) in &dims {
        let coord = out.variables.iter().find(|v| &v.name == dim && v.dims.len() == 1 && &v.dims[0] == dim);
        let ds = match coord {
            Some(v) => write_variable(group, v)?,
            None => {
                let idx = ArrayD::from_shape_fn(IxDyn(&[n]), |i| i[0] as i64);
                let ds = write_array(group, dim, &idx)?;
                write_str_attr(&ds, "long_name", &format!("index along {dim}"))?;
                write_str_attr(&ds, "units", "1")?;
                ds
            }
        };
        let cname = CString::new(dim.as_str())?;
        let rc = hdf5::sync::sync(|| unsafe { ds::H5DSset_scale(ds.id(), cname.as_ptr()) });
        if rc < 0 {
            return Err(anyhow!("cannot make `{dim}` a dimension scale"));
        }
        scales.insert(dim.clone(), ds);
    }
    for v in &out.variables {
        if scales.contains_key(&v.name) && v.dims.len() == 1 && v.dims[0] == v.name {
            continue; // written above as a scale
        }
        let ds = write_variable(group, v).with_context(|| format!("writing `{}`", v.name))?;
        for (i, d) in v.dims.iter().enumerate() {
            let scale = &scales[d];
            let rc = hdf5::sync::sync(|| unsafe { ds::H5DSattach_scale(ds.id(), scale.id(), i as u32) });
            if rc < 0 {
                return Err(anyhow!("cannot attach dimension `{d}` to `{}`", v.name));
            }
        }
    }
    for (k, a) in &out.attrs {
        write_attr(group, k, a)?;
    }
    Ok(())
}

/// The hash of one dataset as it is written and as it reads back: its units, value
/// class (`float`, `int` for integers and flags, `str`), shape and values (floats as
/// their bits, integers as i64, both little-endian; strings NUL-terminated).
struct ValueHasher(blake3::Hasher);

impl ValueHasher {
    fn new(units: &str, class: &str, shape: &[usize]) -> Self {
        let mut h = blake3::Hasher::new();
        h.update(units.as_bytes());
        h.update(&[0]);
        h.update(class.as_bytes());
        h.update(&[0]);
        for &n in shape {
            h.update(&(n as u64).to_le_bytes());
        }
        ValueHasher(h)
    }
    fn floats<'a>(mut self, v: impl Iterator<Item = &'a f64>) -> String {
        v.for_each(|x| {
            self.0.update(&x.to_bits().to_le_bytes());
        });
        self.done()
    }
    fn ints(mut self, v: impl Iterator<Item = i64>) -> String {
        v.for_each(|x| {
            self.0.update(&x.to_le_bytes());
        });
        self.done()
    }
    fn strings<'a>(mut self, v: impl Iterator<Item = &'a str>) -> String {
        v.for_each(|x| {
            self.0.update(x.as_bytes());
            self.0.update(&[0]);
        });
        self.done()
    }
    fn done(self) -> String {
        self.0.finalize().to_hex()[..32].to_string()
    }
}

/// The hash of every dataset `write_output` writes for `out` (its variables and the
/// integer index coordinates of dimensions without one), by name.
pub fn dataset_hashes(out: &Output) -> BTreeMap<String, String> {
    let mut hashes = BTreeMap::new();
    for v in &out.variables {
        let shape = v.values.shape();
        let hash = match &v.values {
            Values::F64(a) => ValueHasher::new(&v.units, "float", &shape).floats(a.iter()),
            Values::I64(a) => ValueHasher::new(&v.units, "int", &shape).ints(a.iter().copied()),
            Values::U8(a) => ValueHasher::new(&v.units, "int", &shape).ints(a.iter().map(|&x| x as i64)),
            Values::Str(s) => ValueHasher::new(&v.units, "str", &shape).strings(s.iter().map(String::as_str)),
        };
        hashes.insert(v.name.clone(), hash);
    }
    if let Ok(dims) = out.dimensions() {
        for (dim, n) in dims {
            if !out.variables.iter().any(|v| v.name == dim && v.dims.len() == 1 && v.dims[0] == dim) {
                hashes.insert(dim, ValueHasher::new("1", "int", &[n]).ints(0..n as i64));
            }
        }
    }
    hashes
}

/// The `dataset_hashes` attribute: one `name hash` line per dataset, sorted by name.
pub fn dataset_hashes_attr(hashes: &BTreeMap<String, String>) -> String {
    hashes.iter().map(|(n, h)| format!("{n} {h}")).collect::<Vec<_>>().join("\n")
}

/// Parse a `dataset_hashes` attribute back.
pub fn parse_dataset_hashes(attr: &str) -> BTreeMap<String, String> {
    attr.lines().filter_map(|l| l.rsplit_once(' ')).map(|(n, h)| (n.to_string(), h.to_string())).collect()
}

/// Content hash of an output: blake3 of its `dataset_hashes` lines, so it can be
/// recomputed from the archive (see [`read_dataset_hash`]) to verify a stored version.
pub fn content_hash(out: &Output) -> String {
    hash_of_dataset_hashes(&dataset_hashes(out))
}

pub fn hash_of_dataset_hashes(hashes: &BTreeMap<String, String>) -> String {
    blake3::hash(dataset_hashes_attr(hashes).as_bytes()).to_hex()[..32].to_string()
}

/// The hash of a dataset as stored (reading every value), comparable with [`dataset_hashes`].
pub fn read_dataset_hash(ds: &hdf5::Dataset) -> Result<String> {
    use hdf5::types::TypeDescriptor as T;
    let units = match ds.attr("units").and_then(|a| a.read_scalar::<VarLenUnicode>()) {
        Ok(u) => u.as_str().to_string(),
        Err(_) => String::new(),
    };
    let shape = ds.shape();
    Ok(match ds.dtype()?.to_descriptor()? {
        T::Float(_) => ValueHasher::new(&units, "float", &shape).floats(ds.read_raw::<f64>()?.iter()),
        T::Integer(_) | T::Unsigned(_) => ValueHasher::new(&units, "int", &shape).ints(ds.read_raw::<i64>()?.into_iter()),
        T::VarLenUnicode => {
            let v = ds.read_raw::<VarLenUnicode>()?;
            ValueHasher::new(&units, "str", &shape).strings(v.iter().map(|s| s.as_str()))
        }
        other => return Err(anyhow!("unexpected type {other:?}")),
    })
}

pub fn read_f64(group: &hdf5::Group, name: &str) -> Result<ArrayD<f64>> {
    let ds = group.dataset(name).with_context(|| format!("no dataset `{name}` in {}", group.name()))?;
    Ok(ds.read_dyn::<f64>()?)
}

pub fn read_i64(group: &hdf5::Group, name: &str) -> Result<ArrayD<i64>> {
    let ds = group.dataset(name).with_context(|| format!("no dataset `{name}` in {}", group.name()))?;
    Ok(ds.read_dyn::<i64>()?)
}

pub fn read_u8(group: &hdf5::Group, name: &str) -> Result<ArrayD<u8>> {
    let ds = group.dataset(name).with_context(|| format!("no dataset `{name}` in {}", group.name()))?;
    Ok(ds.read_dyn::<u8>()?)
}

pub fn read_strings(group: &hdf5::Group, name: &str) -> Result<Vec<String>> {
    let ds = group.dataset(name).with_context(|| format!("no dataset `{name}` in {}", group.name()))?;
    Ok(ds.read_raw::<VarLenUnicode>()?.into_iter().map(|s| s.as_str().to_string()).collect())
}

/// Text of any shape.
pub fn read_strings_nd(group: &hdf5::Group, name: &str) -> Result<ArrayD<String>> {
    let ds = group.dataset(name).with_context(|| format!("no dataset `{name}` in {}", group.name()))?;
    Ok(ds.read_dyn::<VarLenUnicode>()?.mapv(|s| s.as_str().to_string()))
}

/// The dimension names of every dataset of a group, read back from its dimension scales
/// (a scale is named after its dimension, see [`write_output`]; a scale's own dimension is
/// itself). A dimension with no attached scale is named `dim<i>`.
pub fn dimension_names(group: &hdf5::Group) -> Result<BTreeMap<String, Vec<String>>> {
    let mut datasets = Vec::new();
    for name in group.member_names()? {
        if let Ok(d) = group.dataset(&name) {
            datasets.push((name, d));
        }
    }
    let is_scale = |d: &hdf5::Dataset| hdf5::sync::sync(|| unsafe { ds::H5DSis_scale(d.id()) }) > 0;
    let scales: Vec<&(String, hdf5::Dataset)> = datasets.iter().filter(|(_, d)| is_scale(d)).collect();
    let mut out = BTreeMap::new();
    for (name, d) in &datasets {
        let dims = if is_scale(d) {
            vec![name.clone()]
        } else {
            (0..d.ndim())
                .map(|i| {
                    scales
                        .iter()
                        .find(|(_, s)| hdf5::sync::sync(|| unsafe { ds::H5DSis_attached(d.id(), s.id(), i as u32) }) > 0)
                        .map(|(n, _)| n.clone())
                        .unwrap_or_else(|| format!("dim{i}"))
                })
                .collect()
        };
        out.insert(name.clone(), dims);
    }
    Ok(out)
}

/// Attach the dimension scales of `group` anew, as `dims` ([`dimension_names`] of the
/// group it was copied from) names them, dropping the references a copy left behind
/// (`H5Ocopy` does not map the object references inside `DIMENSION_LIST` and
/// `REFERENCE_LIST` to the copied objects).
pub fn reattach_scales(group: &hdf5::Group, dims: &BTreeMap<String, Vec<String>>) -> Result<()> {
    let scales: BTreeMap<&str, hdf5::Dataset> = dims
        .iter()
        .filter(|(name, d)| d.len() == 1 && &d[0] == *name)
        .map(|(name, _)| Ok((name.as_str(), group.dataset(name)?)))
        .collect::<Result<_>>()?;
    let drop_attr = |ds: &hdf5::Dataset, attr: &str| -> Result<()> {
        if ds.attr(attr).is_ok() {
            ds.delete_attr(attr)?;
        }
        Ok(())
    };
    for scale in scales.values() {
        drop_attr(scale, "REFERENCE_LIST")?;
    }
    for (name, d) in dims {
        if scales.contains_key(name.as_str()) {
            continue;
        }
        let ds = group.dataset(name)?;
        drop_attr(&ds, "DIMENSION_LIST")?;
        for (i, dim) in d.iter().enumerate() {
            // `dim<i>`: no scale was attached there.
            let Some(scale) = scales.get(dim.as_str()) else { continue };
            let rc = hdf5::sync::sync(|| unsafe { ds::H5DSattach_scale(ds.id(), scale.id(), i as u32) });
            if rc < 0 {
                return Err(anyhow!("cannot attach dimension `{dim}` to `{name}`"));
            }
        }
    }
    Ok(())
}

/// A swept parameter of a stage version: a coordinate along `point` carrying a
/// `parameter` attribute (written by the runner).
#[derive(Debug, Clone)]
pub struct Swept {
    /// Dataset name (the parameter with dots as underscores).
    pub name: String,
    /// Parameter name as in the pipeline (`effects.drag`).
    pub parameter: String,
    /// Value at each point (NaN for non-numeric values).
    pub values: Vec<f64>,
    /// Value at each point as text.
    pub labels: Vec<String>,
    pub units: String,
}

/// The swept parameters of a version group, in dataset-name order.
pub fn swept_coordinates(group: &hdf5::Group) -> Vec<Swept> {
    let mut out = vec![];
    for name in group.member_names().unwrap_or_default() {
        let Ok(ds) = group.dataset(&name) else { continue };
        let Ok(attrs) = read_attrs(&ds) else { continue };
        let Some(Attr::Str(parameter)) = attrs.get("parameter") else { continue };
        let units = match attrs.get("units") {
            Some(Attr::Str(u)) => u.clone(),
            _ => String::new(),
        };
        let (values, labels) = match read_f64(group, &name) {
            Ok(v) => (
                v.iter().copied().collect::<Vec<_>>(),
                // Whole numbers (element counts, ...) without a trailing `.0`.
                v.iter().map(|x| if x.fract() == 0.0 && x.abs() < 1e15 { format!("{}", *x as i64) } else { crate::params::format_float(*x) }).collect(),
            ),
            Err(_) => {
                let s = read_strings(group, &name).unwrap_or_default();
                (vec![f64::NAN; s.len()], s)
            }
        };
        out.push(Swept { name, parameter: parameter.clone(), values, labels, units });
    }
    out
}

/// `param = value, ...` naming point `p` of a version from its swept coordinates.
///
/// When every swept parameter has a majority value (a zip sweep switching one thing
/// at a time, e.g. each effect off in turn), only the parameters that differ from
/// their majority at `p` are named.
pub fn point_label(swept: &[Swept], p: usize) -> String {
    let label = |s: &Swept| format!("{} = {}", s.parameter, s.labels.get(p).map(String::as_str).unwrap_or("?"));
    fn majority(s: &Swept) -> Option<&String> {
        let n = s.labels.len();
        s.labels.iter().find(|l| s.labels.iter().filter(|m| m == l).count() * 2 > n)
    }
    if swept.len() > 1 && swept.iter().all(|s| majority(s).is_some()) {
        let differing: Vec<String> =
            swept.iter().filter(|s| s.labels.get(p) != majority(s)).map(label).collect();
        if !differing.is_empty() {
            return differing.join(", ");
        }
    }
    swept.iter().map(label).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_stay_near_64k() {
        let c = chunk_shape(&[10, 10, 1001, 3]);
        assert!(c.iter().product::<usize>() <= 65536);
        assert_eq!(c[3], 3);
    }
}

#[cfg(test)]
mod point_label_tests {
    use super::*;

    fn swept(parameter: &str, labels: &[&str]) -> Swept {
        Swept { name: parameter.into(), parameter: parameter.into(), values: vec![], labels: labels.iter().map(|s| s.to_string()).collect(), units: String::new() }
    }

    #[test]
    fn point_labels_name_what_changes() {
        // One effect off in turn (zip): only the switched-off one is named.
        let zip = [swept("effects.drag", &["false", "true", "true"]), swept("effects.gravity", &["true", "false", "true"]), swept("effects.friction", &["true", "true", "false"])];
        assert_eq!(point_label(&zip, 1), "effects.gravity = false");
        // A cartesian sweep has no majorities: every parameter is named.
        let cart = [swept("a", &["1", "1", "2", "2"]), swept("b", &["x", "y", "x", "y"])];
        assert_eq!(point_label(&cart, 2), "a = 2, b = x");
        assert_eq!(point_label(&[swept("elements", &["125", "250"])], 1), "elements = 250");
    }
}
