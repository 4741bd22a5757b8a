//! Runs a pipeline against its archive: decides for every stage whether a complete
//! version with the same fingerprint exists (`up to date (v3)`) or why it must run
//! (`params.diameter changed 5e-05 -> 2e-05`, `input fibre v1 -> v2`, `new stage`),
//! runs what must run, and writes each result as a new version with provenance.
//!
//! The fingerprint of a stage run ([`crate::pipeline::stage_run::fingerprint`]) is blake3
//! over: kind, cache_version, the hash of the stage code ([`stages::code_hash`], `code of
//! grid changed`), canonical parameters (defaults filled in), sweep, replicates, seed, and
//! the content hashes of the input versions. Equal fingerprints mean equal results
//! (stages are deterministic).
//!
//! A version is used only once its datasets match the hashes stored with it
//! ([`VersionInfo::verify`]): a damaged up-to-date version is computed again (and the
//! reason says so), a damaged input of a stage that must run is an error.
//!
//! Each run marks, per stage, the version it matched or wrote as current (`Marks`,
//! `Archive::current`); stages outside an `--only`/`--from` selection use their current
//! version and say why it is out of date when it is. A dry run makes the same decisions
//! without computing or writing (`Decision::dry_run`).
use crate::archive::data::{Attr, Output};
use crate::archive::{provenance, Archive, Integrity, VersionInfo};
use crate::pipeline::stage_run::{fingerprint, pipeline_dir, stage_context};
use crate::pipeline::{Pipeline, StageDecl};
use crate::stages::{self, BadInput};
use anyhow::{anyhow, Result};
use std::collections::BTreeMap;
use std::time::Instant;

#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Run only these stages (in pipeline order), on the current versions of their
    /// other inputs; empty: no such selection.
    pub only: Vec<String>,
    /// Recompute this stage (as with `force`) and run everything downstream of it.
    pub from: Option<String>,
    /// Ignore the cache for these stages.
    pub force: Vec<String>,
    pub progress: bool,
    /// Where stages run; `None`: the pipeline file's `executor:` (local by default).
    pub executor: Option<crate::executor::ExecutorConfig>,
    /// Say what would run and why; compute and write nothing.
    pub dry_run: bool,
}

/// Why a run failed: bad input (exit 2) or a runtime failure (exit 1).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    BadInput(String),
    #[error("{0:#}")]
    Runtime(anyhow::Error),
}

impl RunError {
    pub fn exit_code(&self) -> i32 {
        match self {
            RunError::BadInput(_) => 2,
            RunError::Runtime(_) => 1,
        }
    }
}

fn classify(e: anyhow::Error) -> RunError {
    if let Some(b) = e.downcast_ref::<BadInput>() {
        RunError::BadInput(b.0.clone())
    } else {
        RunError::Runtime(e)
    }
}

/// What happened to one stage.
#[derive(Debug, Clone)]
pub struct StageReport {
    pub stage: String,
    pub kind: String,
    /// The version used or written (0: a dry run's stage that would run).
    pub version: u32,
    /// `None` when up to date, otherwise why it ran (or would run).
    pub ran_because: Option<String>,
    /// Wall time of the computation, as in provenance `wall_seconds` (0 for a stage not computed).
    pub wall_seconds: f64,
    pub outcome: Outcome,
    /// Sweep points and replicates per point, as declared.
    pub points: usize,
    pub replicates: usize,
}

impl StageReport {
    fn new(decl: &StageDecl, version: u32, ran_because: Option<String>, wall_seconds: f64, outcome: Outcome) -> StageReport {
        StageReport {
            stage: decl.name.clone(),
            kind: decl.kind.clone(),
            version,
            ran_because,
            wall_seconds,
            outcome,
            points: decl.points().0.len(),
            replicates: decl.replicates,
        }
    }

    /// The version's group in the archive (`/grid/v2`), if it has one.
    pub fn group(&self) -> Option<String> {
        (self.version > 0).then(|| format!("/{}/v{}", self.stage, self.version))
    }
}

/// What a run did with a stage (`run --json`'s `outcome`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Up to date: an existing version was used.
    Reused,
    /// Computed and written as a new version.
    Computed,
    /// Not selected (`--only`, `--from`): an existing version was used as it is.
    NotSelected,
    /// Dry run: would be computed.
    WouldRun,
    /// Dry run: cannot run (an input has no version).
    CannotRun,
}

impl Outcome {
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Reused => "reused",
            Outcome::Computed => "computed",
            Outcome::NotSelected => "not_selected",
            Outcome::WouldRun => "would_run",
            Outcome::CannotRun => "cannot_run",
        }
    }
}

/// The reason when nothing that [`reason`] compares differs.
const NO_MATCH: &str = "no complete version with this fingerprint";

/// Human reason why `decl` differs from the previous version `prev`.
fn reason(
    decl: &StageDecl,
    cache_version: u32,
    seed: u64,
    inputs: &[(String, u32)],
    files: &[(String, String)],
    prev: Option<&VersionInfo>,
) -> String {
    let Some(prev) = prev else { return "new stage".into() };
    let mut why = vec![];
    if prev.attr_str("stage_kind") != Some(decl.kind.as_str()) {
        why.push(format!("kind {} -> {}", prev.attr_str("stage_kind").unwrap_or("?"), decl.kind));
    }
    let prev_cache = prev.attr_f64("cache_version").unwrap_or(-1.0) as i64;
    if prev_cache != cache_version as i64 {
        why.push(format!("stage code changed (cache_version {prev_cache} -> {cache_version})"));
    }
    match prev.attr_str("code_hash") {
        Some(c) if c == stages::code_hash(&decl.kind) => {}
        Some(_) => why.push(format!("code of {} changed", decl.kind)),
        None => why.push(format!("code of {} changed (v{} has no code hash: written by an older laydown)", decl.kind, prev.number)),
    }
    let old: BTreeMap<String, String> = flatten_yaml(prev.attr_str("params_yaml").unwrap_or(""));
    let new: BTreeMap<String, String> = flatten_yaml(&decl.params.canonical_yaml());
    for (k, v) in &new {
        match old.get(k) {
            Some(o) if o != v => why.push(format!("params.{k} changed {o} -> {v}")),
            None => why.push(format!("params.{k} is new ({v})")),
            _ => {}
        }
    }
    for k in old.keys().filter(|k| !new.contains_key(*k)) {
        why.push(format!("params.{k} removed"));
    }
    if prev.attr_str("sweep_yaml").unwrap_or("") != decl.sweep_yaml() {
        why.push("sweep changed".into());
    }
    let prev_reps = prev.attr_f64("replicates").unwrap_or(-1.0) as i64;
    if prev_reps != decl.replicates as i64 {
        why.push(format!("replicates {prev_reps} -> {}", decl.replicates));
    }
    let prev_seed = prev.attr_str("seed").unwrap_or("?").to_string();
    if prev_seed != seed.to_string() {
        why.push(format!("seed {prev_seed} -> {seed}"));
    }
    let prev_inputs = prev.attr_str("inputs").unwrap_or("");
    for (name, v) in inputs {
        let old = prev_inputs
            .lines()
            .find_map(|l| l.strip_prefix(&format!("/{name}/v")).and_then(|r| r.split_whitespace().next()).map(|s| s.to_string()));
        match old {
            Some(o) if o != v.to_string() => why.push(format!("input {name} v{o} -> v{v}")),
            Some(_) => {}
            None => why.push(format!("input {name} is new (v{v})")),
        }
    }
    let old_files: BTreeMap<&str, &str> =
        prev.attr_str("input_files").unwrap_or("").lines().filter_map(|l| l.rsplit_once(" blake3=")).collect();
    let mut changed = vec![];
    for (path, hash) in files {
        match old_files.get(path.as_str()) {
            Some(o) if o != hash => changed.push(format!("{path} changed")),
            Some(_) => {}
            None => changed.push(format!("{path} is new")),
        }
    }
    let now: Vec<&str> = files.iter().map(|(p, _)| p.as_str()).collect();
    changed.extend(old_files.keys().filter(|p| !now.contains(p)).map(|p| format!("{p} removed")));
    if !changed.is_empty() {
        let n = changed.len();
        changed.truncate(3);
        let more = if n > 3 { format!(" and {} more", n - 3) } else { String::new() };
        why.push(format!("input files: {}{more}", changed.join(", ")));
    }
    if why.is_empty() {
        why.push(NO_MATCH.into());
    }
    why.join(", ")
}

/// (path, blake3 of the content) of each file, in the given order. Paths are shown
/// relative to the pipeline's directory, so the fingerprint does not depend on the
/// working directory the pipeline is run from.
fn hash_files(files: &[std::path::PathBuf], dir: &std::path::Path) -> Result<Vec<(String, String)>> {
    files
        .iter()
        .map(|p| {
            let mut h = blake3::Hasher::new();
            let f = std::fs::File::open(p).map_err(|e| anyhow!("cannot read {}: {e}", p.display()))?;
            h.update_reader(f).map_err(|e| anyhow!("cannot read {}: {e}", p.display()))?;
            let shown = p.strip_prefix(dir).unwrap_or(p);
            Ok((shown.display().to_string(), h.finalize().to_hex()[..32].to_string()))
        })
        .collect()
}

fn files_attr(files: &[(String, String)]) -> String {
    files.iter().map(|(p, h)| format!("{p} blake3={h}")).collect::<Vec<_>>().join("\n")
}

/// `a: {b: 1}` → {"a.b": "1"}, for comparing canonical parameter YAML.
fn flatten_yaml(text: &str) -> BTreeMap<String, String> {
    fn walk(prefix: &str, v: &serde_yaml_ng::Value, out: &mut BTreeMap<String, String>) {
        match v {
            serde_yaml_ng::Value::Mapping(m) => {
                for (k, v) in m {
                    let k = k.as_str().unwrap_or("?");
                    let name = if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
                    walk(&name, v, out);
                }
            }
            serde_yaml_ng::Value::Number(n) => {
                let s = match n.as_f64() {
                    Some(f) if n.is_f64() => crate::params::format_float(f),
                    _ => n.to_string(),
                };
                out.insert(prefix.to_string(), s);
            }
            serde_yaml_ng::Value::Null => {
                out.insert(prefix.to_string(), "auto".into());
            }
            other => {
                let s = serde_yaml_ng::to_string(other).unwrap_or_default();
                out.insert(prefix.to_string(), s.trim().to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    if let Ok(v) = serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text) {
        walk("", &v, &mut out);
    }
    out
}

/// The `current` marks of the archive (`Archive::current`) as this run moves them: a
/// stage's mark moves to the version the run matched or wrote. Marks of stages that
/// were matched wait in `pending` and are committed with the next version written, or
/// at the end of the run ([`run`]), so every mark is written crash-safely in a commit.
struct Marks {
    stored: BTreeMap<String, u32>,
    pending: BTreeMap<String, u32>,
}

impl Marks {
    fn get(&self, stage: &str) -> Option<u32> {
        self.pending.get(stage).or(self.stored.get(stage)).copied()
    }

    /// Mark `number` current; returns the previously current version if it was another.
    fn set(&mut self, stage: &str, number: u32) -> Option<Option<u32>> {
        let before = self.get(stage);
        if self.stored.get(stage) == Some(&number) {
            self.pending.remove(stage);
        } else {
            self.pending.insert(stage.to_string(), number);
        }
        (before != Some(number)).then_some(before)
    }

    /// The pending marks were committed.
    fn committed(&mut self) {
        self.stored.extend(std::mem::take(&mut self.pending));
    }
}

/// `, now current (was v2)` when matching a version moved the stage's mark (`, now
/// current` in an archive without marks).
fn moved(stage: &str, number: u32, marks: &mut Marks) -> String {
    match marks.set(stage, number) {
        Some(Some(before)) => format!(", now current (was v{before})"),
        Some(None) => ", now current".to_string(),
        None => String::new(),
    }
}

/// The stage's current version among `complete` (the newest in archives without marks).
fn current_of<'a>(stage: &str, complete: &[&'a VersionInfo], marks: &Marks) -> Option<&'a VersionInfo> {
    match marks.get(stage) {
        Some(n) => complete.iter().find(|v| v.number == n).copied(),
        None => complete.last().copied(),
    }
}

/// Run the pipeline; prints the absolute archive path, then one line per stage, to
/// stdout. With `opts.dry_run`, says what would run and why, and computes and writes
/// nothing. Marks every stage's current version (see `Marks`), also when a later
/// stage fails.
pub fn run(pipeline: &Pipeline, opts: &RunOptions) -> Result<Vec<StageReport>, RunError> {
    for name in opts.only.iter().chain(opts.from.iter()).chain(opts.force.iter()) {
        if pipeline.stage(name).is_none() {
            let names: Vec<&str> = pipeline.stages.iter().map(|s| s.name.as_str()).collect();
            return Err(RunError::BadInput(format!(
                "{}: no stage named `{name}`; allowed: {}",
                pipeline.file.display(),
                names.join(", ")
            )));
        }
    }
    let selected: Vec<String> = match &opts.from {
        _ if !opts.only.is_empty() => opts.only.clone(),
        Some(from) => pipeline.downstream(from),
        None => pipeline.topological_order(),
    };
    let archive = if opts.dry_run { Archive::open_if_exists(&pipeline.archive) } else { Archive::open_write(&pipeline.archive) }
        .map_err(RunError::Runtime)?;
    let mut marks = Marks { stored: archive.current_marks().map_err(RunError::Runtime)?, pending: BTreeMap::new() };
    crate::status!("archive: {}{}", archive.path.display(), if opts.dry_run { " (dry run: nothing is computed or written)" } else { "" });
    let result = run_stages(pipeline, opts, &archive, &selected, &mut marks);
    if opts.dry_run || marks.pending.is_empty() {
        return result;
    }
    let named: Vec<String> = marks.pending.iter().map(|(s, n)| format!("{s} v{n}")).collect();
    let flushed = archive
        .mark_current(
            &format!("laydown archive of pipeline {}", pipeline.name),
            &marks.pending,
            &format!("{} laydown run {}: current {}", provenance::utc_now(), pipeline.file.display(), named.join(", ")),
        )
        .map_err(RunError::Runtime);
    match (result, flushed) {
        (Ok(r), Ok(())) => Ok(r),
        (Ok(_), Err(e)) => Err(e),
        (Err(e), Ok(())) => Err(e),
        (Err(e), Err(f)) => {
            eprintln!("warning: the current versions of {} could not be marked: {f}", named.join(", "));
            Err(e)
        }
    }
}

/// [`run`]'s stages, in topological order, on an open archive.
fn run_stages(pipeline: &Pipeline, opts: &RunOptions, archive: &Archive, selected: &[String], marks: &mut Marks) -> Result<Vec<StageReport>, RunError> {
    let mut chosen: BTreeMap<String, VersionInfo> = BTreeMap::new();
    // Why the version chosen for a stage is out of date (a stage outside the selection,
    // or one run on such a version).
    let mut stale: BTreeMap<String, String> = BTreeMap::new();
    // Dry run: the stages that would run (their results, hence their content, are unknown).
    let mut would_run: std::collections::BTreeSet<String> = Default::default();
    // Versions checked against their stored hashes (or written) in this run.
    let mut verified: std::collections::BTreeSet<String> = Default::default();
    let mut reports = vec![];

    for name in pipeline.topological_order() {
        let decl = pipeline.stage(&name).unwrap();
        let stage = stages::find(&decl.kind).expect("validated kind");
        let seed = decl.seed.unwrap_or(pipeline.seed);
        let versions = archive.versions(&name).map_err(RunError::Runtime)?;
        let complete: Vec<&VersionInfo> = versions.iter().filter(|v| v.is_complete()).collect();

        // Inputs: the versions chosen for upstream stages in this run.
        let inputs: Option<Vec<VersionInfo>> = decl.inputs.iter().map(|inp| chosen.get(inp).cloned()).collect();
        // Files outside the archive (image scans): their content hashes join the inputs.
        let pipeline_dir = pipeline_dir(pipeline);
        let files = match stage.input_files(&decl.params, &pipeline_dir) {
            Ok(f) => hash_files(&f, &pipeline_dir).map_err(|e| RunError::BadInput(format!("stage `{name}`: {e:#}"))),
            Err(e) => Err(match classify(e) {
                RunError::BadInput(m) => RunError::BadInput(format!("stage `{name}`: {m}")),
                RunError::Runtime(e) => RunError::Runtime(e.context(format!("stage `{name}`"))),
            }),
        };
        let files = match files {
            Ok(f) => f,
            // A stage that is not run does not need its files.
            Err(_) if !selected.contains(&name) => vec![],
            Err(e) => return Err(e),
        };
        let fp_inputs = inputs.as_ref().map(|inputs| {
            let mut fp_inputs: Vec<(String, String)> = inputs
                .iter()
                .map(|v| (v.stage.clone(), v.attr_str("content_hash").unwrap_or("").to_string()))
                .collect();
            fp_inputs.extend(files.iter().map(|(p, h)| (format!("file:{p}"), h.clone())));
            fp_inputs
        });
        let fp = fp_inputs.as_ref().map(|fp_inputs| fingerprint(decl, stage.cache_version(), seed, fp_inputs));
        // The current version when it matches (the mark stays), else the newest that does.
        let current = current_of(&name, &complete, marks);
        let matches = |v: &VersionInfo| fp.as_deref().is_some_and(|fp| v.attr_str("fingerprint") == Some(fp));
        let cached = current.filter(|v| matches(v)).or_else(|| complete.iter().rev().find(|v| matches(v)).copied());
        let stale_input = decl.inputs.iter().find(|i| stale.contains_key(*i) || would_run.contains(*i));
        if !selected.contains(&name) {
            // A stage outside the selection keeps the version matching its inputs, else its
            // current one, and says why that one is out of date.
            let (used, why_stale) = match (cached, current) {
                (Some(v), _) => (v, stale_input.map(|i| format!("input {i} is out of date"))),
                (None, Some(v)) => {
                    let why = match (&inputs, stale_input) {
                        (_, Some(i)) if would_run.contains(i) => format!("input {i} would run"),
                        (Some(inputs), _) => {
                            let numbers: Vec<(String, u32)> = inputs.iter().map(|v| (v.stage.clone(), v.number)).collect();
                            reason(decl, stage.cache_version(), seed, &numbers, &files, Some(v))
                        }
                        (None, _) => "an input has no version".to_string(),
                    };
                    (v, Some(why))
                }
                (None, None) => {
                    crate::status!("{name}: not selected, no version yet");
                    continue;
                }
            };
            let mark = if cached.is_some() && !opts.dry_run { moved(&name, used.number, marks) } else { String::new() };
            match why_stale {
                Some(why) => {
                    crate::status!("{name}: not selected, using v{} (out of date: {why}){mark}", used.number);
                    stale.insert(name.clone(), why);
                }
                None => crate::status!("{name}: not selected, using v{}{mark}", used.number),
            }
            reports.push(StageReport::new(decl, used.number, None, 0.0, Outcome::NotSelected));
            chosen.insert(name.clone(), used.clone());
            continue;
        }
        let forced = opts.force.contains(&name) || opts.from.as_ref() == Some(&name);
        let force_flag = if opts.force.contains(&name) { "--force" } else { "--from" };
        // A stale upstream is used, but never silently.
        let stale_inputs: Vec<&String> = decl.inputs.iter().filter(|i| stale.contains_key(*i)).collect();
        for i in stale_inputs {
            eprintln!("warning: {}", stale_warning(pipeline, &name, &chosen[i], &stale[i]));
            stale.insert(name.clone(), format!("input {i} is out of date"));
        }
        if opts.dry_run {
            let upstream: Vec<&str> = decl.inputs.iter().filter(|i| would_run.contains(*i)).map(String::as_str).collect();
            let ctx = Decision { decl, cache_version: stage.cache_version(), seed, files: &files, current, cached, forced: forced.then_some(force_flag) };
            match ctx.dry_run(inputs.as_deref(), &upstream) {
                Planned::UpToDate(v) => {
                    crate::status!("{name}: up to date (v{})", v.number);
                    crate::detail!("{name}: fingerprint {} matches v{}", fp.as_deref().unwrap_or("?"), v.number);
                    chosen.insert(name.clone(), v.clone());
                    reports.push(StageReport::new(decl, v.number, None, 0.0, Outcome::Reused));
                }
                Planned::Runs(why) => {
                    crate::status!("{name}: would run: {why}");
                    would_run.insert(name.clone());
                    reports.push(StageReport::new(decl, 0, Some(why), 0.0, Outcome::WouldRun));
                }
                Planned::CannotRun(why) => {
                    crate::status!("{name}: cannot run: {why}");
                    reports.push(StageReport::new(decl, 0, Some(why), 0.0, Outcome::CannotRun));
                }
            }
            continue;
        }
        let (Some(inputs), Some(fp)) = (inputs, fp) else {
            let missing = decl.inputs.iter().find(|i| !chosen.contains_key(*i)).cloned().unwrap_or_default();
            return Err(RunError::BadInput(format!(
                "stage `{name}` needs input `{missing}`, which has no complete version in {}; run it first (without --only, or add it to --only)",
                pipeline.archive.display()
            )));
        };
        // An up-to-date version is used only once its stored hashes check out.
        let mut damaged = None;
        if let (Some(v), false) = (cached, forced) {
            match v.verify() {
                Integrity::Damaged(problems) => {
                    eprintln!("warning: {}", v.damage_message(&problems).split("; do not use it").next().unwrap_or(""));
                    damaged = Some(format!("stored v{} is damaged ({}); computing it again", v.number, problems.join("; ")));
                }
                Integrity::Ok | Integrity::Unverifiable => {
                    crate::status!("{name}: up to date (v{}){}", v.number, moved(&name, v.number, marks));
                    crate::detail!("{name}: reused: fingerprint {fp} matches v{}, whose stored dataset hashes check out", v.number);
                    verified.insert(v.group_path());
                    chosen.insert(name.clone(), v.clone());
                    reports.push(StageReport::new(decl, v.number, None, 0.0, Outcome::Reused));
                    continue;
                }
            }
        }
        // Inputs are read only once their stored hashes check out.
        for v in &inputs {
            if !verified.contains(&v.group_path()) {
                match v.verify() {
                    Integrity::Damaged(problems) => {
                        return Err(RunError::Runtime(anyhow!("stage `{name}` needs input {}: {}", v.group_path(), v.damage_message(&problems))));
                    }
                    Integrity::Unverifiable => crate::info!(
                        "note: archive {}: input {} was written before laydown stored dataset hashes and cannot be verified; `laydown run {} --force {}` rewrites it",
                        v.file.display(),
                        v.group_path(),
                        pipeline.file.display(),
                        v.stage
                    ),
                    Integrity::Ok => {}
                }
                verified.insert(v.group_path());
            }
        }
        let input_versions: Vec<(String, u32)> = inputs.iter().map(|v| (v.stage.clone(), v.number)).collect();
        let damaged_or_forced = damaged.is_some() || forced;
        let why = if let Some(d) = damaged {
            d
        } else if forced && cached.is_some() {
            format!("forced ({force_flag})")
        } else {
            reason(decl, stage.cache_version(), seed, &input_versions, &files, current)
        };
        crate::status!("{name}: runs: {why}");
        crate::detail!(
            "{name}: fingerprint {fp}; none of its {} complete versions has it{}; inputs: {}",
            complete.len(),
            current.map(|v| format!(" (compared with v{})", v.number)).unwrap_or_default(),
            if input_versions.is_empty() { "none".to_string() } else { input_versions.iter().map(|(s, n)| format!("{s} v{n}")).collect::<Vec<_>>().join(", ") }
        );

        let next_version = archive.next_version(&name).map_err(RunError::Runtime)?;
        let ctx = stage_context(pipeline, decl, &inputs, opts.progress, next_version);
        let sweep = ctx.sweep.clone();
        let upstream = ctx.inputs.clone();
        let executor = opts.executor.clone().unwrap_or_else(|| pipeline.executor.clone());
        // A complete version that differs only in having fewer replicates: only the new
        // replicates are computed (crate::executor::incremental), on the local executor.
        let grown_from = match (&fp_inputs, damaged_or_forced, executor.kind) {
            (Some(fp_inputs), false, crate::executor::ExecutorKind::Local) => complete.iter().rev().find_map(|v| {
                let stored = v.attr_f64("replicates")? as usize;
                let same = StageDecl { replicates: stored, ..decl.clone() };
                let grown = stored < decl.replicates && v.attr_str("fingerprint") == Some(fingerprint(&same, stage.cache_version(), seed, fp_inputs).as_str());
                // Stored replicates are read only once their hashes check out.
                (grown && matches!(v.verify(), Integrity::Ok)).then_some((*v, stored))
            }),
            _ => None,
        };
        let job = crate::executor::StageJob { pipeline, stage_name: &name, fingerprint: &fp, inputs: &inputs };
        let start_utc = provenance::utc_now();
        let cpu0 = provenance::cpu_seconds();
        let t0 = Instant::now();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| -> Result<(Output, BTreeMap<String, Attr>)> {
            if let Some((v, stored)) = grown_from {
                match crate::executor::incremental::run(stage, &ctx, v, stored)? {
                    Ok(out) => {
                        crate::status!("{name}: computed replicates {stored}..{} only; replicates 0..{stored} were read from v{}", decl.replicates, v.number);
                        let note = format!("v{}: replicates 0..{stored} read from it, {stored}..{} computed", v.number, decl.replicates);
                        return Ok((out, BTreeMap::from([("incremental_from".to_string(), Attr::Str(note))])));
                    }
                    Err(why) => crate::status!("{name}: computes all replicates: the stored ones of v{} cannot be reused ({why})", v.number),
                }
            }
            crate::executor::run_stage(&executor, stage, &ctx, &job)
        }));
        let (mut out, executor_attrs) = match result {
            Ok(Ok(r)) => r,
            Ok(Err(e)) => {
                let e = classify(e);
                eprintln!("{name}: failed; nothing was written for this stage");
                return Err(match e {
                    RunError::BadInput(m) => RunError::BadInput(format!("stage `{name}`: {m}")),
                    RunError::Runtime(e) => RunError::Runtime(e.context(format!("stage `{name}` failed"))),
                });
            }
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                return Err(RunError::Runtime(anyhow!("stage `{name}` crashed: {msg}; nothing was written for this stage")));
            }
        };
        let wall = t0.elapsed().as_secs_f64();
        let cpu = provenance::cpu_seconds() - cpu0;
        let t_commit = Instant::now();
        crate::coordinates::add_sweep_coordinates(&mut out, &name, &sweep, &stage.params()).map_err(RunError::Runtime)?;
        crate::coordinates::add_upstream_coordinates(&mut out, &upstream).map_err(RunError::Runtime)?;
        let hashes = crate::archive::hdf::dataset_hashes(&out);
        let content_hash = crate::archive::hdf::hash_of_dataset_hashes(&hashes);

        let mut attrs = provenance::environment();
        let mut put = |k: &str, v: Attr| {
            attrs.insert(k.to_string(), v);
        };
        put("stage_name", Attr::Str(name.clone()));
        put("stage_kind", Attr::Str(decl.kind.clone()));
        put("cache_version", Attr::I64(stage.cache_version() as i64));
        put("code_hash", Attr::Str(stages::code_hash(&decl.kind).to_string()));
        put("params_yaml", Attr::Str(decl.params.canonical_yaml()));
        put("params_hash", Attr::Str(blake3::hash(decl.params.canonical_yaml().as_bytes()).to_hex()[..16].to_string()));
        put("sweep_yaml", Attr::Str(decl.sweep_yaml()));
        put("replicates", Attr::I64(decl.replicates as i64));
        put("seed", Attr::Str(seed.to_string()));
        put("rng_scheme", Attr::Str(crate::rng::SCHEME.into()));
        put(
            "inputs",
            Attr::Str(
                inputs
                    .iter()
                    .map(|v| format!("{} content_hash={}", v.group_path(), v.attr_str("content_hash").unwrap_or("")))
                    .collect::<Vec<_>>()
                    .join("\n"),
            ),
        );
        if !files.is_empty() {
            put("input_files", Attr::Str(files_attr(&files)));
        }
        put("fingerprint", Attr::Str(fp.clone()));
        put("content_hash", Attr::Str(content_hash));
        put("dataset_hashes", Attr::Str(crate::archive::hdf::dataset_hashes_attr(&hashes)));
        put("pipeline_name", Attr::Str(pipeline.name.clone()));
        put("pipeline_file", Attr::Str(pipeline.file.display().to_string()));
        if let Ok(text) = std::fs::read_to_string(&pipeline.file) {
            put("pipeline_hash", Attr::Str(blake3::hash(text.as_bytes()).to_hex()[..16].to_string()));
            put("pipeline_yaml", Attr::Str(text));
        }
        put("upstream", Attr::Str(upstream_chain(&inputs)));
        put("run_reason", Attr::Str(why.clone()));
        put("start_utc", Attr::Str(start_utc));
        put("end_utc", Attr::Str(provenance::utc_now()));
        put("wall_seconds", Attr::F64(wall));
        put("cpu_seconds", Attr::F64(cpu));
        put("status", Attr::Str("complete".into()));
        put("layout_version", Attr::I64(crate::archive::LAYOUT_VERSION));
        attrs.extend(executor_attrs);

        let number = archive
            .commit_version_marking(
                &format!("laydown archive of pipeline {}", pipeline.name),
                &name,
                &out,
                &attrs,
                &marks.pending,
                &format!(
                    "{} laydown run {}: {name} ({why})",
                    provenance::utc_now(),
                    pipeline.file.display()
                ),
            )
            .map_err(RunError::Runtime)?;
        marks.pending.insert(name.clone(), number);
        marks.committed();
        let v = archive.version(&name, Some(number)).map_err(RunError::Runtime)?;
        crate::executor::committed(&executor, &job);
        crate::status!("{name}: wrote v{number} in {wall:.2} s");
        crate::detail!(
            "{name}: computed in {wall:.3} s wall, {cpu:.3} s CPU; hashed and committed v{number} in {:.3} s; content hash {}",
            t_commit.elapsed().as_secs_f64(),
            v.attr_str("content_hash").unwrap_or("?")
        );
        write_files(&pipeline.archive, &name, number, &out.files).map_err(RunError::Runtime)?;
        verified.insert(v.group_path());
        chosen.insert(name.clone(), v);
        reports.push(StageReport::new(decl, number, Some(why), wall, Outcome::Computed));
    }
    Ok(reports)
}

/// Every version upstream of a stage, one `group content_hash=…` line each, nearest
/// first: its inputs, then their own stored chains (or, for versions written before
/// chains were stored, their inputs), without repeats.
fn upstream_chain(inputs: &[VersionInfo]) -> String {
    let mut lines: Vec<String> = Vec::new();
    for v in inputs {
        lines.push(format!("{} content_hash={}", v.group_path(), v.attr_str("content_hash").unwrap_or("")));
    }
    for v in inputs {
        let theirs = v.attr_str("upstream").or_else(|| v.attr_str("inputs")).unwrap_or("");
        lines.extend(theirs.lines().filter(|l| !l.is_empty()).map(str::to_string));
    }
    let mut seen = std::collections::HashSet::new();
    lines.retain(|l| seen.insert(l.clone()));
    lines.join("\n")
}

/// Write the files a stage handed over ([`Output::files`]) into the figure folder of
/// its committed version `number`, each through a temporary file renamed into place.
fn write_files(archive: &std::path::Path, stage: &str, number: u32, files: &[(String, Vec<u8>)]) -> anyhow::Result<()> {
    if files.is_empty() {
        return Ok(());
    }
    let dir = crate::archive::figure_dir(archive, stage, number);
    let fail = |e: std::io::Error, what: &std::path::Path| anyhow!("{stage}: v{number} is committed, but writing {} failed: {e}; `laydown plot` draws its figures again", what.display());
    std::fs::create_dir_all(&dir).map_err(|e| fail(e, &dir))?;
    for (name, bytes) in files {
        let path = dir.join(name);
        let tmp = dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, bytes).and_then(|_| std::fs::rename(&tmp, &path)).map_err(|e| fail(e, &path))?;
        crate::info!("{stage}: {}", path.display());
    }
    Ok(())
}

/// What a dry run finds for a selected stage.
enum Planned<'a> {
    UpToDate(&'a VersionInfo),
    /// Why it would run.
    Runs(String),
    /// Why it could not (an input has no version).
    CannotRun(String),
}

/// What decides whether a selected stage runs, and says why.
struct Decision<'a> {
    decl: &'a StageDecl,
    cache_version: u32,
    seed: u64,
    files: &'a [(String, String)],
    /// The stage's current version (the newest in archives without marks).
    current: Option<&'a VersionInfo>,
    /// A complete version with the stage's fingerprint, if its inputs are known.
    cached: Option<&'a VersionInfo>,
    /// `--force` or `--from` when that flag forces the stage.
    forced: Option<&'static str>,
}

impl<'a> Decision<'a> {
    fn reason(&self, inputs: &[(String, u32)]) -> String {
        reason(self.decl, self.cache_version, self.seed, inputs, self.files, self.current)
    }

    /// A dry run's decision, given the input versions (`None`: one has no version) and the
    /// inputs that would run first (their new content, hence this stage's fingerprint, unknown).
    fn dry_run(&self, inputs: Option<&[VersionInfo]>, upstream: &[&str]) -> Planned<'a> {
        if !upstream.is_empty() {
            let up = format!("input {} would run first", upstream.join(", "));
            let own = match self.current {
                Some(_) => self.reason(&[]),
                None => "new stage".to_string(),
            };
            return Planned::Runs(match self.forced {
                Some(flag) => format!("forced ({flag}), {up}"),
                None if own == NO_MATCH => format!("{up} (unless its results come out unchanged)"),
                None => format!("{own}, {up}"),
            });
        }
        match (self.cached, self.forced) {
            (Some(v), None) => match v.verify() {
                Integrity::Damaged(problems) => Planned::Runs(format!("stored v{} is damaged ({})", v.number, problems.join("; "))),
                Integrity::Ok | Integrity::Unverifiable => Planned::UpToDate(v),
            },
            (Some(_), Some(flag)) => Planned::Runs(format!("forced ({flag})")),
            (None, _) => match inputs {
                Some(inputs) => Planned::Runs(self.reason(&inputs.iter().map(|v| (v.stage.clone(), v.number)).collect::<Vec<_>>())),
                None => Planned::CannotRun("an input has no complete version; run it first (without --only, or add it to --only)".into()),
            },
        }
    }
}

/// `spectra uses fibre v1, which is out of date (params.diameter changed ...); ...`
fn stale_warning(pipeline: &Pipeline, stage: &str, input: &VersionInfo, why: &str) -> String {
    format!(
        "{stage} uses {} v{}, which is out of date ({why}); `laydown run {}` brings both up to date",
        input.stage,
        input.number,
        pipeline.file.display(),
    )
}
