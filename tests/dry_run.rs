//! `laydown run --dry-run`: what would run and why (new, parameters changed, code
//! changed, upstream changed, up to date), computing and writing nothing.
mod common;
use common::*;
use laydown::archive::Archive;
use std::path::Path;

/// fibre (laydown) -> spectra, and an independent `ideal` spectra stage.
const PIPE: &str = "pipeline: dry\narchive: out/study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: 5.0e-05}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n  - name: ideal\n    kind: spectra\n    params: {preset: spectrum1}\n";

fn ok(dir: &Path, args: &[&str]) -> (String, String) {
    let out = run_in(dir, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "laydown {args:?}\nstdout: {o}\nstderr: {e}");
    (o, e)
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut out = vec![];
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_dry_run_of_a_new_pipeline_says_new_and_creates_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let (o, _) = ok(tmp.path(), &["run", "p.yaml", "--dry-run"]);
    // The absolute path the archive would have (its directory does not exist yet).
    let archive = tmp.path().canonicalize().unwrap().join("out/study.h5");
    assert_eq!(o.lines().next().unwrap(), format!("archive: {} (dry run: nothing is computed or written)", archive.display()), "{o}");
    assert!(o.contains("fibre: would run: new stage\n"), "{o}");
    assert!(o.contains("spectra: would run: new stage, input fibre would run first\n"), "{o}");
    assert!(o.contains("ideal: would run: new stage\n"), "{o}");
    assert!(!tmp.path().join("out").exists(), "a dry run creates no archive, directory or lock");
}

#[test]
fn a_dry_run_says_why_each_stage_would_run_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", PIPE);
    ok(d, &["run", "p.yaml"]);

    // Up to date.
    let before = snapshot(d);
    let (o, _) = ok(d, &["run", "p.yaml", "--dry-run"]);
    for s in ["fibre", "spectra", "ideal"] {
        assert!(o.contains(&format!("{s}: up to date (v1)\n")), "{o}");
    }
    // Parameters changed, and what depends on them.
    write_pipeline(d, "p.yaml", &PIPE.replace("diameter: 5.0e-05", "diameter: 4.0e-05").replace("spectrum1", "spectrum2"));
    let (o, _) = ok(d, &["run", "p.yaml", "--dry-run"]);
    assert!(o.contains("fibre: would run: params.diameter changed 5e-05 -> 4e-05\n"), "{o}");
    assert!(o.contains("spectra: would run: input fibre would run first (unless its results come out unchanged)\n"), "{o}");
    assert!(o.contains("ideal: would run: params.preset changed spectrum1 -> spectrum2\n"), "{o}");
    // --from: forced, and its downstream.
    write_pipeline(d, "p.yaml", PIPE);
    let (o, _) = ok(d, &["run", "p.yaml", "--dry-run", "--from", "fibre"]);
    assert!(o.contains("fibre: would run: forced (--from)\n") && o.contains("spectra: would run: input fibre would run first"), "{o}");
    assert!(o.contains("ideal: not selected, using v1\n"), "{o}");
    // Nothing computed or written by any of these.
    assert_eq!(snapshot(d), before, "a dry run must leave every file as it was");

    // Upstream changed: a newer fibre, written on its own, is current.
    ok(d, &["run", "p.yaml", "--only", "fibre", "--force", "fibre"]);
    let (o, _) = ok(d, &["run", "p.yaml", "--dry-run"]);
    assert!(o.contains("fibre: up to date (v2)\n") && o.contains("spectra: would run: input fibre v1 -> v2\n"), "{o}");

    // Code changed: the stored version was computed by other code of its kind.
    {
        let f = hdf5::File::open_rw(d.join("out/study.h5")).unwrap();
        let g = f.group("ideal/v1").unwrap();
        for (k, v) in [("code_hash", "0123456789abcdef"), ("fingerprint", "0123456789abcdef0123456789abcdef")] {
            g.delete_attr(k).unwrap();
            laydown::archive::hdf::write_str_attr(&g, k, v).unwrap();
        }
        drop(g);
        f.close().unwrap();
    }
    fresh_inode(&d.join("out/study.h5"));
    let before = snapshot(d);
    let (o, _) = ok(d, &["run", "p.yaml", "--dry-run"]);
    assert!(o.contains("ideal: would run: code of spectra changed\n"), "{o}");
    assert_eq!(snapshot(d), before);
    let a = Archive::open_read(&d.join("out/study.h5")).unwrap();
    assert_eq!(a.versions("ideal").unwrap().len(), 1);
}
