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

/// A time step coarser than 0.032 of the inertial coil time ℓ_c/v_f under the default
/// integrator (10-50 m/s, or thin fibres, at the coil-resolved mesh: 0.1) warns where
/// the cause is written (the fibre speed, the diameter) and says to set coil_step; that
/// rule, a small enough time_step_factor, another integrator, or Table 1 draw none.
#[test]
fn a_step_coarse_in_coil_times_warns_and_the_coil_step_rule_does_not() {
    let w = only_warning("pipeline: fast\narchive: study.h5\nstages:\n  - name: single\n    kind: laydown\n    params:\n      fibre_speed: 30\n  - name: ruled\n    kind: laydown\n    params: {fibre_speed: 30, coil_step: 0.04}\n  - name: small\n    kind: laydown\n    params: {fibre_speed: 30, time_step_factor: 0.2}\n  - name: implicit\n    kind: laid_web\n    params: {fibre_speed: 30, integrator: implicit_axial}\n  - name: slow\n    kind: laid_web\n    params: {fibre_speed: 5}\n");
    assert!(w.starts_with("warning: p.yaml:7:20: stages[0].params.fibre_speed: 30 m/s: the time step of integrator trapezoidal_axial (the default) is 0.100 of the inertial coil time"), "{w}");
    assert!(w.contains("coil_step: 0.04"), "says what to set: {w}");
    assert!(w.ends_with("; or measure the change at half the step: step_error_estimate: true"), "and how the laydown stage measures it: {w}");
    // a laid web is warned as a single fibre is, at the sweep item
    let w = only_warning("pipeline: web\narchive: study.h5\nstages:\n  - name: web\n    kind: laid_web\n    sweep:\n      fibre_speed: [5.0, 10.0]\n");
    assert!(w.starts_with("warning: p.yaml:7:26: stages[0].sweep.fibre_speed[1]: 10 m/s"), "{w}");
    assert!(!w.contains("step_error_estimate"), "a laid web has no half-step run: {w}");
    // a thin fibre at Table 1's speed, at its diameter
    let w = only_warning("pipeline: thin\narchive: study.h5\nstages:\n  - name: web\n    kind: laid_web\n    params:\n      diameter: 16.2e-6\n");
    assert!(w.starts_with("warning: p.yaml:7:17: stages[0].params.diameter: 0.0000162 m: the time step"), "{w}");
    // with fibre contact the step checked is the one taken, held to contact_step_factor
    let w = only_warning("pipeline: thin\narchive: study.h5\nstages:\n  - name: web\n    kind: laid_web\n    params:\n      diameter: 16.2e-6\n      fibre_contact: true\n      oscillation_ramp: 0.01\n");
    assert!(w.contains("is 0.062 of the inertial coil time"), "the contact web steps at 0.5 of the stable step, not 0.8: {w}");
}
