//! Adding replicates computes only the new ones (issue 19): a laydown sweep going from 3 to
//! 5 replicates and a laid web from 1 to 2 read the stored replicates back and compute the
//! rest, and the versions written are bit-identical to a full run of 5 and 2 (measured wall
//! times aside). A stage whose stored output cannot give its rows back (a grid, a laydown
//! drawing replicates towards a target) says so and computes everything, as before.
mod common;
use common::*;
use laydown::archive::Archive;
use std::path::Path;

const PIPELINE: &str = "pipeline: inc
archive: ARCHIVE
seed: 9
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.15, elements: 100}
    sweep: {belt_speed: [0.2, 0.5]}
    replicates: FIBRES
  - name: rounds
    kind: laydown
    params: {length: 0.15, elements: 100, valid_replicates_target: 1}
    replicates: FIBRES
  - name: laid
    kind: laid_web
    params: {fibres_across: 2, fibre_spacing: 0.004, belt_travel: 0.02}
    replicates: WEBS
  - name: web
    kind: web
    params: {preset: spectrum1, points_per_segment: 200, fibres_across: 16, segments_per_fibre: 2}
  - name: grid
    kind: grid
    input: web
    params: {window_side: 0.02, boundary: periodic, store_density: false}
    replicates: WEBS
";

fn pipeline(archive: &str, fibres: usize, webs: usize) -> String {
    PIPELINE.replace("ARCHIVE", archive).replace("FIBRES", &fibres.to_string()).replace("WEBS", &webs.to_string())
}

/// The stored dataset hashes of a stage's current version, measured wall times left out.
fn hashes(archive: &Path, stage: &str) -> Vec<String> {
    let a = Archive::open_read(archive).unwrap();
    let v = a.version(stage, None).unwrap();
    v.attr_str("dataset_hashes").unwrap().lines().filter(|l| !l.starts_with("wall_seconds")).map(str::to_string).collect()
}

#[test]
fn new_replicates_alone_are_computed_and_the_version_equals_a_full_run() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    write_pipeline(d, "few.yaml", &pipeline("grown.h5", 3, 1));
    write_pipeline(d, "more.yaml", &pipeline("grown.h5", 5, 2));
    write_pipeline(d, "full.yaml", &pipeline("full.h5", 5, 2));
    for file in ["few.yaml", "more.yaml", "full.yaml"] {
        let out = run_in(d, &["run", file]);
        assert_eq!(out.status.code(), Some(0), "{file}: {:?}", text(&out));
        if file == "more.yaml" {
            let (o, _) = text(&out);
            assert!(o.contains("fibre: computed replicates 3..5 only; replicates 0..3 were read from v1"), "{o}");
            assert!(o.contains("laid: computed replicates 1..2 only; replicates 0..1 were read from v1"), "{o}");
            assert!(o.contains("rounds: computes all replicates: the stored ones of v1 cannot be reused (its units are whole points"), "{o}");
            assert!(o.contains("grid: computes all replicates: the stored ones of v1 cannot be reused (v1 does not hold"), "{o}");
        }
    }
    for stage in ["fibre", "rounds", "laid", "grid"] {
        assert_eq!(hashes(&d.join("grown.h5"), stage), hashes(&d.join("full.h5"), stage), "{stage}");
    }
    let a = Archive::open_read(&d.join("grown.h5")).unwrap();
    assert_eq!(a.version("fibre", None).unwrap().attr_str("incremental_from"), Some("v1: replicates 0..3 read from it, 3..5 computed"));
    assert_eq!(a.version("grid", None).unwrap().attr_str("incremental_from"), None);
}
