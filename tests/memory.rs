//! Memory estimates: a stage whose estimated peak exceeds the available memory (or
//! `--max-memory`) is refused by `validate` and `run` with exit 2 before anything is
//! computed; the refusals of the cases are in tests/bad_pipelines/ (32-34).
mod common;
use common::*;
use std::fs;

const SMALL: &str = "pipeline: small\narchive: study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n";

/// A web inside its documented range whose grid would need 60 GiB: the web, upstream,
/// is not computed and the archive does not gain it.
#[test]
fn a_grid_of_a_too_wide_web_is_refused_before_the_web_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let good = write_pipeline(tmp.path(), "good.yaml", SMALL);
    assert_eq!(run_in(tmp.path(), &["run", good.to_str().unwrap()]).status.code(), Some(0));
    let archive = tmp.path().join("study.h5");
    let before = fs::read(&archive).unwrap();
    let bad = write_pipeline(
        tmp.path(),
        "wide.yaml",
        "pipeline: wide\narchive: study.h5\nstages:\n  - {name: web, kind: web, params: {preset: spectrum1, fibres_across: 4000000000}}\n  - {name: grid, kind: grid, input: web}\n",
    );
    for cmd in ["validate", "run"] {
        let out = run_in(tmp.path(), &[cmd, bad.to_str().unwrap(), "--max-memory", "16GiB"]);
        let (stdout, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(err.contains("stages[0].params.fibres_across: stage `grid` (grid) needs more than the 16.0 GiB allowed by --max-memory: about 59.7 GiB"), "{cmd}: {err}");
        assert!(stdout.is_empty(), "{cmd} printed {stdout}");
    }
    assert_eq!(fs::read(&archive).unwrap(), before, "the archive changed");
    let (ls, _) = text(&run_in(tmp.path(), &["ls", "study.h5"]));
    assert!(!ls.contains("web"), "the web was committed:\n{ls}");
    assert!(!tmp.path().join("study.h5.partial").exists());
}

/// Without --max-memory the limit is the machine's available memory; 320 TiB exceeds
/// any machine.
#[test]
fn the_default_limit_is_the_available_memory() {
    let dir = repo_root().join("tests/bad_pipelines");
    let out = run_in(&dir, &["validate", "33_memory_web_preset_long_fibres.yaml"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    for part in ["available (MemAvailable; --max-memory overrides)", "about 320.1 TiB", "lower segments_per_fibre, points_per_segment"] {
        assert!(err.contains(part), "`{part}` missing in: {err}");
    }
}

#[test]
fn max_memory_refuses_a_small_pipeline_and_allows_it_when_large_enough() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(tmp.path(), "p.yaml", SMALL);
    for cmd in ["validate", "run"] {
        let out = run_in(tmp.path(), &[cmd, p.to_str().unwrap(), "--max-memory", "1KiB"]);
        let (stdout, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(err.contains("p.yaml:4:6: stages[0].replicates: stage `s` (spectra) needs more than the 1.0 KiB allowed by --max-memory: about 32.1 MiB at its peak"), "{cmd}: {err}");
        assert!(err.contains("lower replicates"), "{cmd}: {err}");
        assert!(stdout.is_empty(), "{cmd} printed {stdout}");
    }
    assert!(!tmp.path().join("study.h5").exists(), "a refused run wrote the archive");
    let out = run_in(tmp.path(), &["validate", p.to_str().unwrap(), "--max-memory", "1GiB"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
}

#[test]
fn a_malformed_max_memory_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(tmp.path(), "p.yaml", SMALL);
    for size in ["lots", "2 parsecs", "0"] {
        let out = run_in(tmp.path(), &["validate", p.to_str().unwrap(), "--max-memory", size]);
        let (stdout, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{size}: {err}");
        assert!(err.contains("--max-memory") && err.contains(size), "{size}: {err}");
        assert!(stdout.is_empty());
    }
}

/// Every stage kind that holds large buffers estimates them: with a limit of one byte
/// each stage of the quickstart (laydown, spectra, web, grid, image, laid_web) is refused.
#[test]
fn every_stage_kind_estimates_its_memory() {
    let out = run_in(&repo_root(), &["validate", "pipelines/quickstart.yaml", "--max-memory", "1"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    for kind in ["laydown", "spectra", "web", "grid", "image", "laid_web"] {
        assert!(err.contains(&format!("({kind}) needs more than the 1.0 B allowed by --max-memory")), "no estimate for {kind}:\n{err}");
    }
}

/// `laydown` with its address space limited to `bytes`: an allocation beyond it fails
/// as it would on a machine without that memory.
fn run_with_address_space(dir: &std::path::Path, bytes: u64, args: &[&str]) -> std::process::Output {
    use std::os::unix::process::CommandExt;
    let mut cmd = laydown();
    cmd.current_dir(dir).args(args);
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            let limit = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.output().expect("laydown runs")
}

/// Past the estimate (a generous --max-memory), a buffer that cannot be allocated is a
/// runtime error (exit 1) naming it, not an abort (exit 134), and nothing is committed.
#[test]
fn an_allocation_that_fails_is_an_error_not_an_abort() {
    let tmp = tempfile::tempdir().unwrap();
    let image = write_pipeline(
        tmp.path(),
        "image.yaml",
        "pipeline: big\narchive: image.h5\nstages:\n  - {name: scans, kind: image, params: {synthetic.kind: noise, synthetic.count: 1, synthetic.rows: 20000, synthetic.cols: 20000}}\n",
    );
    let out = run_with_address_space(tmp.path(), 4 << 30, &["run", image.to_str().unwrap(), "--max-memory", "1000TiB"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("stage `scans` failed") && err.contains("cannot allocate 6.0 GiB for a synthetic noise image's spectrum"), "{err}");
    assert!(!tmp.path().join("image.h5").exists() || !text(&run_in(tmp.path(), &["ls", "image.h5"])).0.contains("scans"));

    let wide = write_pipeline(
        tmp.path(),
        "wide.yaml",
        "pipeline: wide\narchive: wide.h5\nstages:\n  - {name: web, kind: web, params: {preset: spectrum1, fibres_across: 4000000000}}\n  - {name: grid, kind: grid, input: web, params: {edge_margin_spreads: 0}}\n",
    );
    let out = run_with_address_space(tmp.path(), 4 << 30, &["run", wide.to_str().unwrap(), "--max-memory", "1000TiB"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("stage `grid` failed") && err.contains("cannot allocate 59.6 GiB for the fibres' displacements"), "{err}");
    let (ls, _) = text(&run_in(tmp.path(), &["ls", "wide.h5"]));
    assert!(ls.contains("web") && !ls.contains("grid "), "{ls}");
}

/// The estimates are not so tight that normal work is refused: every shipped pipeline
/// fits in 2 GiB (the largest, an image sweep, is estimated at under 1 GiB).
#[test]
fn every_shipped_pipeline_fits_in_two_gib() {
    let mut files = vec![];
    let mut dirs = vec![repo_root().join("pipelines")];
    while let Some(d) = dirs.pop() {
        for e in fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "yaml") {
                files.push(p);
            }
        }
    }
    assert!(files.len() > 10);
    for f in files {
        let out = run_in(&repo_root(), &["validate", f.to_str().unwrap(), "--max-memory", "2GiB"]);
        assert_eq!(out.status.code(), Some(0), "{}: {}", f.display(), text(&out).1);
    }
}
