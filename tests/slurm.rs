//! The Slurm executor against a real one-node Slurm cluster on 127.0.0.1
//! (tests/slurm/cluster.sh installs Debian's slurmctld, slurmd, slurm-client and munge
//! when missing and starts the daemons with their state under a temporary directory).
//!
//! Ignored by a plain `cargo test`: it needs root and apt, and takes about a minute.
//! scripts/test.sh runs it with `cargo test --release --test slurm -- --ignored
//! --nocapture`; where Slurm cannot be installed or started it prints
//! `SKIPPED: slurm: <reason>` (and fails instead when LAYDOWN_REQUIRE_SLURM=1).
//!
//! What it checks: a 4-point × 2-replicate laydown sweep with ragged node counts runs
//! as a job array of 4 tasks; a task failed on purpose (the worker's LAYDOWN_FAIL_TASK
//! test hook) and a task killed with `scancel` while running (LAYDOWN_STALL_TASK keeps
//! it running) fail the stage naming both logs and write nothing; the rerun submits
//! only those two tasks; and every gathered dataset is bit-identical to the local
//! executor's, except `wall_seconds` (the measured wall time of each replicate, which
//! differs between any two runs), with each task's Slurm IDs and host in the provenance.
mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

struct Cluster {
    script: PathBuf,
    dir: PathBuf,
}

impl Drop for Cluster {
    /// Stop the daemons by their pid files, on every exit path (panics included).
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(&self.script).arg("stop").arg(&self.dir).status();
    }
}

const SWEEP: &str = "pipeline: slurmtest
archive: local.h5
seed: 11
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.08, laydown_height: 0.03, elements: 40}
    sweep: {elements: [50, 60, 70, 80]}
    replicates: 2
  - name: web
    kind: web
    params: {preset: spectrum1, points_per_segment: 100, fibres_across: 20, fibre_spacing: 0.005, segments_per_fibre: 3}
    sweep: {belt_speed_ratio: [0.1, 0.2, 0.3, 0.4]}
  - name: grid
    kind: grid
    input: web
    params: {cell_size: 0.01, window_side: 0.1, boundary: periodic}
    replicates: 2
";

fn datasets(file: &Path, group: &str) -> Vec<(String, hdf5::Dataset)> {
    let f = hdf5::File::open(file).unwrap();
    let g = f.group(group).unwrap();
    let mut out: Vec<(String, hdf5::Dataset)> =
        g.member_names().unwrap().into_iter().filter_map(|n| g.dataset(&n).ok().map(|d| (n, d))).collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The exact bytes of a dataset's values (f64 by bit pattern, so NaN == NaN).
fn bytes(ds: &hdf5::Dataset) -> Vec<u8> {
    use hdf5::types::{TypeDescriptor as T, VarLenUnicode};
    match ds.dtype().unwrap().to_descriptor().unwrap() {
        T::Float(_) => ds.read_raw::<f64>().unwrap().iter().flat_map(|x| x.to_bits().to_le_bytes()).collect(),
        T::Integer(_) => ds.read_raw::<i64>().unwrap().iter().flat_map(|x| x.to_le_bytes()).collect(),
        T::Unsigned(_) => ds.read_raw::<u8>().unwrap(),
        T::VarLenUnicode => ds.read_raw::<VarLenUnicode>().unwrap().iter().flat_map(|s| [s.as_str().as_bytes(), &[0]].concat()).collect(),
        other => panic!("{}: unexpected type {other:?}", ds.name()),
    }
}

fn attr_text(file: &Path, name: &str) -> String {
    attr_of(file, "/fibre/v1", name)
}

fn attr_of(file: &Path, group: &str, name: &str) -> String {
    let f = hdf5::File::open(file).unwrap();
    let g = f.group(group).unwrap();
    let a = g.attr(name).unwrap_or_else(|_| panic!("no attribute {name}"));
    a.read_scalar::<hdf5::types::VarLenUnicode>().unwrap().as_str().to_string()
}

#[test]
#[ignore = "needs root and apt for a real Slurm; run by scripts/test.sh with --ignored"]
fn job_array_matches_local_and_rerun_submits_only_the_failed_tasks() {
    let t0 = std::time::Instant::now();
    let tmp = tempfile::Builder::new().prefix("laydown-slurm-").tempdir_in("/tmp").unwrap();
    let work = tmp.path();
    let state = work.join("cluster");
    let script = repo_root().join("tests/slurm/cluster.sh");
    let _cluster = Cluster { script: script.clone(), dir: state.clone() };
    let started = Command::new("bash").arg(&script).arg("start").arg(&state).output().unwrap();
    let (so, se) = text(&started);
    print!("{so}");
    eprint!("{se}");
    if started.status.code() == Some(77) {
        assert!(std::env::var("LAYDOWN_REQUIRE_SLURM").is_err(), "LAYDOWN_REQUIRE_SLURM is set but Slurm is unavailable: {so}");
        assert!(so.contains("SKIPPED: slurm:"));
        return;
    }
    assert!(started.status.success(), "cluster.sh start failed: {so}{se}");
    let conf = state.join("slurm.conf");
    println!("slurm: cluster up after {:.1} s", t0.elapsed().as_secs_f64());

    write_pipeline(work, "sweep.yaml", SWEEP);
    let local = run_in(work, &["run", "sweep.yaml", "--archive", "local.h5"]);
    assert!(local.status.success(), "local run: {:?}", text(&local));
    println!("slurm: local run done after {:.1} s", t0.elapsed().as_secs_f64());

    // Task 2 fails on purpose and task 1 is killed with scancel while it runs: the stage
    // fails naming both logs, and nothing is committed.
    let slurm = |fail: bool| {
        let mut c = laydown();
        c.current_dir(work).env("SLURM_CONF", &conf).env_remove("LAYDOWN_FAIL_TASK").env_remove("LAYDOWN_STALL_TASK");
        if fail {
            c.env("LAYDOWN_FAIL_TASK", "2").env("LAYDOWN_STALL_TASK", "1");
        }
        c.args(["run", "sweep.yaml", "--archive", "slurm.h5", "--executor", "slurm", "--max-parallel", "2"]);
        c.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
        c.spawn().unwrap()
    };
    let driver = slurm(true);
    let squeue = |state: &str| {
        let out = Command::new("squeue").env("SLURM_CONF", &conf).args(["-h", "-t", state, "-o", "%i"]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).lines().map(|l| l.trim().to_string()).collect::<Vec<_>>()
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    let stalled = loop {
        if let Some(id) = squeue("R").into_iter().find(|id| id.ends_with("_1")) {
            break id;
        }
        assert!(std::time::Instant::now() < deadline, "task 1 never ran");
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    std::thread::sleep(std::time::Duration::from_millis(500));
    let cancel = Command::new("scancel").env("SLURM_CONF", &conf).arg(&stalled).status().unwrap();
    assert!(cancel.success(), "scancel {stalled}");
    println!("slurm: killed array task {stalled} with scancel after {:.1} s", t0.elapsed().as_secs_f64());
    let failed = driver.wait_with_output().unwrap();
    let (so, se) = text(&failed);
    println!("slurm: run with task 2 failing and task 1 killed done after {:.1} s:\n{so}{se}", t0.elapsed().as_secs_f64());
    assert_eq!(failed.status.code(), Some(1), "{so}{se}");
    assert!(so.contains("submitting 4 of 4 Slurm array tasks (4 points);"), "{so}");
    let dirs: Vec<PathBuf> = std::fs::read_dir(work.join("slurm.h5.slurm/fibre")).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(dirs.len(), 1);
    let task_dir = &dirs[0];
    let (log1, log2) = (task_dir.join("task-1.log"), task_dir.join("task-2.log"));
    assert!(se.contains("2 of 4 Slurm array tasks failed or were killed"), "{se}");
    assert!(se.contains(&format!("task 1 (points 1..2): see its log {}", log1.display())), "{se}");
    assert!(se.contains(&format!("task 2 (points 2..3): see its log {}", log2.display())), "{se}");
    assert!(std::fs::read_to_string(&log2).unwrap().contains("LAYDOWN_FAIL_TASK=2"));
    let log1_text = std::fs::read_to_string(&log1).unwrap();
    assert!(log1_text.contains("CANCELLED"), "task 1's log: {log1_text}");
    for i in [0, 3] {
        assert!(task_dir.join(format!("task-{i}.h5")).exists(), "task {i} kept");
    }
    assert!(!task_dir.join("task-1.h5").exists() && !task_dir.join("task-2.h5").exists());
    let ls = run_in(work, &["ls", "slurm.h5"]);
    assert!(!text(&ls).0.contains("fibre"), "nothing committed: {:?}", text(&ls));

    // The rerun submits only the missing tasks.
    let rerun = slurm(false).wait_with_output().unwrap();
    let (so, se) = text(&rerun);
    println!("slurm: rerun done after {:.1} s:\n{so}{se}", t0.elapsed().as_secs_f64());
    assert!(rerun.status.success(), "{so}{se}");
    assert!(so.contains("submitting 2 of 4 Slurm array tasks (4 points); 2 complete from an earlier run kept"), "{so}");
    assert!(!work.join("slurm.h5.slurm").exists(), "work directory removed after the commit");

    // Bit-identical to the local executor, except the measured wall times: the laydown
    // sweep (split by point) and the grid of a swept web (split by web point; the web
    // itself runs in the driver).
    assert!(so.contains("grid: submitting 4 of 4 Slurm array tasks (4 points)"), "{so}");
    let mut compared = 0;
    for group in ["/fibre/v1", "/web/v1", "/grid/v1"] {
        let (a, b) = (datasets(&work.join("local.h5"), group), datasets(&work.join("slurm.h5"), group));
        let names = |v: &[(String, hdf5::Dataset)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(names(&a), names(&b), "{group}");
        for ((name, da), (_, db)) in a.iter().zip(&b) {
            assert_eq!(da.shape(), db.shape(), "{group}/{name}");
            if name == "wall_seconds" {
                continue;
            }
            assert!(bytes(da) == bytes(db), "dataset {group}/{name} differs between the local and the Slurm executor");
            let attrs = |d: &hdf5::Dataset| laydown::archive::hdf::read_attrs(d).unwrap();
            assert_eq!(attrs(da), attrs(db), "attributes of {group}/{name}");
            compared += 1;
        }
        assert_eq!(attr_of(&work.join("local.h5"), group, "fingerprint"), attr_of(&work.join("slurm.h5"), group, "fingerprint"), "{group}");
    }
    assert!(compared >= 60, "compared {compared} datasets");
    assert_eq!(attr_of(&work.join("slurm.h5"), "/grid/v1", "executor"), "slurm");
    let a = datasets(&work.join("local.h5"), "/fibre/v1");
    let shape = a.iter().find(|(n, _)| n == "positions").unwrap().1.shape();
    assert_eq!(shape[..2], [4, 2]);
    // Points with fewer nodes than the longest are NaN-padded: the gather must pad alike.
    let elements = hdf5::File::open(work.join("slurm.h5")).unwrap().dataset("/fibre/v1/elements").unwrap().read_raw::<f64>().unwrap();
    assert!(elements[0] < elements[7], "ragged node counts across points: {elements:?}");
    for k in ["fingerprint", "params_yaml", "sweep_yaml", "seed"] {
        assert_eq!(attr_text(&work.join("local.h5"), k), attr_text(&work.join("slurm.h5"), k), "{k}");
    }

    // Provenance: each task's Slurm IDs and host; task 2 ran in the rerun's job.
    assert_eq!(attr_text(&work.join("slurm.h5"), "executor"), "slurm");
    let tasks: serde_json::Value = serde_json::from_str(&attr_text(&work.join("slurm.h5"), "slurm_tasks")).unwrap();
    let tasks = tasks.as_array().unwrap();
    assert_eq!(tasks.len(), 4);
    let job = |i: usize| tasks[i]["slurm_array_job_id"].as_str().unwrap().to_string();
    assert!(!job(0).is_empty());
    assert_eq!(job(0), job(3));
    assert_eq!(job(1), job(2), "tasks 1 and 2 ran in the rerun's job");
    assert_ne!(job(0), job(1), "tasks 1 and 2 ran in the rerun's job");
    for (i, t) in tasks.iter().enumerate() {
        assert_eq!(t["slurm_array_task_id"].as_str().unwrap(), i.to_string());
        assert!(!t["host"].as_str().unwrap().is_empty());
    }
    assert_eq!(attr_text(&work.join("slurm.h5"), "slurm_job_ids").split(' ').count(), 2);
    println!("slurm: all checks passed in {:.1} s", t0.elapsed().as_secs_f64());
}
