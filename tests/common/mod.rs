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

/// Write a pipeline file into `dir` and return its path.
pub fn write_pipeline(dir: &Path, name: &str, yaml: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, yaml).unwrap();
    p
}
