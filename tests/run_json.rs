//! `laydown run --json`: one JSON document on stdout saying what ran, with the field
//! names the README documents; the per-stage lines move to stderr.
mod common;
use common::*;
use serde_json::Value;

/// fibre (laydown, 2 points × 2 replicates) -> spectra, and an independent spectra stage.
const PIPE: &str = "pipeline: js\narchive: out/study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60}\n    sweep: {diameter: [5.0e-05, 6.0e-05]}\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n  - name: ideal\n    kind: spectra\n    params: {preset: spectrum1}\n";

fn json_run(dir: &std::path::Path, args: &[&str]) -> (Value, String) {
    let out = run_in(dir, args);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{args:?}\nstdout: {o}\nstderr: {e}");
    let doc: Value = serde_json::from_str(&o).unwrap_or_else(|err| panic!("stdout is one JSON document ({err}): {o}"));
    (doc, e)
}

fn stage<'a>(doc: &'a Value, name: &str) -> &'a Value {
    doc["stages"].as_array().unwrap().iter().find(|s| s["name"] == name).unwrap_or_else(|| panic!("{name} in {doc}"))
}

#[test]
fn run_json_reports_every_stage_with_stable_fields() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", PIPE);
    let archive = d.canonicalize().unwrap().join("out/study.h5").display().to_string();

    let (doc, e) = json_run(d, &["run", "p.yaml", "--json"]);
    // The per-stage lines are still said, on stderr.
    assert!(e.contains("fibre: runs: new stage") && e.contains("fibre: wrote v1"), "{e}");
    assert_eq!(doc["pipeline"], "js");
    assert_eq!(doc["archive"], archive.as_str());
    assert_eq!(doc["dry_run"], false);
    assert!(doc["pipeline_file"].as_str().unwrap().ends_with("p.yaml"));
    let names: Vec<&str> = doc["stages"].as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names.len(), 3);
    assert!(names.iter().position(|n| *n == "fibre") < names.iter().position(|n| *n == "spectra"), "in the order they ran: {names:?}");
    let fibre = stage(&doc, "fibre");
    let keys: Vec<&str> = fibre.as_object().unwrap().keys().map(String::as_str).collect();
    let mut expected = vec!["archive", "group", "kind", "name", "outcome", "points", "reason", "replicates", "version", "wall_seconds"];
    expected.sort();
    let mut keys = keys;
    keys.sort();
    assert_eq!(keys, expected, "the documented fields, no others");
    assert_eq!(fibre["kind"], "laydown");
    assert_eq!(fibre["outcome"], "computed");
    assert_eq!(fibre["version"], 1);
    assert_eq!(fibre["group"], "/fibre/v1");
    assert_eq!(fibre["archive"], archive.as_str());
    assert_eq!(fibre["reason"], "new stage");
    assert_eq!((fibre["points"].as_u64(), fibre["replicates"].as_u64()), (Some(2), Some(2)));
    assert!(fibre["wall_seconds"].as_f64().unwrap() > 0.0);
    // The wall time is the one stored in provenance.
    let show: Value = serde_json::from_slice(&run_in(d, &["show", "out/study.h5", "fibre", "--json"]).stdout).unwrap();
    assert_eq!(show["provenance"]["wall_seconds"].as_f64(), fibre["wall_seconds"].as_f64());
    assert_eq!(stage(&doc, "ideal")["kind"], "spectra");

    // Up to date: reused, with the version used, no reason, no time.
    let (doc, _) = json_run(d, &["run", "p.yaml", "--json"]);
    for name in ["fibre", "spectra", "ideal"] {
        let s = stage(&doc, name);
        assert_eq!((s["outcome"].as_str(), s["version"].as_u64(), s["reason"].is_null(), s["wall_seconds"].as_f64()), (Some("reused"), Some(1), true, Some(0.0)), "{s}");
        assert_eq!(s["group"], format!("/{name}/v1"));
    }

    // A changed stage computes v2; --only leaves the others as not_selected.
    write_pipeline(d, "p.yaml", &PIPE.replace("spectrum1", "spectrum2"));
    let (doc, _) = json_run(d, &["run", "p.yaml", "--json", "--only", "ideal"]);
    let ideal = stage(&doc, "ideal");
    assert_eq!((ideal["outcome"].as_str(), ideal["version"].as_u64()), (Some("computed"), Some(2)));
    assert_eq!(ideal["reason"], "params.preset changed spectrum1 -> spectrum2");
    assert_eq!(stage(&doc, "fibre")["outcome"], "not_selected");
    assert_eq!(stage(&doc, "fibre")["version"], 1);

    // A dry run: would_run with no version yet; nothing written.
    write_pipeline(d, "p.yaml", &PIPE.replace("spectrum1", "spectrum3").replace("elements: 60", "elements: 50"));
    let before = std::fs::read(d.join("out/study.h5")).unwrap();
    let (doc, _) = json_run(d, &["run", "p.yaml", "--json", "--dry-run"]);
    assert_eq!(doc["dry_run"], true);
    let fibre = stage(&doc, "fibre");
    assert_eq!((fibre["outcome"].as_str(), fibre["version"].is_null(), fibre["group"].is_null()), (Some("would_run"), true, true), "{fibre}");
    assert_eq!(fibre["reason"], "params.elements changed 60 -> 50");
    assert_eq!(stage(&doc, "spectra")["outcome"], "would_run");
    assert_eq!(std::fs::read(d.join("out/study.h5")).unwrap(), before);
}

#[test]
fn run_json_prints_nothing_on_stdout_on_failure_and_nothing_else_under_quiet() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "p.yaml", &PIPE.replace("spectrum1", "spectrum9"));
    let out = run_in(d, &["run", "p.yaml", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty(), "{:?}", text(&out));
    // -q with --json: the document, and nothing on stderr.
    write_pipeline(d, "p.yaml", PIPE);
    let out = run_in(d, &["-q", "run", "p.yaml", "--json", "--only", "ideal"]);
    let (o, e) = text(&out);
    assert_eq!((out.status.code(), e.as_str()), (Some(0), ""), "{o}");
    let doc: Value = serde_json::from_str(&o).unwrap();
    assert_eq!(stage(&doc, "ideal")["outcome"], "computed");
}
