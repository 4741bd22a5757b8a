//! Physical parameters and sweep coordinates flow downstream (issue 19): a web built on
//! the spectra of 30 and 50 µm laid fibres takes their diameter, density and belt ratio
//! unless its pipeline sets them, says so, and a grid's densities follow; the laydown's
//! swept diameter is a named coordinate of the spectra, web and grid points.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};
use std::path::Path;

const PIPELINE: &str = include_str!("fixtures/parameter_flow.yaml");

fn f64s(dir: &Path, stage: &str, name: &str) -> Vec<f64> {
    let a = Archive::open_read(&dir.join("flow.h5")).unwrap();
    hdf::read_f64(&a.version(stage, None).unwrap().open().unwrap(), name).unwrap().iter().copied().collect()
}

fn strings(dir: &Path, stage: &str, name: &str) -> Vec<String> {
    let a = Archive::open_read(&dir.join("flow.h5")).unwrap();
    hdf::read_strings(&a.version(stage, None).unwrap().open().unwrap(), name).unwrap()
}

#[test]
fn physical_parameters_are_inherited_unless_given() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    write_pipeline(dir, "p.yaml", PIPELINE);
    let out = run_in(dir, &["run", "p.yaml"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");

    // The spectra record what the fibres were laid with, per point.
    assert_eq!(f64s(dir, "spectra", "fibre_diameter"), [3e-5, 5e-5]);
    assert_eq!(f64s(dir, "spectra", "fibre_density"), [1200.0, 1200.0]);
    assert_eq!(f64s(dir, "spectra", "belt_speed_ratio"), [0.3 / 5.0, 0.3 / 5.0]);

    // `auto` takes them; the web says so in the archive and on stderr.
    assert_eq!(f64s(dir, "web", "fibre_diameter"), [3e-5, 5e-5]);
    assert_eq!(f64s(dir, "web", "fibre_density"), [1200.0, 1200.0]);
    assert_eq!(f64s(dir, "web", "belt_speed_ratio"), [0.06, 0.06]);
    let inherited = strings(dir, "web", "inherited_parameters");
    assert!(inherited[1].contains("point 1") && inherited[1].contains("fibre_diameter = 5e-5 m"), "{inherited:?}");
    assert!(err.contains("web: point 1: from the laid fibres of /spectra/v1 point 1"), "{err}");

    // A value the pipeline gives wins; the others are still inherited.
    assert_eq!(f64s(dir, "web_given", "fibre_diameter"), [2e-5]);
    assert_eq!(f64s(dir, "web_given", "fibre_density"), [1200.0]);
    assert!(!strings(dir, "web_given", "inherited_parameters")[0].contains("fibre_diameter"));

    // Fibres analysed with the belt motion in them already drift: no second drift.
    assert_eq!(f64s(dir, "web_kept_belt", "belt_speed_ratio"), [0.0]);
    assert!(strings(dir, "web_kept_belt", "inherited_parameters")[0].contains("keep the belt drift"));

    // The grid's expected density is the laid fibres' mass per area: ρπd²/4/(Δw·c).
    let expected: Vec<f64> = [3e-5f64, 5e-5].iter().map(|d| 1200.0 * std::f64::consts::PI * d * d / 4.0 / (0.001 * 0.06) * 1e3).collect();
    for (got, want) in f64s(dir, "grid", "expected_interior_density").iter().zip(&expected) {
        assert!((got / want - 1.0).abs() < 1e-12, "{got} {want}");
    }
}

/// (values as f64, `parameter`, `stage`, stored as integers) of a coordinate.
fn coordinate(dir: &Path, stage: &str, name: &str) -> (Vec<f64>, String, String, bool) {
    let a = Archive::open_read(&dir.join("flow.h5")).unwrap();
    let g = a.version(stage, None).unwrap().open().unwrap();
    let ds = g.dataset(name).unwrap_or_else(|_| panic!("{stage} has no coordinate {name}"));
    let attrs = hdf::read_attrs(&ds).unwrap();
    let text = |k: &str| match attrs.get(k) {
        Some(laydown::archive::data::Attr::Str(s)) => s.clone(),
        other => panic!("{stage}/{name}: attribute {k} is {other:?}"),
    };
    let integer = matches!(ds.dtype().unwrap().to_descriptor().unwrap(), hdf5::types::TypeDescriptor::Integer(_));
    (hdf::read_f64(&g, name).unwrap().iter().copied().collect(), text("parameter"), text("stage"), integer)
}

#[test]
fn swept_parameters_reach_every_stage_downstream() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    write_pipeline(dir, "p.yaml", PIPELINE);
    let out = run_in(dir, &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let diameter = (vec![3e-5, 5e-5], "diameter".to_string(), "fibre".to_string(), false);
    // Swept in the laydown; the spectra have one point per laydown point.
    assert_eq!(coordinate(dir, "fibre", "diameter"), diameter);
    assert_eq!(coordinate(dir, "spectra", "diameter"), diameter);
    // The web's own sweep of input_point is its integer `input_point` variable; the
    // diameter of the spectra point each web point reads comes along.
    assert_eq!(coordinate(dir, "web", "input_point"), (vec![0.0, 1.0], "input_point".into(), "web".into(), true));
    assert_eq!(coordinate(dir, "web", "diameter"), diameter);
    // One web point of spectra point 1: the diameter there only.
    assert_eq!(coordinate(dir, "web_given", "diameter").0, [5e-5]);
    // Three stages down, by name; the web's `input_point` is renamed after its stage
    // (the grid has its own `input_point`, the web point it grids).
    assert_eq!(coordinate(dir, "grid", "diameter"), diameter);
    assert_eq!(coordinate(dir, "grid", "web_input_point"), (vec![0.0, 1.0], "input_point".into(), "web".into(), true));
    let a = Archive::open_read(&dir.join("flow.h5")).unwrap();
    let g = a.version("grid", None).unwrap().open().unwrap();
    let attrs = hdf::read_attrs(&g.dataset("cv").unwrap()).unwrap();
    let Some(laydown::archive::data::Attr::Str(coords)) = attrs.get("coordinates") else { panic!("{attrs:?}") };
    assert!(coords.split(' ').any(|c| c == "diameter"), "{coords}");
}
