//! The archive's on-disk format: versions committed atomically, `current`, history,
//! dimension scales, attributes readable back, the run lock.
use laydown::archive::data::{Attr, Output};
use laydown::archive::{hdf, Archive};
use ndarray::{Array1, Array2};
use std::collections::BTreeMap;

pub fn sample_output() -> Output {
    let mut out = Output::new();
    out.coord("node", (0..5).map(|i| i as f64 * 0.25).collect(), "m", "arc length of node");
    out.f64("positions", &["node", "xyz"], Array2::from_shape_fn((5, 3), |(i, j)| (i * 3 + j) as f64), "m", "node positions");
    out.flags("valid", &["replicate"], Array1::from(vec![true, false]), "replicate is valid");
    out.strings("invalid_reason", "replicate", vec!["".into(), "bounced".into()], "why a replicate is invalid");
    out.i64("steps", &["replicate"], Array1::from(vec![10i64, 12]), "1", "time steps taken");
    out
}

pub fn complete() -> BTreeMap<String, Attr> {
    let mut attrs = BTreeMap::new();
    attrs.insert("status".to_string(), Attr::Str("complete".into()));
    attrs.insert("wall_seconds".to_string(), Attr::F64(1.5));
    attrs
}

#[test]
fn versions_current_history_and_attributes_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.h5");
    let archive = Archive::open_write(&path).unwrap();
    let n1 = archive.commit_version("t", "fibre", &sample_output(), &complete(), "line one").unwrap();
    let n2 = archive.commit_version("t", "fibre", &sample_output(), &complete(), "line two").unwrap();
    assert_eq!((n1, n2), (1, 2));

    // A second writer fails fast while the first holds the lock.
    let err = Archive::open_write(&path).err().expect("lock must be exclusive").to_string();
    assert!(err.contains("in use by another"), "{err}");

    let f = hdf5::File::open(&path).unwrap();
    let root = hdf::read_attrs(&f).unwrap();
    assert_eq!(root.get("history"), Some(&Attr::Str("line one\nline two".into())));
    assert_eq!(root.get("layout_version"), Some(&Attr::I64(2)));
    // A committed version is current; no soft link duplicates it.
    let stage = f.group("fibre").unwrap();
    assert_eq!(hdf::read_attrs(&stage).unwrap().get("current"), Some(&Attr::Str("v2".into())));
    assert!(!stage.link_exists("latest"));
    assert_eq!(archive.current("fibre").unwrap(), Some(2));
    let pos = hdf::read_f64(&f.group("fibre/v1").unwrap(), "positions").unwrap();
    assert_eq!(pos.shape(), &[5, 3]);
    assert_eq!(pos[[4, 2]], 14.0);
    let reasons = hdf::read_strings(&f.group("fibre/v2").unwrap(), "invalid_reason").unwrap();
    assert_eq!(reasons, vec!["".to_string(), "bounced".to_string()]);
    let versions = archive.versions("fibre").unwrap();
    assert_eq!(versions.len(), 2);
    assert!(versions[1].is_complete());
}

#[test]
fn stale_partial_copy_is_removed_and_archive_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.h5");
    {
        let archive = Archive::open_write(&path).unwrap();
        archive.commit_version("t", "fibre", &sample_output(), &complete(), "h").unwrap();
    }
    let before = std::fs::read(&path).unwrap();
    // A killed run leaves its half-written copy behind.
    let partial = dir.path().join("study.h5.partial");
    std::fs::write(&partial, b"half written").unwrap();
    let archive = Archive::open_write(&path).unwrap();
    assert!(!partial.exists(), "stale partial copy must be removed");
    assert_eq!(archive.versions("fibre").unwrap().len(), 1);
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn dataset_hashes_read_back_from_the_file_for_every_value_type() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.h5");
    let archive = Archive::open_write(&path).unwrap();
    let out = sample_output();
    let hashes = hdf::dataset_hashes(&out);
    // Floats, flags, strings, integers, a coordinate and the index coordinates `xyz` and `replicate`.
    let names: Vec<&str> = hashes.keys().map(String::as_str).collect();
    assert_eq!(names, ["invalid_reason", "node", "positions", "replicate", "steps", "valid", "xyz"]);
    let mut attrs = complete();
    attrs.insert("dataset_hashes".into(), Attr::Str(hdf::dataset_hashes_attr(&hashes)));
    attrs.insert("content_hash".into(), Attr::Str(hdf::content_hash(&out)));
    archive.commit_version("t", "fibre", &out, &attrs, "h").unwrap();
    let v = archive.version("fibre", Some(1)).unwrap();
    let g = v.open().unwrap();
    for (name, hash) in &hashes {
        assert_eq!(&hdf::read_dataset_hash(&g.dataset(name).unwrap()).unwrap(), hash, "{name}");
    }
    assert_eq!(v.verify(), laydown::archive::Integrity::Ok);
    // A changed stored hash list no longer matches content_hash.
    let mut wrong = hashes.clone();
    wrong.insert("steps".into(), "0".repeat(32));
    attrs.insert("dataset_hashes".into(), Attr::Str(hdf::dataset_hashes_attr(&wrong)));
    archive.commit_version("t", "fibre", &out, &attrs, "h").unwrap();
    let laydown::archive::Integrity::Damaged(problems) = archive.version("fibre", Some(2)).unwrap().verify() else { panic!("not damaged") };
    assert_eq!(problems, ["attribute `dataset_hashes` does not match `content_hash`", "dataset `steps` differs from its stored hash"]);
    // Versions without dataset hashes (older laydown) cannot be checked, and say so.
    archive.commit_version("t", "old", &out, &complete(), "h").unwrap();
    assert_eq!(archive.version("old", None).unwrap().verify(), laydown::archive::Integrity::Unverifiable);
}

#[test]
fn a_failed_commit_removes_the_partial_copy_and_keeps_the_archive() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.h5");
    let archive = Archive::open_write(&path).unwrap();
    archive.commit_version("t", "fibre", &sample_output(), &complete(), "h").unwrap();
    let before = std::fs::read(&path).unwrap();
    // Variables that disagree on a dimension's length cannot be written.
    let mut bad = sample_output();
    bad.f64("other", &["node"], Array1::from(vec![1.0, 2.0]), "m", "too short");
    let err = archive.commit_version("t", "fibre", &bad, &complete(), "h").unwrap_err().to_string();
    assert!(err.starts_with(&format!("archive {}: committing failed, the archive is unchanged: ", archive.path.display())), "{err}");
    assert!(err.contains("dimension `node`") && !err.contains('\n'), "{err}");
    assert!(!dir.path().join("study.h5.partial").exists(), ".partial left behind");
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn current_marks_move_only_inside_commits() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.h5");
    let archive = Archive::open_write(&path).unwrap();
    for _ in 0..2 {
        archive.commit_version("t", "fibre", &sample_output(), &complete(), "h").unwrap();
    }
    archive.commit_version("t", "web", &sample_output(), &complete(), "h").unwrap();
    archive.mark_current("t", &BTreeMap::from([("fibre".to_string(), 1)]), "back to v1").unwrap();
    assert_eq!(archive.current("fibre").unwrap(), Some(1));
    assert_eq!(archive.version("fibre", None).unwrap().number, 1);
    // A mark travels with the next version written, in the same commit.
    let marks = BTreeMap::from([("fibre".to_string(), 2)]);
    archive.commit_version_marking("t", "web", &sample_output(), &complete(), &marks, "h").unwrap();
    assert_eq!(archive.current_marks().unwrap(), BTreeMap::from([("fibre".to_string(), 2), ("web".to_string(), 2)]));
    // A version that does not exist is never marked.
    let before = std::fs::read(&path).unwrap();
    let err = archive.mark_current("t", &BTreeMap::from([("fibre".to_string(), 9)]), "h").unwrap_err().to_string();
    assert!(err.ends_with("cannot mark /fibre/v9 current: there is no such version"), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
}
