//! The pipeline stages, one module each, behind one small contract ([`Stage`]).
//!
//! A stage publishes its parameter table (with units, defaults and ranges), says what
//! inputs it takes, and turns a [`RunContext`] (resolved parameters of every sweep
//! point, replicate count, seed, input versions) into an [`Output`]. It knows nothing
//! of YAML, files or versions: the pipeline runner and the archive do that.
use crate::archive::data::Output;
use crate::archive::{hdf, VersionInfo};
use crate::params::{ParamSet, ParamSpec, ParamValue};
use anyhow::Result;
use ndarray::ArrayD;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

pub mod accuracy;
pub mod grid;
pub mod image;
pub mod laydown;
pub mod param_table;
pub mod spectra;
pub mod web;

/// What upstream stages a stage accepts.
#[derive(Debug, Clone, Copy)]
pub struct InputRule {
    pub kinds: &'static [&'static str],
    pub min: usize,
    pub max: usize,
}

/// A problem with the user's input found while running (exit code 2), as opposed to
/// a runtime failure (exit code 1).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

pub trait Stage: Send + Sync {
    /// The `kind:` that selects this stage in a pipeline.
    fn kind(&self) -> &'static str;
    /// One line for `--help` and the docs.
    fn summary(&self) -> &'static str;
    /// Bumped whenever the stage's results for the same parameters would change;
    /// part of the cache fingerprint.
    fn cache_version(&self) -> u32;
    fn params(&self) -> Vec<ParamSpec>;
    fn inputs(&self) -> InputRule;
    /// Checks that involve several parameters of one resolved point:
    /// `Err((parameter, message))`.
    fn check(&self, _params: &ParamSet) -> std::result::Result<(), (String, String)> {
        Ok(())
    }
    fn run(&self, ctx: &RunContext) -> Result<Output>;
    /// Files outside the archive that the run of one resolved parameter set reads
    /// (paths relative to `pipeline_dir` resolved). The runner hashes their contents
    /// into the fingerprint, so editing a file reruns the stage. A missing file or an
    /// empty glob is a [`BadInput`].
    fn input_files(&self, _params: &ParamSet, _pipeline_dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
        Ok(vec![])
    }
    /// Dimensions of this stage's output that stack the sweep points (a variable whose
    /// first dimension is one of them holds one slice per point, in point order), when
    /// the stage's points can be computed separately and concatenated: that is what
    /// lets an executor split the stage over processes (e.g. a Slurm job array). Empty
    /// (the default): the stage runs as a whole.
    fn point_dims(&self) -> &'static [&'static str] {
        &[]
    }
    /// How many sweep points the stage computes: its own, unless it takes them from its
    /// input (a grid of a swept web). An executor splits this range.
    fn point_count(&self, ctx: &RunContext) -> Result<usize> {
        Ok(ctx.points.len())
    }
}

/// An upstream stage version a stage reads from.
pub struct Input {
    pub name: String,
    pub kind: String,
    pub version: VersionInfo,
}

impl Input {
    pub fn read_f64(&self, name: &str) -> Result<ArrayD<f64>> {
        let g = self.version.open()?;
        hdf::read_f64(&g, name)
    }
    pub fn read_i64(&self, name: &str) -> Result<ArrayD<i64>> {
        let g = self.version.open()?;
        hdf::read_i64(&g, name)
    }
    pub fn read_u8(&self, name: &str) -> Result<ArrayD<u8>> {
        let g = self.version.open()?;
        hdf::read_u8(&g, name)
    }
    pub fn read_strings(&self, name: &str) -> Result<Vec<String>> {
        let g = self.version.open()?;
        hdf::read_strings(&g, name)
    }
    pub fn has(&self, name: &str) -> bool {
        self.version.open().map(|f| f.link_exists(name)).unwrap_or(false)
    }
}

/// Everything a stage run needs.
pub struct RunContext {
    pub stage_name: String,
    /// Resolved parameters, one set per sweep point (one point without a sweep).
    pub points: Vec<ParamSet>,
    /// Swept parameter names and their value at each point.
    pub sweep: Vec<(String, Vec<ParamValue>)>,
    pub replicates: usize,
    pub seed: u64,
    pub inputs: Vec<Input>,
    /// Show progress bars (stderr is a terminal).
    pub progress: bool,
    /// Directory of the pipeline file: relative paths in parameters are relative to it.
    pub pipeline_dir: std::path::PathBuf,
    /// Where this run may write figures: `<archive dir>/<archive stem>_figures/<stage>/v<N>`
    /// with N the version this run will become. Not created by the runner.
    pub figure_dir: std::path::PathBuf,
    /// Global index of `points[0]` in the stage's whole sweep: non-zero when an
    /// executor runs a share of the points ([`RunContext::restrict`]). Anything keyed
    /// by the point (random streams, file names) must use [`RunContext::point_index`].
    pub point_offset: usize,
    /// Set by [`RunContext::restrict`]: the global points `a..b` this run computes. A
    /// stage whose points come from its input (see [`Stage::point_count`]) computes only
    /// these; for the others `points` is already cut to them.
    pub point_range: Option<(usize, usize)>,
}

impl RunContext {
    /// The random stream of `item` within `replicate` (see provenance::RNG_SCHEME):
    /// independent of thread count and of the order in which items are computed.
    pub fn rng(&self, replicate: usize, item: u64) -> ChaCha8Rng {
        stream_rng(self.seed, replicate as u64, item)
    }

    /// Global sweep index of the local point `local` (`points[local]`).
    pub fn point_index(&self, local: usize) -> usize {
        self.point_offset + local
    }

    /// The same run restricted to the global points `a..b` (their indices kept). A
    /// stage's own sweep points are cut to the range; a single point is kept whole (the
    /// stage may take its points from its input and reads [`RunContext::point_range`]).
    pub fn restrict(mut self, a: usize, b: usize) -> Self {
        if self.points.len() > 1 {
            let a0 = a - self.point_offset;
            let b0 = b - self.point_offset;
            self.points = self.points[a0..b0].to_vec();
            for (_, values) in self.sweep.iter_mut() {
                *values = values[a0..b0].to_vec();
            }
        }
        self.point_offset = a;
        self.point_range = Some((a, b));
        self
    }

    pub fn input(&self, index: usize) -> &Input {
        &self.inputs[index]
    }

    /// Run `f(point, replicate)` for every unit in parallel; results come back in
    /// (point, replicate) order whatever the thread count.
    pub fn par_units<T: Send>(&self, f: impl Fn(usize, usize) -> T + Sync + Send) -> Vec<T> {
        let n = self.points.len() * self.replicates;
        let bar = crate::progress::bar(self.progress, n as u64, &format!("{} units", self.stage_name));
        let out = (0..n)
            .into_par_iter()
            .map(|u| {
                let r = f(u / self.replicates, u % self.replicates);
                bar.inc(1);
                r
            })
            .collect();
        bar.finish_and_clear();
        out
    }
}

/// ChaCha8Rng keyed by blake3("laydown-rng-v1" | seed | replicate), on stream `item`.
pub fn stream_rng(seed: u64, replicate: u64, item: u64) -> ChaCha8Rng {
    let mut h = blake3::Hasher::new();
    h.update(b"laydown-rng-v1");
    h.update(&seed.to_le_bytes());
    h.update(&replicate.to_le_bytes());
    let mut rng = ChaCha8Rng::from_seed(*h.finalize().as_bytes());
    rng.set_stream(item);
    rng
}

/// Every stage kind the pipeline knows.
pub fn registry() -> Vec<&'static dyn Stage> {
    vec![&laydown::LaydownStage, &spectra::SpectraStage, &web::WebStage, &grid::GridStage, &image::stage::ImageStage, &accuracy::AccuracyStage]
}

pub fn find(kind: &str) -> Option<&'static dyn Stage> {
    registry().into_iter().find(|s| s.kind() == kind)
}

pub fn kinds() -> Vec<&'static str> {
    registry().iter().map(|s| s.kind()).collect()
}
