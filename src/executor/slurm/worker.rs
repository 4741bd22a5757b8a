//! `laydown worker`: one array task: reload the pipeline, check the plan still holds,
//! compute the task's units and write their rows to `task-I.h5`.

use super::*;

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
        "laydown worker: stage {} task {task} (units {a}..{b}) on {} as Slurm job {} (array {}_{})",
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
    // The driver checked the pipeline's memory; a task computes only its share.
    let mut p = pipeline::load_with(&plan.pipeline, crate::memory::Limit::Unchecked).map_err(|d| anyhow!("{d}"))?;
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
    let fp = stage_run::fingerprint(decl, stage.cache_version(), seed, &hashes);
    if fp != plan.fingerprint {
        bail!("the stage `{}` in {} has changed since it was submitted (fingerprint {fp}, submitted {}); rerun laydown run", plan.stage, plan.pipeline.display(), plan.fingerprint);
    }
    let ctx = stage_run::stage_context(&p, decl, &inputs, false, 0);
    let units = stage.units(&ctx)?.ok_or_else(|| anyhow!("stage `{}` cannot be split into units any more", plan.stage))?;
    if (units.points, units.per_point) != (plan.points, plan.per_point) {
        bail!(
            "stage `{}` now has {} points × {} units per point, the plan {} × {}; rerun laydown run",
            plan.stage,
            units.points,
            units.per_point,
            plan.points,
            plan.per_point
        );
    }
    println!("laydown worker: {}", units.describe(a, b));
    let start = provenance::utc_now();
    let t0 = Instant::now();
    let out = stage.run_units(&ctx, a..b).with_context(|| format!("stage `{}` task {task}", plan.stage))?;
    let wall = t0.elapsed().as_secs_f64();
    let mut attrs = BTreeMap::new();
    let mut put = |k: &str, v: Attr| {
        attrs.insert(k.to_string(), v);
    };
    put("stage", Attr::Str(plan.stage.clone()));
    put("fingerprint", Attr::Str(plan.fingerprint.clone()));
    put("task", Attr::I64(task as i64));
    put("units_start", Attr::I64(a as i64));
    put("units_end", Attr::I64(b as i64));
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
