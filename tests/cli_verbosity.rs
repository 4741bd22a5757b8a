//! `-q/--quiet` and `-v/--verbose` (issue 19): quiet prints only warnings and errors with
//! unchanged exit codes; verbose adds why each stage was reused or rerun, its fingerprint
//! and its timings.
mod common;
use common::*;

/// A fast spectra stage and a synthetic constant image (whose analysis warns, and whose
/// stage prints a Table-4-like summary on stderr).
const PIPE: &str = "pipeline: talk\narchive: out/study.h5\nstages:\n  - name: ideal\n    kind: spectra\n    params: {preset: spectrum1}\n  - name: flat\n    kind: image\n    params:\n      synthetic: {kind: constant, count: 1}\n";

#[test]
fn quiet_prints_nothing_but_warnings_and_keeps_exit_codes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", PIPE);
    // The same run without -q says a lot, on both streams.
    let loud = tempfile::tempdir().unwrap();
    write_pipeline(loud.path(), "p.yaml", PIPE);
    let out = run_in(loud.path(), &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.contains("ideal: runs: new stage") && o.contains("flat@v1 (laydown table"), "{o}");
    assert!(e.contains("CV_corr") && e.contains("constant image"), "the image stage's summary and warning: {e}");

    for flag in ["-q", "--quiet"] {
        let _ = std::fs::remove_dir_all(d.join("out"));
        // The flag is global: before or after the subcommand.
        for args in [vec![flag, "run", "p.yaml"], vec!["run", "p.yaml", flag]] {
            let _ = std::fs::remove_dir_all(d.join("out"));
            let out = run_in(d, &args);
            let (o, e) = text(&out);
            assert_eq!(out.status.code(), Some(0), "{args:?}: {e}");
            assert_eq!(o, "", "{args:?}: nothing on stdout under -q");
            assert!(!e.contains("CV_corr") && !e.contains("runs:"), "{args:?}: no summary under -q: {e}");
            assert!(e.contains("warning") && e.contains("constant image"), "{args:?}: warnings still print: {e}");
            assert!(e.lines().all(|l| l.contains("warning")), "{args:?}: only warnings: {e}");
            assert!(d.join("out/study.h5").is_file(), "-q changes what is said, not what is done");
        }
    }
    // Up to date under -q: silent.
    let out = run_in(d, &["-q", "run", "p.yaml"]);
    assert_eq!((out.status.code(), text(&out)), (Some(0), (String::new(), String::new())));
    // Errors still print, with the same exit codes.
    let out = run_in(d, &["-q", "run", "missing.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(o.is_empty() && e.contains("missing.yaml"), "{e}");
    let out = run_in(d, &["-q", "ls", "nothing.h5"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.starts_with("error:"), "{:?}", text(&out));
    write_pipeline(d, "bad.yaml", &PIPE.replace("preset: spectrum1", "preset: spectrum9"));
    let out = run_in(d, &["-q", "run", "bad.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("spectrum9"), "{:?}", text(&out));
}

#[test]
fn quiet_and_verbose_exclude_each_other() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let out = run_in(tmp.path(), &["-q", "-v", "run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("cannot be used with"), "{:?}", text(&out));
    assert!(!tmp.path().join("out").exists());
}

#[test]
fn verbose_says_why_each_stage_was_rerun_or_reused_with_fingerprint_and_timings() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", &common::TWO_SPECTRA.replace("archive: study.h5", "archive: out/study.h5"));
    let out = run_in(d, &["-v", "run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    // The normal lines are all still there, on stdout.
    assert!(o.contains("first: runs: new stage") && o.contains("first: wrote v1"), "{o}");
    // Detail on stderr: the fingerprint, why, and the timings.
    let runs = e.lines().find(|l| l.starts_with("first: fingerprint ")).unwrap_or_else(|| panic!("{e}"));
    assert!(runs.contains("none of its 0 complete versions has it"), "{runs}");
    let fp = runs["first: fingerprint ".len()..].split(';').next().unwrap().to_string();
    assert!(fp.len() >= 16 && fp.chars().all(|c| c.is_ascii_hexdigit()), "{fp}");
    let timing = e.lines().find(|l| l.starts_with("first: computed in ")).unwrap_or_else(|| panic!("{e}"));
    assert!(timing.contains("s CPU") && timing.contains("committed v1") && timing.contains("content hash"), "{timing}");
    // The fingerprint stored is the one said.
    let show = run_in(d, &["show", "out/study.h5", "first", "--json"]);
    let doc: serde_json::Value = serde_json::from_slice(&show.stdout).unwrap();
    assert_eq!(doc["provenance"]["fingerprint"].as_str(), Some(fp.as_str()));

    // Reused: which version matched.
    let out = run_in(d, &["run", "p.yaml", "--verbose"]);
    let e = text(&out).1;
    assert!(e.contains(&format!("first: reused: fingerprint {fp} matches v1")), "{e}");
    // A changed parameter: the new fingerprint is compared with the current version.
    write_pipeline(d, "p.yaml", &common::TWO_SPECTRA.replace("archive: study.h5", "archive: out/study.h5").replace("cutoff_number: 20", "cutoff_number: 30"));
    let out = run_in(d, &["run", "p.yaml", "-v"]);
    let (o, e) = text(&out);
    assert!(o.contains("first: runs: params.cutoff_number changed 20 -> 30"), "{o}");
    assert!(e.contains("none of its 1 complete versions has it (compared with v1)"), "{e}");
    assert!(!e.contains(&format!("first: fingerprint {fp}")), "a new fingerprint: {e}");
    // Without -v: no detail.
    let out = run_in(d, &["run", "p.yaml"]);
    assert!(!text(&out).1.contains("fingerprint"), "{:?}", text(&out));
}

#[test]
fn no_progress_bars_when_stderr_is_not_a_terminal() {
    // Children here write stderr to a pipe: a progress bar's frame would show as `[00:00:0`.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", "pipeline: bars\narchive: out/study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, mesh_error_estimate: false}\n    replicates: 2\n");
    let out = run_in(d, &["run", "p.yaml"]);
    let e = text(&out).1;
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(!e.contains("[00:0") && !e.contains('\u{1b}'), "no bar, no escape codes: {e:?}");
}

#[test]
fn on_a_terminal_bars_are_drawn_and_quiet_hides_them() {
    // `script` (util-linux, Essential on Debian) runs laydown on a pseudo-terminal.
    if std::process::Command::new("script").arg("--version").output().is_err() {
        eprintln!("SKIPPED: no `script` to give laydown a terminal");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", "pipeline: bars\narchive: out/study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, mesh_error_estimate: false}\n    replicates: 2\n");
    let on_tty = |args: &str| {
        let cmd = format!("{} {args}", env!("CARGO_BIN_EXE_laydown"));
        let out = std::process::Command::new("script").args(["-qec", &cmd, "/dev/null"]).current_dir(d).output().unwrap();
        assert!(out.status.success(), "{cmd}: {:?}", text(&out));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let loud = on_tty("run p.yaml");
    assert!(loud.contains("fibre units [00:0"), "a bar on a terminal: {loud:?}");
    std::fs::remove_dir_all(d.join("out")).unwrap();
    let quiet = on_tty("-q run p.yaml");
    assert_eq!(quiet, "", "nothing at all under -q, bar included");
    assert!(d.join("out/study.h5").is_file());
}
