//! The pipeline checker: walks the parsed YAML, checks every key, value, reference and
//! sweep against the stage kinds' parameter tables, and collects [`Diagnostic`]s with
//! file, line, column and key (all of them, not just the first). [`super::parse`] runs it.

use crate::error::InvalidParam;
use crate::params::ParamCaution;
use super::yaml::{self, Kind, Node, Pos, Scalar};
use super::*;

/// Parse and check `text`, the pipeline file at `path` (see [`super::parse_with`]).
pub(super) fn check(text: &str, path: &Path, limit: Limit) -> Result<Pipeline, Diagnostics> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut c = Checker { file: path.display().to_string(), dir, limit, diags: vec![], warnings: vec![] };
    let root = match yaml::parse(text) {
        Ok(r) => r,
        Err((pos, msg)) => {
            c.err(pos, "", format!("invalid YAML: {msg}"));
            return Err(Diagnostics(c.diags));
        }
    };
    let pipeline = c.pipeline(&root, path);
    if c.diags.is_empty() {
        let mut pipeline = pipeline.expect("no diagnostics means a pipeline");
        pipeline.warnings = c.warnings;
        Ok(pipeline)
    } else {
        Err(Diagnostics(c.diags))
    }
}

struct Checker {
    file: String,
    /// The pipeline file's directory (relative input files are taken from it).
    dir: PathBuf,
    limit: Limit,
    diags: Vec<Diagnostic>,
    /// Valid settings cautioned against ([`Stage::cautions`]), once per stage and key.
    warnings: Vec<Diagnostic>,
}

const TOP_KEYS: &[&str] = &["pipeline", "archive", "seed", "description", "executor", "stages"];
const EXECUTOR_KEYS: &[&str] = &["kind", "partition", "max_parallel", "units_per_task", "sbatch_args"];
const STAGE_KEYS: &[&str] = &["name", "kind", "input", "params", "sweep", "sweep_mode", "replicates", "seed", "description"];
const MAX_SWEEP_POINTS: usize = 100_000;

impl Checker {
    fn err(&mut self, pos: Pos, key: &str, message: impl Into<String>) {
        self.diags.push(Diagnostic { file: self.file.clone(), pos, key: key.to_string(), message: message.into() });
    }

    fn map<'a>(&mut self, node: &'a Node, key: &str, what: &str) -> Option<&'a [(String, Pos, Node)]> {
        match &node.kind {
            Kind::Map(entries) => Some(entries),
            _ => {
                self.err(node.pos, key, format!("expected {what} (a mapping), found {}", node.type_name()));
                None
            }
        }
    }

    fn unknown_keys(&mut self, entries: &[(String, Pos, Node)], allowed: &[&str], prefix: &str, what: &str) {
        for (k, pos, _) in entries {
            if !allowed.contains(&k.as_str()) {
                let hint = suggest(k, allowed.iter().copied()).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                self.err(*pos, &join(prefix, k), format!("unknown key in {what}; allowed keys: {}{hint}", allowed.join(", ")));
            }
        }
    }

    fn string(&mut self, node: &Node, key: &str) -> Option<String> {
        match &node.kind {
            Kind::Scalar(Scalar::Str(s)) => Some(s.clone()),
            _ => {
                self.err(node.pos, key, format!("expected text, found {}", node.type_name()));
                None
            }
        }
    }

    fn identifier(&mut self, node: &Node, key: &str) -> Option<String> {
        let s = self.string(node, key)?;
        let ok = !s.is_empty()
            && s.chars().next().is_some_and(|c| c.is_ascii_lowercase())
            && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
        if !ok {
            self.err(node.pos, key, format!("`{s}` is not a valid name; allowed: lowercase letters, digits and _, starting with a letter"));
            return None;
        }
        Some(s)
    }

    fn uint(&mut self, node: &Node, key: &str, min: i64, max: i64) -> Option<i64> {
        match &node.kind {
            Kind::Scalar(Scalar::Int(i)) if *i >= min && *i <= max => Some(*i),
            Kind::Scalar(Scalar::Int(i)) => {
                self.err(node.pos, key, format!("{i} is out of range; allowed: a whole number from {min} to {max}"));
                None
            }
            _ => {
                self.err(node.pos, key, format!("expected a whole number from {min} to {max}, found {}", node.type_name()));
                None
            }
        }
    }

    fn pipeline(&mut self, root: &Node, path: &Path) -> Option<Pipeline> {
        let entries = self.map(root, "", "a pipeline")?;
        self.unknown_keys(entries, TOP_KEYS, "", "the pipeline");
        let get = |k: &str| entries.iter().find(|(n, _, _)| n == k).map(|(_, _, v)| v);
        let missing = |c: &mut Self, k: &str| c.err(root.pos, k, "required key is missing");

        let name = match get("pipeline") {
            Some(n) => self.string(n, "pipeline"),
            None => {
                missing(self, "pipeline");
                None
            }
        };
        // Relative to the pipeline file (as image files are), whatever the working directory.
        let archive = match get("archive") {
            Some(n) => self.string(n, "archive").and_then(|a| {
                let path = crate::archive::absolute(&self.dir.join(&a));
                if a.trim().is_empty() {
                    self.err(n.pos, "archive", "the archive path is empty");
                    None
                } else if path.is_dir() {
                    self.err(n.pos, "archive", format!("`{a}` is a directory; allowed: the path of an HDF5 file, e.g. {}", Path::new(&a).join("study.h5").display()));
                    None
                } else {
                    Some(path)
                }
            }),
            None => {
                missing(self, "archive");
                None
            }
        };
        let seed = match get("seed") {
            Some(n) => self.uint(n, "seed", 0, i64::MAX).map(|s| s as u64),
            None => Some(0),
        };
        let description = get("description").and_then(|n| self.string(n, "description")).unwrap_or_default();
        let executor = match get("executor") {
            Some(n) => self.executor(n),
            None => Some(ExecutorConfig::default()),
        };
        let stages = match get("stages") {
            Some(n) => self.stages(n),
            None => {
                missing(self, "stages");
                None
            }
        };
        Some(Pipeline {
            file: path.to_path_buf(),
            name: name?,
            archive: archive?,
            seed: seed?,
            description,
            stages: stages?,
            executor: executor?,
            warnings: vec![],
        })
    }

    /// `executor: slurm` or `executor: {kind: slurm, partition: P, max_parallel: N, units_per_task: K, sbatch_args: [...]}`.
    fn executor(&mut self, node: &Node) -> Option<ExecutorConfig> {
        let kind = |c: &mut Self, n: &Node, key: &str| -> Option<ExecutorKind> {
            let s = c.string(n, key)?;
            match ExecutorKind::from_name(&s) {
                Ok(k) => Some(k),
                Err(_) => {
                    let hint = suggest(&s, ExecutorKind::NAMES.iter().copied()).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                    c.err(n.pos, key, format!("unknown executor `{s}`; allowed: {}{hint}", ExecutorKind::NAMES.join(", ")));
                    None
                }
            }
        };
        if let Kind::Scalar(_) = &node.kind {
            return Some(ExecutorConfig { kind: kind(self, node, "executor")?, ..Default::default() });
        }
        let entries = self.map(node, "executor", "an executor name or an executor")?;
        self.unknown_keys(entries, EXECUTOR_KEYS, "executor", "the executor");
        let before = self.diags.len();
        let get = |k: &str| entries.iter().find(|(n, _, _)| n == k).map(|(_, _, v)| v);
        let mut cfg = ExecutorConfig::default();
        match get("kind") {
            Some(n) => cfg.kind = kind(self, n, "executor.kind").unwrap_or_default(),
            None => self.err(node.pos, "executor.kind", format!("required key is missing; allowed: {}", ExecutorKind::NAMES.join(", "))),
        }
        if let Some(n) = get("partition") {
            cfg.partition = self.string(n, "executor.partition");
        }
        if let Some(n) = get("max_parallel") {
            cfg.max_parallel = self.uint(n, "executor.max_parallel", 1, 1_000_000).map(|m| m as usize);
        }
        if let Some(n) = get("units_per_task") {
            cfg.units_per_task = self.uint(n, "executor.units_per_task", 1, 1_000_000).map(|m| m as usize);
        }
        if let Some(n) = get("sbatch_args") {
            match &n.kind {
                Kind::Seq(items) => {
                    for (i, item) in items.iter().enumerate() {
                        if let Some(a) = self.string(item, &format!("executor.sbatch_args[{i}]")) {
                            cfg.sbatch_args.push(a);
                        }
                    }
                }
                _ => self.err(n.pos, "executor.sbatch_args", format!("expected a list of sbatch arguments such as [--time=01:00:00], found {}", n.type_name())),
            }
        }
        if self.diags.len() > before {
            return None;
        }
        Some(cfg)
    }

    fn stages(&mut self, node: &Node) -> Option<Vec<StageDecl>> {
        let Kind::Seq(items) = &node.kind else {
            self.err(node.pos, "stages", format!("expected a list of stages, found {}", node.type_name()));
            return None;
        };
        if items.is_empty() {
            self.err(node.pos, "stages", "the pipeline has no stages; allowed: a list of at least one stage");
            return None;
        }
        let before = self.diags.len();
        let decls: Vec<Option<StageDecl>> = items.iter().enumerate().map(|(i, n)| self.stage(n, &format!("stages[{i}]"))).collect();
        // Names unique.
        let mut seen: HashMap<String, usize> = HashMap::new();
        for (i, d) in decls.iter().enumerate() {
            if let Some(d) = d {
                if let Some(j) = seen.insert(d.name.clone(), i) {
                    self.err(d.pos, &format!("stages[{i}].name"), format!("stage name `{}` is already used by stages[{j}]", d.name));
                }
            }
        }
        let all: Vec<&StageDecl> = decls.iter().flatten().collect();
        // Stages with errors of their own, by the name they were given: an input naming
        // one gets one line saying so, not "names no stage".
        let broken: Vec<(usize, String)> = decls
            .iter()
            .zip(items)
            .enumerate()
            .filter(|(_, (d, _))| d.is_none())
            .filter_map(|(i, (_, n))| Some((i, declared_name(n)?)))
            .collect();
        // Inputs exist and have the right kinds.
        for (i, d) in decls.iter().enumerate() {
            let Some(d) = d else { continue };
            let Some(stage) = stages::find(&d.kind) else { continue };
            let rule = stage.inputs();
            let key = format!("stages[{i}].input");
            if d.inputs.len() < rule.min || d.inputs.len() > rule.max {
                let kinds = rule.kinds.join(" or ");
                let want = if rule.max == 0 {
                    "no input".to_string()
                } else if rule.min == rule.max {
                    format!("exactly {} input stage(s) of kind {kinds}", rule.min)
                } else {
                    format!("{} to {} input stage(s) of kind {kinds}", rule.min, rule.max)
                };
                self.err(d.pos, &key, format!("stage `{}` of kind {} takes {want}, but has {}", d.name, d.kind, d.inputs.len()));
            }
            for inp in &d.inputs {
                match all.iter().find(|s| &s.name == inp) {
                    None if broken.iter().any(|(_, n)| n == inp) => {
                        let at = broken.iter().find(|(_, n)| n == inp).map(|(j, _)| *j).unwrap_or(0);
                        self.err(d.pos, &key, format!("input `{inp}` (stages[{at}]) has errors of its own, reported above; this stage is checked once they are fixed"));
                    }
                    None => {
                        let hint = suggest(inp, all.iter().map(|s| s.name.as_str())).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                        let names: Vec<&str> = all.iter().map(|s| s.name.as_str()).filter(|n| *n != d.name).collect();
                        self.err(d.pos, &key, format!("input `{inp}` names no stage of this pipeline; allowed: {}{hint}", names.join(", ")));
                    }
                    Some(up) if !rule.kinds.contains(&up.kind.as_str()) => {
                        self.err(d.pos, &key, format!("input `{inp}` is a {} stage; a {} stage takes {}", up.kind, d.kind, rule.kinds.join(" or ")));
                    }
                    _ => {}
                }
            }
        }
        {
            if let Some(cycle) = find_cycle(&all) {
                let first = all.iter().find(|s| s.name == cycle[0]).unwrap();
                self.err(first.pos, "stages", format!("the stages' inputs form a cycle: {}; allowed: inputs that lead back to stages without input", cycle.join(" -> ")));
            }
        }
        if self.diags.len() > before {
            return None;
        }
        self.declared_checks(items, &all);
        if self.diags.len() > before {
            return None;
        }
        self.memory(items, &all);
        if self.diags.len() > before {
            return None;
        }
        Some(decls.into_iter().flatten().collect())
    }

    /// Every stage against its inputs as declared ([`inputs::check`]),
    /// e.g. a web choosing one point of a swept spectra stage: what `run` would find
    /// only after computing the upstream stages. Reported where the parameter is set,
    /// else at the stage's `input:`, else at the stage.
    fn declared_checks(&mut self, items: &[Node], all: &[&StageDecl]) {
        for (i, d) in all.iter().enumerate() {
            let Err(InvalidParam { key: param, message: msg }) = inputs::check(d, &declared(all, d, &self.dir)) else { continue };
            let node = &items[i];
            let (pos, path) = match param_or_key_pos(node, &param) {
                Some((pos, path)) => (pos, path),
                None => {
                    let input = match &node.kind {
                        Kind::Map(entries) => entries.iter().find(|(k, _, _)| k == "input").map(|(_, _, v)| v.pos),
                        _ => None,
                    };
                    (input.unwrap_or(d.pos), format!("params.{param}"))
                }
            };
            self.err(pos, &format!("stages[{i}].{path}"), msg);
        }
    }

    /// Every stage's estimated peak memory within the limit; a stage above it is
    /// reported at the first parameter that drives its estimate.
    fn memory(&mut self, items: &[Node], all: &[&StageDecl]) {
        let Some((limit, source)) = self.limit.resolve() else { return };
        for d in all {
            let Some(stage) = stages::find(&d.kind) else { continue };
            let Some(e) = stage.estimate_memory(&declared(all, d, &self.dir)) else { continue };
            let bytes = e.bytes + PROCESS_BYTES;
            if bytes.is_nan() || bytes <= limit {
                continue;
            }
            let name = |(s, p): &(String, String)| if *s == d.name { p.clone() } else { format!("{p} of stage `{s}`") };
            let mut advice = vec![];
            if !e.params.is_empty() {
                advice.push(format!("lower {}", e.params.iter().map(name).collect::<Vec<_>>().join(", ")));
            }
            if !e.inverse.is_empty() {
                advice.push(format!("raise {}", e.inverse.iter().map(name).collect::<Vec<_>>().join(", ")));
            }
            // reported where the first parameter is set, in the stage that sets it
            let (stage_name, key) = e.drivers().next().map_or((d.name.as_str(), ""), |(s, p)| (s.as_str(), p.as_str()));
            let at = all.iter().position(|x| x.name == stage_name).unwrap_or(0);
            let (pos, key) = match items.get(at).and_then(|n| param_or_key_pos(n, key)) {
                Some((pos, path)) => (pos, format!("stages[{at}].{path}")),
                // a parameter left at its default: the stage's position
                None if key.is_empty() => (all[at].pos, format!("stages[{at}]")),
                None if STAGE_KEYS.contains(&key) => (all[at].pos, format!("stages[{at}].{key}")),
                None => (all[at].pos, format!("stages[{at}].params.{key}")),
            };
            self.err(
                pos,
                &key,
                format!(
                    "stage `{}` ({}) needs more than the {} {source}: about {} at its peak ({}); allowed: a run within that memory: {}",
                    d.name,
                    d.kind,
                    format_size(limit),
                    format_size(bytes),
                    e.what,
                    advice.join(" or ")
                ),
            );
        }
    }

    fn stage(&mut self, node: &Node, key: &str) -> Option<StageDecl> {
        let entries = self.map(node, key, "a stage")?;
        self.unknown_keys(entries, STAGE_KEYS, key, "a stage");
        let get = |k: &str| entries.iter().find(|(n, _, _)| n == k).map(|(_, _, v)| v);
        let name = match get("name") {
            Some(n) => self.identifier(n, &join(key, "name")),
            None => {
                self.err(node.pos, &join(key, "name"), "required key is missing");
                None
            }
        };
        let kinds = stages::kinds();
        let (kind, stage) = match get("kind") {
            Some(n) => match self.string(n, &join(key, "kind")) {
                Some(k) => match stages::find(&k) {
                    Some(s) => (Some(k), Some(s)),
                    None => {
                        let hint = suggest(&k, kinds.iter().copied()).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                        self.err(n.pos, &join(key, "kind"), format!("unknown stage kind `{k}`; allowed: {}{hint}", kinds.join(", ")));
                        (None, None)
                    }
                },
                None => (None, None),
            },
            None => {
                self.err(node.pos, &join(key, "kind"), format!("required key is missing; allowed: {}", kinds.join(", ")));
                (None, None)
            }
        };
        let inputs = match get("input") {
            None => Some(vec![]),
            Some(n) => match &n.kind {
                Kind::Scalar(Scalar::Str(s)) => Some(vec![s.clone()]),
                Kind::Seq(items) => items.iter().enumerate().map(|(i, it)| self.string(it, &format!("{key}.input[{i}]"))).collect(),
                _ => {
                    self.err(n.pos, &join(key, "input"), format!("expected a stage name or a list of stage names, found {}", n.type_name()));
                    None
                }
            },
        };
        let replicates = match get("replicates") {
            Some(n) => self.uint(n, &join(key, "replicates"), 1, 100_000).map(|r| r as usize),
            None => Some(1),
        };
        let seed = match get("seed") {
            Some(n) => self.uint(n, &join(key, "seed"), 0, i64::MAX).map(|s| Some(s as u64)),
            None => Some(None),
        };
        let sweep_mode = match get("sweep_mode") {
            None => Some(SweepMode::Cartesian),
            Some(n) => match self.string(n, &join(key, "sweep_mode")).as_deref() {
                Some("cartesian") => Some(SweepMode::Cartesian),
                Some("zip") => Some(SweepMode::Zip),
                Some(other) => {
                    self.err(n.pos, &join(key, "sweep_mode"), format!("`{other}` is not allowed; allowed: cartesian, zip"));
                    None
                }
                None => None,
            },
        };
        if let Some(n) = get("description") {
            self.string(n, &join(key, "description"));
        }
        let stage = stage?;
        let specs = stage.params();
        let given = match get("params") {
            Some(n) => self.params(n, &join(key, "params"), &specs, stage.kind()),
            None => Some(BTreeMap::new()),
        };
        let sweep = match get("sweep") {
            Some(n) => self.sweep(n, &join(key, "sweep"), &specs, stage.kind(), sweep_mode),
            None => Some(vec![]),
        };
        let given = given?;
        let params = ParamSet::resolve(&specs, &given);
        let decl = StageDecl {
            name: name?,
            kind: kind?,
            inputs: inputs?,
            params,
            sweep: sweep?,
            sweep_mode: sweep_mode?,
            replicates: replicates?,
            seed: seed?,
            pos: node.pos,
        };
        // Cross-parameter checks on every sweep point.
        let (points, _) = decl.points();
        for p in &points {
            if let Err(InvalidParam { key: param, message: msg }) = stage.check(p) {
                let pos = find_param_pos(entries, &param).unwrap_or(node.pos);
                self.err(pos, &format!("{key}.params.{param}"), msg);
                return None;
            }
        }
        // Files outside the archive (image scans) exist now, not only at run time.
        for p in &points {
            if let Err(InvalidParam { key: param, message: msg }) = stage.check_files(p, &self.dir) {
                let pos = find_param_pos(entries, &param).unwrap_or(node.pos);
                self.err(pos, &format!("{key}.params.{param}"), msg);
                return None;
            }
        }
        // Valid settings known to give poor results: one warning per parameter (at the
        // first sweep point that draws it), at its value as written under params or sweep.
        let mut cautioned: Vec<String> = vec![];
        for (i, p) in points.iter().enumerate() {
            for ParamCaution { key: param, message } in stage.cautions(p) {
                if cautioned.contains(&param) {
                    continue;
                }
                let (full, pos) = match decl.sweep_item(i, &param) {
                    Some(item) => (format!("{key}.sweep.{param}[{item}]"), find_section_pos(entries, "sweep", &format!("{param}[{item}]"))),
                    None => (format!("{key}.params.{param}"), find_param_pos(entries, &param)),
                };
                self.warnings.push(Diagnostic { file: self.file.clone(), pos: pos.unwrap_or(node.pos), key: full, message });
                cautioned.push(param);
            }
        }
        Some(decl)
    }

    fn params(&mut self, node: &Node, key: &str, specs: &[ParamSpec], kind: &str) -> Option<BTreeMap<String, ParamValue>> {
        let mut flat = vec![];
        self.flatten(node, key, "", &mut flat)?;
        let before = self.diags.len();
        let mut out = BTreeMap::new();
        for (name, kpos, vnode) in flat {
            let full = join(key, &name);
            match specs.iter().find(|s| s.name == name) {
                None => {
                    let hint = suggest(&name, specs.iter().map(|s| s.name)).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                    self.err(kpos, &full, format!("unknown parameter for a {kind} stage{hint} (see `laydown stages {kind}` for the table)"));
                }
                Some(spec) => {
                    if let Some(v) = self.value(&vnode, &full, spec) {
                        out.insert(name, v);
                    }
                }
            }
        }
        (self.diags.len() == before).then_some(out)
    }

    /// Flatten nested parameter mappings into dotted names.
    fn flatten(&mut self, node: &Node, key: &str, prefix: &str, out: &mut Vec<(String, Pos, Node)>) -> Option<()> {
        let entries = self.map(node, key, "parameters")?;
        for (k, kpos, v) in entries {
            let name = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
            match &v.kind {
                Kind::Map(_) => self.flatten(v, &join(key, k), &name, out)?,
                _ => out.push((name, *kpos, v.clone())),
            }
        }
        Some(())
    }

    fn value(&mut self, node: &Node, key: &str, spec: &ParamSpec) -> Option<ParamValue> {
        let raw = match &node.kind {
            Kind::Scalar(Scalar::Null) => ParamValue::Auto,
            Kind::Scalar(Scalar::Str(s)) if s == "auto" && spec.auto => ParamValue::Auto,
            Kind::Scalar(Scalar::Bool(b)) => ParamValue::Bool(*b),
            Kind::Scalar(Scalar::Int(i)) => ParamValue::Int(*i),
            Kind::Scalar(Scalar::Float(f)) => ParamValue::Float(*f),
            Kind::Scalar(Scalar::Str(s)) => ParamValue::Text(s.clone()),
            Kind::Seq(items) if spec.kind == crate::params::ParamKind::TextList => {
                let mut texts = vec![];
                for (i, it) in items.iter().enumerate() {
                    match &it.kind {
                        Kind::Scalar(Scalar::Str(s)) => texts.push(s.clone()),
                        _ => {
                            self.err(it.pos, &format!("{key}[{i}]"), format!("expected text, found {}; quote numbers used as labels, e.g. \"0.020\"", it.type_name()));
                            return None;
                        }
                    }
                }
                ParamValue::List(texts)
            }
            _ => {
                self.err(node.pos, key, format!("expected {}, found {}", spec.allowed(), node.type_name()));
                return None;
            }
        };
        match spec.check(&raw) {
            Ok(v) => Some(v),
            Err(msg) => {
                self.err(node.pos, key, msg);
                None
            }
        }
    }

    fn sweep(
        &mut self,
        node: &Node,
        key: &str,
        specs: &[ParamSpec],
        kind: &str,
        mode: Option<SweepMode>,
    ) -> Option<Vec<(String, Vec<ParamValue>)>> {
        let mut flat = vec![];
        self.flatten(node, key, "", &mut flat)?;
        let before = self.diags.len();
        let mut out = vec![];
        for (name, kpos, vnode) in &flat {
            let full = join(key, name);
            let Some(spec) = specs.iter().find(|s| s.name == name) else {
                let hint = suggest(name, specs.iter().map(|s| s.name)).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
                self.err(*kpos, &full, format!("unknown parameter for a {kind} stage{hint}"));
                continue;
            };
            let Kind::Seq(items) = &vnode.kind else {
                self.err(vnode.pos, &full, format!("expected a list of values to sweep, found {}", vnode.type_name()));
                continue;
            };
            if items.is_empty() {
                self.err(vnode.pos, &full, "the sweep list is empty; allowed: at least one value");
                continue;
            }
            let values: Vec<Option<ParamValue>> = items.iter().enumerate().map(|(i, it)| self.value(it, &format!("{full}[{i}]"), spec)).collect();
            if let Some(values) = values.into_iter().collect::<Option<Vec<_>>>() {
                out.push((name.clone(), values));
            }
        }
        if self.diags.len() > before {
            return None;
        }
        if mode == Some(SweepMode::Zip) {
            if let Some((first, n)) = out.first().map(|(k, v)| (k.clone(), v.len())) {
                for (name, values) in &out {
                    if values.len() != n {
                        let pos = flat.iter().find(|(k, _, _)| k == name).map(|(_, _, v)| v.pos).unwrap_or(node.pos);
                        self.err(pos, &join(key, name), format!("zipped sweep lists must have equal lengths: `{first}` has {n} values, `{name}` has {}", values.len()));
                        return None;
                    }
                }
            }
        }
        let points: usize = match mode {
            Some(SweepMode::Zip) => out.first().map(|(_, v)| v.len()).unwrap_or(1),
            _ => out.iter().map(|(_, v)| v.len()).product(),
        };
        if points > MAX_SWEEP_POINTS {
            self.err(node.pos, key, format!("the sweep has {points} points; allowed: at most {MAX_SWEEP_POINTS}"));
            return None;
        }
        Some(out)
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// The `name:` a stage node gives itself, valid or not (to name a stage with errors).
fn declared_name(stage: &Node) -> Option<String> {
    let Kind::Map(entries) = &stage.kind else { return None };
    match &entries.iter().find(|(k, _, _)| k == "name")?.2.kind {
        Kind::Scalar(Scalar::Str(s)) => Some(s.clone()),
        _ => None,
    }
}

/// A stage as declared with its inputs, for [`stages::Stage::estimate_memory`].
fn declared(all: &[&StageDecl], d: &StageDecl, dir: &Path) -> stages::Declared {
    stages::Declared {
        name: d.name.clone(),
        kind: d.kind.clone(),
        points: d.points().0,
        replicates: d.replicates,
        inputs: d.inputs.iter().filter_map(|i| all.iter().find(|s| s.name == *i)).map(|i| declared(all, i, dir)).collect(),
        pipeline_dir: dir.to_path_buf(),
    }
}

/// Where a stage node writes `name`: a parameter (`params.x`, or its sweep list
/// `sweep.x`) or a stage key such as `replicates`, with its key path below the stage.
fn param_or_key_pos(stage: &Node, name: &str) -> Option<(Pos, String)> {
    let Kind::Map(entries) = &stage.kind else { return None };
    if let Some(pos) = find_param_pos(entries, name) {
        return Some((pos, format!("params.{name}")));
    }
    let key = |k: &str| entries.iter().find(|(n, _, _)| n == k).map(|(_, _, v)| v);
    if let Some(Kind::Map(sweep)) = key("sweep").map(|n| &n.kind) {
        if let Some((_, _, v)) = sweep.iter().find(|(n, _, _)| n == name) {
            return Some((v.pos, format!("sweep.{name}")));
        }
    }
    key(name).map(|v| (v.pos, name.to_string()))
}

fn find_param_pos(stage_entries: &[(String, Pos, Node)], dotted: &str) -> Option<Pos> {
    find_section_pos(stage_entries, "params", dotted)
}

/// The position of a dotted parameter (or list item, `name[i]`) under the stage's
/// `section` (`params` or `sweep`).
fn find_section_pos(stage_entries: &[(String, Pos, Node)], section: &str, dotted: &str) -> Option<Pos> {
    let (_, _, node) = stage_entries.iter().find(|(k, _, _)| k == section)?;
    let parts: Vec<&str> = dotted.split('.').collect();
    find_in(node, &parts)
}

/// The position of a dotted parameter below `node`, written nested (`synthetic: {rows: 1}`)
/// or flat (`synthetic.rows: 1`), its last part possibly a list item (`files[1]`).
fn find_in(node: &Node, parts: &[&str]) -> Option<Pos> {
    let Kind::Map(entries) = &node.kind else { return None };
    // the longest run of parts written as one key first
    for k in (1..=parts.len()).rev() {
        let key = parts[..k].join(".");
        let (name, index) = match key.strip_suffix(']').and_then(|p| p.split_once('[')) {
            Some((n, i)) => (n.to_string(), i.parse::<usize>().ok()),
            None => (key.clone(), None),
        };
        let Some((_, _, v)) = entries.iter().find(|(n, _, _)| *n == name) else { continue };
        let v = match (index, &v.kind) {
            (Some(i), Kind::Seq(items)) => items.get(i)?,
            _ => v,
        };
        return if k == parts.len() { Some(v.pos) } else { find_in(v, &parts[k..]).or(Some(v.pos)) };
    }
    None
}

fn find_cycle(stages: &[&StageDecl]) -> Option<Vec<String>> {
    fn visit(name: &str, stages: &[&StageDecl], path: &mut Vec<String>, done: &mut Vec<String>) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|p| p == name) {
            let mut cycle = path[i..].to_vec();
            cycle.push(name.to_string());
            return Some(cycle);
        }
        if done.iter().any(|d| d == name) {
            return None;
        }
        path.push(name.to_string());
        if let Some(s) = stages.iter().find(|s| s.name == name) {
            for i in &s.inputs {
                if let Some(c) = visit(i, stages, path, done) {
                    return Some(c);
                }
            }
        }
        path.pop();
        done.push(name.to_string());
        None
    }
    let mut done = vec![];
    for s in stages {
        if let Some(c) = visit(&s.name, stages, &mut vec![], &mut done) {
            return Some(c);
        }
    }
    None
}

/// The closest allowed word within a small edit distance.
fn suggest<'a>(word: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .map(|c| (strsim::levenshtein(word, c), c))
        .filter(|(d, c)| *d <= 2.max(c.len() / 4) && *d > 0)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}
