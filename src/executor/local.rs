//! The default executor: every unit in this process, in parallel on all cores (rayon,
//! through each stage's parallel map, [`crate::progress::par_map`]). Nothing about Slurm
//! is needed.
use crate::archive::data::{Attr, Output};
use crate::stages::{RunContext, Stage};
use anyhow::Result;
use std::collections::BTreeMap;

pub fn run_stage(stage: &dyn Stage, ctx: &RunContext) -> Result<(Output, BTreeMap<String, Attr>)> {
    Ok((stage.run(ctx)?, BTreeMap::new()))
}

/// `laydown run -j N`: this process's rayon pool gets N threads (instead of
/// RAYON_NUM_THREADS, or one per core). Called before anything uses rayon: the memory
/// estimates count the threads. Results do not depend on N: every random stream is keyed
/// by its item, never by the thread that computes it. Slurm array tasks size their own
/// pool (SLURM_CPUS_PER_TASK).
pub fn set_threads(n: usize) -> Result<()> {
    rayon::ThreadPoolBuilder::new().num_threads(n).build_global().map_err(|e| anyhow::anyhow!("cannot start a pool of {n} threads: {e}"))
}
