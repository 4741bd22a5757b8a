//! `kind: laydown`: one fibre fed onto a moving belt per (sweep point, replicate), the
//! paper's §2 scene. The physics lives in [`crate::rod`] (shared with `laid_web`); this
//! module is the pipeline stage around it and re-exports the physics API.
//!
//! # Ten valid replicates per point
//! The stage parameter `valid_replicates_target` = T (the paper: 10) draws replicates
//! beyond `replicates`, each with the random stream it would have with a larger
//! `replicates`, in rounds sized from earlier results only, until T are valid or
//! `max_replicates` were attempted (shortfall in `valid_shortfall`). Every attempt is
//! stored; `used` marks the first T valid ones, over which means and standard
//! deviations are taken. Identical for 1 and 2 threads (tested).
//!
//! # Measured numbers
//! Cost, accuracy against the explicit reference, mesh convergence, the Figures 5-6
//! trends and the hard cases, with the commands that produced them, are in
//! `pipelines/paper/LAYDOWN_MEASUREMENTS.md`. Tests:
//! `cargo test --release --lib stages::laydown`; manual ensembles:
//! `cargo run --release --example laydown_ensemble`.

#[cfg(test)]
mod tests;

pub use crate::rod::{
    contact, forces, integrator, metrics, params, parameter_table_markdown, prepared_simulator, replicate_rng, run_jobs, scene,
    shape_measures, simulate, stable_time_step, laid_polyline, BounceCheck, Effects, EnergySample, Integrator, LaydownJob,
    LaydownParams, LaydownResult, ParamError, Simulator, Snapshot, TimeStepLimits, Work, PARAMETERS,
};

mod stage;
pub use stage::{declared_fibres, scene, LaydownStage, LaydownStageParams, SIM_BYTES_PER_NODE};
