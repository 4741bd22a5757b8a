//! The spectra stage through the pipeline: presets, laid-fibre input, and its bad
//! inputs (no valid replicate, Δs longer than the fibre) as exit code 2 with the
//! archive untouched.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};

const LAID: &str = "pipeline: laid
archive: study.h5
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.12, elements: 60, BOUNCE}
    replicates: 2
  - name: spectra
    kind: spectra
    input: fibre
    params: {SPECTRA}
";

#[test]
fn presets_sweep_gives_the_paper_energies() {
    let tmp = tempfile::tempdir().unwrap();
    let p = repo_root().join("pipelines/paper/fig10_spectra.yaml");
    let out = run_in(tmp.path(), &["run", p.to_str().unwrap(), "--archive", "paper.h5"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let a = Archive::open_read(&tmp.path().join("paper.h5")).unwrap();
    let g = a.version("ideal_spectra", None).unwrap().open().unwrap();
    let e_spec = hdf::read_f64(&g, "bending_energy_from_spectrum").unwrap();
    let e_kappa = hdf::read_f64(&g, "bending_energy_from_curvature").unwrap();
    for (p, e) in [2.5e3, 2.5e4, 2.5e5].iter().enumerate() {
        for f in 0..10 {
            // Every realisation carries exactly e (random phases keep |K_r|; Parseval).
            assert!((e_spec[[p, f]] - e).abs() < 1e-9 * e, "point {p}: {}", e_spec[[p, f]]);
            assert!((e_kappa[[p, f]] - e).abs() < 1e-9 * e, "point {p}: {}", e_kappa[[p, f]]);
        }
    }
    let presets = hdf::read_strings(&g, "preset").unwrap();
    assert_eq!(presets, vec!["spectrum1", "spectrum2", "spectrum3"]);
}

#[test]
fn laydown_with_no_valid_replicate_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    // bounce_tolerance 0 on the transient lift: any rise of a landed node at any time
    // invalidates the replicate (the default final-profile test may find none).
    write_pipeline(tmp.path(), "p.yaml", &LAID.replace("BOUNCE", "bounce_tolerance: 0.0, bounce_check: transient").replace("SPECTRA", ""));
    let out = run_in(tmp.path(), &["run", "p.yaml"]);
    let (o, e) = text(&out);
    let a = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    let fibre = a.version("fibre", None).unwrap();
    let valid = hdf::read_u8(&fibre.open().unwrap(), "valid").unwrap();
    assert!(valid.iter().all(|&v| v == 0), "the scene must invalidate every replicate: {valid}");
    assert_eq!(out.status.code(), Some(2), "{o}{e}");
    assert!(e.contains("has no valid fibre"), "{e}");
    assert!(a.versions("spectra").unwrap().is_empty(), "nothing written for the failed stage");
}

#[test]
fn sample_spacing_longer_than_the_fibre_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", &LAID.replace("BOUNCE", "bounce_tolerance: 1.0").replace("SPECTRA", "sample_spacing: 0.5"));
    let out = run_in(tmp.path(), &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{o}{e}");
    assert!(e.contains("stage `spectra`") && e.contains("0.5"), "{e}");
    let a = Archive::open_read(&tmp.path().join("study.h5")).unwrap();
    assert!(a.versions("spectra").unwrap().is_empty());
    assert_eq!(a.versions("fibre").unwrap().len(), 1, "the upstream version stays");
}
