//! The bad-pipeline corpus: every file in tests/bad_pipelines/ must be rejected with
//! exit code 2 and the message in its `# expect:` line (file, line, column, key path,
//! what is allowed), by `validate` and by `run`, leaving an existing archive
//! byte-identical. A case marked `# run: skipped` is checked by `validate` only (its
//! subject, the `archive:` path, is replaced by `run --archive`). A case with an
//! `# args: --max-memory 16GiB (why)` line is checked with those arguments (the words
//! before the parenthesis), so a memory refusal reads the same on any machine. A case
//! with an `# errors: N (why)` line must print exactly N `error:` lines (by `validate`).
mod common;
use common::*;
use std::fs;

/// (file name, expected message, extra arguments) of every case.
fn corpus() -> Vec<(String, String, Vec<String>)> {
    let dir = repo_root().join("tests/bad_pipelines");
    let mut cases: Vec<(String, String, Vec<String>)> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.ends_with(".yaml"))
        .map(|n| {
            let text = fs::read_to_string(dir.join(&n)).unwrap();
            let expect = text
                .lines()
                .next()
                .and_then(|l| l.strip_prefix("# expect: "))
                .unwrap_or_else(|| panic!("{n}: first line must be `# expect: ...`"))
                .to_string();
            let args = text
                .lines()
                .find_map(|l| l.strip_prefix("# args: "))
                .map(|a| a.split(" (").next().unwrap().split_whitespace().map(str::to_string).collect())
                .unwrap_or_default();
            (n, expect, args)
        })
        .collect();
    cases.sort();
    cases
}

#[test]
fn corpus_is_large_enough() {
    assert!(corpus().len() >= 15, "keep at least 15 bad pipelines");
}

#[test]
fn validate_rejects_each_with_its_message() {
    let dir = repo_root().join("tests/bad_pipelines");
    let mut failures = vec![];
    for (name, expect, args) in corpus() {
        let mut cmd = vec!["validate", name.as_str()];
        cmd.extend(args.iter().map(String::as_str));
        let out = run_in(&dir, &cmd);
        let (_, err) = text(&out);
        if out.status.code() != Some(2) || !err.contains(&expect) {
            failures.push(format!("{name}: exit {:?}\n  expected: {expect}\n  got: {err}", out.status.code()));
        }
        let count = fs::read_to_string(dir.join(&name)).unwrap().lines().find_map(|l| l.strip_prefix("# errors: ").map(|n| n.split(' ').next().unwrap().parse::<usize>().unwrap()));
        let lines = err.lines().filter(|l| l.starts_with("error: ")).count();
        if count.is_some_and(|n| n != lines) {
            failures.push(format!("{name}: expected {count:?} error lines, got {lines}:\n{err}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn run_rejects_each_and_leaves_the_archive_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    // A real archive with one version in it.
    let good = write_pipeline(
        tmp.path(),
        "good.yaml",
        "pipeline: good\narchive: study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n",
    );
    let out = run_in(tmp.path(), &["run", good.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let archive = tmp.path().join("study.h5");
    let before = fs::read(&archive).unwrap();
    let dir = repo_root().join("tests/bad_pipelines");
    for (name, expect, args) in corpus() {
        if fs::read_to_string(dir.join(&name)).unwrap().lines().any(|l| l.starts_with("# run: skipped")) {
            continue;
        }
        let mut cmd = vec!["run", name.as_str(), "--archive", archive.to_str().unwrap()];
        cmd.extend(args.iter().map(String::as_str));
        let out = run_in(&dir, &cmd);
        let (_, err) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(&expect), "{name}: expected `{expect}` in:\n{err}");
        assert_eq!(fs::read(&archive).unwrap(), before, "{name} changed the archive");
    }
    assert!(!tmp.path().join("results").exists(), "nothing may be created for bad input");
}

#[test]
fn unknown_stage_in_cli_flags_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let p = write_pipeline(tmp.path(), "p.yaml", "pipeline: p\narchive: a.h5\nstages:\n  - {name: s, kind: spectra}\n");
    let out = run_in(tmp.path(), &["run", p.to_str().unwrap(), "--only", "nope"]);
    let (_, err) = text(&out);
    assert_eq!(out.status.code(), Some(2));
    assert!(err.contains("no stage named `nope`; allowed: s"), "{err}");
    assert!(!tmp.path().join("a.h5").exists());
}

#[test]
fn missing_pipeline_file_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let out = run_in(tmp.path(), &["validate", "nope.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("nope.yaml"), "{:?}", text(&out));
}
