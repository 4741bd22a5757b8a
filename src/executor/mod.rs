//! Where a stage's units of work run: in this process on all cores (the default local
//! executor, rayon) or as a Slurm job array ([`slurm`]).
//!
//! The unit of distribution is one replicate of one sweep point. A stage that can be
//! split says how many units it has ([`crate::stages::Stage::units`]: points ×
//! replicates, or points alone when its replicates must stay together), computes any
//! contiguous range of them ([`crate::stages::Stage::run_units`]) as per-replicate rows,
//! and reduces the rows of all units to its output ([`crate::stages::Stage::reduce`]:
//! placing the replicates, per-point means, standard deviations and valid counts). The
//! local executor runs all units in this process and reduces them
//! ([`crate::stages::run_by_units`]); the Slurm executor ([`slurm`]) runs ranges of units
//! as the tasks of a job array, each writing its rows to a partial file ([`partial`]),
//! gathers the rows in unit order and reduces them by the same call. Random streams are
//! keyed by a unit's global point and replicate, never by the process that computes it,
//! so both give exactly the same output, which is committed through the normal archive
//! path.
pub mod local;
pub mod partial;
pub mod slurm;

use crate::archive::data::{Attr, Output};
use crate::archive::VersionInfo;
use crate::pipeline::Pipeline;
use crate::stages::{RunContext, Stage};
use anyhow::Result;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExecutorKind {
    /// All units in this process, on all cores.
    #[default]
    Local,
    /// One Slurm job array per stage.
    Slurm,
}

impl ExecutorKind {
    pub const NAMES: [&'static str; 2] = ["local", "slurm"];
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "local" => Some(ExecutorKind::Local),
            "slurm" => Some(ExecutorKind::Slurm),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            ExecutorKind::Local => "local",
            ExecutorKind::Slurm => "slurm",
        }
    }
}

/// The `executor:` block of a pipeline file, overridden by `laydown run --executor ...`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExecutorConfig {
    pub kind: ExecutorKind,
    /// Slurm partition (`sbatch --partition`); the cluster's default otherwise.
    pub partition: Option<String>,
    /// At most this many array tasks at once (`--array=...%N`).
    pub max_parallel: Option<usize>,
    /// Units (replicates) per array task; 1 when unset (more when a stage has over
    /// [`slurm::MAX_TASKS`] units).
    pub units_per_task: Option<usize>,
    /// Extra `sbatch` arguments, e.g. `--time=02:00:00`, `--mem=4G`.
    pub sbatch_args: Vec<String>,
}

/// What a stage run needs besides its context: enough to let a worker process
/// reconstruct exactly the same run.
pub struct StageJob<'a> {
    pub pipeline: &'a Pipeline,
    pub stage_name: &'a str,
    pub fingerprint: &'a str,
    /// The input versions chosen for this run (same order as the stage's inputs).
    pub inputs: &'a [VersionInfo],
}

/// Run one stage with the configured executor: its output and any extra provenance
/// attributes (Slurm job and task IDs, hosts).
pub fn run_stage(
    cfg: &ExecutorConfig,
    stage: &dyn Stage,
    ctx: &RunContext,
    job: &StageJob,
) -> Result<(Output, BTreeMap<String, Attr>)> {
    match cfg.kind {
        ExecutorKind::Local => local::run_stage(stage, ctx),
        ExecutorKind::Slurm => match stage.units(ctx)? {
            Some(units) if units.count() > 0 => slurm::run_stage(cfg, stage, ctx, job, units),
            _ => {
                println!("{}: a {} stage cannot be split over Slurm tasks; running it here", job.stage_name, stage.kind());
                let (out, mut attrs) = local::run_stage(stage, ctx)?;
                attrs.insert("executor".into(), Attr::Str("local (stage cannot be split)".into()));
                Ok((out, attrs))
            }
        },
    }
}

/// Called once the stage's version is committed: drop the executor's scratch files.
pub fn committed(cfg: &ExecutorConfig, job: &StageJob) {
    if cfg.kind == ExecutorKind::Slurm {
        slurm::cleanup(&job.pipeline.archive, job.stage_name, job.fingerprint);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn parse(executor: &str) -> Result<crate::pipeline::Pipeline, crate::pipeline::Diagnostics> {
        let text = format!("pipeline: p\narchive: a.h5\n{executor}stages:\n  - {{name: s, kind: spectra}}\n");
        crate::pipeline::parse(&text, Path::new("p.yaml"))
    }

    #[test]
    fn default_is_local() {
        assert_eq!(parse("").unwrap().executor, ExecutorConfig::default());
        assert_eq!(ExecutorConfig::default().kind, ExecutorKind::Local);
    }

    #[test]
    fn executor_block_and_shorthand() {
        assert_eq!(parse("executor: slurm\n").unwrap().executor.kind, ExecutorKind::Slurm);
        let e = parse("executor:\n  kind: slurm\n  partition: short\n  max_parallel: 3\n  units_per_task: 4\n  sbatch_args: [--time=00:10:00, --mem=1G]\n")
            .unwrap()
            .executor;
        assert_eq!(
            e,
            ExecutorConfig {
                kind: ExecutorKind::Slurm,
                partition: Some("short".into()),
                max_parallel: Some(3),
                units_per_task: Some(4),
                sbatch_args: vec!["--time=00:10:00".into(), "--mem=1G".into()],
            }
        );
    }

    #[test]
    fn bad_executor_blocks_are_located() {
        let d = parse("executor:\n  kind: slurm\n  max_paralel: 3\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:5:3: executor.max_paralel: unknown key in the executor"), "{d}");
        assert!(d.contains("did you mean `max_parallel`?"), "{d}");
        let d = parse("executor:\n  kind: slurm\n  max_parallel: 0\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:5:17: executor.max_parallel: 0 is out of range"), "{d}");
        let d = parse("executor:\n  partition: x\n").unwrap_err().to_string();
        assert!(d.contains("executor.kind: required key is missing; allowed: local, slurm"), "{d}");
        let d = parse("executor: 3\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:3:11: executor: expected text"), "{d}");
    }
}
