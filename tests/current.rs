//! Current versions (issue 19): the pipeline's last run marks, per stage, the version it
//! matched or wrote (`current` on `/<stage>`); `ls`, `show`, `table` and `plot` use it;
//! a stale upstream under `--only` is a warning saying why; `--from` forces its stage.
mod common;
use common::*;
use laydown::archive::data::Attr;
use laydown::archive::{hdf, Archive};

const PIPE: &str = TWO_SPECTRA;

/// A laydown feeding a spectra stage: a real dependency.
const CHAIN: &str = "pipeline: chain\narchive: study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: 5.0e-05}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n";

fn ok(dir: &std::path::Path, args: &[&str]) -> (String, String) {
    let out = run_in(dir, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "laydown {args:?}\nstdout: {o}\nstderr: {e}");
    (o, e)
}

fn current_attr(archive: &std::path::Path, stage: &str) -> Option<Attr> {
    let f = hdf5::File::open(archive).unwrap();
    hdf::read_attrs(&f.group(stage).unwrap()).unwrap().remove("current")
}

#[test]
fn changing_a_parameter_back_makes_the_old_version_current_everywhere() {
    let tmp = tempfile::tempdir().unwrap();
    let archive = tmp.path().join("study.h5");
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    assert_eq!(current_attr(&archive, "first"), Some(Attr::Str("v1".into())));
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000"));
    ok(tmp.path(), &["run", "p.yaml"]);
    assert_eq!(current_attr(&archive, "first"), Some(Attr::Str("v2".into())));
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let (o, _) = ok(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: up to date (v1), now current (was v2)"), "{o}");
    assert!(o.contains("second: up to date (v1)\n"), "an unmoved mark says nothing more: {o}");

    // The archive says so, in the same attribute h5py and xarray users read; no `latest`.
    assert_eq!(current_attr(&archive, "first"), Some(Attr::Str("v1".into())));
    let f = hdf5::File::open(&archive).unwrap();
    assert!(!f.group("first").unwrap().link_exists("latest"));
    assert_eq!(hdf::read_attrs(&f).unwrap().get("layout_version"), Some(&Attr::I64(2)));
    let history = match hdf::read_attrs(&f).unwrap().remove("history") {
        Some(Attr::Str(h)) => h,
        other => panic!("{other:?}"),
    };
    assert!(history.lines().last().unwrap().ends_with("laydown run p.yaml: current first v1"), "{history}");
    drop(f);
    let a = Archive::open_read(&archive).unwrap();
    assert_eq!(a.current("first").unwrap(), Some(1));
    assert_eq!(a.version("first", None).unwrap().number, 1, "a stage without @vN means its current version");

    // ls marks it, show and table use it.
    let (o, _) = ok(tmp.path(), &["ls", "study.h5"]);
    let line = |v: &str| o.lines().find(|l| l.starts_with("first") && l.contains(v)).unwrap().to_string();
    assert!(line("v1").contains("v1*") && !line("v2").contains("v2*"), "{o}");
    assert!(o.contains("* current: the version the pipeline's last run matched or wrote"), "{o}");
    let (o, _) = ok(tmp.path(), &["show", "study.h5", "first", "--json"]);
    let doc: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!((doc["version"].as_u64(), doc["current"].as_bool()), (Some(1), Some(true)));
    let (o, _) = ok(tmp.path(), &["show", "study.h5", "first@v2"]);
    assert!(o.lines().next().unwrap().contains("not current: the pipeline's last run used v1"), "{o}");
    let (o, _) = ok(tmp.path(), &["table", "study.h5", "first", "--format", "json"]);
    assert!(o.contains("2500") && !o.contains("3000"), "table must read v1: {o}");

    // A run that matches every current version leaves the file untouched.
    let before = std::fs::read(&archive).unwrap();
    let (o, _) = ok(tmp.path(), &["run", "p.yaml"]);
    assert!(!o.contains("now current"), "{o}");
    assert_eq!(std::fs::read(&archive).unwrap(), before);
}

#[test]
fn plot_without_stages_draws_the_current_versions() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000"));
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    let (o, _) = ok(tmp.path(), &["plot", "study.h5"]);
    assert!(o.contains("study_figures/first/v1/") && !o.contains("first/v2"), "{o}");
}

#[test]
fn a_stale_upstream_under_only_is_a_warning_saying_why() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &CHAIN.replace("diameter: 5.0e-05", "diameter: 4.0e-05"));
    let (o, e) = ok(tmp.path(), &["run", "p.yaml", "--only", "spectra", "--force", "spectra"]);
    assert!(o.contains("fibre: not selected, using v1 (out of date: params.diameter changed 5e-05 -> 4e-05)"), "{o}");
    assert!(
        e.contains("warning: spectra uses fibre v1, which is out of date (params.diameter changed 5e-05 -> 4e-05); `laydown run p.yaml` brings both up to date"),
        "{e}"
    );
    // The stale upstream keeps its mark; the stage that ran is current.
    let a = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    assert_eq!((a.current("fibre").unwrap(), a.current("spectra").unwrap()), (Some(1), Some(2)));
    // Up to date upstream: no warning.
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    let (_, e) = ok(tmp.path(), &["run", "p.yaml", "--only", "spectra"]);
    assert!(!e.contains("warning"), "{e}");
}

#[test]
fn from_forces_its_stage_and_runs_what_depends_on_it() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    ok(tmp.path(), &["run", "p.yaml"]);
    let (o, _) = ok(tmp.path(), &["run", "p.yaml", "--from", "fibre"]);
    assert!(o.contains("fibre: runs: forced (--from)") && o.contains("fibre: wrote v2"), "{o}");
    // The laydown stores wall times, so its new content differs and spectra reruns.
    assert!(o.contains("spectra: runs: input fibre v1 -> v2") && o.contains("spectra: wrote v2"), "{o}");
    let (o, _) = ok(tmp.path(), &["run", "p.yaml", "--from", "spectra"]);
    assert!(o.contains("fibre: not selected, using v2\n") && o.contains("spectra: runs: forced (--from)"), "{o}");
}

#[test]
fn an_archive_without_marks_reads_its_newest_versions_and_loses_latest_on_the_next_commit() {
    let tmp = tempfile::tempdir().unwrap();
    let archive = tmp.path().join("study.h5");
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000"));
    ok(tmp.path(), &["run", "p.yaml"]);
    // Make it look like layout 1: `latest` soft links, no marks.
    {
        let f = hdf5::File::open_rw(&archive).unwrap();
        for (stage, n) in [("first", 2), ("second", 1)] {
            let g = f.group(stage).unwrap();
            g.delete_attr("current").unwrap();
            g.link_soft(&format!("/{stage}/v{n}"), "latest").unwrap();
        }
        f.close().unwrap();
    }
    fresh_inode(&archive);
    let a = Archive::open_read(&archive).unwrap();
    assert_eq!(a.current("first").map_err(|e| format!("{e:#}")), Ok(None));
    assert_eq!(a.version("first", None).unwrap().number, 2, "no mark: the newest");
    let (o, _) = ok(tmp.path(), &["ls", "study.h5"]);
    assert!(!o.contains('*'), "{o}");
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let (o, _) = ok(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: up to date (v1), now current\n") && o.contains("second: up to date (v1), now current\n"), "{o}");
    let f = hdf5::File::open(&archive).unwrap();
    for stage in ["first", "second"] {
        assert!(!f.group(stage).unwrap().link_exists("latest"), "{stage}");
    }
    assert_eq!(current_attr(&archive, "first"), Some(Attr::Str("v1".into())));
    assert_eq!(current_attr(&archive, "second"), Some(Attr::Str("v1".into())));
}

#[test]
fn a_run_that_fails_later_still_marks_what_it_matched() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000"));
    ok(tmp.path(), &["run", "p.yaml"]);
    // Back to v1's parameters, plus a stage that passes validation and fails to decode its file.
    std::fs::write(tmp.path().join("bad.png"), b"not a png").unwrap();
    write_pipeline(tmp.path(), "p.yaml", &format!("{PIPE}  - name: scans\n    kind: image\n    params: {{files: [bad.png], dpi: 75}}\n"));
    let out = run_in(tmp.path(), &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_ne!(out.status.code(), Some(0), "{o}\n{e}");
    assert!(o.contains("first: up to date (v1), now current (was v2)"), "{o}");
    assert!(e.contains("bad.png"), "{e}");
    let a = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    assert_eq!(a.current("first").unwrap(), Some(1));
    assert!(a.versions("scans").unwrap().is_empty());
}

#[test]
fn a_matching_current_version_keeps_its_mark() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    ok(tmp.path(), &["run", "p.yaml"]);
    // v2 has the same fingerprint as v1; v1 is current.
    ok(tmp.path(), &["run", "p.yaml", "--force", "first"]);
    let archive = tmp.path().join("study.h5");
    Archive::open_write(&archive).unwrap().mark_current("t", &std::collections::BTreeMap::from([("first".to_string(), 1)]), "h").unwrap();
    fresh_inode(&archive);
    let (o, _) = ok(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: up to date (v1)\n"), "{o}");
}
