//! `laydown run --json`: one JSON document on stdout saying what the run did with each
//! stage. Field names are stable (documented in the README's CLI section):
//!
//! ```json
//! {"pipeline": "quickstart", "pipeline_file": "/abs/pipelines/quickstart.yaml",
//!  "archive": "/abs/results/quickstart.h5", "dry_run": false,
//!  "stages": [{"name": "fibre", "kind": "laydown", "outcome": "computed", "version": 2,
//!              "group": "/fibre/v2", "archive": "/abs/results/quickstart.h5",
//!              "reason": "params.diameter changed 5e-05 -> 4e-05", "wall_seconds": 1.52,
//!              "points": 3, "replicates": 4}]}
//! ```
//!
//! `outcome` is `reused`, `computed`, `not_selected` (outside `--only`/`--from`; an
//! existing version used), `would_run` or `cannot_run` (dry runs). `version` and `group`
//! are null for a stage that has none (a dry run's stage that would run); `reason` is null
//! for a stage that did not run; `wall_seconds` is the computation's wall time (0 when not
//! computed). Stages in the order they ran.
use crate::pipeline::Pipeline;
use crate::runner::StageReport;
use serde_json::{json, Value};

pub fn json(pipeline: &Pipeline, reports: &[StageReport], dry_run: bool) -> Value {
    // As `run` prints it: symlinks resolved (the archive the run wrote).
    let archive = crate::archive::resolve(&pipeline.archive).unwrap_or_else(|_| crate::archive::absolute(&pipeline.archive));
    let archive = archive.display().to_string();
    let file = std::path::absolute(&pipeline.file).unwrap_or_else(|_| pipeline.file.clone());
    let stages: Vec<Value> = reports
        .iter()
        .map(|r| {
            json!({
                "name": r.stage,
                "kind": r.kind,
                "outcome": r.outcome.as_str(),
                "version": (r.version > 0).then_some(r.version),
                "group": r.group(),
                "archive": archive,
                "reason": r.ran_because,
                "wall_seconds": r.wall_seconds,
                "points": r.points,
                "replicates": r.replicates,
            })
        })
        .collect();
    json!({
        "pipeline": pipeline.name,
        "pipeline_file": file.display().to_string(),
        "archive": archive,
        "dry_run": dry_run,
        "stages": stages,
    })
}
