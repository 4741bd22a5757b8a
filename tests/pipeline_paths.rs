//! Paths in a pipeline file, the archive included, are relative to the pipeline file,
//! not to the working directory; `run` prints the archive's absolute path.
mod common;
use common::*;

const PIPE: &str = "pipeline: paths\narchive: results/study.h5\nstages:\n  - {name: s, kind: spectra, params: {preset: spectrum1}}\n";

#[test]
fn the_same_pipeline_from_two_working_directories_uses_one_archive() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().canonicalize().unwrap();
    let study = root.join("study");
    let elsewhere = root.join("elsewhere/deeper");
    std::fs::create_dir_all(&study).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    write_pipeline(&study, "p.yaml", PIPE);
    let archive = study.join("results/study.h5");

    let out = run_in(&study, &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.starts_with(&format!("archive: {}\n", archive.display())), "{o}");
    assert!(o.contains("s: runs: new stage"), "{o}");

    let out = run_in(&elsewhere, &["run", "../../study/p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.starts_with(&format!("archive: {}\n", archive.display())), "{o}");
    assert!(o.contains("s: up to date (v1)"), "{o}");
    assert!(!elsewhere.join("results").exists(), "no second archive beside the working directory");

    // A pipeline in a subfolder naming the same archive with `..` shares it; the path
    // printed is the real one, without `..`.
    std::fs::create_dir_all(study.join("sub")).unwrap();
    write_pipeline(&study.join("sub"), "p.yaml", &PIPE.replace("results/study.h5", "../results/study.h5"));
    let out = run_in(&elsewhere, &["run", "../../study/sub/p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.starts_with(&format!("archive: {}\n", archive.display())) && o.contains("s: up to date (v1)"), "{o}");

    // validate checks `archive:` where run will write it: a directory there is refused.
    write_pipeline(&study, "q.yaml", &PIPE.replace("results/study.h5", "results"));
    let out = run_in(&elsewhere, &["validate", "../../study/q.yaml"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(e.contains("archive: `results` is a directory"), "{e}");

    // --archive is a command-line path: relative to the working directory.
    let out = run_in(&elsewhere, &["run", "../../study/p.yaml", "--archive", "here.h5"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.starts_with(&format!("archive: {}\n", elsewhere.join("here.h5").display())), "{o}");
}
