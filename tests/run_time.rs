//! Run-time estimates: `validate` prints each laid web's and laydown's estimated CPU time
//! ("at least" with fibre contact, "at most" for the fed start), and `validate` and `run`
//! with `--max-cpu-time` refuse a stage estimated above the limit with exit 2, naming it
//! and what lowers it, before anything is computed.
mod common;
use common::*;

/// A laid web of 4000 fibres over a metre of belt: hours of CPU time, refused by a
/// one-hour limit at the stage's line; the archive is not created.
#[test]
fn a_laid_web_estimated_above_max_cpu_time_is_refused_before_it_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let big = write_pipeline(
        tmp.path(),
        "big.yaml",
        "pipeline: big\narchive: study.h5\nstages:\n  - name: laid\n    kind: laid_web\n    params: {fibres_across: 4000, belt_travel: 1.0}\n",
    );
    for cmd in ["validate", "run"] {
        let out = run_in(tmp.path(), &[cmd, big.to_str().unwrap(), "--max-cpu-time", "1h", "--max-memory", "1TiB"]);
        let (stdout, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(err.contains("big.yaml:4:5: stages[0]: stage `laid` (laid_web) is estimated at about "), "{cmd}: {err}");
        assert!(err.contains("above --max-cpu-time 60 min; lower belt_travel, fibres_across or replicates"), "{cmd}: {err}");
        assert!(stdout.is_empty(), "{cmd} printed {stdout}");
    }
    assert!(!tmp.path().join("study.h5").exists(), "the refused run wrote an archive");
}

/// `validate` states the estimate ("at least" with fibre contact), and a limit above it
/// lets the pipeline through.
#[test]
fn validate_prints_the_estimated_cpu_time_of_each_laid_web() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(
        tmp.path(),
        "p.yaml",
        "pipeline: p\narchive: study.h5\nstages:\n  - {name: plain, kind: laid_web, params: {fibres_across: 2, belt_travel: 0.01}}\n  - {name: touching, kind: laid_web, params: {fibres_across: 2, belt_travel: 0.01, fibre_contact: true, oscillation_ramp: 0.01}}\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n",
    );
    let out = run_in(tmp.path(), &["validate", p.to_str().unwrap(), "--max-cpu-time", "1d"]);
    let (stdout, err) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(stdout.contains("stage `plain` (laid_web): about "), "{stdout}");
    assert!(stdout.contains("stage `touching` (laid_web): at least "), "{stdout}");
    assert!(!stdout.contains("stage `s`"), "spectra makes no estimate: {stdout}");
}

#[test]
fn a_malformed_max_cpu_time_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(tmp.path(), "p.yaml", "pipeline: p\narchive: study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n");
    let out = run_in(tmp.path(), &["validate", p.to_str().unwrap(), "--max-cpu-time", "3 weeks"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("unknown unit `weeks`"), "{err}");
}

/// The explicit reference at a fine mesh: minutes a replicate, so 200 of them are refused
/// by a one-hour limit with the advice to use a projection integrator (`run --dry-run`:
/// were the refusal gone, nothing would be computed); the default scheme at the same mesh
/// passes. The fed start is an upper bound, a valid-replicate target a lower one, both
/// together neither; a sweep over both starts sums an estimate and an upper bound.
#[test]
fn a_laydown_estimated_above_max_cpu_time_is_refused_before_it_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(
        tmp.path(),
        "p.yaml",
        "pipeline: p\narchive: study.h5\nstages:\n  - {name: fast, kind: laydown, params: {elements: 2000}, replicates: 200}\n  - {name: fed, kind: laydown, params: {start: fed}}\n  - {name: reference, kind: laydown, params: {integrator: explicit, elements: 2000}, replicates: 200}\n",
    );
    for cmd in [&["validate"][..], &["run", "--dry-run"][..]] {
        let out = run_in(tmp.path(), &[cmd, &[p.to_str().unwrap(), "--max-cpu-time", "1h"]].concat());
        let (stdout, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{cmd:?}: {err}");
        assert!(err.contains("p.yaml:6:6: stages[2]: stage `reference` (laydown) is estimated at about "), "{cmd:?}: {err}");
        assert!(
            err.contains("; lower elements, coil_resolution or replicates, set mesh_error_estimate: false (its half-mesh run), use a projection integrator (the default trapezoidal_axial), or raise the limit"),
            "{cmd:?}: {err}"
        );
        assert!(!err.contains("`fast`") && !err.contains("`fed`"), "{cmd:?}: {err}");
        assert!(stdout.is_empty(), "{cmd:?} printed {stdout}");
    }
    assert!(!tmp.path().join("study.h5").exists(), "the refused run wrote an archive");
    let p = write_pipeline(
        tmp.path(),
        "bounds.yaml",
        "pipeline: p\narchive: study.h5\nstages:\n  - {name: fast, kind: laydown}\n  - {name: fed, kind: laydown, params: {start: fed}}\n  - {name: target, kind: laydown, params: {valid_replicates_target: 2}}\n  - {name: fed_target, kind: laydown, params: {start: fed, valid_replicates_target: 2}}\n  - {name: starts, kind: laydown, sweep: {start: [vertical, fed]}}\n",
    );
    let out = run_in(tmp.path(), &["validate", p.to_str().unwrap()]);
    let (stdout, err) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    for (stage, bound) in [("fast", "about"), ("fed", "at most"), ("target", "at least"), ("fed_target", "about"), ("starts", "at most")] {
        assert!(stdout.contains(&format!("stage `{stage}` (laydown): {bound} ")), "{stage}: {stdout}");
    }
}
