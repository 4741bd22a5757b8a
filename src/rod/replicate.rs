//! One replicate of the laydown scene by either start ([`Start`]), and batches of
//! replicates in parallel. `start: vertical` is the paper's scene ([`super::scene`]),
//! `start: fed` a continuous feed ([`super::feed`]); both give a [`LaydownResult`].

use super::feed::simulate_fed;
use super::metrics::LaydownResult;
use super::params::{LaydownParams, Start};
use super::scene::{replicate_rng, simulate_vertical};
use rand::Rng;
use rayon::prelude::*;

/// Run one replicate. Imperfections are drawn from `rng` (in practice a `ChaCha8Rng`
/// per replicate, see [`replicate_rng`]). Never panics on bad input: errors are
/// reported in [`LaydownResult::error`].
pub fn simulate<R: Rng + ?Sized>(params: &LaydownParams, rng: &mut R) -> LaydownResult {
    if let Err(e) = params.validate() {
        return LaydownResult::failed(e.to_string());
    }
    match params.start {
        Start::Vertical => simulate_vertical(params, rng),
        Start::Fed => simulate_fed(params, rng),
    }
}

/// One (parameter point, replicate) job.
#[derive(Clone, Debug)]
pub struct LaydownJob {
    pub params: LaydownParams,
    pub seed: u64,
    pub replicate: u64,
}

/// Run jobs in parallel on the current rayon pool; results come back in job order and
/// are identical for any number of threads (each job owns its RNG).
pub fn run_jobs(jobs: &[LaydownJob]) -> Vec<LaydownResult> {
    jobs.par_iter().map(|j| simulate(&j.params, &mut replicate_rng(j.seed, j.replicate))).collect()
}
