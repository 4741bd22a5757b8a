//! Sweep coordinates along a stage's `point` dimension: the stage's own swept parameters
//! ([`add_sweep_coordinates`]) and those of every stage upstream of it
//! ([`add_upstream_coordinates`]), so a grid's points carry the fibre diameter swept in
//! the laydown three stages up, and CV can be plotted against it directly.
//!
//! **One rule for every coordinate.** It is a 1-D variable along `point` named after its
//! parameter (dots as `_`), in the parameter's type (i64 for integers, f64 for numbers,
//! strings otherwise), with the attributes `parameter` (the name as in the pipeline) and
//! `stage` (the stage that swept it), and is listed in the `coordinates` attribute of
//! every variable along `point`. Where the stage already stores a variable of that name
//! with the same values (a web's swept `belt_speed_ratio`), that variable is the
//! coordinate. Where the name is taken by other values, the coordinate is prefixed: by
//! `sweep_` for the stage's own sweep, by the sweeping stage's name for an upstream one.
//!
//! **Upstream.** A stage whose points come from its one input's points says which in an
//! i64 variable `input_point` along `point` (spectra of laid fibres: one point per input
//! point; a web: the spectra point it uses; a grid: the web point it grids). The input's
//! coordinates, its own and those it copied, are copied along that map, so the chain
//! reaches any depth one stage at a time.
use crate::archive::data::{Attr, Output, Values};
use crate::archive::hdf;
use crate::params::{ParamSpec, ParamValue};
use crate::stages::Input;
use anyhow::{anyhow, Result};
use ndarray::{ArrayD, IxDyn};

/// Adds the swept parameters of stage `stage` as coordinates along `point`, with units
/// from its parameter table `specs`.
pub fn add_sweep_coordinates(out: &mut Output, stage: &str, sweep: &[(String, Vec<ParamValue>)], specs: &[ParamSpec]) -> Result<()> {
    if sweep.is_empty() {
        return Ok(());
    }
    let n = sweep[0].1.len();
    if out.dimensions().map_err(|e| anyhow!(e))?.get("point").is_some_and(|&m| m != n) {
        return Err(anyhow!("stage output has a `point` dimension of the wrong length"));
    }
    let mut names = vec![];
    for (param, values) in sweep {
        let unit = specs.iter().find(|s| s.name == param).map(|s| s.unit).unwrap_or("");
        let unit = if unit.is_empty() { "1" } else { unit };
        let values = typed(values, n);
        let plain = param.replace('.', "_");
        let name = match out.get(&plain) {
            Some(v) if v.dims == ["point"] && v.values == values => plain,
            Some(_) => format!("sweep_{plain}"),
            None => plain,
        };
        if out.get(&name).is_none() {
            let var = out.push_values(&name, &["point"], values, unit, &format!("swept {param}"));
            var.attrs.insert("description".into(), Attr::Str(format!("parameter {param} swept by stage {stage}")));
        }
        let var = out.get_mut(&name).expect("added above");
        var.attrs.insert("parameter".into(), Attr::Str(param.clone()));
        var.attrs.insert("stage".into(), Attr::Str(stage.into()));
        names.push(name);
    }
    list_coordinates(out, &names);
    Ok(())
}

/// Copies the coordinates of `inputs` (when there is exactly one and the output maps its
/// points onto the input's by `input_point`) onto the output's points.
pub fn add_upstream_coordinates(out: &mut Output, inputs: &[Input]) -> Result<()> {
    let [input] = inputs else { return Ok(()) };
    let map: Vec<usize> = match out.get("input_point") {
        Some(v) if v.dims == ["point"] => match &v.values {
            Values::I64(a) => a.iter().map(|&i| i as usize).collect(),
            _ => return Err(anyhow!("`input_point` must be an integer variable")),
        },
        _ => return Ok(()),
    };
    let g = input.version.open()?;
    let mut names = vec![];
    for member in g.member_names()? {
        let Ok(ds) = g.dataset(&member) else { continue };
        let attrs = hdf::read_attrs(&ds)?;
        let Some(Attr::Str(param)) = attrs.get("parameter") else { continue };
        let stage = match attrs.get("stage") {
            Some(Attr::Str(s)) => s.clone(),
            _ => input.name.clone(),
        };
        let text = |key: &str| match attrs.get(key) {
            Some(Attr::Str(s)) => s.clone(),
            _ => String::new(),
        };
        if ds.ndim() != 1 || map.iter().any(|&i| i >= ds.size()) {
            continue;
        }
        let values = match ds.dtype()?.to_descriptor()? {
            hdf5::types::TypeDescriptor::Float(_) => Values::F64(pick(&hdf::read_f64(&g, &member)?, &map)),
            hdf5::types::TypeDescriptor::Integer(_) => Values::I64(pick(&hdf::read_i64(&g, &member)?, &map)),
            _ => Values::Str(pick(&hdf::read_strings_nd(&g, &member)?, &map)),
        };
        let name = match out.get(&member) {
            None => member.clone(),
            Some(v) if v.attrs.get("parameter") == Some(&Attr::Str(param.clone())) && v.attrs.get("stage") == Some(&Attr::Str(stage.clone())) => continue,
            Some(_) => format!("{stage}_{member}"),
        };
        if out.get(&name).is_some() {
            continue;
        }
        let long = if text("long_name").is_empty() { format!("swept {param}") } else { text("long_name") };
        let var = out.push_values(&name, &["point"], values, &text("units"), &long);
        var.attrs.insert("parameter".into(), Attr::Str(param.clone()));
        var.attrs.insert("stage".into(), Attr::Str(stage.clone()));
        var.attrs.insert("description".into(), Attr::Str(format!("parameter {param} swept by stage {stage}, at the {} point each point reads", input.name)));
        names.push(name);
    }
    list_coordinates(out, &names);
    Ok(())
}

fn pick<T: Clone>(all: &ArrayD<T>, map: &[usize]) -> ArrayD<T> {
    ArrayD::from_shape_vec(IxDyn(&[map.len()]), map.iter().map(|&i| all[[i]].clone()).collect()).expect("1-D")
}

/// Sweep values in their type: integers as i64, numbers as f64, anything else as text.
fn typed(values: &[ParamValue], n: usize) -> Values {
    let shape = IxDyn(&[n]);
    if values.iter().all(|v| matches!(v, ParamValue::Int(_))) {
        let ints = values.iter().map(|v| if let ParamValue::Int(i) = v { *i } else { 0 }).collect();
        Values::I64(ArrayD::from_shape_vec(shape, ints).expect("one value per point"))
    } else if values.iter().all(|v| matches!(v, ParamValue::Float(_) | ParamValue::Int(_))) {
        let floats = values
            .iter()
            .map(|v| match v {
                ParamValue::Float(f) => *f,
                ParamValue::Int(i) => *i as f64,
                _ => f64::NAN,
            })
            .collect();
        Values::F64(ArrayD::from_shape_vec(shape, floats).expect("one value per point"))
    } else {
        Values::Str(ArrayD::from_shape_vec(shape, values.iter().map(|v| v.to_string()).collect()).expect("one value per point"))
    }
}

/// Appends `names` to the `coordinates` attribute of every other variable along `point`.
fn list_coordinates(out: &mut Output, names: &[String]) {
    if names.is_empty() {
        return;
    }
    let coords = names.join(" ");
    for v in out.variables.iter_mut() {
        if v.dims.iter().any(|d| d == "point") && !names.contains(&v.name) {
            let joined = match v.attrs.get("coordinates") {
                Some(Attr::Str(own)) => format!("{own} {coords}"),
                _ => coords.clone(),
            };
            v.attrs.insert("coordinates".into(), Attr::Str(joined));
        }
    }
}
