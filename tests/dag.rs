//! `laydown dag PIPELINE [--dot]`: the stage graph, as text or Graphviz DOT, without
//! touching any archive.
mod common;
use common::*;

const PIPE: &str = "pipeline: g\narchive: out/g.h5\nstages:\n  - name: fibre\n    kind: laydown\n    replicates: 2\n  - name: spectra\n    kind: spectra\n    input: fibre\n  - name: web\n    kind: web\n    input: spectra\n  - name: ideal\n    kind: spectra\n    params: {preset: spectrum1}\n  - name: both\n    kind: accuracy\n    input: [ideal, spectra]\n";

#[test]
fn dag_prints_the_stage_graph_as_text_and_dot() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let out = run_in(tmp.path(), &["dag", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    let lines: Vec<&str> = o.lines().collect();
    assert_eq!(lines[0], "pipeline g: 5 stages, in the order they run", "{o}");
    assert!(lines[1].starts_with("fibre ") && lines[1].contains("laydown") && lines[1].contains("1 point × 2 replicates"), "{o}");
    assert!(lines[2].starts_with("spectra ") && lines[2].ends_with("<- fibre"), "{o}");
    assert!(lines.iter().any(|l| l.starts_with("both ") && l.ends_with("<- ideal, spectra")), "{o}");
    let pos = |s: &str| lines.iter().position(|l| l.starts_with(&format!("{s} "))).unwrap();
    assert!(pos("fibre") < pos("spectra") && pos("spectra") < pos("web") && pos("ideal") < pos("both"), "{o}");

    let out = run_in(tmp.path(), &["dag", "p.yaml", "--dot"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.starts_with("digraph \"g\" {") && o.trim_end().ends_with('}'), "{o}");
    for edge in ["\"fibre\" -> \"spectra\";", "\"spectra\" -> \"web\";", "\"ideal\" -> \"both\";", "\"spectra\" -> \"both\";"] {
        assert!(o.contains(edge), "{edge} missing: {o}");
    }
    assert_eq!(o.matches(" -> ").count(), 4, "{o}");
    assert!(!tmp.path().join("out").exists(), "dag touches no archive");
}

#[test]
fn dag_of_an_invalid_pipeline_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", &PIPE.replace("input: spectra\n  - name: ideal", "input: nope\n  - name: ideal"));
    let out = run_in(tmp.path(), &["dag", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(o.is_empty() && e.contains("p.yaml:") && e.contains("nope"), "{o}\n{e}");
}
