//! The Slurm executor against a real one-node Slurm cluster on 127.0.0.1
//! (tests/slurm/cluster.sh installs Debian's slurmctld, slurmd, slurm-client and munge
//! when missing and starts the daemons with their state under a temporary directory).
//!
//! Ignored by a plain `cargo test`: it needs root and apt, and takes about a minute.
//! scripts/test.sh runs it with `cargo test --release --test slurm -- --ignored
//! --nocapture`; where Slurm cannot be installed or started it prints
//! `SKIPPED: slurm: <reason>` (and fails instead when LAYDOWN_REQUIRE_SLURM=1).
//!
//! What it checks: a pipeline whose stages split into units of one (sweep point,
//! replicate) each, one unit per array task (the default): a 4-point × 2-replicate
//! laydown sweep with ragged node counts (8 tasks), a single-point laydown with 6
//! replicates (6 tasks), a grid of a swept web (4 points × 2 realisations, 8 tasks) and
//! a grid of an unswept web with 4 realisations (4 tasks), grids of a laid_segments and a
//! lay_down_sde web (2 tasks each); and a laydown sweep with
//! `valid_replicates_target`, whose unit is the whole point (4 tasks). A task failed on
//! purpose (the worker's LAYDOWN_FAIL_TASK test hook) and a task killed with `scancel`
//! while running (LAYDOWN_STALL_TASK keeps it running) fail the stage naming both logs
//! and write nothing; the rerun submits only those two tasks; and every gathered dataset
//! (per-point statistics over replicates included, computed at gather time) is
//! bit-identical to the local executor's, except `wall_seconds*` (the measured wall times
//! of each replicate, which differ between any two runs), with each task's Slurm IDs and
//! host in the provenance. Last, a driver sent SIGTERM while its array runs cancels the
//! array (`squeue` empties) and dies of the signal.
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
  - name: single
    kind: laydown
    params: {length: 0.06, laydown_height: 0.03, elements: 30}
    replicates: 6
  - name: rounds
    kind: laydown
    params: {length: 0.06, laydown_height: 0.03, valid_replicates_target: 2, max_replicates: 5, bounce_tolerance: 1e-9}
    sweep: {elements: [30, 35, 40, 45]}
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
  - name: web1
    kind: web
    params: {preset: spectrum1, points_per_segment: 100, fibres_across: 20, fibre_spacing: 0.005, segments_per_fibre: 3}
  - name: grid1
    kind: grid
    input: web1
    params: {cell_size: 0.01, window_side: 0.1, boundary: periodic}
    replicates: 4
  - name: single_spectra
    kind: spectra
    input: single
    params: {sample_spacing: 0.0002}
  - name: segweb
    kind: web
    input: single_spectra
    params: {generator: laid_segments, mirror: true, fibres_across: 20, fibre_spacing: 0.005, segments_per_fibre: 400}
  - name: seggrid
    kind: grid
    input: segweb
    params: {cell_size: 0.01, window_side: 0.1, boundary: periodic}
    replicates: 2
  - name: sdeweb
    kind: web
    params: {generator: lay_down_sde, sde_potential_length: 0.004, sde_noise: 3.0, points_per_segment: 100, segment_length: 0.1, fibres_across: 20, fibre_spacing: 0.005, segments_per_fibre: 30}
  - name: sdegrid
    kind: grid
    input: sdeweb
    params: {cell_size: 0.01, window_side: 0.1, boundary: periodic}
    replicates: 2
  - name: laid
    kind: laid_web
    params: {fibres_across: 2, fibre_spacing: 0.005, belt_travel: 0.04}
    sweep: {oscillation_amplitude: [0.005, 0.01]}
    replicates: 2
  - name: laidgrid
    kind: grid
    input: laid
    params: {cell_size: 0.001, window_side: 0.01, edge_margin_spreads: 0.0}
    replicates: 2
  - name: laidcontact
    kind: laid_web
    params: {fibres_across: 2, fibre_spacing: 0.025, belt_travel: 0.02, fibre_contact: true, oscillation_ramp: 0.01}
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
        // "active": squeue's default states (pending, running, completing, ...), not the
        // finished jobs that slurmctld still remembers.
        let mut cmd = Command::new("squeue");
        cmd.env("SLURM_CONF", &conf).args(["-h", "-o", "%i"]);
        if state != "active" {
            cmd.args(["-t", state]);
        }
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "squeue: {:?}", text(&out));
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
    assert!(so.contains("fibre: submitting 8 of 8 Slurm array tasks (8 units: 4 points × 2 replicates, 1 per task);"), "{so}");
    let dirs: Vec<PathBuf> = std::fs::read_dir(work.join("slurm.h5.slurm/fibre")).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(dirs.len(), 1);
    let task_dir = &dirs[0];
    let (log1, log2) = (task_dir.join("task-1.log"), task_dir.join("task-2.log"));
    assert!(se.contains("2 of 8 Slurm array tasks failed or were killed"), "{se}");
    assert!(se.contains(&format!("task 1 (point 0 replicates 1..2): see its log {}", log1.display())), "{se}");
    assert!(se.contains(&format!("task 2 (point 1 replicates 0..1): see its log {}", log2.display())), "{se}");
    assert!(std::fs::read_to_string(&log2).unwrap().contains("LAYDOWN_FAIL_TASK=2"));
    let log1_text = std::fs::read_to_string(&log1).unwrap();
    assert!(log1_text.contains("CANCELLED"), "task 1's log: {log1_text}");
    for i in [0, 3, 4, 5, 6, 7] {
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
    assert!(so.contains("fibre: submitting 2 of 8 Slurm array tasks (8 units: 4 points × 2 replicates, 1 per task); 6 complete from an earlier run kept"), "{so}");
    assert!(!work.join("slurm.h5.slurm").exists(), "work directory removed after the commit");

    // Every stage that splits ran as an array of at least 4 tasks: the single-point
    // stages by replicate (realisation), the laydown with a valid-replicate target by
    // point (its extra rounds depend on earlier results).
    assert!(so.contains("single: submitting 6 of 6 Slurm array tasks (6 units: 1 point × 6 replicates, 1 per task)"), "{so}");
    assert!(so.contains("rounds: valid_replicates_target draws extra replicates in rounds"), "{so}");
    assert!(so.contains("rounds: submitting 4 of 4 Slurm array tasks (4 points, 1 per task)"), "{so}");
    assert!(so.contains("grid: submitting 8 of 8 Slurm array tasks (8 units: 4 points × 2 replicates, 1 per task)"), "{so}");
    assert!(so.contains("grid1: submitting 4 of 4 Slurm array tasks (4 units: 1 point × 4 replicates, 1 per task)"), "{so}");
    assert!(so.contains("web: a web stage cannot be split over Slurm tasks; running it here"), "{so}");
    assert!(so.contains("laid: submitting 4 of 4 Slurm array tasks (4 units: 2 points × 2 replicates, 1 per task)"), "{so}");
    assert!(so.contains("laidgrid: submitting 4 of 4 Slurm array tasks (4 units: 2 points × 2 replicates, 1 per task)"), "{so}");
    assert!(so.contains("laidcontact: submitting 2 of 2 Slurm array tasks (2 units: 1 point × 2 replicates, 1 per task)"), "{so}");

    // Bit-identical to the local executor, except the measured wall times: the datasets
    // of every stage, the per-point statistics over replicates (reduced at gather time)
    // among them.
    let mut compared = 0;
    for group in [
        "/fibre/v1", "/single/v1", "/rounds/v1", "/web/v1", "/grid/v1", "/web1/v1", "/grid1/v1", "/segweb/v1", "/seggrid/v1", "/sdeweb/v1", "/sdegrid/v1", "/laid/v1", "/laidgrid/v1", "/laidcontact/v1",
    ] {
        let (a, b) = (datasets(&work.join("local.h5"), group), datasets(&work.join("slurm.h5"), group));
        let names = |v: &[(String, hdf5::Dataset)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(names(&a), names(&b), "{group}");
        for ((name, da), (_, db)) in a.iter().zip(&b) {
            assert_eq!(da.shape(), db.shape(), "{group}/{name}");
            if name.starts_with("wall_seconds") {
                continue;
            }
            assert!(bytes(da) == bytes(db), "dataset {group}/{name} differs between the local and the Slurm executor");
            let attrs = |d: &hdf5::Dataset| laydown::archive::hdf::read_attrs(d).unwrap();
            assert_eq!(attrs(da), attrs(db), "attributes of {group}/{name}");
            compared += 1;
        }
        // A stage's fingerprint holds its inputs' content hashes, and the laid web's content
        // includes its measured wall times: the laid web's grid has equal datasets but not
        // an equal fingerprint.
        if group != "/laidgrid/v1" {
            assert_eq!(attr_of(&work.join("local.h5"), group, "fingerprint"), attr_of(&work.join("slurm.h5"), group, "fingerprint"), "{group}");
        }
    }
    assert!(compared >= 150, "compared {compared} datasets");
    for (group, tasks) in [("/fibre/v1", 8), ("/single/v1", 6), ("/rounds/v1", 4), ("/grid/v1", 8), ("/grid1/v1", 4), ("/seggrid/v1", 2), ("/sdegrid/v1", 2), ("/laid/v1", 4), ("/laidgrid/v1", 4), ("/laidcontact/v1", 2)] {
        assert_eq!(attr_of(&work.join("slurm.h5"), group, "executor"), "slurm", "{group}");
        let t: serde_json::Value = serde_json::from_str(&attr_of(&work.join("slurm.h5"), group, "slurm_tasks")).unwrap();
        let t = t.as_array().unwrap();
        assert_eq!(t.len(), tasks, "{group}");
        for (i, r) in t.iter().enumerate() {
            assert_eq!(r["slurm_array_task_id"].as_str().unwrap(), i.to_string(), "{group}");
            assert!(!r["slurm_job_id"].as_str().unwrap().is_empty(), "{group}");
        }
    }
    let read_f64 = |group: &str, name: &str| {
        hdf5::File::open(work.join("slurm.h5")).unwrap().dataset(&format!("{group}/{name}")).unwrap().read_raw::<f64>().unwrap()
    };
    let read_i64 = |group: &str, name: &str| {
        hdf5::File::open(work.join("slurm.h5")).unwrap().dataset(&format!("{group}/{name}")).unwrap().read_raw::<i64>().unwrap()
    };
    // The statistics over the replicates of the single point are real numbers: a mean
    // and a standard deviation over the 6 replicates computed by 6 different tasks.
    assert_eq!(read_i64("/single/v1", "valid_replicates"), vec![6]);
    assert!(read_f64("/single/v1", "radius_of_gyration_std")[0] > 0.0);
    assert!(read_f64("/grid1/v1", "cv_std")[0] > 0.0);
    // The target drew extra rounds somewhere (else the point-as-unit case is untested).
    assert!(read_i64("/rounds/v1", "attempted_replicates").iter().any(|&n| n > 2), "no extra rounds");
    let a = datasets(&work.join("local.h5"), "/fibre/v1");
    let shape = a.iter().find(|(n, _)| n == "positions").unwrap().1.shape();
    assert_eq!(shape[..2], [4, 2]);
    // Points with fewer nodes than the longest are NaN-padded: the gather must pad alike.
    let elements = read_f64("/fibre/v1", "elements");
    assert!(elements[0] < elements[7], "ragged node counts across points: {elements:?}");
    for k in ["fingerprint", "params_yaml", "sweep_yaml", "seed"] {
        assert_eq!(attr_text(&work.join("local.h5"), k), attr_text(&work.join("slurm.h5"), k), "{k}");
    }

    // Provenance: each task's Slurm IDs and host; task 2 ran in the rerun's job.
    assert_eq!(attr_text(&work.join("slurm.h5"), "executor"), "slurm");
    let tasks: serde_json::Value = serde_json::from_str(&attr_text(&work.join("slurm.h5"), "slurm_tasks")).unwrap();
    let tasks = tasks.as_array().unwrap();
    assert_eq!(tasks.len(), 8);
    let job = |i: usize| tasks[i]["slurm_array_job_id"].as_str().unwrap().to_string();
    assert!(!job(0).is_empty());
    for i in [3, 4, 5, 6, 7] {
        assert_eq!(job(0), job(i), "task {i} ran in the first job");
    }
    assert_eq!(job(1), job(2), "tasks 1 and 2 ran in the rerun's job");
    assert_ne!(job(0), job(1), "tasks 1 and 2 ran in the rerun's job");
    for (i, t) in tasks.iter().enumerate() {
        assert_eq!(t["slurm_array_task_id"].as_str().unwrap(), i.to_string());
        assert_eq!(t["units"], serde_json::json!([i, i + 1]));
        assert_eq!(t["points"], serde_json::json!([i / 2, i / 2 + 1]));
        assert!(!t["host"].as_str().unwrap().is_empty());
    }
    assert_eq!(attr_text(&work.join("slurm.h5"), "slurm_job_ids").split(' ').count(), 2);

    // A driver sent SIGTERM while its array runs cancels the array and dies of the signal.
    let mut c = laydown();
    c.current_dir(work).env("SLURM_CONF", &conf).env_remove("LAYDOWN_FAIL_TASK").env("LAYDOWN_STALL_TASK", "0");
    c.args(["run", "sweep.yaml", "--archive", "cancel.h5", "--executor", "slurm", "--only", "single"]);
    c.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
    let driver = c.spawn().unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    let stalled = loop {
        if let Some(id) = squeue("R").into_iter().find(|id| id.ends_with("_0")) {
            break id;
        }
        assert!(std::time::Instant::now() < deadline, "task 0 of `single` never ran");
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    assert!(!squeue("active").is_empty());
    // SAFETY: kill(2) on the pid of the child this test spawned.
    assert_eq!(unsafe { libc::kill(driver.id() as libc::pid_t, libc::SIGTERM) }, 0);
    let killed = driver.wait_with_output().unwrap();
    let (so, se) = text(&killed);
    println!("slurm: driver sent SIGTERM while {stalled} ran, after {:.1} s:\n{so}{se}", t0.elapsed().as_secs_f64());
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(killed.status.signal(), Some(libc::SIGTERM), "the driver dies of SIGTERM: {:?}", killed.status);
    let job_id = stalled.split('_').next().unwrap();
    assert!(se.contains(&format!("single: interrupted (SIGTERM): cancelled Slurm job {job_id} (scancel {job_id})")), "{se}");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while !squeue("active").is_empty() {
        assert!(std::time::Instant::now() < deadline, "tasks left after the driver's scancel: {:?}", squeue("active"));
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    let log0 = std::fs::read_dir(work.join("cancel.h5.slurm/single")).unwrap().next().unwrap().unwrap().path().join("task-0.log");
    let log0 = std::fs::read_to_string(log0).unwrap();
    assert!(log0.contains("CANCELLED"), "task 0's log: {log0}");
    println!("slurm: squeue empty {:.1} s after the driver's scancel", t0.elapsed().as_secs_f64());
    println!("slurm: all checks passed in {:.1} s", t0.elapsed().as_secs_f64());
}
