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
pub mod incremental;
pub mod local;
pub mod partial;
pub mod slurm;

use crate::archive::data::{Attr, Output};
use crate::archive::VersionInfo;
use crate::pipeline::Pipeline;
use crate::stages::{RunContext, Stage};
use anyhow::Result;
use std::collections::BTreeMap;

/// The `executor:` block is part of a pipeline's declaration ([`crate::pipeline`]).
pub use crate::pipeline::{ExecutorConfig, ExecutorKind};

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
                crate::status!("{}: a {} stage cannot be split over Slurm tasks; running it here", job.stage_name, stage.kind());
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
