//! Helpers shared by the integration tests: run the `laydown` binary, make pipelines.
#![allow(dead_code)]
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn laydown() -> Command {
    Command::new(env!("CARGO_BIN_EXE_laydown"))
}

pub fn run_in(dir: &Path, args: &[&str]) -> Output {
    laydown().current_dir(dir).args(args).output().expect("laydown runs")
}

pub fn run_in_with_threads(dir: &Path, threads: usize, args: &[&str]) -> Output {
    laydown().current_dir(dir).env("RAYON_NUM_THREADS", threads.to_string()).args(args).output().expect("laydown runs")
}

pub fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Two independent spectra stages (the first with two replicates): the smallest study
/// whose stages can be changed, rerun and marked one at a time.
pub const TWO_SPECTRA: &str = "pipeline: two_spectra
archive: study.h5
seed: 7
stages:
  - name: first
    kind: spectra
    params: {preset: none, bending_energy: 2500, cutoff_number: 20}
    replicates: 2
  - name: second
    kind: spectra
    params: {preset: spectrum2}
";

/// Write a pipeline file into `dir` and return its path.
pub fn write_pipeline(dir: &Path, name: &str, yaml: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, yaml).unwrap();
    p
}

/// Give a file a fresh inode (copy, then rename over it). After this test process has
/// written an HDF5 file itself, a `laydown` child spawned meanwhile by another test thread
/// may have inherited HDF5's descriptor (opened without close-on-exec) and with it the
/// file's lock; the copy carries no lock.
pub fn fresh_inode(path: &Path) {
    let tmp = path.with_extension("fresh");
    std::fs::copy(path, &tmp).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}
