//! What a stage hands to the archive: named variables with named dimensions, units and
//! long names, in the xarray/netCDF data model. Coordinates are 1-D variables named
//! after their dimension; they become HDF5 dimension scales.
use ndarray::{ArrayD, IxDyn};
use std::collections::BTreeMap;

#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    F64(ArrayD<f64>),
    I64(ArrayD<i64>),
    /// Flags (booleans stored as 0/1 bytes).
    U8(ArrayD<u8>),
    /// Text along one dimension (variable-length UTF-8).
    Str(ArrayD<String>),
}

impl Values {
    pub fn shape(&self) -> Vec<usize> {
        match self {
            Values::F64(a) => a.shape().to_vec(),
            Values::I64(a) => a.shape().to_vec(),
            Values::U8(a) => a.shape().to_vec(),
            Values::Str(a) => a.shape().to_vec(),
        }
    }
    pub fn type_name(&self) -> &'static str {
        match self {
            Values::F64(_) => "f64",
            Values::I64(_) => "i64",
            Values::U8(_) => "u8",
            Values::Str(_) => "str",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Attr {
    Str(String),
    F64(f64),
    I64(i64),
}

impl From<&str> for Attr {
    fn from(s: &str) -> Self {
        Attr::Str(s.to_string())
    }
}
impl From<String> for Attr {
    fn from(s: String) -> Self {
        Attr::Str(s)
    }
}
impl From<f64> for Attr {
    fn from(v: f64) -> Self {
        Attr::F64(v)
    }
}
impl From<i64> for Attr {
    fn from(v: i64) -> Self {
        Attr::I64(v)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub dims: Vec<String>,
    pub values: Values,
    /// UDUNITS string ("m", "s", "g m-2", "1" for dimensionless).
    pub units: String,
    pub long_name: String,
    pub attrs: BTreeMap<String, Attr>,
}

impl Variable {
    pub fn attr(mut self, key: &str, value: impl Into<Attr>) -> Self {
        self.attrs.insert(key.to_string(), value.into());
        self
    }
    /// The full explanation (`description` attribute) beside a short `long_name`, which
    /// xarray and plotting tools use as an axis label.
    pub fn describe(&mut self, text: impl Into<String>) -> &mut Self {
        self.attrs.insert("description".into(), Attr::Str(text.into()));
        self
    }
}

/// The datasets of one stage version.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Output {
    pub variables: Vec<Variable>,
    /// Extra attributes on the version group (stage-specific summaries, notes).
    pub attrs: BTreeMap<String, Attr>,
    /// Files (name, bytes) the runner writes beside the version once it is committed,
    /// in its figure folder `<archive stem>_figures/<stage>/v<N>/` (figures, tables): a
    /// stage writes no file itself, and a version that fails leaves none.
    pub files: Vec<(String, Vec<u8>)>,
}

impl Output {
    pub fn new() -> Self {
        Self::default()
    }

    /// Hand over a file to be written beside the version once it is committed (see
    /// [`Output::files`]).
    pub fn file(&mut self, name: impl Into<String>, bytes: Vec<u8>) {
        self.files.push((name.into(), bytes));
    }

    /// Add a variable of any type; returns it for further attributes.
    pub fn push_values(&mut self, name: &str, dims: &[&str], values: Values, units: &str, long_name: &str) -> &mut Variable {
        self.push(name, dims, values, units, long_name)
    }

    fn push(&mut self, name: &str, dims: &[&str], values: Values, units: &str, long_name: &str) -> &mut Variable {
        let shape = values.shape();
        assert_eq!(
            shape.len(),
            dims.len(),
            "variable `{name}` has {} dimensions but {} names",
            shape.len(),
            dims.len()
        );
        assert!(self.get(name).is_none(), "variable `{name}` added twice");
        self.variables.push(Variable {
            name: name.to_string(),
            dims: dims.iter().map(|d| d.to_string()).collect(),
            values,
            units: units.to_string(),
            long_name: long_name.to_string(),
            attrs: BTreeMap::new(),
        });
        self.variables.last_mut().unwrap()
    }

    /// Add a float variable; returns it for further attributes.
    pub fn f64<D: ndarray::Dimension>(
        &mut self,
        name: &str,
        dims: &[&str],
        data: ndarray::Array<f64, D>,
        units: &str,
        long_name: &str,
    ) -> &mut Variable {
        self.push(name, dims, Values::F64(data.into_dyn()), units, long_name)
    }
    pub fn i64<D: ndarray::Dimension>(
        &mut self,
        name: &str,
        dims: &[&str],
        data: ndarray::Array<i64, D>,
        units: &str,
        long_name: &str,
    ) -> &mut Variable {
        self.push(name, dims, Values::I64(data.into_dyn()), units, long_name)
    }
    /// Booleans stored as 0/1 with CF flag attributes.
    pub fn flags<D: ndarray::Dimension>(
        &mut self,
        name: &str,
        dims: &[&str],
        data: ndarray::Array<bool, D>,
        long_name: &str,
    ) -> &mut Variable {
        let v = self.push(name, dims, Values::U8(data.mapv(u8::from).into_dyn()), "1", long_name);
        v.attrs.insert("flag_values".into(), Attr::Str("0 1".into()));
        v.attrs.insert("flag_meanings".into(), Attr::Str("false true".into()));
        v
    }
    pub fn strings(&mut self, name: &str, dim: &str, data: Vec<String>, long_name: &str) -> &mut Variable {
        let n = data.len();
        self.push(name, &[dim], Values::Str(ArrayD::from_shape_vec(IxDyn(&[n]), data).expect("1-D")), "", long_name)
    }
    /// Text on any dimensions (e.g. a reason per point and replicate).
    pub fn strings_nd<D: ndarray::Dimension>(&mut self, name: &str, dims: &[&str], data: ndarray::Array<String, D>, long_name: &str) -> &mut Variable {
        self.push(name, dims, Values::Str(data.into_dyn()), "", long_name)
    }
    /// A coordinate: a 1-D variable named after its own dimension.
    pub fn coord(&mut self, dim: &str, data: Vec<f64>, units: &str, long_name: &str) -> &mut Variable {
        let n = data.len();
        self.push(dim, &[dim], Values::F64(ArrayD::from_shape_vec(IxDyn(&[n]), data).unwrap()), units, long_name)
    }

    pub fn get(&self, name: &str) -> Option<&Variable> {
        self.variables.iter().find(|v| v.name == name)
    }

    pub fn get_mut(&mut self, name: &str) -> Option<&mut Variable> {
        self.variables.iter_mut().find(|v| v.name == name)
    }

    pub fn set_attr(&mut self, key: &str, value: impl Into<Attr>) {
        self.attrs.insert(key.to_string(), value.into());
    }

    /// Bytes of all values, uncompressed (what a commit may need on disk, at most).
    pub fn byte_size(&self) -> u64 {
        self.variables
            .iter()
            .map(|v| match &v.values {
                Values::F64(a) => 8 * a.len() as u64,
                Values::I64(a) => 8 * a.len() as u64,
                Values::U8(a) => a.len() as u64,
                Values::Str(s) => s.iter().map(|x| x.len() as u64 + 16).sum(),
            })
            .sum()
    }

    /// Length of every dimension, checking that all variables agree.
    pub fn dimensions(&self) -> Result<BTreeMap<String, usize>, String> {
        let mut dims = BTreeMap::new();
        for v in &self.variables {
            for (d, n) in v.dims.iter().zip(v.values.shape()) {
                if let Some(&m) = dims.get(d) {
                    if m != n {
                        return Err(format!(
                            "dimension `{d}` has length {m} elsewhere but {n} in variable `{}`",
                            v.name
                        ));
                    }
                } else {
                    dims.insert(d.clone(), n);
                }
            }
        }
        Ok(dims)
    }
}
