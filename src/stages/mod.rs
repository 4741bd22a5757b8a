//! The pipeline stages, one module each, behind one small contract ([`Stage`]).
//!
//! A stage publishes its parameter table (with units, defaults and ranges), says what
//! inputs it takes, and turns a [`RunContext`] (resolved parameters of every sweep
//! point, replicate count, seed, input versions) into an [`Output`]. It knows nothing
//! of YAML, files or versions: the pipeline runner and the archive do that.
use crate::error::InvalidParam;
use crate::params::ParamCaution;
use crate::archive::data::{Attr, Output};
use crate::archive::{hdf, VersionInfo};
use crate::memory::Estimate;
use crate::params::{ParamSet, ParamSpec, ParamValue};
use anyhow::Result;
use ndarray::ArrayD;
use rand_chacha::ChaCha8Rng;

pub mod accuracy;
pub mod grid;
pub mod image;
pub mod laid_web;
pub mod laydown;
pub mod spectra;
pub mod web;

/// What upstream stages a stage accepts.
#[derive(Debug, Clone, Copy)]
pub struct InputRule {
    pub kinds: &'static [&'static str],
    pub min: usize,
    pub max: usize,
}

/// A stage as the pipeline declares it, with its inputs' declarations: what a memory
/// estimate ([`Stage::estimate_memory`]) is taken from before anything runs.
#[derive(Debug, Clone)]
pub struct Declared {
    pub name: String,
    pub kind: String,
    /// Resolved parameters of every sweep point.
    pub points: Vec<ParamSet>,
    pub replicates: usize,
    pub inputs: Vec<Declared>,
    /// Directory of the pipeline file (relative paths in parameters).
    pub pipeline_dir: std::path::PathBuf,
}

/// Threads that hold per-item buffers at once: rayon's pool, at most `items`.
pub fn concurrent(items: f64) -> f64 {
    (rayon::current_num_threads() as f64).min(items).max(1.0)
}

/// Laid fibres of one sweep point of an upstream stage, as declared (upper bounds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeclaredFibres {
    /// Fibres stored over every replicate.
    pub count: f64,
    /// Nodes per fibre.
    pub nodes: f64,
    /// Length per fibre (m).
    pub length: f64,
}

/// A stage's bad input is the crate's ([`crate::error`]).
pub use crate::error::BadInput;

/// Whether an estimate is the expected value or a bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    About,
    AtMost,
    AtLeast,
}

impl Bound {
    /// The bound of a sum of estimates with these bounds: at least (at most) when some are
    /// at least (at most) and none is the other way, otherwise about (the estimates that
    /// are "about" are taken as exact).
    pub fn of_sum(bounds: impl IntoIterator<Item = Bound>) -> Bound {
        let (mut least, mut most) = (false, false);
        for b in bounds {
            least |= b == Bound::AtLeast;
            most |= b == Bound::AtMost;
        }
        match (least, most) {
            (true, false) => Bound::AtLeast,
            (false, true) => Bound::AtMost,
            _ => Bound::About,
        }
    }

    /// "about", "at most" or "at least".
    pub fn words(self) -> &'static str {
        match self {
            Bound::About => "about",
            Bound::AtMost => "at most",
            Bound::AtLeast => "at least",
        }
    }
}

/// A stage's estimate of the CPU time of one replicate ([`Stage::estimate_cpu_time`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CpuTime {
    pub seconds: f64,
    /// How far to trust it: about, at least (the run may take several times longer, e.g.
    /// a laid web with fibre contact) or at most.
    pub bound: Bound,
    /// What lowers it, for the refusal above `--max-cpu-time`, e.g. "lower belt_travel,
    /// fibres_across or replicates".
    pub advice: String,
}

pub trait Stage: Send + Sync {
    /// The `kind:` that selects this stage in a pipeline.
    fn kind(&self) -> &'static str;
    /// One line for `--help` and the docs.
    fn summary(&self) -> &'static str;
    /// Bumped by hand to force a rerun that the code hash ([`code_hash`]) would not
    /// catch (e.g. a change in a dependency crate); part of the cache fingerprint.
    fn cache_version(&self) -> u32;
    fn params(&self) -> Vec<ParamSpec>;
    fn inputs(&self) -> InputRule;
    /// Checks that involve several parameters of one resolved point:
    /// `Err(InvalidParam::new(parameter, message))`.
    fn check(&self, _params: &ParamSet) -> std::result::Result<(), InvalidParam> {
        Ok(())
    }
    /// Valid settings of one resolved point known to give poor results, each a parameter
    /// and what to do instead: `validate` and `run` print them as warnings with the
    /// parameter's place in the file, and the stage still runs.
    fn cautions(&self, _params: &ParamSet) -> Vec<ParamCaution> {
        Vec::new()
    }
    /// The peak memory of a run of `stage` (its resolved sweep points and replicates,
    /// and its inputs as declared), with the parameters that drive it; `None` when the
    /// stage holds nothing large. Checked by `validate` and `run` before anything is
    /// computed ([`crate::memory`]).
    fn estimate_memory(&self, _stage: &Declared) -> Option<Estimate> {
        None
    }
    /// The CPU time one replicate of a resolved point is expected to take, from the
    /// parameters alone; `None` when the stage does not estimate it. `validate` prints
    /// each stage's total and `--max-cpu-time` refuses a stage above it
    /// ([`crate::run_time`]).
    fn estimate_cpu_time(&self, _params: &ParamSet) -> Option<CpuTime> {
        None
    }
    fn run(&self, ctx: &RunContext) -> Result<Output>;
    /// Files outside the archive that the run of one resolved parameter set reads
    /// (paths relative to `pipeline_dir` resolved). The runner hashes their contents
    /// into the fingerprint, so editing a file reruns the stage. A missing file or an
    /// empty glob is a [`BadInput`].
    fn input_files(&self, _params: &ParamSet, _pipeline_dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
        Ok(vec![])
    }
    /// Check, when the pipeline is validated, that the files named by the parameters
    /// exist (relative to `pipeline_dir`): `Err(InvalidParam::new(parameter such as files[1], message))`.
    fn check_files(&self, _params: &ParamSet, _pipeline_dir: &std::path::Path) -> Result<(), InvalidParam> {
        Ok(())
    }
    /// How the stage's work splits into units that can be computed apart (e.g. in
    /// different processes of a Slurm job array), or `None` (the default): the stage
    /// runs as a whole. A stage that returns `Some` implements [`Stage::run_units`] and
    /// [`Stage::reduce`], and its [`Stage::run`] is [`run_by_units`].
    fn units(&self, _ctx: &RunContext) -> Result<Option<Units>> {
        Ok(None)
    }
    /// Compute the units `range` (global unit indices, see [`Units`]) and return their
    /// per-replicate results: an output whose per-replicate variables have the leading
    /// dimension [`UNIT_DIM`] (one row per (point, replicate) computed, with the row's
    /// global point and replicate in the i64 variables `unit_point` and
    /// `unit_replicate`), and whose other variables and attributes do not depend on the
    /// range. The rows of consecutive ranges concatenated along [`UNIT_DIM`] (ragged
    /// trailing dimensions NaN-padded, [`crate::archive::gather::gather`]) equal the
    /// rows of the whole range.
    fn run_units(&self, _ctx: &RunContext, _range: std::ops::Range<usize>) -> Result<Output> {
        anyhow::bail!("stage kind `{}` cannot be run by units", self.kind())
    }
    /// Turn the rows of every unit (what [`Stage::run_units`] returns for the whole
    /// range, or the executor's gather of its parts) into the stage's output: the
    /// per-point statistics over replicates are computed here, by the same code for the
    /// local executor and for a gathered Slurm array.
    fn reduce(&self, _ctx: &RunContext, _rows: Output) -> Result<Output> {
        anyhow::bail!("stage kind `{}` cannot be run by units", self.kind())
    }
}

/// The hash of the source code that computes `kind` (its module and what it uses, see
/// [`crate::code_hash::STAGE_CODE`]), taken when this binary was built; part of every
/// stage fingerprint, so changed code reruns exactly the stages it computes.
pub fn code_hash(kind: &str) -> &'static str {
    match kind {
        "laydown" => env!("LAYDOWN_CODE_HASH_LAYDOWN"),
        "laid_web" => env!("LAYDOWN_CODE_HASH_LAID_WEB"),
        "spectra" => env!("LAYDOWN_CODE_HASH_SPECTRA"),
        "web" => env!("LAYDOWN_CODE_HASH_WEB"),
        "grid" => env!("LAYDOWN_CODE_HASH_GRID"),
        "image" => env!("LAYDOWN_CODE_HASH_IMAGE"),
        "accuracy" => env!("LAYDOWN_CODE_HASH_ACCURACY"),
        _ => "",
    }
}

/// The leading dimension of the per-replicate rows of [`Stage::run_units`].
pub const UNIT_DIM: &str = "unit";

/// A stage's units of work: `points` × `per_point`, numbered `u = point * per_point + k`.
/// With `per_point` = the stage's replicates, a unit is one (point, replicate); with
/// `per_point` = 1, a unit is a whole point with all its replicates (`note` says why).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Units {
    pub points: usize,
    pub per_point: usize,
    /// Why the replicates of a point are not separate units, when they are not.
    pub note: Option<&'static str>,
}

impl Units {
    pub fn count(&self) -> usize {
        self.points * self.per_point
    }
    /// The (point, replicate) of unit `u` when a unit is one replicate; (point, 0) for a
    /// whole point.
    pub fn split(&self, u: usize) -> (usize, usize) {
        (u / self.per_point, u % self.per_point)
    }
    /// The points that the units `a..b` touch (half-open).
    pub fn points_of(&self, a: usize, b: usize) -> (usize, usize) {
        (a / self.per_point, b.div_ceil(self.per_point))
    }
    /// What the units `a..b` are, for messages: `points 2..4`, `point 0 replicates 5..10`,
    /// `units 3..7 (points 1..3)`.
    pub fn describe(&self, a: usize, b: usize) -> String {
        let (p0, p1) = self.points_of(a, b);
        if self.per_point == 1 {
            if b == a + 1 {
                format!("point {a}")
            } else {
                format!("points {a}..{b}")
            }
        } else if p1 == p0 + 1 {
            format!("point {p0} replicates {}..{}", a - p0 * self.per_point, b - p0 * self.per_point)
        } else if a.is_multiple_of(self.per_point) && b.is_multiple_of(self.per_point) {
            format!("points {p0}..{p1}")
        } else {
            format!("units {a}..{b} (points {p0}..{p1})")
        }
    }
}

/// The local run of a stage that splits into units: all its units, then [`Stage::reduce`].
pub fn run_by_units(stage: &dyn Stage, ctx: &RunContext) -> Result<Output> {
    let units = stage.units(ctx)?.ok_or_else(|| anyhow::anyhow!("stage kind `{}` has no units", stage.kind()))?;
    let rows = stage.run_units(ctx, 0..units.count())?;
    stage.reduce(ctx, rows)
}

/// Reading the per-replicate rows of [`Stage::run_units`] back by name.
pub mod rows {
    use crate::archive::data::{Output, Values};
    use anyhow::{anyhow, bail, Result};
    use ndarray::ArrayD;

    fn var<'a>(rows: &'a Output, name: &str) -> Result<&'a Values> {
        rows.get(name).map(|v| &v.values).ok_or_else(|| anyhow!("the per-replicate rows lack `{name}`"))
    }
    pub fn f64<'a>(rows: &'a Output, name: &str) -> Result<&'a ArrayD<f64>> {
        match var(rows, name)? {
            Values::F64(a) => Ok(a),
            _ => bail!("`{name}` in the per-replicate rows is not f64"),
        }
    }
    pub fn i64<'a>(rows: &'a Output, name: &str) -> Result<&'a ArrayD<i64>> {
        match var(rows, name)? {
            Values::I64(a) => Ok(a),
            _ => bail!("`{name}` in the per-replicate rows is not i64"),
        }
    }
    pub fn u8<'a>(rows: &'a Output, name: &str) -> Result<&'a ArrayD<u8>> {
        match var(rows, name)? {
            Values::U8(a) => Ok(a),
            _ => bail!("`{name}` in the per-replicate rows is not a flag"),
        }
    }
    pub fn strings_nd<'a>(rows: &'a Output, name: &str) -> Result<&'a ArrayD<String>> {
        match var(rows, name)? {
            Values::Str(a) => Ok(a),
            _ => bail!("`{name}` in the per-replicate rows is not text"),
        }
    }
    pub fn strings<'a>(rows: &'a Output, name: &str) -> Result<&'a [String]> {
        match var(rows, name)? {
            Values::Str(a) if a.ndim() == 1 => a.as_slice().ok_or_else(|| anyhow::anyhow!("`{name}` in the per-replicate rows is not contiguous")),
            _ => bail!("`{name}` in the per-replicate rows is not 1-D text"),
        }
    }
    /// The row values of a per-row array `a` (rows, rest…) placed at (point,
    /// replicate): shape (npoints, nreps, rest…), `fill` where no row was computed.
    pub fn place<T: Clone>(a: &ArrayD<T>, index: &[(usize, usize)], npoints: usize, nreps: usize, fill: T) -> ArrayD<T> {
        use ndarray::Axis;
        let mut shape = vec![npoints, nreps];
        shape.extend_from_slice(&a.shape()[1..]);
        let mut out = ArrayD::from_elem(ndarray::IxDyn(&shape), fill);
        for (row, &(p, r)) in index.iter().enumerate() {
            out.index_axis_mut(Axis(0), p).index_axis_mut(Axis(0), r).assign(&a.index_axis(Axis(0), row));
        }
        out
    }

    /// The (point, replicate) of every row.
    pub fn index(rows: &Output) -> Result<Vec<(usize, usize)>> {
        let p = i64(rows, "unit_point")?;
        let r = i64(rows, "unit_replicate")?;
        Ok(p.iter().zip(r.iter()).map(|(&p, &r)| (p as usize, r as usize)).collect())
    }
}

/// Mean and sample standard deviation of `values` (NaN when empty; the standard
/// deviation of a single value is undefined: NaN, not 0).
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let var = if n > 1 { values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64 } else { f64::NAN };
    (mean, var.sqrt())
}

/// An upstream stage version a stage reads from.
#[derive(Clone)]
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

    /// The value of the input stage's numeric parameter `name` at each of its `points`
    /// points: its sweep coordinate (the variable whose `parameter` attribute is `name`)
    /// where it was swept, else its resolved value from the version's `params_yaml`.
    /// `None` when the input has no such parameter.
    pub fn parameter_per_point(&self, name: &str, points: usize) -> Result<Option<Vec<f64>>> {
        let g = self.version.open()?;
        for member in g.member_names()? {
            let Ok(ds) = g.dataset(&member) else { continue };
            let attrs = hdf::read_attrs(&ds)?;
            let own = !matches!(attrs.get("stage"), Some(Attr::Str(s)) if *s != self.name);
            if own && matches!(attrs.get("parameter"), Some(Attr::Str(p)) if p == name) {
                let values = hdf::read_f64(&g, &member)?;
                if values.ndim() != 1 || values.len() != points {
                    anyhow::bail!("{}: the sweep coordinate `{member}` of `{name}` has {} values for {points} points", self.version.group_path(), values.len());
                }
                return Ok(Some(values.iter().copied().collect()));
            }
        }
        let params: Option<serde_yaml_ng::Value> = self.version.attr_str("params_yaml").and_then(|t| serde_yaml_ng::from_str(t).ok());
        match params.as_ref().and_then(|p| p.get(name)) {
            Some(serde_yaml_ng::Value::Null) => anyhow::bail!("{}: parameter `{name}` is auto, with no value recorded", self.version.group_path()),
            Some(v) => Ok(v.as_f64().map(|v| vec![v; points])),
            None => Ok(None),
        }
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
    /// Where the files the stage hands over ([`Output::file`]) will be written once its
    /// version is committed: `<archive dir>/<archive stem>_figures/<stage>/v<N>`, N the
    /// version this run will become. A stage writes no file itself.
    pub figure_dir: std::path::PathBuf,
}

impl RunContext {
    /// The random stream of `item` within `replicate` ([`crate::rng`]): independent of
    /// thread count and of the order in which items are computed.
    pub fn rng(&self, replicate: usize, item: u64) -> ChaCha8Rng {
        crate::rng::stream_rng(self.seed, replicate as u64, item)
    }

    pub fn input(&self, index: usize) -> &Input {
        &self.inputs[index]
    }

    /// Run `f(point, replicate)` for the units `range` of (point, replicate) units
    /// (`replicates` per point) in parallel, counted on a progress bar; results come back
    /// in unit order whatever the thread count.
    pub fn par_units<T: Send>(&self, range: std::ops::Range<usize>, f: impl Fn(usize, usize) -> T + Sync + Send) -> Vec<T> {
        let reps = self.replicates;
        crate::progress::par_map_shown(self.progress, &format!("{} units", self.stage_name), range, |u| f(u / reps, u % reps))
    }
}

/// Every stage kind the pipeline knows.
pub fn registry() -> Vec<&'static dyn Stage> {
    vec![&laydown::LaydownStage, &laid_web::LaidWebStage, &spectra::SpectraStage, &web::WebStage, &grid::GridStage, &image::stage::ImageStage, &accuracy::AccuracyStage]
}

pub fn find(kind: &str) -> Option<&'static dyn Stage> {
    registry().into_iter().find(|s| s.kind() == kind)
}

pub fn kinds() -> Vec<&'static str> {
    registry().iter().map(|s| s.kind()).collect()
}

#[cfg(test)]
mod tests {
    use super::Bound::{About, AtLeast, AtMost};

    /// A sum is at least (at most) what its parts are only when none is bounded the other way.
    #[test]
    fn a_sum_of_estimates_keeps_a_bound_only_its_parts_share() {
        assert_eq!(super::Bound::of_sum([About, AtLeast, About]), AtLeast);
        assert_eq!(super::Bound::of_sum([AtMost, About]), AtMost);
        assert_eq!(super::Bound::of_sum([AtMost, AtLeast]), About);
        assert_eq!(super::Bound::of_sum([About]), About);
    }

    /// A parameter `a` and another `a.b` cannot both be written in YAML (`a` would be a
    /// value and a mapping at once); the JSON schema nests dotted names, so it could not
    /// describe such a pair either.
    #[test]
    fn no_parameter_name_is_a_group_of_another() {
        for stage in super::registry() {
            let names: Vec<&str> = stage.params().iter().map(|p| p.name).collect();
            for a in &names {
                for b in &names {
                    assert!(!b.starts_with(&format!("{a}.")), "{}: `{a}` and `{b}`", stage.kind());
                }
            }
        }
    }
}
