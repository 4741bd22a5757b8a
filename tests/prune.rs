//! `laydown prune ARCHIVE [--keep N] [--dry-run] [--repack]`: removes versions that are
//! not current, never a current version nor one a kept version was computed from, in one
//! atomic commit; `--repack` gives the space back.
mod common;
use common::*;
use serde_json::Value;
use std::path::Path;

/// fibre (laydown) -> spectra. `DIAMETER` and `SEED` are replaced per step.
const PIPE: &str = "pipeline: prune\narchive: out/study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: DIAMETER}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n    seed: SEED\n";

fn pipe(d: &Path, diameter: &str, seed: u32) {
    write_pipeline(d, "p.yaml", &PIPE.replace("DIAMETER", diameter).replace("SEED", &seed.to_string()));
}

fn ok(d: &Path, args: &[&str]) -> String {
    let out = run_in(d, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "laydown {args:?}\nstdout: {o}\nstderr: {e}");
    o
}

/// `stage -> [versions]` from `ls --json`, and the current ones.
fn versions(d: &Path) -> (Vec<(String, Vec<u64>)>, Vec<(String, u64)>) {
    let doc: Value = serde_json::from_str(&ok(d, &["ls", "out/study.h5", "--json"])).unwrap();
    let mut all = vec![];
    let mut current = vec![];
    for s in doc["stages"].as_array().unwrap() {
        let name = s["name"].as_str().unwrap().to_string();
        all.push((name.clone(), s["versions"].as_array().unwrap().iter().map(|v| v["version"].as_u64().unwrap()).collect()));
        current.push((name, s["current"].as_u64().unwrap()));
    }
    (all, current)
}

fn v(list: &[(&str, &[u64])]) -> Vec<(String, Vec<u64>)> {
    list.iter().map(|(s, n)| (s.to_string(), n.to_vec())).collect()
}

/// Builds: fibre v1, v2 (v2 current); spectra v1, v2, v3, with current spectra v2
/// computed from fibre v1 (non-current, so protected), spectra v1 and v3 prunable.
fn study(d: &Path) {
    pipe(d, "5.0e-05", 1);
    ok(d, &["run", "p.yaml"]); // fibre v1, spectra v1
    pipe(d, "5.0e-05", 2);
    ok(d, &["run", "p.yaml"]); // spectra v2 <- fibre v1
    pipe(d, "4.0e-05", 2);
    ok(d, &["run", "p.yaml"]); // fibre v2, spectra v3 <- fibre v2
    pipe(d, "5.0e-05", 2);
    let o = ok(d, &["run", "p.yaml"]); // back: fibre v1, spectra v2 current
    assert!(o.contains("spectra: up to date (v2)"), "{o}");
    // fibre v2 current; spectra has no version for (fibre v2, seed 3): v2 stays current
    pipe(d, "4.0e-05", 3);
    let o = ok(d, &["run", "p.yaml", "--only", "fibre"]);
    assert!(o.contains("fibre: up to date (v2)"), "{o}");
    assert_eq!(versions(d), (v(&[("fibre", &[1, 2]), ("spectra", &[1, 2, 3])]), vec![("fibre".into(), 2), ("spectra".into(), 2)]));
}

#[test]
fn prune_keeps_current_versions_and_their_inputs_and_removes_the_rest_atomically() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    study(d);
    let archive = d.join("out/study.h5");
    let before = std::fs::read(&archive).unwrap();
    let table_before = ok(d, &["table", "out/study.h5", "spectra"]);

    // Dry run: says what it would remove, changes nothing.
    let o = ok(d, &["prune", "out/study.h5", "--dry-run"]);
    assert!(o.contains("would remove /spectra/v1\n") && o.contains("would remove /spectra/v3\n"), "{o}");
    assert!(!o.contains("remove /fibre"), "fibre v1 is the input of the current spectra v2: {o}");
    assert!(o.contains("keep /fibre: v1 (input of /spectra/v2), v2 (current)"), "{o}");
    assert!(o.contains("dry run: 2 versions would be removed"), "{o}");
    assert_eq!(std::fs::read(&archive).unwrap(), before, "a dry run writes nothing");

    // --keep 1: the newest non-current spectra (v3) stays, and so does its input.
    let o = ok(d, &["prune", "out/study.h5", "--keep", "1"]);
    assert!(o.contains("removed /spectra/v1\n") && !o.contains("/spectra/v3\n"), "{o}");
    assert!(o.contains("removed 1 version from") && o.contains("--repack"), "{o}");
    assert_eq!(versions(d).0, v(&[("fibre", &[1, 2]), ("spectra", &[2, 3])]));

    // Default --keep 0; the figures of removed versions go with them, the kept ones' stay.
    ok(d, &["plot", "out/study.h5", "spectra@v3", "spectra@v2"]);
    let figures = |n: u32| d.join(format!("out/study_figures/spectra/v{n}"));
    assert!(figures(3).is_dir() && figures(2).is_dir());
    let o = ok(d, &["prune", "out/study.h5"]);
    assert!(o.contains("removed /spectra/v3\n"), "{o}");
    assert!(!figures(3).exists() && figures(2).is_dir(), "figures of the removed v3 left, or of the kept v2 removed");
    assert_eq!(versions(d), (v(&[("fibre", &[1, 2]), ("spectra", &[2])]), vec![("fibre".into(), 2), ("spectra".into(), 2)]));
    // Nothing left to prune.
    let o = ok(d, &["prune", "out/study.h5"]);
    assert!(o.contains("removed 0 versions"), "{o}");
    // What is kept is whole: verified, same table, history says what went.
    let o = ok(d, &["verify", "out/study.h5"]);
    assert_eq!(o.lines().filter(|l| l.starts_with("ok ")).count(), 3, "{o}");
    assert_eq!(ok(d, &["table", "out/study.h5", "spectra"]), table_before);
    let show: Value = serde_json::from_str(&ok(d, &["show", "out/study.h5", "spectra@v2", "--json"])).unwrap();
    assert!(show["provenance"]["inputs"].as_str().unwrap().starts_with("/fibre/v1 "));
    let h5 = hdf5::File::open(&archive).unwrap();
    let history = match laydown::archive::hdf::read_attrs(&h5).unwrap().remove("history") {
        Some(laydown::archive::data::Attr::Str(h)) => h,
        other => panic!("{other:?}"),
    };
    drop(h5);
    assert!(history.contains("laydown prune: removed /spectra/v1") && history.contains("laydown prune: removed /spectra/v3"), "{history}");
    assert!(!d.join("out/study.h5.partial").exists());

    // A number is never reused: the rerun of the removed spectra v3 becomes v4.
    fresh_inode(&archive);
    let o = ok(d, &["run", "p.yaml"]);
    assert!(o.contains("spectra: runs:") && o.contains("spectra: wrote v4"), "{o}");
}

#[test]
fn repack_gives_the_space_back_and_keeps_every_dataset_and_dimension() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    study(d);
    let archive = d.join("out/study.h5");
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    let table = ok(d, &["table", "out/study.h5", "fibre", "--all"]);
    let shown = ok(d, &["show", "out/study.h5", "spectra", "--json"]);
    let dims = |p: &Path| {
        let f = hdf5::File::open(p).unwrap();
        let g = f.group("/spectra/v2").unwrap();
        laydown::archive::hdf::dimension_names(&g).unwrap()
    };
    let dims_before = dims(&archive);
    assert!(!dims_before.is_empty());

    let full = size(&archive);
    ok(d, &["prune", "out/study.h5"]);
    let pruned = size(&archive);
    assert!(pruned >= full * 9 / 10, "HDF5 keeps the space of unlinked groups: {full} -> {pruned}");
    let o = ok(d, &["prune", "out/study.h5", "--repack"]);
    assert!(o.contains("removed 0 versions; repacked"), "{o}");
    let repacked = size(&archive);
    assert!(repacked < pruned * 8 / 10, "the removed versions' space is given back: {pruned} -> {repacked}");
    // Everything kept reads back the same, hashes check out, dimension scales survive.
    let o = ok(d, &["verify", "out/study.h5"]);
    assert!(!o.contains("DAMAGED") && o.lines().filter(|l| l.starts_with("ok ")).count() == 3, "{o}");
    assert_eq!(ok(d, &["table", "out/study.h5", "fibre", "--all"]), table);
    let mut a: Value = serde_json::from_str(&shown).unwrap();
    let mut b: Value = serde_json::from_str(&ok(d, &["show", "out/study.h5", "spectra", "--json"])).unwrap();
    a["provenance"].as_object_mut().unwrap().remove("history");
    b["provenance"].as_object_mut().unwrap().remove("history");
    assert_eq!(a, b);
    assert_eq!(dims(&archive), dims_before);
    // Still an archive runs continue on: up to date, marks kept.
    fresh_inode(&archive);
    let o = ok(d, &["run", "p.yaml", "--only", "fibre"]);
    assert!(o.contains("fibre: up to date (v2)"), "{o}");

    // Prune and repack in one command.
    pipe(d, "6.0e-05", 2);
    ok(d, &["run", "p.yaml"]);
    pipe(d, "4.0e-05", 2);
    ok(d, &["run", "p.yaml"]);
    let o = ok(d, &["prune", "out/study.h5", "--repack"]);
    assert!(o.contains("removed /fibre/v3") && o.contains("repacked"), "{o}");
    assert!(!d.join("out/study.h5.partial").exists());
}

#[test]
fn prune_of_a_missing_archive_is_bad_input_and_a_locked_one_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let out = run_in(d, &["prune", "nothing.h5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty() && text(&out).1.contains("does not exist"), "{:?}", text(&out));

    study(d);
    let archive = d.join("out/study.h5");
    let before = std::fs::read(&archive).unwrap();
    // Another process holds the run lock: prune fails at once and changes nothing.
    let lock = std::fs::OpenOptions::new().write(true).create(true).truncate(false).open(d.join("out/study.h5.lock")).unwrap();
    lock.try_lock().unwrap();
    let out = run_in(d, &["prune", "out/study.h5"]);
    assert_eq!(out.status.code(), Some(1), "{:?}", text(&out));
    assert!(out.stdout.is_empty() && text(&out).1.contains("in use"), "{:?}", text(&out));
    drop(lock);
    assert_eq!(std::fs::read(&archive).unwrap(), before);
}
