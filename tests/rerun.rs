//! Reruns: only stages whose fingerprint has no complete version run, each with a
//! stated reason; old versions stay readable; --only, --from, --force.
mod common;
use common::*;
use laydown::archive::Archive;
use std::fs;

const PIPE: &str = TWO_SPECTRA;

fn run(dir: &std::path::Path, args: &[&str]) -> String {
    let out = run_in(dir, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "laydown {args:?}\nstdout: {o}\nstderr: {e}");
    o
}

#[test]
fn unchanged_pipeline_is_up_to_date_and_touches_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: runs: new stage"), "{o}");
    assert!(o.contains("second: runs: new stage"), "{o}");
    let before = fs::read(tmp.path().join("study.h5")).unwrap();
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: up to date (v1)") && o.contains("second: up to date (v1)"), "{o}");
    assert_eq!(fs::read(tmp.path().join("study.h5")).unwrap(), before, "an up-to-date run must not rewrite the archive");
}

#[test]
fn changed_params_make_a_new_version_and_say_why() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    run(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000"));
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: runs: params.bending_energy changed 2500.0 -> 3000.0"), "{o}");
    assert!(o.contains("second: up to date (v1)"), "{o}");
    let archive = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    let versions = archive.versions("first").unwrap();
    assert_eq!(versions.len(), 2);
    // The old version is still complete and readable, with its own parameters.
    assert!(versions[0].attr_str("params_yaml").unwrap().contains("bending_energy: 2500.0"));
    let g = versions[0].open().unwrap();
    let e = laydown::archive::hdf::read_f64(&g, "bending_energy_from_spectrum").unwrap();
    assert!((e[[0, 0]] - 2500.0).abs() < 1e-6, "{e}");
    // Going back to the old parameters finds the old version again.
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("first: up to date (v1)"), "{o}");
    // Seed and replicates are part of the fingerprint too.
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("seed: 7", "seed: 8").replace("replicates: 2", "replicates: 3"));
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("replicates 2 -> 3") && o.contains("seed 7 -> 8"), "{o}");
}

#[test]
fn only_from_and_force_select_stages() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    run(tmp.path(), &["run", "p.yaml"]);
    let o = run(tmp.path(), &["run", "p.yaml", "--force", "second"]);
    assert!(o.contains("second: runs: forced (--force)") && o.contains("first: up to date (v1)"), "{o}");
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("bending_energy: 2500", "bending_energy: 3000").replace("spectrum2", "spectrum3"));
    let o = run(tmp.path(), &["run", "p.yaml", "--only", "second"]);
    assert!(o.contains("first: not selected, using v1"), "{o}");
    assert!(o.contains("second: runs: params.preset changed spectrum2 -> spectrum3"), "{o}");
    let o = run(tmp.path(), &["run", "p.yaml", "--from", "first"]);
    assert!(o.contains("first: runs: params.bending_energy changed 2500.0 -> 3000.0"), "{o}");
    assert!(o.contains("second: not selected, using v3"), "second is not downstream of first: {o}");
    let archive = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    assert_eq!(archive.versions("second").unwrap().len(), 3);
    // ls and show read every version.
    let o = run(tmp.path(), &["ls", "study.h5"]);
    assert_eq!(o.lines().filter(|l| l.starts_with("second")).count(), 3, "{o}");
    let o = run(tmp.path(), &["show", "study.h5", "second@v2", "--json"]);
    let doc: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!(doc["provenance"]["run_reason"], "forced (--force)");
    assert_eq!(doc["version"], 2);
}

#[test]
fn same_seed_gives_bit_identical_datasets_with_one_or_two_threads() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    for threads in [1, 2] {
        let out = run_in_with_threads(tmp.path(), threads, &["run", "p.yaml", "--archive", &format!("t{threads}.h5")]);
        assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    }
    let a = Archive::open_read(&tmp.path().join("t1.h5")).unwrap();
    let b = Archive::open_read(&tmp.path().join("t2.h5")).unwrap();
    for stage in ["first", "second"] {
        let va = a.version(stage, None).unwrap();
        let vb = b.version(stage, None).unwrap();
        assert_eq!(va.attrs.get("threads"), Some(&laydown::archive::data::Attr::I64(1)));
        assert_eq!(vb.attrs.get("threads"), Some(&laydown::archive::data::Attr::I64(2)));
        assert_eq!(va.attr_str("content_hash"), vb.attr_str("content_hash"), "{stage}");
        let ka = laydown::archive::hdf::read_f64(&va.open().unwrap(), "curvature").unwrap();
        let kb = laydown::archive::hdf::read_f64(&vb.open().unwrap(), "curvature").unwrap();
        assert!(ka.iter().zip(kb.iter()).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}

#[test]
fn changing_an_upstream_stage_reruns_downstream_with_the_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let chain = "pipeline: chain\narchive: study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: 5.0e-05}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n";
    write_pipeline(tmp.path(), "p.yaml", chain);
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("fibre: runs: new stage") && o.contains("spectra: runs: new stage"), "{o}");
    write_pipeline(tmp.path(), "p.yaml", &chain.replace("diameter: 5.0e-05", "diameter: 4.0e-05"));
    let o = run(tmp.path(), &["run", "p.yaml"]);
    assert!(o.contains("fibre: runs: params.diameter changed 5e-05 -> 4e-05"), "{o}");
    assert!(o.contains("spectra: runs: input fibre v1 -> v2"), "{o}");
    let o = run(tmp.path(), &["run", "p.yaml", "--only", "spectra", "--force", "spectra"]);
    assert!(o.contains("fibre: not selected, using v2") && o.contains("spectra: runs: forced (--force)"), "{o}");
}

#[test]
fn only_takes_several_stages_and_runs_them_in_pipeline_order() {
    let tmp = tempfile::tempdir().unwrap();
    let chain = "pipeline: chain\narchive: study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: 5.0e-05}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n  - name: other\n    kind: spectra\n    input: fibre\n";
    write_pipeline(tmp.path(), "p.yaml", chain);
    run(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &chain.replace("diameter: 5.0e-05", "diameter: 4.0e-05"));
    // named downstream first: still run upstream first, and the second on the first's new version
    let o = run(tmp.path(), &["run", "p.yaml", "--only", "spectra,fibre"]);
    assert!(o.contains("fibre: runs: params.diameter changed 5e-05 -> 4e-05"), "{o}");
    assert!(o.contains("spectra: runs: input fibre v1 -> v2"), "{o}");
    assert!(o.contains("other: not selected, using v1 (out of date"), "{o}");
    assert!(o.find("fibre: runs").unwrap() < o.find("spectra: runs").unwrap(), "{o}");
    // repeated flags select the same way
    let o = run(tmp.path(), &["run", "p.yaml", "--only", "other", "--only", "spectra"]);
    assert!(o.contains("other: runs: input fibre v1 -> v2") && o.contains("spectra: up to date (v2)"), "{o}");
    // a name that is not a stage is refused before anything runs
    let out = run_in(tmp.path(), &["run", "p.yaml", "--only", "spectra,fibres"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(e.contains("no stage named `fibres`; allowed: fibre, spectra, other"), "{e}");
}
