//! `laydown export ARCHIVE STAGE[@vN]`: a pipeline file that computes that version again,
//! from its provenance alone: the version and every version upstream of it (followed
//! through each version's `inputs`), upstream first, each with the kind, inputs,
//! parameters (all of them, as resolved), sweep, replicates and seed it was computed
//! with. Run with the same laydown (`git_commit`), it writes datasets with the same
//! content hashes; the header names the versions and hashes to compare with.
//!
//! Relative paths inside parameters (an image stage's `files`) are relative to the
//! directory of the pipeline that made the version; keep the exported file there or
//! edit them.

use super::{Archive, VersionInfo};
use anyhow::{anyhow, bail, Result};

/// The pipeline text reproducing `stage` version `number` (None: its current one).
pub fn export_pipeline(archive: &Archive, stage: &str, number: Option<u32>) -> Result<String> {
    let target = archive.version(stage, number)?;
    let mut order: Vec<VersionInfo> = Vec::new();
    visit(archive, target.clone(), &mut order, &mut Vec::new())?;
    let first = &order[order.len() - 1];
    let pipeline_name = first.attr_str("pipeline_name").unwrap_or("exported");
    let stem = archive.path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "archive".into());
    let mut out = format!(
        "# Exported by `laydown export` from {} {}@v{}: this pipeline computes it again.\n",
        archive.path.display(),
        target.stage,
        target.number
    );
    out.push_str(&format!("# laydown {} (git {}), the code that computed it.\n", first.attr_str("laydown_version").unwrap_or("?"), first.attr_str("git_commit").unwrap_or("?")));
    out.push_str("# The versions, with the content hashes a rerun must give:\n");
    for v in &order {
        out.push_str(&format!("#   {}@v{} content_hash={}\n", v.stage, v.number, v.attr_str("content_hash").unwrap_or("?")));
    }
    out.push_str(&format!("pipeline: {}\narchive: {stem}_export.h5\nstages:\n", yaml_scalar(pipeline_name)));
    for v in &order {
        let get = |k: &str| v.attr_str(k).ok_or_else(|| anyhow!("{}@v{} has no `{k}` in its provenance: it cannot be exported", v.stage, v.number));
        out.push_str(&format!("  - name: {}\n    kind: {}\n", v.stage, get("stage_kind")?));
        let inputs = input_refs(v)?;
        match inputs.len() {
            0 => {}
            1 => out.push_str(&format!("    input: {}\n", inputs[0].0)),
            _ => out.push_str(&format!("    input: [{}]\n", inputs.iter().map(|(s, _)| s.as_str()).collect::<Vec<_>>().join(", "))),
        }
        out.push_str(&format!("    replicates: {}\n    seed: {}\n", v.attrs.get("replicates").map(attr_text).unwrap_or_else(|| "1".into()), get("seed")?));
        let params = get("params_yaml")?.trim_end();
        if params != "{}" {
            out.push_str("    params:\n");
            out.push_str(&indent(params, 6));
        }
        let sweep = v.attr_str("sweep_yaml").unwrap_or("");
        let mut mode = None;
        let mut axes = Vec::new();
        for line in sweep.lines().filter(|l| !l.trim().is_empty()) {
            match line.strip_prefix("mode: ") {
                Some(m) => mode = Some(m.trim().to_string()),
                None => axes.push(line.to_string()),
            }
        }
        if !axes.is_empty() {
            if let Some(m) = mode {
                out.push_str(&format!("    sweep_mode: {m}\n"));
            }
            out.push_str("    sweep:\n");
            out.push_str(&indent(&axes.join("\n"), 6));
        }
    }
    Ok(out)
}

/// Depth-first, inputs before the version; a version reached twice is listed once.
fn visit(archive: &Archive, v: VersionInfo, order: &mut Vec<VersionInfo>, path: &mut Vec<(String, u32)>) -> Result<()> {
    let key = (v.stage.clone(), v.number);
    if order.iter().any(|o| o.stage == key.0 && o.number == key.1) {
        return Ok(());
    }
    if path.contains(&key) {
        bail!("the inputs of {}@v{} lead back to it", key.0, key.1);
    }
    if order.iter().any(|o| o.stage == key.0) {
        bail!("two versions of stage `{}` are upstream of the exported one; a pipeline has one stage of that name", key.0);
    }
    path.push(key);
    for (stage, number) in input_refs(&v)? {
        let input = archive.version(&stage, Some(number)).map_err(|e| anyhow!("input {stage}@v{number} of {}@v{}: {e}", v.stage, v.number))?;
        visit(archive, input, order, path)?;
    }
    path.pop();
    order.push(v);
    Ok(())
}

/// (stage, version) of each line `/<stage>/v<N> content_hash=…` of `inputs`.
fn input_refs(v: &VersionInfo) -> Result<Vec<(String, u32)>> {
    let mut refs = Vec::new();
    for line in v.attr_str("inputs").unwrap_or("").lines().filter(|l| !l.trim().is_empty()) {
        let group = line.split_whitespace().next().unwrap_or("");
        let parsed = group.strip_prefix('/').and_then(|g| g.rsplit_once("/v")).and_then(|(s, n)| Some((s.to_string(), n.parse::<u32>().ok()?)));
        match parsed {
            Some(r) => refs.push(r),
            None => bail!("{}@v{}: cannot read input `{line}` of its provenance", v.stage, v.number),
        }
    }
    Ok(refs)
}

fn attr_text(a: &super::data::Attr) -> String {
    match a {
        super::data::Attr::Str(s) => s.clone(),
        super::data::Attr::I64(i) => i.to_string(),
        super::data::Attr::F64(f) => f.to_string(),
    }
}

fn indent(text: &str, by: usize) -> String {
    text.lines().map(|l| format!("{}{l}\n", " ".repeat(by))).collect()
}

/// A pipeline name as a YAML scalar (quoted when it could be read as something else).
fn yaml_scalar(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c)) {
        s.to_string()
    } else {
        format!("{s:?}")
    }
}
