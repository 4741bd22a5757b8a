//! `laydown table` on a small archive holding every stage kind, and the table `laydown run`
//! prints for an image stage: the values must be the archive's, bit for bit.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};
use std::path::Path;

const PIPELINE: &str = "\
pipeline: tables
archive: t.h5
seed: 3
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.08, elements: 80}
    sweep: {friction_coefficient: [0.5, 1.0]}
    replicates: 2
  - name: spectra
    kind: spectra
    input: fibre
  - name: web
    kind: web
    input: spectra
    params: {input_point: 1, fibres_across: 200, fibre_spacing: 0.0005, segments_per_fibre: 300, belt_speed_ratio: 0.04}
  - name: grid
    kind: grid
    input: web
    params: {cell_size: 0.001, window_side: 0.06, boundary: periodic}
    replicates: 2
  - name: scans
    kind: image
    input: grid
    params:
      bonds: {shape: circle, size1: 0.0015, period1: 0.0042, period2: 0.0042, contrast: 0.15}
      panels: false
  - name: notch
    kind: image
    input: grid
    params:
      bonds: {shape: circle, size1: 0.0015, period1: 0.0042, period2: 0.0042, contrast: 0.15}
      panels: false
    sweep: {notch_sigma_bins: [1.5, 3.0]}
  - name: cost
    kind: accuracy
    input: [scans, notch]
    params: {metrics: [cv_corr], reference_metrics: [cv_web]}
";

/// Minimal RFC 4180 reader: rows of fields.
fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let mut rows = vec![];
    let (mut row, mut field, mut quoted) = (vec![], String::new(), false);
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => row.push(std::mem::take(&mut field)),
            ('\n', false) => {
                row.push(std::mem::take(&mut field));
                rows.push(std::mem::take(&mut row));
            }
            (c, _) => field.push(c),
        }
    }
    rows
}

struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn col(&self, name: &str) -> Vec<String> {
        let k = self.header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column `{name}` in {:?}", self.header));
        self.rows.iter().map(|r| r[k].clone()).collect()
    }
    fn num(&self, name: &str) -> Vec<f64> {
        self.col(name).iter().map(|v| v.parse::<f64>().unwrap_or_else(|_| panic!("{name}: `{v}` is not a number"))).collect()
    }
}

fn table(dir: &Path, args: &[&str]) -> (Csv, String) {
    let mut all = vec!["table", "t.h5"];
    all.extend_from_slice(args);
    let o = run_in(dir, &all);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
    let mut rows = parse_csv(&out);
    let header = rows.remove(0);
    assert!(rows.iter().all(|r| r.len() == header.len()), "{args:?}: ragged CSV\n{out}");
    (Csv { header, rows }, err)
}

fn dataset(dir: &Path, stage: &str, name: &str) -> Vec<f64> {
    let a = Archive::open_read(&dir.join("t.h5")).unwrap();
    let g = a.version(stage, None).unwrap().open().unwrap();
    match hdf::read_f64(&g, name) {
        Ok(v) => v.iter().copied().collect(),
        Err(e) => panic!("{stage}/{name}: {e}"),
    }
}

/// Bit-for-bit equal, NaN equal to NaN.
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits() || x.is_nan() && y.is_nan())
}

#[test]
fn every_stage_kind_tabulates_its_per_point_and_per_replicate_results() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", PIPELINE);
    let o = run_in(d, &["run", "p.yaml"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");

    // laydown: a row per point with the swept parameter and mean ± std; --all per replicate.
    let (t, _) = table(d, &["fibre"]);
    assert_eq!(t.header[..2], ["point", "friction_coefficient"]);
    assert_eq!(t.num("friction_coefficient"), [0.5, 1.0]);
    assert!(same(&t.num("bending_energy_mean"), &dataset(d, "fibre", "bending_energy_mean")));
    assert!(same(&t.num("bending_energy_std"), &dataset(d, "fibre", "bending_energy_std")));
    let (t, _) = table(d, &["fibre@v1", "--all"]);
    assert_eq!(t.col("point"), ["0", "0", "1", "1"]);
    assert_eq!(t.col("replicate"), ["0", "1", "0", "1"]);
    assert_eq!(t.num("friction_coefficient"), [0.5, 0.5, 1.0, 1.0]);
    assert!(same(&t.num("bending_energy"), &dataset(d, "fibre", "bending_energy")), "per replicate, (point, replicate) row-major");
    let means = dataset(d, "fibre", "radius_of_gyration_mean");
    assert!(same(&t.num("radius_of_gyration_mean"), &[means[0], means[0], means[1], means[1]]), "per-point values repeated per replicate");

    // spectra: the mean spectrum per (point, bin); --all per fibre.
    let (t, _) = table(d, &["spectra"]);
    let bins = dataset(d, "spectra", "angular_frequency").len() / 2;
    assert_eq!(t.rows.len(), 2 * bins);
    assert!(same(&t.num("mean_energy_spectrum"), &dataset(d, "spectra", "mean_energy_spectrum")));
    let (t, _) = table(d, &["spectra", "--all"]);
    assert!(same(&t.num("bending_energy_from_curvature"), &dataset(d, "spectra", "bending_energy_from_curvature")));

    // web: per point only; --all says so and gives the same table.
    let (t, _) = table(d, &["web"]);
    assert_eq!(t.rows.len(), 1);
    assert!(same(&t.num("interior_areal_density"), &dataset(d, "web", "interior_areal_density")));
    let (t2, note) = table(d, &["web", "--all"]);
    assert!(note.contains("no per-replicate values"), "{note}");
    assert_eq!(t2.rows, t.rows);

    // grid: means and stds per point, --all per realisation.
    let (t, _) = table(d, &["grid"]);
    assert!(same(&t.num("cv_mean"), &dataset(d, "grid", "cv_mean")) && same(&t.num("cv_std"), &dataset(d, "grid", "cv_std")));
    let (t, _) = table(d, &["grid", "--all"]);
    assert_eq!(t.col("realisation"), ["0", "1"]);
    assert!(same(&t.num("cv"), &dataset(d, "grid", "cv")));

    // image: per condition (swept: per point and condition) with the swept parameter;
    // --all per sample with its labels.
    let (t, _) = table(d, &["scans"]);
    assert_eq!(t.header[0], "condition");
    assert!(same(&t.num("cv_corr_mean"), &dataset(d, "scans", "cv_corr_mean")));
    let (t, _) = table(d, &["notch"]);
    assert_eq!(t.header[..3], ["point", "condition", "notch_sigma_bins"]);
    assert_eq!(t.num("notch_sigma_bins").len(), dataset(d, "notch", "cv_corr_mean").len());
    assert!(same(&t.num("cv_corr_mean"), &dataset(d, "notch", "cv_corr_mean")));
    let (t, _) = table(d, &["notch", "--all"]);
    assert!(same(&t.num("cv_corr"), &dataset(d, "notch", "cv_corr")));
    assert!(t.num("file_pixel_size").iter().all(|v| v.is_nan()), "NaN is written as NaN");
    assert!(t.col("pixel_size_source").iter().all(|s| s == "grid"));

    // accuracy: per candidate and metric.
    let (t, _) = table(d, &["cost"]);
    assert!(same(&t.num("relative_error"), &dataset(d, "cost", "relative_error")));
    assert!(t.col("candidate_label").iter().any(|l| l.contains("notch_sigma_bins")));

    // `laydown run` printed the image stages' tables on stdout, as `laydown table` does.
    let (t, _) = table(d, &["scans"]);
    let mut expected = t.header.join(",");
    for r in &t.rows {
        expected += &format!("\n{}", r.join(","));
    }
    let archive = d.canonicalize().unwrap().join("t.h5");
    assert!(out.contains(&format!("scans@v1 (laydown table {} scans@v1):", archive.display())) && out.contains(&expected), "{out}");
    assert!(out.contains("notch@v1 (laydown table"), "{out}");
    assert!(!out.contains("fibre@v1 (laydown table"), "only image stages: {out}");
}

#[test]
fn markdown_and_json_hold_the_same_values_and_bad_references_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", &PIPELINE[..PIPELINE.find("  - name: spectra").unwrap()]);
    assert_eq!(run_in(d, &["run", "p.yaml"]).status.code(), Some(0));
    let (csv, _) = table(d, &["fibre", "--all"]);

    let o = run_in(d, &["table", "t.h5", "fibre", "--all", "--format", "markdown"]);
    let md = text(&o).0;
    let lines: Vec<&str> = md.lines().collect();
    assert_eq!(lines.len(), 2 + csv.rows.len(), "{md}");
    assert!(lines[0].starts_with("| point | replicate | friction_coefficient |") && lines[0].contains("| radius_of_gyration (m) |"), "units in the header: {}", lines[0]);
    assert!(lines[1].starts_with("|---:|---:|"));
    let cells: Vec<&str> = lines[2].trim_matches('|').split('|').map(str::trim).collect();
    assert_eq!(cells, csv.rows[0].iter().map(String::as_str).collect::<Vec<_>>());

    let o = run_in(d, &["table", "t.h5", "fibre", "--all", "--format", "json"]);
    let j: serde_json::Value = serde_json::from_str(&text(&o).0).unwrap();
    assert_eq!(j["stage"], "fibre");
    assert_eq!(j["row_dims"], serde_json::json!(["point", "replicate"]));
    let names: Vec<&str> = j["columns"].as_array().unwrap().iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert_eq!(names, csv.header.iter().map(String::as_str).collect::<Vec<_>>());
    let k = names.iter().position(|n| *n == "bending_energy").unwrap();
    let from_json: Vec<f64> = j["rows"].as_array().unwrap().iter().map(|r| r[k].as_f64().unwrap()).collect();
    assert!(same(&from_json, &csv.num("bending_energy")));

    for (args, expect) in [
        (vec!["table", "t.h5", "nosuch"], "nosuch"),
        (vec!["table", "t.h5", "fibre@v9"], "v9"),
        (vec!["table", "t.h5", "fibre@9"], "expected STAGE or STAGE@vN"),
        (vec!["table", "missing.h5", "fibre"], "missing.h5"),
    ] {
        let o = run_in(d, &args);
        let e = text(&o).1;
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(expect), "{args:?}: {e}");
    }
}

#[test]
fn a_laid_web_tabulates_per_point_and_per_replicate() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(
        d,
        "p.yaml",
        "pipeline: laid\narchive: t.h5\nseed: 4\nstages:\n  - name: laid\n    kind: laid_web\n    params: {fibres_across: 2, belt_travel: 0.03}\n    replicates: 2\n",
    );
    let o = run_in(d, &["run", "p.yaml"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o).1);
    let (t, _) = table(d, &["laid"]);
    assert_eq!(t.col("point"), ["0"]);
    assert!(same(&t.num("expected_interior_density"), &dataset(d, "laid", "expected_interior_density")));
    let (t, _) = table(d, &["laid", "--all"]);
    assert_eq!(t.col("replicate"), ["0", "1"]);
    assert!(same(&t.num("spread"), &dataset(d, "laid", "spread")));
}
