//! Machine-readable output (`ls --json`, `stages --json`), parsed with serde_json, and
//! `run -j/--threads N`: the pool size is N, recorded in provenance, and the results are
//! bit-identical with any N (every dataset but the laydown's per-replicate wall times).
mod common;
use common::*;
use serde_json::Value;

const CHAIN: &str = "pipeline: chain\narchive: study.h5\nstages:\n  - name: fibre\n    kind: laydown\n    params: {length: 0.12, elements: 60, diameter: 5.0e-05}\n    replicates: 4\n  - name: spectra\n    kind: spectra\n    input: fibre\n";

fn ok(dir: &std::path::Path, args: &[&str]) -> String {
    let out = run_in(dir, args);
    assert_eq!(out.status.code(), Some(0), "{args:?}: {:?}", text(&out));
    text(&out).0
}

fn json(dir: &std::path::Path, args: &[&str]) -> Value {
    let o = ok(dir, args);
    serde_json::from_str(&o).unwrap_or_else(|e| panic!("{args:?}: not JSON ({e}):\n{o}"))
}

#[test]
fn ls_json_lists_every_version_with_the_current_one() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &CHAIN.replace("diameter: 5.0e-05", "diameter: 4.0e-05"));
    ok(tmp.path(), &["run", "p.yaml"]);
    // back to the first parameters: v1 is current again, v2 stays
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    ok(tmp.path(), &["run", "p.yaml"]);

    let doc = json(tmp.path(), &["ls", "study.h5", "--json"]);
    let archive = doc["archive"].as_str().unwrap();
    assert!(std::path::Path::new(archive).is_absolute() && archive.ends_with("study.h5"), "{archive}");
    let stages = doc["stages"].as_array().unwrap();
    let names: Vec<&str> = stages.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["fibre", "spectra"]);
    for s in stages {
        assert_eq!(s["current"], 1, "{s}");
        let versions = s["versions"].as_array().unwrap();
        assert_eq!(versions.iter().map(|v| v["version"].as_u64().unwrap()).collect::<Vec<_>>(), [1, 2]);
        assert_eq!(versions.iter().map(|v| v["current"].as_bool().unwrap()).collect::<Vec<_>>(), [true, false]);
        for v in versions {
            assert_eq!(v["kind"], s["name"].as_str().map(|n| if n == "fibre" { "laydown" } else { "spectra" }).unwrap());
            assert_eq!(v["status"], "complete", "{v}");
            assert!(v["params_hash"].as_str().is_some_and(|h| !h.is_empty()), "{v}");
            assert!(v["wall_seconds"].as_f64().is_some_and(|w| w >= 0.0), "{v}");
            assert!(v["end_utc"].is_string(), "{v}");
        }
    }
    // the text listing says the same
    let text_ls = ok(tmp.path(), &["ls", "study.h5"]);
    assert!(text_ls.contains("v1*") && text_ls.lines().filter(|l| l.starts_with("fibre")).count() == 2, "{text_ls}");
}

#[test]
fn ls_json_of_a_missing_archive_is_bad_input_and_prints_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = run_in(tmp.path(), &["ls", "nope.h5", "--json"]);
    assert_eq!(out.status.code(), Some(2), "{:?}", text(&out));
    assert!(out.stdout.is_empty());
}

#[test]
fn stages_json_lists_kinds_and_typed_parameter_tables() {
    let tmp = tempfile::tempdir().unwrap();
    let doc = json(tmp.path(), &["stages", "--json"]);
    let kinds: Vec<&str> = doc["kinds"].as_array().unwrap().iter().map(|k| k["kind"].as_str().unwrap()).collect();
    // the same kinds as the text listing, in the same order
    let text_kinds: Vec<String> = ok(tmp.path(), &["stages"]).lines().take_while(|l| !l.is_empty()).map(|l| l.split_whitespace().next().unwrap().to_string()).collect();
    assert_eq!(kinds, text_kinds);
    let grid = doc["kinds"].as_array().unwrap().iter().find(|k| k["kind"] == "grid").unwrap();
    assert!(grid["input"]["kinds"].as_array().unwrap().contains(&Value::from("web")), "{grid}");
    assert_eq!(grid["input"]["min"], 1);

    let web = json(tmp.path(), &["stages", "web", "--json"]);
    assert_eq!(web["kind"], "web");
    let params = web["params"].as_array().unwrap();
    let p = |n: &str| params.iter().find(|p| p["name"] == n).unwrap_or_else(|| panic!("no {n}"));
    assert_eq!(p("input_point")["default"], Value::Null);
    assert_eq!(p("input_point")["auto"], true);
    assert_eq!(p("input_point")["type"], "int");
    assert!(p("fibres_across")["default"].is_i64(), "{}", p("fibres_across"));
    assert_eq!(p("preset")["type"], "choice");
    assert_eq!(p("preset")["schema"]["enum"], serde_json::json!(["none", "spectrum1", "spectrum2", "spectrum3"]));
    assert!(p("fibre_spacing")["default"].is_f64() && p("fibre_spacing")["unit"] == "m", "{}", p("fibre_spacing"));
    assert!(p("fibre_diameter")["auto"] == true && p("fibre_diameter")["unit"] == "m", "{}", p("fibre_diameter"));
    // every parameter of the text table, in order
    let text_params: Vec<String> = ok(tmp.path(), &["stages", "web"])
        .lines()
        .skip_while(|l| !l.starts_with("parameter"))
        .skip(1)
        .map(|l| l.split_whitespace().next().unwrap().to_string())
        .collect();
    assert_eq!(params.iter().map(|p| p["name"].as_str().unwrap()).collect::<Vec<_>>(), text_params);

    let out = run_in(tmp.path(), &["stages", "nope", "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
}

#[test]
fn threads_flag_sets_the_pool_and_results_stay_bit_identical() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    // the flag wins over RAYON_NUM_THREADS
    for (flag, n) in [("-j", 1), ("--threads", 2)] {
        let out = run_in_with_threads(tmp.path(), 3, &["run", "p.yaml", "--archive", &format!("t{n}.h5"), flag, &n.to_string()]);
        assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    }
    for stage in ["fibre", "spectra"] {
        let a = json(tmp.path(), &["show", "t1.h5", stage, "--json"]);
        let b = json(tmp.path(), &["show", "t2.h5", stage, "--json"]);
        assert_eq!(a["provenance"]["threads"], 1);
        assert_eq!(b["provenance"]["threads"], 2);
        // every dataset bit for bit, but a replicate's wall time
        let hashes = |d: &Value| -> Vec<String> {
            d["provenance"]["dataset_hashes"].as_str().unwrap().lines().filter(|l| !l.contains("wall_seconds")).map(str::to_string).collect()
        };
        assert!(hashes(&a).len() > 5, "{a}");
        assert_eq!(hashes(&a), hashes(&b), "{stage}");
    }
    for bad in ["0", "two"] {
        let out = run_in(tmp.path(), &["run", "p.yaml", "-j", bad]);
        assert_eq!(out.status.code(), Some(2), "-j {bad}: {:?}", text(&out));
    }
}

/// Provenance holds what is needed to rerun a stage and to know where it ran: the
/// pipeline file's text and hash, the repository and Cargo.lock hash, OS, CPU and
/// working directory, and the whole chain of versions upstream (not only the inputs).
#[test]
fn provenance_records_the_pipeline_machine_and_whole_upstream_chain() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = "pipeline: chain3\narchive: study.h5\nseed: 3\nstages:\n  - {name: spectrum, kind: spectra, params: {preset: spectrum1}}\n  - name: web\n    kind: web\n    input: spectrum\n    params: {fibres_across: 40, fibre_spacing: 0.00025, segments_per_fibre: 4, belt_speed_ratio: 0.028}\n  - name: grid\n    kind: grid\n    input: web\n    params: {cell_size: 0.001, window_side: 0.01, boundary: periodic}\n";
    write_pipeline(tmp.path(), "p.yaml", yaml);
    ok(tmp.path(), &["run", "p.yaml"]);
    let doc = json(tmp.path(), &["show", "study.h5", "grid", "--json"]);
    let p = &doc["provenance"];
    assert_eq!(p["pipeline_yaml"].as_str(), Some(yaml));
    let hash = p["pipeline_hash"].as_str().unwrap();
    assert!(hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()), "{hash}");
    let lock = p["cargo_lock_hash"].as_str().unwrap();
    assert!(lock.len() == 32 && lock.chars().all(|c| c.is_ascii_hexdigit()), "{lock}");
    assert!(p["os"].as_str().unwrap().starts_with(std::env::consts::OS.chars().next().unwrap().to_ascii_uppercase()), "{}", p["os"]);
    assert!(p["cpu"].as_str().unwrap().contains("logical CPUs"), "{}", p["cpu"]);
    assert!(std::path::Path::new(p["working_directory"].as_str().unwrap()).is_absolute());
    assert!(p["repository"].as_str().is_some_and(|r| !r.is_empty()));
    // the grid's chain reaches the spectrum through the web, nearest first
    let chain: Vec<&str> = p["upstream"].as_str().unwrap().lines().map(|l| l.split(' ').next().unwrap()).collect();
    assert_eq!(chain, ["/web/v1", "/spectrum/v1"]);
    assert_eq!(p["inputs"].as_str().unwrap().lines().count(), 1);
}

/// `export` writes a pipeline that computes an older version again from its provenance
/// alone, after the pipeline file has moved on: the same content hashes.
#[test]
fn export_reproduces_an_older_version_with_its_upstream() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", CHAIN);
    ok(tmp.path(), &["run", "p.yaml"]);
    write_pipeline(tmp.path(), "p.yaml", &CHAIN.replace("diameter: 5.0e-05", "diameter: 4.0e-05"));
    ok(tmp.path(), &["run", "p.yaml"]);
    let exported = ok(tmp.path(), &["export", "study.h5", "spectra@v1"]);
    assert!(exported.contains("name: fibre") && exported.contains("input: fibre"), "{exported}");
    std::fs::write(tmp.path().join("again.yaml"), &exported).unwrap();
    ok(tmp.path(), &["run", "again.yaml", "--archive", "again.h5"]);
    for stage in ["fibre", "spectra"] {
        let original = json(tmp.path(), &["show", "study.h5", &format!("{stage}@v1"), "--json"]);
        let changed = json(tmp.path(), &["show", "study.h5", &format!("{stage}@v2"), "--json"]);
        let again = json(tmp.path(), &["show", "again.h5", stage, "--json"]);
        let hashes = |d: &Value| -> Vec<String> {
            d["provenance"]["dataset_hashes"].as_str().unwrap().lines().filter(|l| !l.contains("wall_seconds")).map(str::to_string).collect()
        };
        assert_eq!(hashes(&again), hashes(&original), "{stage}");
        assert_ne!(hashes(&again), hashes(&changed), "{stage}: the test must tell the versions apart");
    }
    let out = run_in(tmp.path(), &["export", "study.h5", "nope"]);
    assert_eq!(out.status.code(), Some(2), "{:?}", text(&out));
}
