//! Pipeline files: parsing and checking YAML into a [`Pipeline`] of stage declarations.
//!
//! ```yaml
//! pipeline: quickstart
//! archive: results/quickstart.h5
//! seed: 42
//! stages:
//!   - name: spectra
//!     kind: spectra
//!     params: { source: idealised, preset: spectrum1 }
//!     sweep: { ... }          # optional: parameter -> list of values
//!     sweep_mode: cartesian   # or zip
//!     replicates: 1
//! ```
//! Every problem is reported with file, line, column, key path and what is allowed;
//! checking collects all problems rather than stopping at the first. Last, every
//! stage's memory estimate is checked against the [`Limit`] (see [`crate::memory`]).
mod check;
pub mod dag;
pub mod executor_config;
pub mod inputs;
pub mod stage_run;
pub mod yaml;

pub use executor_config::{ExecutorConfig, ExecutorKind};
use crate::memory::{format_size, Limit, PROCESS_BYTES};
use crate::params::{ParamSet, ParamSpec, ParamValue};
use crate::stages;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};
use yaml::Pos;

/// One problem in a pipeline file.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    pub file: String,
    pub pos: Pos,
    /// Key path such as `stages[1].params.diameter`.
    pub key: String,
    pub message: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}:{}:{}: {}", self.file, self.pos.line, self.pos.col, self.message)
        } else {
            write!(f, "{}:{}:{}: {}: {}", self.file, self.pos.line, self.pos.col, self.key, self.message)
        }
    }
}

/// All problems found in a pipeline file.
#[derive(Debug, Clone)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "error: {d}")?;
        }
        Ok(())
    }
}
impl std::error::Error for Diagnostics {}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepMode {
    /// Every combination of the listed values.
    Cartesian,
    /// The i-th values of every list together (lists of equal length).
    Zip,
}

/// One stage as declared in the pipeline, checked against its kind's parameter table.
#[derive(Debug, Clone)]
pub struct StageDecl {
    pub name: String,
    pub kind: String,
    pub inputs: Vec<String>,
    /// Parameters with every default filled in (the base of every sweep point).
    pub params: ParamSet,
    pub sweep: Vec<(String, Vec<ParamValue>)>,
    pub sweep_mode: SweepMode,
    pub replicates: usize,
    /// Seed override for this stage; the pipeline seed otherwise.
    pub seed: Option<u64>,
    pub pos: Pos,
}

impl StageDecl {
    /// Which item of `param`'s sweep list point `point` of [`StageDecl::points`] takes, or
    /// `None` when `param` is not swept.
    pub fn sweep_item(&self, point: usize, param: &str) -> Option<usize> {
        let k = self.sweep.iter().position(|(n, _)| n == param)?;
        Some(match self.sweep_mode {
            SweepMode::Zip => point,
            // the last list varies fastest
            SweepMode::Cartesian => point / self.sweep[k + 1..].iter().map(|(_, v)| v.len()).product::<usize>() % self.sweep[k].1.len(),
        })
    }

    /// The parameter sets of all sweep points, in sweep order (last parameter fastest
    /// for cartesian products), with each point's swept values.
    pub fn points(&self) -> (Vec<ParamSet>, Vec<(String, Vec<ParamValue>)>) {
        if self.sweep.is_empty() {
            return (vec![self.params.clone()], vec![]);
        }
        let combos: Vec<Vec<usize>> = match self.sweep_mode {
            SweepMode::Zip => (0..self.sweep[0].1.len()).map(|i| vec![i; self.sweep.len()]).collect(),
            SweepMode::Cartesian => {
                let mut combos = vec![vec![]];
                for (_, values) in &self.sweep {
                    combos = combos
                        .into_iter()
                        .flat_map(|c| (0..values.len()).map(move |i| [c.clone(), vec![i]].concat()))
                        .collect();
                }
                combos
            }
        };
        let mut coords: Vec<(String, Vec<ParamValue>)> = self.sweep.iter().map(|(n, _)| (n.clone(), vec![])).collect();
        let points = combos
            .iter()
            .map(|combo| {
                let mut p = self.params.clone();
                for (k, &i) in combo.iter().enumerate() {
                    let (name, values) = &self.sweep[k];
                    p.0.insert(name.clone(), values[i].clone());
                    coords[k].1.push(values[i].clone());
                }
                p
            })
            .collect();
        (points, coords)
    }

    /// Canonical description of the sweep (part of the fingerprint and provenance).
    pub fn sweep_yaml(&self) -> String {
        if self.sweep.is_empty() {
            return String::new();
        }
        let mode = match self.sweep_mode {
            SweepMode::Cartesian => "cartesian",
            SweepMode::Zip => "zip",
        };
        let mut s = format!("mode: {mode}\n");
        for (name, values) in &self.sweep {
            let vs: Vec<String> = values.iter().map(|v| v.to_string()).collect();
            s.push_str(&format!("{name}: [{}]\n", vs.join(", ")));
        }
        s
    }
}

#[derive(Debug, Clone)]
pub struct Pipeline {
    pub file: PathBuf,
    pub name: String,
    /// Absolute: `archive:` is relative to the pipeline file's directory.
    pub archive: PathBuf,
    pub seed: u64,
    pub description: String,
    pub stages: Vec<StageDecl>,
    /// Where stages run (`executor:`; local by default).
    pub executor: ExecutorConfig,
    /// Valid settings that are known to give poor results ([`crate::stages::Stage::cautions`]),
    /// with their place in the file: `validate` and `run` print them as warnings.
    pub warnings: Vec<Diagnostic>,
}

impl Pipeline {
    pub fn stage(&self, name: &str) -> Option<&StageDecl> {
        self.stages.iter().find(|s| s.name == name)
    }

    /// Stage names in an order where every stage comes after its inputs (file order
    /// otherwise).
    pub fn topological_order(&self) -> Vec<String> {
        let mut done: Vec<String> = vec![];
        while done.len() < self.stages.len() {
            let before = done.len();
            for s in &self.stages {
                if !done.contains(&s.name) && s.inputs.iter().all(|i| done.contains(i)) {
                    done.push(s.name.clone());
                }
            }
            assert!(done.len() > before, "cycle slipped through validation");
        }
        done
    }

    /// Stages downstream of `name` (including itself), in topological order.
    pub fn downstream(&self, name: &str) -> Vec<String> {
        let mut set = vec![name.to_string()];
        for s in self.topological_order() {
            if self.stage(&s).unwrap().inputs.iter().any(|i| set.contains(i)) && !set.contains(&s) {
                set.push(s);
            }
        }
        self.topological_order().into_iter().filter(|s| set.contains(s)).collect()
    }
}

/// Read and check a pipeline file, its stages' memory against the available memory.
pub fn load(path: &Path) -> Result<Pipeline, Diagnostics> {
    load_with(path, Limit::Available)
}

/// [`load`] with the memory limit given.
pub fn load_with(path: &Path, limit: Limit) -> Result<Pipeline, Diagnostics> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| {
        Diagnostics(vec![Diagnostic {
            file: file.clone(),
            pos: Pos { line: 0, col: 0 },
            key: String::new(),
            message: format!("cannot read the pipeline file: {e}"),
        }])
    })?;
    parse_with(&text, path, limit)
}

/// Check pipeline text (`path` is used in messages and kept in the result).
pub fn parse(text: &str, path: &Path) -> Result<Pipeline, Diagnostics> {
    parse_with(text, path, Limit::Available)
}

/// [`parse`] with the memory limit given.
pub fn parse_with(text: &str, path: &Path, limit: Limit) -> Result<Pipeline, Diagnostics> {
    check::check(text, path, limit)
}
