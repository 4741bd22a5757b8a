//! The default executor: every unit in this process, in parallel on all cores (rayon,
//! through [`crate::stages::RunContext::par_units`]). Nothing about Slurm is needed.
use crate::archive::data::{Attr, Output};
use crate::stages::{RunContext, Stage};
use anyhow::Result;
use std::collections::BTreeMap;

pub fn run_stage(stage: &dyn Stage, ctx: &RunContext) -> Result<(Output, BTreeMap<String, Attr>)> {
    Ok((stage.run(ctx)?, BTreeMap::new()))
}
