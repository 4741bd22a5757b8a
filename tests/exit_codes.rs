//! The same exit codes from every command: 2 for bad input (a missing archive, an
//! unknown stage or version, a malformed argument), 1 for a runtime failure or a
//! damaged archive; and nothing on stdout when a command fails.
mod common;
use common::*;
use std::path::Path;

fn archive_with_one_stage(dir: &Path) {
    write_pipeline(dir, "p.yaml", "pipeline: codes\narchive: study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n");
    let out = run_in(dir, &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
}

/// Runs `args` in `dir`; checks the exit code, that stdout is empty and that stderr is
/// one `error:` line containing `expect`.
fn fails(dir: &Path, args: &[&str], code: i32, expect: &str) {
    let out = run_in(dir, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {e}");
    assert!(o.is_empty(), "{args:?} printed to stdout before failing: {o}");
    assert_eq!(e.lines().count(), 1, "{args:?}: one line expected: {e}");
    assert!(e.starts_with("error: ") && e.contains(expect), "{args:?}: expected `{expect}` in {e}");
}

#[test]
fn bad_input_is_2_for_every_command() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    archive_with_one_stage(d);
    for cmd in ["ls", "plot", "verify"] {
        fails(d, &[cmd, "missing.h5"], 2, "archive missing.h5 does not exist");
        fails(d, &[cmd, "."], 2, "is a directory");
    }
    fails(d, &["show", "missing.h5", "s"], 2, "archive missing.h5 does not exist");
    fails(d, &["show", "study.h5", "nope"], 2, "stage `nope` has no versions in");
    fails(d, &["show", "study.h5", "s@v7"], 2, "stage `s` has no version v7");
    fails(d, &["show", "study.h5", "s@7"], 2, "expected STAGE or STAGE@vN");
    fails(d, &["plot", "study.h5", "nope"], 2, "stage `nope` has no versions in");
    fails(d, &["stages", "nope"], 2, "unknown stage kind `nope`");
}

#[test]
fn an_archive_hdf5_cannot_open_is_1_for_every_command() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("junk.h5"), "this is not an HDF5 file\n").unwrap();
    let expect = "archive junk.h5 cannot be opened by HDF5 (";
    fails(d, &["ls", "junk.h5"], 1, expect);
    fails(d, &["verify", "junk.h5"], 1, expect);
    fails(d, &["show", "junk.h5", "s"], 1, expect);
    fails(d, &["plot", "junk.h5"], 1, expect);
    fails(d, &["plot", "junk.h5", "s"], 1, expect);
    write_pipeline(d, "p.yaml", "pipeline: codes\narchive: junk.h5\nstages:\n  - {name: s, kind: spectra}\n");
    let out = run_in(d, &["run", "p.yaml"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("cannot be opened by HDF5") && e.contains("it is damaged or not a laydown archive"), "{e}");
}

#[test]
fn help_names_every_stage_kind_and_the_exit_codes() {
    // The list comes from the stage registry, so a new kind cannot be left out of it.
    let tmp = tempfile::tempdir().unwrap();
    let out = run_in(tmp.path(), &["--help"]);
    let (o, _) = text(&out);
    assert_eq!(out.status.code(), Some(0));
    let kinds = o.lines().find(|l| l.starts_with("Stage kinds:")).expect("a Stage kinds line");
    for kind in ["laydown", "laid_web", "spectra", "web", "grid", "image", "accuracy"] {
        assert!(kinds.contains(&format!(" {kind},")) || kinds.contains(&format!(" {kind}.")), "{kind} missing from: {kinds}");
    }
    assert!(o.contains("Exit codes: 0 success, 1 runtime failure or damaged archive, 2 bad input."), "{o}");
}
