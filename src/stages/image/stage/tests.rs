//! The grid-input path against the grid stage's contract (`density` (point, realisation,
//! md, cd) in g/m², coordinates `md`, `cd` in m, scalar `cell_size`, swept parameters as
//! 1-D variables along `point` with a `parameter` attribute), on a fixture version
//! written through the archive API: the grid stage itself is not on this branch.
use super::*;
use crate::archive::Archive;
use crate::params::ParamValue;
use crate::stages::image::render::random_fibre_web;
use ndarray::{Array0, Array4};
use std::collections::BTreeMap;

const CELL: f64 = 0.34e-3;

fn fixture(dir: &Path, rows: usize, cols: usize) -> Input {
    let (np, nr) = (2, 2);
    let mut density = Array4::zeros((np, nr, rows, cols));
    for pt in 0..np {
        for r in 0..nr {
            let web = random_fibre_web(rows, cols, CELL, 20.0 + 10.0 * pt as f64, 10e-3, 1e-3, Some(35.0), (7 + 10 * pt + r) as u64);
            density.slice_mut(s![pt, r, .., ..]).assign(&web);
        }
    }
    let mut out = Output::new();
    out.f64("density", &["point", "realisation", "md", "cd"], density, "g m-2", "areal density");
    out.coord("md", (0..rows).map(|i| (i as f64 + 0.5) * CELL).collect(), "m", "MD cell centre");
    out.coord("cd", (0..cols).map(|j| (j as f64 + 0.5) * CELL).collect(), "m", "CD cell centre");
    out.f64("cell_size", &[], Array0::from_elem((), CELL), "m", "grid cell side");
    out.f64("belt_speed_ratio", &["point"], Array1::from(vec![0.02, 0.07]), "1", "swept parameter belt_speed_ratio")
        .attrs
        .insert("parameter".into(), Attr::Str("belt_speed_ratio".into()));
    let path = dir.join("fixture.h5");
    let archive = Archive::open_write(&path).unwrap();
    let mut attrs = BTreeMap::new();
    attrs.insert("status".to_string(), Attr::Str("complete".into()));
    attrs.insert("content_hash".to_string(), Attr::Str("fixture".into()));
    let n = archive.commit_version("fixture", "grid", &out, &attrs, "fixture").unwrap();
    Input { name: "grid".into(), kind: "grid".into(), version: archive.version("grid", Some(n)).unwrap() }
}

fn ctx(dir: &Path, input: Vec<Input>, given: &[(&str, ParamValue)]) -> RunContext {
    let given: BTreeMap<String, ParamValue> = given.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
    RunContext {
        stage_name: "image".into(),
        points: vec![ParamSet::resolve(&ImageStage.params(), &given)],
        sweep: vec![],
        replicates: 1,
        seed: 0,
        inputs: input,
        progress: false,
        pipeline_dir: dir.to_path_buf(),
        figure_dir: dir.join("figures"),
    }
}

fn get(out: &Output, name: &str) -> Vec<f64> {
    match &out.get(name).unwrap_or_else(|| panic!("no {name}")).values {
        crate::archive::data::Values::F64(a) => a.iter().copied().collect(),
        crate::archive::data::Values::I64(a) => a.iter().map(|&v| v as f64).collect(),
        other => panic!("{name}: {other:?}"),
    }
}

#[test]
fn grid_input_with_bonds_recovers_the_web_cv() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture(dir.path(), 128, 160);
    let c = ctx(
        dir.path(),
        vec![input],
        &[
            ("bonds.shape", ParamValue::Text("circle".into())),
            ("bonds.size1", ParamValue::Float(1.6e-3)),
            ("bonds.contrast", ParamValue::Float(0.4)),
            ("max_stored_images", ParamValue::Int(1)),
        ],
    );
    ImageStage.check(&c.points[0]).unwrap();
    let out = ImageStage.run(&c).unwrap();
    assert!(out.dimensions().is_ok());
    let (raw, comp, web) = (get(&out, "cv_raw"), get(&out, "cv_corr_compensated"), get(&out, "cv_web"));
    assert_eq!(raw.len(), 4);
    for i in 0..4 {
        println!("sample {i}: web {:.4} raw {:.4} comp {:.4}", web[i], raw[i], comp[i]);
        assert!(raw[i] > 1.3 * web[i], "bonds must dominate the raw CV");
        assert!((comp[i] / web[i] - 1.0).abs() < 0.05, "sample {i}: {} vs {}", comp[i], web[i]);
    }
    let periods = get(&out, "lattice_period1");
    assert!(periods.iter().all(|p| (p - 4e-3).abs() < 0.1e-3), "{periods:?}");
    assert_eq!(get(&out, "condition_belt_speed_ratio"), vec![0.02, 0.07]);
    assert_eq!(get(&out, "condition_samples"), vec![2.0, 2.0]);
    match &out.get("condition").unwrap().values {
        crate::archive::data::Values::Str(v) => assert_eq!(v.iter().collect::<Vec<_>>(), ["belt_speed_ratio=0.02", "belt_speed_ratio=0.07"]),
        other => panic!("{other:?}"),
    }
    assert_eq!(out.get("raw_image").unwrap().values.shape(), vec![1, 128, 160]);
    // the panel is handed to the runner, written only once the version is committed
    assert!(!dir.path().join("figures").exists(), "the stage wrote into an uncommitted version's folder");
    let names: Vec<&str> = out.files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["sample000_belt_speed_ratio_0.02.png"]);
    let panel = image::load_from_memory(&out.files[0].1).unwrap();
    let gap = crate::stages::image::panel::GAP as u32;
    assert_eq!((panel.width(), panel.height()), (2 * 160 + 3 * gap, 2 * 128 + 3 * gap));
}

#[test]
fn grid_input_without_bonds_changes_nothing_and_files_are_refused_alongside() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture(dir.path(), 96, 112);
    let out = ImageStage.run(&ctx(dir.path(), vec![input], &[("panels", ParamValue::Bool(false))])).unwrap();
    let (raw, corr, web) = (get(&out, "cv_raw"), get(&out, "cv_corr"), get(&out, "cv_web"));
    for i in 0..raw.len() {
        assert!((corr[i] / raw[i] - 1.0).abs() < 0.005, "{} vs {}", corr[i], raw[i]);
        assert!((raw[i] / web[i] - 1.0).abs() < 1e-12);
    }
    assert!(!dir.path().join("figures").exists());
    let input = fixture(&dir.path().join("b"), 96, 112);
    let e = ImageStage.run(&ctx(dir.path(), vec![input], &[("files", ParamValue::List(vec!["x.png".into()]))])).unwrap_err();
    assert!(e.downcast_ref::<BadInput>().is_some() && e.to_string().contains("not both"), "{e}");
}

#[test]
fn a_grid_version_without_density_or_with_nan_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let archive = Archive::open_write(&dir.path().join("bad.h5")).unwrap();
    let mut attrs = BTreeMap::new();
    attrs.insert("status".to_string(), Attr::Str("complete".into()));
    let mut out = Output::new();
    out.f64("cell_size", &[], Array0::from_elem((), CELL), "m", "grid cell side");
    let n = archive.commit_version("fixture", "grid", &out, &attrs, "fixture").unwrap();
    let input = Input { name: "grid".into(), kind: "grid".into(), version: archive.version("grid", Some(n)).unwrap() };
    let e = ImageStage.run(&ctx(dir.path(), vec![input], &[])).unwrap_err();
    assert!(e.downcast_ref::<BadInput>().is_some() && e.to_string().contains("has no `density`"), "{e}");

    let mut density = Array4::from_elem((1, 1, 32, 32), 20.0);
    density[[0, 0, 3, 4]] = f64::NAN;
    out.f64("density", &["point", "realisation", "md", "cd"], density, "g m-2", "areal density");
    let n = archive.commit_version("fixture", "grid", &out, &attrs, "fixture").unwrap();
    let input = Input { name: "grid".into(), kind: "grid".into(), version: archive.version("grid", Some(n)).unwrap() };
    let e = ImageStage.run(&ctx(dir.path(), vec![input], &[])).unwrap_err();
    assert!(e.downcast_ref::<BadInput>().is_some() && e.to_string().contains("point 0 realisation 0"), "{e}");
}

/// A sweep of the analysis: every result gains a leading `point` dimension and point k
/// is exactly the unswept run with point k's parameters; the sample descriptors and
/// text are stored once; parameters that change which images are read are refused.
#[test]
fn a_swept_analysis_stacks_the_unswept_runs() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture(dir.path(), 96, 128);
    let fixed = [
        ("bonds.shape", ParamValue::Text("circle".into())),
        ("bonds.size1", ParamValue::Float(1.6e-3)),
        ("bonds.contrast", ParamValue::Float(0.4)),
        ("max_stored_images", ParamValue::Int(1)),
        ("panels", ParamValue::Bool(false)),
    ];
    let values = [0.5, 2.0];
    let single: Vec<Output> = values
        .iter()
        .map(|&w| {
            let mut given = fixed.to_vec();
            given.push(("notch_sigma_bins", ParamValue::Float(w)));
            let input = Input { name: input.name.clone(), kind: input.kind.clone(), version: input.version.clone() };
            ImageStage.run(&ctx(dir.path(), vec![input], &given)).unwrap()
        })
        .collect();
    let mut swept = ctx(dir.path(), vec![input], &fixed);
    swept.points = values
        .iter()
        .map(|&w| {
            let mut given: BTreeMap<String, ParamValue> = fixed.iter().map(|(k, v)| (k.to_string(), v.clone())).collect();
            given.insert("notch_sigma_bins".into(), ParamValue::Float(w));
            ParamSet::resolve(&ImageStage.params(), &given)
        })
        .collect();
    swept.sweep = vec![("notch_sigma_bins".into(), values.iter().map(|&w| ParamValue::Float(w)).collect())];
    let out = ImageStage.run(&swept).unwrap();
    assert!(out.dimensions().is_ok());
    assert_eq!(out.get("cv_corr").unwrap().dims, vec!["point", "sample"]);
    assert_eq!(out.get("cv_corr_mean").unwrap().dims, vec!["point", "condition"]);
    assert_eq!(out.get("raw_image").unwrap().dims, vec!["point", "stored", "row", "col"]);
    assert_eq!(out.get("rows").unwrap().dims, vec!["sample"]);
    assert_eq!(out.get("condition_belt_speed_ratio").unwrap().dims, vec!["condition"]);
    let mut differs = false;
    for v in &single[0].variables {
        let stacked = out.get(&v.name).unwrap();
        if stacked.dims.first().map(String::as_str) != Some("point") {
            assert_eq!(bits(&stacked.values), bits(&v.values), "{} is shared but differs", v.name);
            continue;
        }
        for (k, one) in single.iter().enumerate() {
            let want = &one.get(&v.name).unwrap().values;
            // The peak table is as wide as the widest point's: the rest is padding.
            let width = want.shape().get(1).copied().unwrap_or(0);
            let trim = |a: ndarray::ArrayViewD<'_, f64>| if v.dims.last().map(String::as_str) == Some("peak") { a.slice_axis(Axis(1), (0..width).into()).to_owned() } else { a.to_owned() };
            let got = match &stacked.values {
                Values::F64(a) => {
                    let point = a.index_axis(Axis(0), k);
                    if v.dims.last().map(String::as_str) == Some("peak") {
                        assert!(point.slice_axis(Axis(1), (width..).into()).iter().all(|x| x.is_nan()), "{} padding", v.name);
                    }
                    Values::F64(trim(point))
                }
                Values::I64(a) => {
                    let point = a.index_axis(Axis(0), k).mapv(|x| x as f64);
                    if v.dims.last().map(String::as_str) == Some("peak") {
                        assert!(point.slice_axis(Axis(1), (width..).into()).iter().all(|&x| x == -1.0), "{} padding", v.name);
                    }
                    Values::I64(trim(point.view()).mapv(|x| x as i64))
                }
                other => panic!("{}: {other:?}", v.name),
            };
            if v.name != "wall_seconds" {
                assert_eq!(bits(&got), bits(want), "{} at point {k}", v.name);
            }
        }
        differs |= single[0].get(&v.name).unwrap().values != single[1].get(&v.name).unwrap().values && v.name == "cv_corr";
    }
    assert!(differs, "the notch width must change cv_corr");

    let mut bad = ctx(dir.path(), vec![], &[]);
    bad.sweep = vec![("zone_min".into(), vec![ParamValue::Float(1e-3), ParamValue::Float(2e-3)])];
    let e = ImageStage.run(&bad).unwrap_err();
    assert!(e.downcast_ref::<BadInput>().is_some() && e.to_string().contains("`zone_min` cannot be swept"), "{e}");
}

/// Values as bits (NaN padding compares equal to itself), with their shape.
fn bits(v: &Values) -> (Vec<usize>, Vec<u64>) {
    let b = match v {
        Values::F64(a) => a.iter().map(|x| x.to_bits()).collect(),
        Values::I64(a) => a.iter().map(|&x| x as u64).collect(),
        Values::U8(a) => a.iter().map(|&x| x as u64).collect(),
        Values::Str(s) => s.iter().flat_map(|t| t.bytes().map(u64::from).chain([u64::MAX])).collect(),
    };
    (v.shape(), b)
}

#[test]
fn default_group_labels_are_file_stems_or_the_directory_of_a_whole_directory_glob() {
    let v = |s: &[&str]| s.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    assert_eq!(
        default_groups(&v(&["scans/a01.png", "/data/scans/v020/*.png", "v028/*", "b/w*.tif", "c.jpg"])),
        v(&["a01", "v020", "v028", "w*", "c"])
    );
    // Labels that would merge distinct entries keep the whole entry.
    assert_eq!(default_groups(&v(&["a/x.png", "b/x.png", "y.png"])), v(&["a/x.png", "b/x.png", "y"]));
    assert_eq!(default_groups(&v(&["*.png"])), v(&["*.png"]), "a glob with no directory has nothing shorter");
}

/// The stage takes the library's rows as they are (same names, same SI units), its
/// table is its typed parameters, and its defaults are the library's defaults, with no
/// rescaling between them.
#[test]
fn the_stage_rows_are_the_library_rows_and_map_without_rescaling() {
    let rows = ImageStage.params();
    for lib in PARAMETERS {
        assert_eq!(ParamSpec::find(&rows, lib.name), lib, "{}", lib.name);
    }
    let defaults = ParamSet::resolve(&rows, &BTreeMap::new());
    let typed = ImageStageParams::of(&defaults);
    assert_eq!(typed.analysis, ImageParams::default());
    crate::params::assert_table_matches(&rows, &typed);
    assert_eq!((typed.synthetic.rows, typed.bonds.shape, typed.render.bits), (617, BondShapeKind::None, 0));
    let given: BTreeMap<String, ParamValue> = [("pixel_size", 4.2e-5), ("zone_min", 1.1e-3), ("zone_max", 7.3e-3)]
        .iter()
        .map(|(k, v)| (k.to_string(), ParamValue::Float(*v)))
        .collect();
    let ip = ImageStageParams::of(&ParamSet::resolve(&rows, &given)).analysis;
    assert_eq!((ip.pixel_size, ip.zone_min, ip.zone_max), (Some(4.2e-5), 1.1e-3, 7.3e-3));
    assert_eq!(ip.pixel_size_or_default(), 4.2e-5);
}
