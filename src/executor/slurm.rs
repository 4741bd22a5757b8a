//! The Slurm executor: a stage's sweep points become one Slurm job array.
//!
//! `laydown run PIPELINE --executor slurm [--partition P] [--max-parallel N]
//! [--sbatch-arg ARG]...` (or an `executor:` block in the pipeline file) splits every
//! stage that can be split (its [`crate::stages::Stage::point_dims`]) into array tasks
//! of contiguous sweep points, submits them with `sbatch --wait --array=...%N`, and
//! waits. Each task runs `laydown worker --plan PLAN --task I` (a hidden subcommand):
//! it reloads the pipeline, checks that the stage's fingerprint is still the one
//! submitted, runs the stage on its points (keeping their global indices, so every
//! random stream is the local executor's) and writes `task-I.h5`. When the array has
//! finished the driver gathers the partials into exactly the datasets the local
//! executor writes and commits them through the normal archive path, with each task's
//! Slurm job and array IDs, host and log in the provenance (`slurm_tasks`, JSON).
//! Stages run one after another: the driver waits for a stage's array before
//! submitting the next, so stages wait for their inputs.
//!
//! Files: `<archive>.slurm/<stage>/<fingerprint>/` holds `plan.json`, `task.sh`,
//! `task-I.h5` (written to `.tmp` then renamed: a file that exists is complete) and
//! `task-I.log` (the task's stdout and stderr). A failed or killed task makes the
//! stage fail naming its log; nothing is written to the archive, and the next run of
//! the same command submits only the tasks without a partial. The directory is removed
//! once the stage's version is committed.
//!
//! Test hooks: `LAYDOWN_FAIL_TASK=I` in the environment of `laydown run` (sbatch passes
//! the environment on) makes worker task I fail before computing, and
//! `LAYDOWN_STALL_TASK=I` makes it wait (up to 600 s) to be killed, e.g. by `scancel`;
//! tests/slurm.rs uses them to check the failure message and the rerun.
//!
//! # Running on a real multi-node cluster
//! - The archive's directory must be on a file system shared by the login node and
//!   every compute node (the partials and logs are written next to the archive, in
//!   `<archive>.slurm/`), and so must the pipeline file; paths are made absolute.
//! - The `laydown` binary is run on the compute nodes by the absolute path of the
//!   binary that submitted (`std::env::current_exe`): install or build it on the shared
//!   file system, for the compute nodes' architecture and libraries (libhdf5).
//! - Run `laydown run` on a login node (or in a long, cheap allocation): it holds the
//!   archive's lock and waits for each array (`sbatch --wait`). If it is killed, running
//!   tasks go on; rerunning the same command later gathers their partials.
//! - Set `--partition`, `--max-parallel` (array throttle) and whatever the site needs
//!   through `--sbatch-arg`, e.g. `--sbatch-arg=--time=04:00:00 --sbatch-arg=--mem=4G
//!   --sbatch-arg=--account=proj --sbatch-arg=--cpus-per-task=8`; or in the pipeline:
//!   `executor: {kind: slurm, partition: compute, max_parallel: 50, sbatch_args:
//!   [--time=04:00:00]}`. A task uses `SLURM_CPUS_PER_TASK` threads when set.
//! - Each task takes one or more whole sweep points (at most 1000 tasks per stage):
//!   sweeps with more points give more parallelism; replicates of a point stay together.
//!   Stages that cannot be split (today every kind but `laydown`) run in the driver.
//! - Where the shared file system has no POSIX locks (some NFS, Lustre mounts), set
//!   `HDF5_USE_FILE_LOCKING=FALSE` in the environment of `laydown run` (it is passed on).
//! - The gathered datasets are bit-identical to `--executor local`'s (only measured
//!   times differ); a failed or killed task is resubmitted alone by the next run.
use super::{partial, ExecutorConfig, StageJob};
use crate::archive::data::{Attr, Output};
use crate::archive::{provenance, Archive};
use crate::pipeline;
use crate::runner;
use crate::stages::{self, RunContext, Stage};
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
    /// Half-open ranges of global sweep-point indices, one per task.
    pub tasks: Vec<(usize, usize)>,
}

/// Contiguous ranges of points, at most [`MAX_TASKS`] of them.
pub fn split(points: usize) -> Vec<(usize, usize)> {
    let per = points.div_ceil(MAX_TASKS).max(1);
    (0..points).step_by(per).map(|a| (a, (a + per).min(points))).collect()
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

pub fn run_stage(cfg: &ExecutorConfig, stage: &dyn Stage, ctx: &RunContext, job: &StageJob) -> Result<(Output, BTreeMap<String, Attr>)> {
    let name = job.stage_name;
    let points = stage.point_count(ctx)?;
    let tasks = split(points);
    let dir = work_dir(&job.pipeline.archive, name, job.fingerprint)?;
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let plan = Plan {
        pipeline: std::path::absolute(&job.pipeline.file)?,
        archive: std::path::absolute(&job.pipeline.archive)?,
        stage: name.to_string(),
        fingerprint: job.fingerprint.to_string(),
        inputs: job.inputs.iter().map(|v| (v.stage.clone(), v.number)).collect(),
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

    let missing: Vec<usize> = (0..tasks.len()).filter(|&i| !task_file(&dir, i).exists()).collect();
    if !missing.is_empty() {
        let kept = tasks.len() - missing.len();
        let kept_note = if kept > 0 { format!("; {kept} complete from an earlier run kept") } else { String::new() };
        let ids: Vec<String> = missing.iter().map(|i| i.to_string()).collect();
        let mut array = ids.join(",");
        if let Some(m) = cfg.max_parallel {
            array.push_str(&format!("%{m}"));
        }
        let mut cmd = Command::new("sbatch");
        cmd.arg("--parsable").arg("--wait").arg(format!("--array={array}")).arg(format!("--job-name=laydown-{name}"));
        cmd.arg(format!("--output={}", dir.join("task-%a.log").display()));
        if let Some(p) = &cfg.partition {
            cmd.arg(format!("--partition={p}"));
        }
        cmd.args(&cfg.sbatch_args).arg(&script);
        println!(
            "{name}: submitting {} of {} Slurm array tasks ({} points){kept_note}; logs in {}",
            missing.len(),
            tasks.len(),
            points,
            dir.display()
        );
        let out = cmd.output().map_err(|e| {
            anyhow!("cannot run sbatch ({e}): is Slurm installed and on PATH? The local executor needs no Slurm: leave out --executor slurm")
        })?;
        let job_id = String::from_utf8_lossy(&out.stdout).lines().next().unwrap_or("").split(';').next().unwrap_or("").trim().to_string();
        if job_id.is_empty() {
            bail!("sbatch submitted nothing (exit {}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim());
        }
        println!("{name}: Slurm job {job_id} finished ({})", if out.status.success() { "all tasks succeeded".to_string() } else { format!("sbatch --wait: {}", out.status) });
    }

    let failed: Vec<usize> = (0..tasks.len()).filter(|&i| !task_file(&dir, i).exists()).collect();
    if !failed.is_empty() {
        let lines: Vec<String> = failed
            .iter()
            .map(|&i| format!("  task {i} (points {}..{}): see its log {}", tasks[i].0, tasks[i].1, task_log(&dir, i).display()))
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
    for i in 0..tasks.len() {
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
        let array_job = s("slurm_array_job_id");
        if !job_ids.contains(&array_job) {
            job_ids.push(array_job.clone());
        }
        if !hosts.contains(&s("host")) {
            hosts.push(s("host"));
        }
        records.push(serde_json::json!({
            "task": i,
            "points": [tasks[i].0, tasks[i].1],
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
    let gathered = partial::gather(&parts, stage.point_dims()).with_context(|| format!("gathering the partial results in {}", dir.display()))?;
    let mut attrs = BTreeMap::new();
    attrs.insert("executor".to_string(), Attr::Str("slurm".into()));
    attrs.insert("slurm_job_ids".to_string(), Attr::Str(job_ids.join(" ")));
    attrs.insert("slurm_hosts".to_string(), Attr::Str(hosts.join(" ")));
    attrs.insert("slurm_tasks".to_string(), Attr::Str(serde_json::to_string(&records)?));
    if let Some(p) = &cfg.partition {
        attrs.insert("slurm_partition".to_string(), Attr::Str(p.clone()));
    }
    if !cfg.sbatch_args.is_empty() {
        attrs.insert("slurm_sbatch_args".to_string(), Attr::Str(cfg.sbatch_args.join(" ")));
    }
    Ok((gathered, attrs))
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// `laydown worker --plan PLAN --task I`: run one array task and write its partial.
pub fn worker(plan_path: &Path, task: usize) -> Result<()> {
    let plan: Plan = serde_json::from_str(&std::fs::read_to_string(plan_path).with_context(|| format!("reading {}", plan_path.display()))?)
        .with_context(|| format!("parsing {}", plan_path.display()))?;
    let dir = plan_path.parent().unwrap_or(Path::new("."));
    let &(a, b) = plan.tasks.get(task).ok_or_else(|| anyhow!("task {task} is not in {} ({} tasks)", plan_path.display(), plan.tasks.len()))?;
    if std::env::var_os("RAYON_NUM_THREADS").is_none() {
        if let Ok(n) = std::env::var("SLURM_CPUS_PER_TASK") {
            std::env::set_var("RAYON_NUM_THREADS", n);
        }
    }
    let env = |k: &str| std::env::var(k).unwrap_or_default();
    println!(
        "laydown worker: stage {} task {task} (points {a}..{b}) on {} as Slurm job {} (array {}_{})",
        plan.stage,
        provenance::hostname(),
        env("SLURM_JOB_ID"),
        env("SLURM_ARRAY_JOB_ID"),
        env("SLURM_ARRAY_TASK_ID")
    );
    let hook = |k: &str| std::env::var(k).ok().and_then(|v| v.trim().parse::<usize>().ok()) == Some(task);
    if hook("LAYDOWN_FAIL_TASK") {
        bail!("LAYDOWN_FAIL_TASK={task}: failing this task on purpose (test hook)");
    }
    if hook("LAYDOWN_STALL_TASK") {
        println!("LAYDOWN_STALL_TASK={task}: waiting to be killed (test hook)");
        use std::io::Write;
        let _ = std::io::stdout().flush();
        std::thread::sleep(std::time::Duration::from_secs(600));
        bail!("LAYDOWN_STALL_TASK={task}: not killed within 600 s");
    }
    let mut p = pipeline::load(&plan.pipeline).map_err(|d| anyhow!("{d}"))?;
    p.archive = plan.archive.clone();
    let decl = p.stage(&plan.stage).ok_or_else(|| anyhow!("{} has no stage `{}` any more", plan.pipeline.display(), plan.stage))?;
    let stage = stages::find(&decl.kind).expect("validated kind");
    let mut inputs = vec![];
    if !plan.inputs.is_empty() {
        let archive = Archive::open_read(&plan.archive)?;
        for (name, n) in &plan.inputs {
            inputs.push(archive.version(name, Some(*n))?);
        }
    }
    let seed = decl.seed.unwrap_or(p.seed);
    let hashes: Vec<(String, String)> = inputs.iter().map(|v| (v.stage.clone(), v.attr_str("content_hash").unwrap_or("").to_string())).collect();
    let fp = runner::fingerprint(decl, stage.cache_version(), seed, &hashes);
    if fp != plan.fingerprint {
        bail!("the stage `{}` in {} has changed since it was submitted (fingerprint {fp}, submitted {}); rerun laydown run", plan.stage, plan.pipeline.display(), plan.fingerprint);
    }
    let ctx = runner::stage_context(&p, decl, &inputs, false, 0).restrict(a, b);
    let start = provenance::utc_now();
    let t0 = Instant::now();
    let out = stage.run(&ctx).with_context(|| format!("stage `{}` task {task}", plan.stage))?;
    let wall = t0.elapsed().as_secs_f64();
    let mut attrs = BTreeMap::new();
    let mut put = |k: &str, v: Attr| {
        attrs.insert(k.to_string(), v);
    };
    put("stage", Attr::Str(plan.stage.clone()));
    put("fingerprint", Attr::Str(plan.fingerprint.clone()));
    put("task", Attr::I64(task as i64));
    put("points_start", Attr::I64(a as i64));
    put("points_end", Attr::I64(b as i64));
    put("host", Attr::Str(provenance::hostname()));
    put("slurm_job_id", Attr::Str(env("SLURM_JOB_ID")));
    put("slurm_array_job_id", Attr::Str(env("SLURM_ARRAY_JOB_ID")));
    put("slurm_array_task_id", Attr::Str(env("SLURM_ARRAY_TASK_ID")));
    put("start_utc", Attr::Str(start));
    put("wall_seconds", Attr::F64(wall));
    partial::write(&task_file(dir, task), &out, &attrs)?;
    println!("laydown worker: wrote {} in {wall:.2} s", task_file(dir, task).display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_covers_every_point_once() {
        assert_eq!(split(4), vec![(0, 1), (1, 2), (2, 3), (3, 4)]);
        let s = split(2500);
        assert!(s.len() <= MAX_TASKS);
        assert_eq!(s.first().unwrap().0, 0);
        assert_eq!(s.last().unwrap().1, 2500);
        assert!(s.windows(2).all(|w| w[0].1 == w[1].0));
    }
}
