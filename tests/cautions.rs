//! A valid setting known to give poor results (a stage's `cautions`) is a warning, not an
//! error: `validate` and `run` print it with the file, line, column and key of the value
//! that draws it (under params, or the sweep item), also under `-q`, once per parameter,
//! and the pipeline still validates and runs.
mod common;
use common::*;

const HIGH_FRICTION: &str = "pipeline: cautions
archive: study.h5
seed: 1
stages:
  - name: single
    kind: laydown
    params:
      friction_coefficient: 3
  - name: web
    kind: laid_web
    params:
      fibres_across: 2
      fibre_spacing: 0.002
      belt_travel: 0.02
    sweep:
      friction_coefficient: [1.0, 3.0, 5.0]
  - name: damped
    kind: laydown
    params:
      friction_coefficient: 3
      integrator: implicit_axial
";

fn warnings(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with("warning:")).collect()
}

/// `validate` of `yaml` as p.yaml: exit 0 and exactly one warning, returned.
fn only_warning(yaml: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", yaml);
    let out = run_in(tmp.path(), &["validate", "p.yaml"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    let w = warnings(&e);
    assert_eq!(w.len(), 1, "{e}");
    w[0].to_string()
}

#[test]
fn high_friction_with_the_default_integrator_warns_where_it_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", HIGH_FRICTION);
    for args in [&["validate", "p.yaml"][..], &["-q", "validate", "p.yaml"], &["run", "--dry-run", "p.yaml"]] {
        let out = run_in(tmp.path(), args);
        let (o, e) = text(&out);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {o}\n{e}");
        let w = warnings(&e);
        assert_eq!(w.len(), 2, "{args:?}: one warning per stage and parameter, none for implicit_axial:\n{e}");
        assert!(w[0].starts_with("warning: p.yaml:8:29: stages[0].params.friction_coefficient: 3 is above 2"), "{}", w[0]);
        // the sweep's first value above 2 (3.0, item 1), not the list
        assert!(w[1].starts_with("warning: p.yaml:16:35: stages[1].sweep.friction_coefficient[1]: 3 is above 2"), "{}", w[1]);
        assert!(w.iter().all(|l| l.contains("integrator: implicit_axial")), "says what to do instead: {e}");
        assert!(!e.contains("error"), "{e}");
    }
    // the dry run wrote nothing
    assert!(!tmp.path().join("study.h5").exists());
}

#[test]
fn defaults_and_friction_up_to_2_draw_no_warning() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", "pipeline: quiet\narchive: study.h5\nstages:\n  - {name: single, kind: laydown}\n  - {name: web, kind: laid_web, params: {friction_coefficient: 2.0}}\n");
    let out = run_in(tmp.path(), &["validate", "p.yaml"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(warnings(&e).is_empty(), "{e}");
}

/// In a zip sweep the warning names the item of the point that draws it, even where an
/// earlier item has the same value; a small enough step draws none.
#[test]
fn a_zip_sweep_warns_at_the_item_of_the_point() {
    let w = only_warning("pipeline: zip\narchive: study.h5\nstages:\n  - name: single\n    kind: laydown\n    sweep_mode: zip\n    sweep:\n      friction_coefficient: [3.0, 3.0, 3.0]\n      integrator: [implicit_axial, trapezoidal_axial, trapezoidal_axial]\n      time_step_factor: [0.8, 0.2, 0.8]\n");
    assert!(w.starts_with("warning: p.yaml:8:40: stages[0].sweep.friction_coefficient[2]: 3 is above 2"), "{w}");
}

/// In a cartesian sweep the item is found from the point's place in the grid (the last
/// list varies fastest).
#[test]
fn a_cartesian_sweep_warns_at_the_item_of_the_point() {
    let w = only_warning("pipeline: grid\narchive: study.h5\nstages:\n  - name: single\n    kind: laydown\n    sweep:\n      friction_coefficient: [1.0, 3.0]\n      integrator: [implicit_axial, trapezoidal_axial]\n");
    assert!(w.starts_with("warning: p.yaml:7:35: stages[0].sweep.friction_coefficient[1]: 3 is above 2"), "{w}");
}
