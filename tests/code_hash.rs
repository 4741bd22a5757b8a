//! Stale results are never "up to date": the hash of the code that computes each stage
//! kind (taken at build time) is part of its fingerprint, and a version computed by other
//! code reruns with the reason `code of KIND changed`.
mod common;
use common::*;
use laydown::archive::data::Attr;
use laydown::archive::hdf;
use laydown::code_hash::{code_files, code_hash, COMMON_CODE, STAGE_CODE};

#[test]
fn every_kind_has_its_code_hashed_at_build_time() {
    let root = repo_root();
    for stage in laydown::stages::registry() {
        let kind = stage.kind();
        let (_, paths) = STAGE_CODE.iter().find(|(k, _)| *k == kind).unwrap_or_else(|| panic!("{kind} missing from STAGE_CODE"));
        let all: Vec<&str> = paths.iter().chain(COMMON_CODE).copied().collect();
        for p in &all {
            assert!(!code_files(&root, p).is_empty(), "{kind}: {p} holds no Rust file (renamed?)");
        }
        // What build.rs embedded is the hash of the sources this test was built from.
        assert_eq!(laydown::stages::code_hash(kind), code_hash(&root, &all), "{kind}");
    }
    assert_ne!(laydown::stages::code_hash("spectra"), laydown::stages::code_hash("grid"));
}

#[test]
fn the_hash_follows_the_code_and_ignores_tests() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::create_dir_all(root.join("src/stages/x/sub")).unwrap();
    std::fs::write(root.join("src/stages/x/mod.rs"), "fn a() {}\n").unwrap();
    std::fs::write(root.join("src/stages/x/sub/deep.rs"), "fn b() {}\n").unwrap();
    std::fs::write(root.join("src/stages/x/tests.rs"), "#[test] fn t() {}\n").unwrap();
    std::fs::write(root.join("src/stages/x/energy_tests.rs"), "#[test] fn e() {}\n").unwrap();
    std::fs::write(root.join("src/other.rs"), "fn c() {}\n").unwrap();
    let h = || code_hash(root, &["src/stages/x"]);
    let before = h();
    std::fs::write(root.join("src/stages/x/tests.rs"), "#[test] fn t2() {}\n").unwrap();
    std::fs::write(root.join("src/stages/x/energy_tests.rs"), "#[test] fn e2() {}\n").unwrap();
    std::fs::write(root.join("src/other.rs"), "fn c2() {}\n").unwrap();
    assert_eq!(h(), before, "tests and code outside the stage do not count");
    std::fs::write(root.join("src/stages/x/sub/deep.rs"), "fn b() { 1; }\n").unwrap();
    assert_ne!(h(), before, "a change in a nested file counts");
}

#[test]
fn a_version_from_other_code_reruns_and_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(
        d,
        "p.yaml",
        "pipeline: code\narchive: study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n  - {name: u, kind: spectra, params: {preset: spectrum2}}\n  - {name: old, kind: spectra, params: {preset: spectrum3}}\n",
    );
    assert_eq!(run_in(d, &["run", "p.yaml"]).status.code(), Some(0));
    // Make /s/v1 look computed by other spectra code, and /old/v1 by a laydown without code hashes.
    {
        let f = hdf5::File::open_rw(d.join("study.h5")).unwrap();
        let s = f.group("/s/v1").unwrap();
        for (k, v) in [("code_hash", "0123456789abcdef0123456789abcdef"), ("fingerprint", "from-older-code")] {
            s.delete_attr(k).unwrap();
            hdf::write_attr(&s, k, &Attr::Str(v.into())).unwrap();
        }
        let old = f.group("/old/v1").unwrap();
        old.delete_attr("code_hash").unwrap();
        old.delete_attr("fingerprint").unwrap();
        hdf::write_attr(&old, "fingerprint", &Attr::Str("from-older-laydown".into())).unwrap();
    }
    let out = run_in(d, &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{o}{e}");
    assert!(o.contains("s: runs: code of spectra changed\n"), "{o}");
    assert!(o.contains("u: up to date (v1)"), "{o}");
    assert!(o.contains("old: runs: code of spectra changed (v1 has no code hash: written by an older laydown)"), "{o}");
    let out = run_in(d, &["run", "p.yaml"]);
    assert!(text(&out).0.contains("s: up to date (v2)"), "{:?}", text(&out));
}
