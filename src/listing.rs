//! What `laydown ls` and `laydown stages` print, as aligned text for people or as JSON
//! for programs (`--json`). Everything is read before anything is rendered, so a failing
//! command prints nothing to stdout.
//!
//! `ls --json`: `{"archive": PATH, "stages": [{"name", "current": N|null, "versions":
//! [{"version", "current", "kind", "status", "params_hash", "wall_seconds", "end_utc"}]}]}`
//! (a missing attribute, or a NaN wall time, is `null`).
//!
//! `stages --json`: `{"kinds": [{"kind", "summary", "input": {"kinds", "min", "max"}}]}`;
//! `stages KIND --json`: one kind with `"params": [{"name", "unit", "type", "default",
//! "auto", "allowed", "schema", "doc"}]`, `schema` being the parameter's JSON Schema as in
//! `schemas/pipeline.schema.json`.
use crate::archive::Archive;
use crate::params::{ParamKind, ParamSpec, ParamValue};
use crate::stages::{self, BadInput, Stage};
use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// One version of a stage, as `ls` lists it.
#[derive(Debug, Clone)]
pub struct VersionRow {
    pub version: u32,
    pub current: bool,
    pub kind: Option<String>,
    pub status: Option<String>,
    pub params_hash: Option<String>,
    pub wall_seconds: Option<f64>,
    pub end_utc: Option<String>,
}

/// An archive's stages and versions, oldest first.
#[derive(Debug, Clone)]
pub struct Listing {
    pub archive: PathBuf,
    /// (stage, its current version, its versions).
    pub stages: Vec<(String, Option<u32>, Vec<VersionRow>)>,
}

/// Read every stage and version of an archive.
pub fn list(path: &Path) -> Result<Listing> {
    let archive = Archive::open_read(path)?;
    let marks = archive.current_marks()?;
    let mut stages = vec![];
    for stage in archive.stages()? {
        let current = marks.get(&stage).copied();
        let rows = archive
            .versions(&stage)?
            .iter()
            .map(|v| VersionRow {
                version: v.number,
                current: current == Some(v.number),
                kind: v.attr_str("stage_kind").map(str::to_string),
                status: v.attr_str("status").map(str::to_string),
                params_hash: v.attr_str("params_hash").map(str::to_string),
                wall_seconds: v.attr_f64("wall_seconds"),
                end_utc: v.attr_str("end_utc").map(str::to_string),
            })
            .collect();
        stages.push((stage, current, rows));
    }
    Ok(Listing { archive: crate::archive::absolute(path), stages })
}

impl Listing {
    /// One line per version; `*` marks the current ones.
    pub fn text(&self) -> String {
        // the stage column as wide as the longest name, so that the columns stay aligned
        let w = self.stages.iter().map(|(s, _, _)| s.chars().count()).max().unwrap_or(0).max(16);
        let mut lines = vec![format!("{:<w$} {:>5} {:<10} {:<10} {:<17} {:>10}  {}", "stage", "ver", "kind", "status", "params hash", "wall (s)", "finished (UTC)")];
        for (stage, _, rows) in &self.stages {
            for v in rows {
                lines.push(format!(
                    "{:<w$} {:>5} {:<10} {:<10} {:<17} {:>10.2}  {}",
                    stage,
                    format!("v{}{}", v.version, if v.current { "*" } else { " " }),
                    v.kind.as_deref().unwrap_or("?"),
                    v.status.as_deref().unwrap_or("?"),
                    v.params_hash.as_deref().unwrap_or("?"),
                    v.wall_seconds.unwrap_or(f64::NAN),
                    v.end_utc.as_deref().unwrap_or("?"),
                ));
            }
        }
        if self.stages.iter().any(|(_, c, _)| c.is_some()) {
            lines.push("* current: the version the pipeline's last run matched or wrote".into());
        }
        lines.join("\n") + "\n"
    }

    pub fn json(&self) -> Value {
        let stages: Vec<Value> = self
            .stages
            .iter()
            .map(|(name, current, rows)| {
                let versions: Vec<Value> = rows
                    .iter()
                    .map(|v| {
                        json!({
                            "version": v.version,
                            "current": v.current,
                            "kind": v.kind,
                            "status": v.status,
                            "params_hash": v.params_hash,
                            "wall_seconds": v.wall_seconds.filter(|w| w.is_finite()),
                            "end_utc": v.end_utc,
                        })
                    })
                    .collect();
                json!({"name": name, "current": current, "versions": versions})
            })
            .collect();
        json!({"archive": self.archive.display().to_string(), "stages": stages})
    }
}

/// The kinds, or one kind's parameter table, as `laydown stages [KIND]` prints it.
pub fn stages_text(kind: Option<&str>) -> Result<String> {
    let mut out = String::new();
    match kind {
        None => {
            for s in stages::registry() {
                out += &format!("{:<10} {}\n", s.kind(), s.summary());
            }
            out += "\n`laydown stages KIND` prints a kind's parameters.\n";
        }
        Some(k) => {
            let s = find(k)?;
            out += &format!("{} — {}\n\n", s.kind(), s.summary());
            let rule = s.inputs();
            if rule.max > 0 {
                out += &format!("input: {} to {} stage(s) of kind {}\n\n", rule.min, rule.max, rule.kinds.join(" or "));
            }
            out += &format!("{:<32} {:<10} {:<14} {:<40} {}\n", "parameter", "unit", "default", "allowed", "meaning");
            for p in s.params() {
                let unit = if p.unit.is_empty() { "-" } else { p.unit };
                let allowed = match &p.kind {
                    ParamKind::Choice(c) => c.join("|"),
                    _ => p.allowed(),
                };
                out += &format!("{:<32} {:<10} {:<14} {:<40} {}\n", p.name, unit, p.default.to_string(), allowed, p.doc);
            }
        }
    }
    Ok(out)
}

/// [`stages_text`] as JSON.
pub fn stages_json(kind: Option<&str>) -> Result<Value> {
    Ok(match kind {
        None => json!({"kinds": stages::registry().iter().map(|s| kind_json(*s, false)).collect::<Vec<_>>()}),
        Some(k) => kind_json(find(k)?, true),
    })
}

fn find(k: &str) -> Result<&'static dyn Stage> {
    stages::find(k)
        .ok_or_else(|| BadInput(format!("unknown stage kind `{k}`; allowed: {}", stages::kinds().join(", "))))
        .context("laydown stages")
}

fn kind_json(s: &dyn Stage, params: bool) -> Value {
    let rule = s.inputs();
    let mut v = json!({"kind": s.kind(), "summary": s.summary(), "input": {"kinds": rule.kinds, "min": rule.min, "max": rule.max}});
    if params {
        v["params"] = Value::Array(s.params().iter().map(param_json).collect());
    }
    v
}

fn param_json(p: &ParamSpec) -> Value {
    let kind = match &p.kind {
        ParamKind::Float { .. } => "float",
        ParamKind::Int { .. } => "int",
        ParamKind::Bool => "bool",
        ParamKind::Choice(_) => "choice",
        ParamKind::Text => "text",
        ParamKind::TextList => "text_list",
    };
    json!({
        "name": p.name,
        "unit": p.unit,
        "type": kind,
        "default": value_json(&p.default.value()),
        "auto": p.auto,
        "allowed": p.allowed(),
        "schema": crate::schema::value_schema(p),
        "doc": p.doc,
    })
}

/// A parameter value as JSON: numbers, booleans, texts, lists; `auto` is `null`.
fn value_json(v: &ParamValue) -> Value {
    match v {
        ParamValue::Float(f) if f.is_finite() => json!(f),
        ParamValue::Float(f) => json!(f.to_string()),
        ParamValue::Int(i) => json!(i),
        ParamValue::Bool(b) => json!(b),
        ParamValue::Text(t) => json!(t),
        ParamValue::List(l) => json!(l),
        ParamValue::Auto => Value::Null,
    }
}

#[cfg(test)]
mod text_tests {
    use super::*;

    /// A stage name longer than the default column (`grid_implicit_axial`) widens it: every
    /// line's kind and status start where their headings do.
    #[test]
    fn long_stage_names_keep_the_columns_aligned() {
        let row = |version| VersionRow { version, current: version == 2, kind: Some("grid".into()), status: Some("complete".into()), params_hash: Some("54cf8b505a1f60f5".into()), wall_seconds: Some(1.2), end_utc: Some("2026-12-03T08:35:27Z".into()) };
        let listing = Listing { archive: "a.h5".into(), stages: vec![("grid".into(), Some(2), vec![row(1), row(2)]), ("grid_implicit_axial".into(), Some(2), vec![row(1), row(2)])] };
        let text = listing.text();
        let lines: Vec<&str> = text.lines().take(5).collect();
        let (kind, status) = (lines[0].find("kind").unwrap(), lines[0].find("status").unwrap());
        for l in &lines[1..] {
            assert_eq!((&l[kind..kind + 4], &l[status..status + 8]), ("grid", "complete"), "columns moved:\n{text}");
        }
    }
}
