//! The short form of pipelines/accuracy_cost.yaml: an `accuracy` stage compares
//! candidates with a reference and records error and wall time per candidate.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};

const PIPELINE: &str = "\
pipeline: accuracy_short
archive: acc.h5
seed: 7
stages:
  - name: reference
    kind: laydown
    params: {integrator: explicit, length: 0.08, elements: 80}
    replicates: 2
  - name: schemes
    kind: laydown
    params: {length: 0.08, elements: 80}
    sweep: {integrator: [explicit, trapezoidal_axial]}
    replicates: 2
  - name: mesh
    kind: laydown
    params: {length: 0.08}
    sweep: {elements: [40, 80]}
    replicates: 2
  - name: cost
    kind: accuracy
    input: [reference, schemes, mesh]
";

#[test]
fn accuracy_stage_records_error_and_time_per_candidate() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    let o = run_in(dir.path(), &["run", "p.yaml"]);
    let (_, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("| candidate | setting | wall per unit (s) | speed-up |"), "{err}");

    let a = Archive::open_read(&dir.path().join("acc.h5")).unwrap();
    let g = a.version("cost", None).unwrap().open().unwrap();
    let stages = hdf::read_strings(&g, "candidate_stage").unwrap();
    let labels = hdf::read_strings(&g, "candidate_label").unwrap();
    assert_eq!(stages, ["schemes", "schemes", "mesh", "mesh"]);
    assert_eq!(labels[1], "integrator = trapezoidal_axial");
    let error = hdf::read_f64(&g, "relative_error").unwrap();
    let wall = hdf::read_f64(&g, "wall_seconds").unwrap();
    assert_eq!(error.shape(), [4, 2]);
    // The explicit candidate is the reference's own setting with the same seed: identical.
    assert_eq!(error[[0, 0]], 0.0);
    assert_eq!(error[[0, 1]], 0.0);
    // The others differ but stay finite and are not wildly off for a short fibre.
    for c in 1..4 {
        for m in 0..2 {
            assert!(error[[c, m]].is_finite() && error[[c, m]].abs() < 1.0, "candidate {c} metric {m}: {}", error[[c, m]]);
        }
        assert!(wall[[c]] > 0.0);
    }
    // The markdown table is beside the archive.
    let md = std::fs::read_to_string(dir.path().join("acc_figures/cost/v1/accuracy_cost.md")).unwrap();
    assert!(md.contains("| schemes | integrator = trapezoidal_axial |"), "{md}");
    // And it plots.
    let o = run_in(dir.path(), &["plot", "acc.h5", "cost"]);
    assert!(o.status.success(), "{:?}", text(&o));
}

#[test]
fn reference_with_several_points_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", &PIPELINE.replace("input: [reference, schemes, mesh]", "input: [mesh, schemes]"));
    let o = run_in(dir.path(), &["run", "p.yaml"]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("the reference `mesh` has 2 sweep points"), "{err}");
}
