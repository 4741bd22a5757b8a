//! The Slurm executor: a stage's units of work become one Slurm job array.
//!
//! `laydown run PIPELINE --executor slurm [--partition P] [--max-parallel N]
//! [--units-per-task K] [--sbatch-arg ARG]...` (or an `executor:` block in the pipeline
//! file) splits every stage that can be split ([`crate::stages::Stage::units`]: today
//! `laydown` and `grid`) into its units — one (sweep point, replicate) of a laydown, one
//! (point, realisation) of a grid — cuts them into contiguous ranges of K units (1 by
//! default; more when the stage has over [`MAX_TASKS`] units), submits one array task per
//! range with `sbatch --array=...%N`, and waits for the array by polling `squeue`. Each
//! task runs `laydown worker --plan PLAN --task I` (a hidden subcommand): it reloads the
//! pipeline, checks that the stage's fingerprint and units are still the ones submitted,
//! computes its units ([`crate::stages::Stage::run_units`]: every random stream is keyed
//! by the unit's global point and replicate, so it is the local executor's) and writes
//! their per-replicate rows to `task-I.h5`. When the array has finished the driver
//! gathers the rows ([`crate::archive::gather::gather`]) and reduces them to the stage's output with
//! [`crate::stages::Stage::reduce`] — the same call the local executor makes, so the
//! per-point statistics over replicates are computed by one piece of code — and commits
//! it through the normal archive path, with each task's Slurm job and array IDs, host and
//! log in the provenance (`slurm_tasks`, JSON). Stages run one after another: the driver
//! waits for a stage's array before submitting the next, so stages wait for their inputs.
//!
//! A laydown with `valid_replicates_target` draws extra replicates in rounds that depend
//! on how many earlier ones were valid; its unit is the whole point (all its rounds run in
//! one task), and the driver says so.
//!
//! Files: `<archive>.slurm/<stage>/<fingerprint>/` holds `plan.json`, `task.sh`,
//! `task-I.h5` (written to `.tmp` then renamed: a file that exists is complete) and
//! `task-I.log` (the task's stdout and stderr). A failed or killed task makes the
//! stage fail naming its log; nothing is written to the archive, and the next run of
//! the same command submits only the tasks without a partial. The directory is removed
//! once the stage's version is committed.
//!
//! Interrupting the driver: SIGINT (Ctrl-C) or SIGTERM while it waits for an array makes
//! it `scancel` that array, say so, and die of the signal; complete tasks' partials stay
//! and a rerun submits only the rest. Other ways of losing the driver (SIGHUP when the
//! login session ends, SIGKILL) leave the array running; a rerun gathers it.
//!
//! Test hooks: `LAYDOWN_FAIL_TASK=I` in the environment of `laydown run` (sbatch passes
//! the environment on) makes worker task I fail before computing, and
//! `LAYDOWN_STALL_TASK=I` makes it wait (up to 600 s) to be killed, e.g. by `scancel`;
//! tests/slurm.rs uses them to check the failure message, the rerun and the
//! cancellation of the array when the driver is killed.
//!
//! # Running on a real multi-node cluster
//! What the cluster needs (shared file system, the binary, where to run the driver,
//! throttles, file locking) is in the README's "Running on a Slurm cluster".
//!
//! The driver is this module; `signals` lets Ctrl-C cancel the running array, and
//! [`worker`] is what each array task runs.
mod signals;
mod worker;
use signals::{wait_for_array, SignalGuard};
pub use worker::worker;

use super::{partial, ExecutorConfig, StageJob};
use crate::archive::data::{Attr, Output};
use crate::archive::{provenance, Archive};
use crate::pipeline::{self, stage_run};
use crate::stages::{self, RunContext, Stage, Units};
use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// At most this many array tasks per stage (sites cap MaxArraySize, often at 1001).
pub const MAX_TASKS: usize = 1000;

/// What every task of a stage's array needs to reconstruct the run (`plan.json`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Plan {
    pub pipeline: PathBuf,
    pub archive: PathBuf,
    pub stage: String,
    pub fingerprint: String,
    /// Input stage names and the version numbers chosen by the driver.
    pub inputs: Vec<(String, u32)>,
    /// The stage's units: points and units per point ([`Units`]).
    pub points: usize,
    pub per_point: usize,
    /// Half-open ranges of global unit indices, one per task.
    pub tasks: Vec<(usize, usize)>,
}

/// Contiguous ranges of `per_task` units (at least 1, and more when needed to stay within
/// [`MAX_TASKS`] ranges), covering `0..units` in order.
pub fn split(units: usize, per_task: usize) -> Vec<(usize, usize)> {
    let per = per_task.max(units.div_ceil(MAX_TASKS)).max(1);
    (0..units).step_by(per).map(|a| (a, (a + per).min(units))).collect()
}

/// `<archive>.slurm/<stage>/<fingerprint>`.
pub fn work_dir(archive: &Path, stage: &str, fingerprint: &str) -> Result<PathBuf> {
    let archive = std::path::absolute(archive)?;
    let mut name = archive.file_name().ok_or_else(|| anyhow!("archive path {} has no file name", archive.display()))?.to_os_string();
    name.push(".slurm");
    Ok(archive.with_file_name(name).join(stage).join(fingerprint))
}

fn task_file(dir: &Path, i: usize) -> PathBuf {
    dir.join(format!("task-{i}.h5"))
}
fn task_log(dir: &Path, i: usize) -> PathBuf {
    dir.join(format!("task-{i}.log"))
}

/// Remove a committed stage's work directory (and its parents when empty).
pub fn cleanup(archive: &Path, stage: &str, fingerprint: &str) {
    if let Ok(dir) = work_dir(archive, stage, fingerprint) {
        let _ = std::fs::remove_dir_all(&dir);
        if let Some(stage_dir) = dir.parent() {
            let _ = std::fs::remove_dir(stage_dir);
            if let Some(root) = stage_dir.parent() {
                let _ = std::fs::remove_dir(root);
            }
        }
    }
}

pub fn run_stage(cfg: &ExecutorConfig, stage: &dyn Stage, ctx: &RunContext, job: &StageJob, units: Units) -> Result<(Output, BTreeMap<String, Attr>)> {
    let (dir, tasks) = prepare(cfg, job, units)?;
    submit_missing(cfg, job.stage_name, &dir, &tasks, units)?;
    let (out, mut attrs) = collect(stage, ctx, job, units, &dir, &tasks)?;
    if let Some(p) = &cfg.partition {
        attrs.insert("slurm_partition".to_string(), Attr::Str(p.clone()));
    }
    if !cfg.sbatch_args.is_empty() {
        attrs.insert("slurm_sbatch_args".to_string(), Attr::Str(cfg.sbatch_args.join(" ")));
    }
    Ok((out, attrs))
}

fn units_text(units: Units) -> String {
    let points = if units.points == 1 { "1 point".to_string() } else { format!("{} points", units.points) };
    if units.per_point == 1 {
        points
    } else {
        format!("{} units: {points} × {} replicates", units.count(), units.per_point)
    }
}

/// Split the stage's units into tasks and write the work directory's `plan.json` and
/// `task.sh`: the directory and the tasks' unit ranges.
pub fn prepare(cfg: &ExecutorConfig, job: &StageJob, units: Units) -> Result<(PathBuf, Vec<(usize, usize)>)> {
    let name = job.stage_name;
    let mut tasks = split(units.count(), cfg.units_per_task.unwrap_or(1));
    let dir = work_dir(&job.pipeline.archive, name, job.fingerprint)?;
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    // A rerun keeps the split of the run whose partials are there, whatever
    // --units-per-task says now, so that no complete task is lost.
    if let Some(old) = std::fs::read_to_string(dir.join("plan.json")).ok().and_then(|t| serde_json::from_str::<Plan>(&t).ok()) {
        if (old.points, old.per_point) == (units.points, units.per_point) && old.tasks != tasks && (0..old.tasks.len()).any(|i| task_file(&dir, i).exists()) {
            crate::status!("{name}: keeping the split of the earlier run ({} tasks) so that its complete tasks are kept", old.tasks.len());
            tasks = old.tasks;
        }
    }
    let plan = Plan {
        pipeline: std::path::absolute(&job.pipeline.file)?,
        archive: std::path::absolute(&job.pipeline.archive)?,
        stage: name.to_string(),
        fingerprint: job.fingerprint.to_string(),
        inputs: job.inputs.iter().map(|v| (v.stage.clone(), v.number)).collect(),
        points: units.points,
        per_point: units.per_point,
        tasks: tasks.clone(),
    };
    std::fs::write(dir.join("plan.json"), serde_json::to_string_pretty(&plan)?)?;
    let exe = std::env::current_exe().context("finding the laydown binary to run on the compute nodes")?;
    let script = dir.join("task.sh");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\n# laydown stage `{name}`: one array task (written by laydown run --executor slurm)\nexec {} worker --plan {} --task \"$SLURM_ARRAY_TASK_ID\"\n",
            shell_quote(&exe.display().to_string()),
            shell_quote(&dir.join("plan.json").display().to_string()),
        ),
    )?;
    if let Some(note) = units.note {
        crate::status!("{name}: {note}");
    }
    Ok((dir, tasks))
}

/// Submit one array task for every task without a partial, and wait for the array.
fn submit_missing(cfg: &ExecutorConfig, name: &str, dir: &Path, tasks: &[(usize, usize)], units: Units) -> Result<()> {
    let what = units_text(units);
    let missing: Vec<usize> = (0..tasks.len()).filter(|&i| !task_file(dir, i).exists()).collect();
    if !missing.is_empty() {
        let kept = tasks.len() - missing.len();
        let kept_note = if kept > 0 { format!("; {kept} complete from an earlier run kept") } else { String::new() };
        let ids: Vec<String> = missing.iter().map(|i| i.to_string()).collect();
        let mut array = ids.join(",");
        if let Some(m) = cfg.max_parallel {
            array.push_str(&format!("%{m}"));
        }
        let mut cmd = Command::new("sbatch");
        cmd.arg("--parsable").arg(format!("--array={array}")).arg(format!("--job-name=laydown-{name}"));
        cmd.arg(format!("--output={}", dir.join("task-%a.log").display()));
        if let Some(p) = &cfg.partition {
            cmd.arg(format!("--partition={p}"));
        }
        cmd.args(&cfg.sbatch_args).arg(dir.join("task.sh"));
        let per = tasks[0].1 - tasks[0].0;
        crate::status!(
            "{name}: submitting {} of {} Slurm array tasks ({what}, {per} per task){kept_note}; logs in {}",
            missing.len(),
            tasks.len(),
            dir.display()
        );
        // From here until the array has left the queue, SIGINT and SIGTERM cancel it.
        let _guard = SignalGuard::install();
        let out = cmd.output().map_err(|e| {
            anyhow!("cannot run sbatch ({e}): is Slurm installed and on PATH? The local executor needs no Slurm: leave out --executor slurm")
        })?;
        let job_id = String::from_utf8_lossy(&out.stdout).lines().next().unwrap_or("").split(';').next().unwrap_or("").trim().to_string();
        if job_id.is_empty() || !out.status.success() {
            bail!("sbatch submitted nothing ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim());
        }
        crate::status!("{name}: Slurm job {job_id} submitted; waiting for its tasks");
        wait_for_array(name, &job_id, dir)?;
        crate::status!("{name}: Slurm job {job_id} finished");
    }
    Ok(())
}

/// Read every task's partial (naming the logs of the missing ones), gather their rows in
/// unit order and reduce them to the stage's output with [`Stage::reduce`], the call the
/// local executor makes; with the provenance of the tasks.
pub fn collect(stage: &dyn Stage, ctx: &RunContext, job: &StageJob, units: Units, dir: &Path, tasks: &[(usize, usize)]) -> Result<(Output, BTreeMap<String, Attr>)> {
    let dir = dir.to_path_buf();
    let failed: Vec<usize> = (0..tasks.len()).filter(|&i| !task_file(&dir, i).exists()).collect();
    if !failed.is_empty() {
        let lines: Vec<String> = failed
            .iter()
            .map(|&i| format!("  task {i} ({}): see its log {}", units.describe(tasks[i].0, tasks[i].1), task_log(&dir, i).display()))
            .collect();
        bail!(
            "{} of {} Slurm array tasks failed or were killed:\n{}\nthe {} complete tasks are kept in {}; rerunning the same command submits only the failed ones",
            failed.len(),
            tasks.len(),
            lines.join("\n"),
            tasks.len() - failed.len(),
            dir.display()
        );
    }

    let mut parts = vec![];
    let mut records = vec![];
    let mut job_ids = vec![];
    let mut hosts = vec![];
    for (i, &(a, b)) in tasks.iter().enumerate() {
        let (out, attrs) = partial::read(&task_file(&dir, i))?;
        let s = |k: &str| match attrs.get(k) {
            Some(Attr::Str(s)) => s.clone(),
            Some(Attr::F64(f)) => f.to_string(),
            Some(Attr::I64(v)) => v.to_string(),
            None => String::new(),
        };
        if s("fingerprint") != job.fingerprint {
            bail!("{} belongs to another run (fingerprint {}); remove it", task_file(&dir, i).display(), s("fingerprint"));
        }
        if (s("units_start"), s("units_end")) != (a.to_string(), b.to_string()) {
            bail!("{} holds units {}..{}, but task {i} is units {a}..{b}; remove it", task_file(&dir, i).display(), s("units_start"), s("units_end"));
        }
        let array_job = s("slurm_array_job_id");
        if !job_ids.contains(&array_job) {
            job_ids.push(array_job.clone());
        }
        if !hosts.contains(&s("host")) {
            hosts.push(s("host"));
        }
        let (p0, p1) = units.points_of(a, b);
        records.push(serde_json::json!({
            "task": i,
            "units": [a, b],
            "points": [p0, p1],
            "slurm_array_job_id": array_job,
            "slurm_array_task_id": s("slurm_array_task_id"),
            "slurm_job_id": s("slurm_job_id"),
            "host": s("host"),
            "start_utc": s("start_utc"),
            "wall_seconds": attrs.get("wall_seconds").and_then(|a| match a {
                Attr::F64(f) => Some(*f),
                Attr::I64(i) => Some(*i as f64),
                Attr::Str(_) => None,
            }),
            "log": task_log(&dir, i).display().to_string(),
        }));
        parts.push(out);
    }
    let rows = crate::archive::gather::gather(&parts, &[stages::UNIT_DIM]).with_context(|| format!("gathering the partial results in {}", dir.display()))?;
    let gathered = stage.reduce(ctx, rows).with_context(|| format!("reducing the gathered partial results in {}", dir.display()))?;
    let mut attrs = BTreeMap::new();
    attrs.insert("executor".to_string(), Attr::Str("slurm".into()));
    attrs.insert("slurm_job_ids".to_string(), Attr::Str(job_ids.join(" ")));
    attrs.insert("slurm_hosts".to_string(), Attr::Str(hosts.join(" ")));
    attrs.insert("slurm_tasks".to_string(), Attr::Str(serde_json::to_string(&records)?));
    attrs.insert("slurm_units".to_string(), Attr::Str(units_text(units)));
    Ok((gathered, attrs))
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::*;
    // (a test may set up its inputs with the runner, a layer above)
    use crate::runner;

    fn covers(s: &[(usize, usize)], n: usize) -> bool {
        s.first().map(|t| t.0) == Some(0) && s.last().map(|t| t.1) == Some(n) && s.windows(2).all(|w| w[0].1 == w[1].0) && s.iter().all(|t| t.1 > t.0)
    }

    #[test]
    fn split_covers_every_unit_once() {
        assert_eq!(split(4, 1), vec![(0, 1), (1, 2), (2, 3), (3, 4)]);
        assert_eq!(split(10, 4), vec![(0, 4), (4, 8), (8, 10)]);
        assert_eq!(split(3, 8), vec![(0, 3)]);
        assert!(split(0, 1).is_empty());
        // Over MAX_TASKS units: more per task, never more than MAX_TASKS tasks.
        for (n, k) in [(2500, 1), (1000, 1), (1001, 1), (40_000, 3), (7, 2)] {
            let s = split(n, k);
            assert!(s.len() <= MAX_TASKS, "{n} units, {k} per task: {} tasks", s.len());
            assert!(covers(&s, n), "{n} units, {k} per task: {s:?}");
        }
        assert_eq!(split(1000, 1).len(), 1000);
        assert_eq!(split(1001, 1).len(), 501);
    }

    #[test]
    fn a_single_point_with_many_replicates_becomes_many_tasks() {
        // The case issue 8 left open: one point, 40 replicates, one per task.
        let u = Units { points: 1, per_point: 40, note: None };
        let s = split(u.count(), 1);
        assert_eq!(s.len(), 40);
        assert_eq!(u.describe(s[7].0, s[7].1), "point 0 replicates 7..8");
        let s = split(u.count(), 16);
        assert_eq!(s, vec![(0, 16), (16, 32), (32, 40)]);
        assert_eq!(u.describe(32, 40), "point 0 replicates 32..40");
        let u = Units { points: 4, per_point: 2, note: None };
        assert_eq!(u.describe(2, 4), "point 1 replicates 0..2");
        assert_eq!(u.describe(2, 6), "points 1..3");
        assert_eq!(u.describe(1, 4), "units 1..4 (points 0..2)");
        assert_eq!(u.points_of(1, 4), (0, 2));
        let whole = Units { points: 5, per_point: 1, note: Some("rounds") };
        assert_eq!(whole.describe(1, 2), "point 1");
        assert_eq!(whole.describe(1, 3), "points 1..3");
    }

    /// Every variable of `b` equals `a`'s (f64 by bit pattern, so NaN padding counts),
    /// with the same names, order, dimensions and metadata; `wall_seconds*` (measured
    /// times) only in shape.
    fn assert_same(a: &Output, b: &Output, what: &str) {
        use crate::archive::data::Values;
        let names = |o: &Output| o.variables.iter().map(|v| v.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(a), names(b), "{what}: variables");
        assert_eq!(a.attrs, b.attrs, "{what}: attributes");
        for (x, y) in a.variables.iter().zip(&b.variables) {
            assert_eq!((&x.dims, &x.units, &x.long_name, &x.attrs), (&y.dims, &y.units, &y.long_name, &y.attrs), "{what}: {}", x.name);
            assert_eq!(x.values.shape(), y.values.shape(), "{what}: shape of {}", x.name);
            if x.name.starts_with("wall_seconds") {
                continue;
            }
            let same = match (&x.values, &y.values) {
                (Values::F64(p), Values::F64(q)) => p.iter().zip(q.iter()).all(|(u, v)| u.to_bits() == v.to_bits()),
                (p, q) => p == q,
            };
            assert!(same, "{what}: values of {} differ", x.name);
        }
    }

    const PIPELINE: &str = "pipeline: units
archive: units.h5
seed: 5
stages:
  - name: single
    kind: laydown
    params: {length: 0.06, laydown_height: 0.03, elements: 30}
    replicates: 6
  - name: ragged
    kind: laydown
    params: {length: 0.06, laydown_height: 0.03}
    sweep: {elements: [30, 45]}
    replicates: 3
  - name: rounds
    kind: laydown
    params: {length: 0.06, laydown_height: 0.03, elements: 30, valid_replicates_target: 3, max_replicates: 7, bounce_tolerance: 1e-9}
    sweep: {elements: [30, 40]}
    replicates: 2
  - name: web
    kind: web
    params: {preset: spectrum1, points_per_segment: 100, fibres_across: 20, fibre_spacing: 0.005, segments_per_fibre: 3}
  - name: grid
    kind: grid
    input: web
    params: {cell_size: 0.01, window_side: 0.1, boundary: periodic}
    replicates: 5
";

    /// What an array task does, without Slurm: the driver's plan, every task's worker in
    /// this process (each writes its partial file), then the driver's gather and reduce.
    /// The result must be the local executor's output, variable for variable.
    #[test]
    fn units_run_by_workers_and_reduced_at_gather_equal_the_local_run() {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("units.yaml");
        std::fs::write(&file, PIPELINE).unwrap();
        let mut p = pipeline::load(&file).unwrap();
        p.archive = tmp.path().join("units.h5");
        runner::run(&p, &runner::RunOptions::default()).unwrap();
        let archive = Archive::open_read(&p.archive).unwrap();
        // (stage, units per task, expected tasks, expected units)
        let cases = [
            ("single", 1, 6, (1, 6)),
            ("single", 4, 2, (1, 6)),
            ("ragged", 1, 6, (2, 3)),
            ("ragged", 4, 2, (2, 3)),
            ("rounds", 1, 2, (2, 1)),
            ("grid", 1, 5, (1, 5)),
            ("grid", 2, 3, (1, 5)),
        ];
        for (name, per_task, ntasks, (points, per_point)) in cases {
            let what = format!("{name}, {per_task} per task");
            let decl = p.stage(name).unwrap();
            let stage = stages::find(&decl.kind).unwrap();
            let inputs: Vec<_> = decl.inputs.iter().map(|i| archive.version(i, Some(1)).unwrap()).collect();
            let hashes: Vec<(String, String)> = inputs.iter().map(|v| (v.stage.clone(), v.attr_str("content_hash").unwrap_or("").to_string())).collect();
            let fp = stage_run::fingerprint(decl, stage.cache_version(), decl.seed.unwrap_or(p.seed), &hashes);
            let ctx = stage_run::stage_context(&p, decl, &inputs, false, 0);
            let units = stage.units(&ctx).unwrap().unwrap();
            assert_eq!((units.points, units.per_point), (points, per_point), "{what}");
            assert_eq!(units.note.is_some(), name == "rounds", "{what}");
            let job = StageJob { pipeline: &p, stage_name: name, fingerprint: &fp, inputs: &inputs };
            let cfg = ExecutorConfig { units_per_task: Some(per_task), ..Default::default() };
            let (dir, tasks) = prepare(&cfg, &job, units).unwrap();
            assert_eq!(tasks.len(), ntasks, "{what}: {tasks:?}");
            for i in 0..tasks.len() {
                worker(&dir.join("plan.json"), i).unwrap();
            }
            let (gathered, attrs) = collect(stage, &ctx, &job, units, &dir, &tasks).unwrap();
            let local = stage.run(&ctx).unwrap();
            assert_same(&local, &gathered, &what);
            let Some(Attr::Str(records)) = attrs.get("slurm_tasks") else { panic!("{what}: no slurm_tasks") };
            let records: serde_json::Value = serde_json::from_str(records).unwrap();
            assert_eq!(records.as_array().unwrap().len(), ntasks, "{what}");
            assert_eq!(records[0]["units"], serde_json::json!([tasks[0].0, tasks[0].1]), "{what}");
            if name == "rounds" {
                let attempted = local.get("attempted_replicates").unwrap();
                let crate::archive::data::Values::I64(a) = &attempted.values else { panic!() };
                assert!(a.iter().any(|&n| n > 2), "{what}: the target needs extra rounds, attempted {a:?}");
            }
            // A missing partial is named with its units and log; nothing is reduced.
            std::fs::remove_file(task_file(&dir, 1)).unwrap();
            let e = collect(stage, &ctx, &job, units, &dir, &tasks).unwrap_err().to_string();
            let want = format!("task 1 ({}): see its log {}", units.describe(tasks[1].0, tasks[1].1), task_log(&dir, 1).display());
            assert!(e.contains(&want), "{what}: {e}");
            // A partial of another split is refused.
            if tasks.len() > 2 {
                std::fs::copy(task_file(&dir, 2), task_file(&dir, 1)).unwrap();
                let e = collect(stage, &ctx, &job, units, &dir, &tasks).unwrap_err().to_string();
                assert!(e.contains("but task 1 is units"), "{what}: {e}");
            }
            cleanup(&p.archive, name, &fp);
        }

        // A rerun with another --units-per-task keeps the split whose partials exist.
        let decl = p.stage("single").unwrap();
        let stage = stages::find(&decl.kind).unwrap();
        let fp = stage_run::fingerprint(decl, stage.cache_version(), decl.seed.unwrap_or(p.seed), &[]);
        let ctx = stage_run::stage_context(&p, decl, &[], false, 0);
        let units = stage.units(&ctx).unwrap().unwrap();
        let job = StageJob { pipeline: &p, stage_name: "single", fingerprint: &fp, inputs: &[] };
        let one = ExecutorConfig { units_per_task: Some(1), ..Default::default() };
        let four = ExecutorConfig { units_per_task: Some(4), ..Default::default() };
        let (dir, first) = prepare(&one, &job, units).unwrap();
        assert_eq!(first.len(), 6);
        assert_eq!(prepare(&four, &job, units).unwrap().1.len(), 2, "nothing complete yet: the new split");
        prepare(&one, &job, units).unwrap();
        worker(&dir.join("plan.json"), 3).unwrap();
        assert_eq!(prepare(&four, &job, units).unwrap().1, first, "task 3 is complete: the earlier split is kept");
        cleanup(&p.archive, "single", &fp);
    }
}
