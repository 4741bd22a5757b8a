//! Hard cases of every stage at reduced size (issue 7): each gives finite, bounded,
//! physically sensible results or a clear error with exit code 2. The laydown hard
//! cases (fast fibres, extreme friction, thin and thick fibres, ...) live beside the
//! solver in `src/stages/laydown/tests.rs`; the same cases at full size are in
//! `pipelines/stability/`.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};

fn run_pipeline(dir: &std::path::Path, yaml: &str) -> std::process::Output {
    write_pipeline(dir, "p.yaml", yaml);
    run_in(dir, &["run", "p.yaml"])
}

fn read(dir: &std::path::Path, stage: &str, name: &str) -> ndarray::ArrayD<f64> {
    let a = Archive::open_read(&dir.join("hard.h5")).unwrap();
    let g = a.version(stage, None).unwrap().open().unwrap();
    hdf::read_f64(&g, name).unwrap()
}

/// Spectra: the stiffest idealised spectrum with a high cut-off, and a straight fibre (e = 0).
#[test]
fn spectra_extremes_are_exact() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_pipeline(
        dir.path(),
        "pipeline: hard\narchive: hard.h5\nstages:\n  \
         - {name: stiff, kind: spectra, params: {bending_energy: 2.5e5, cutoff_number: 100}, replicates: 3}\n  \
         - {name: straight, kind: spectra, params: {bending_energy: 0.0}, replicates: 2}\n",
    );
    assert!(o.status.success(), "{:?}", text(&o));
    for (stage, e) in [("stiff", 2.5e5), ("straight", 0.0)] {
        for name in ["bending_energy_from_spectrum", "bending_energy_from_curvature"] {
            for &v in read(dir.path(), stage, name).iter() {
                assert!((v - e).abs() <= 1e-9 * e.max(1.0), "{stage} {name}: {v} != {e}");
            }
        }
        let kappa = read(dir.path(), stage, "curvature");
        assert!(kappa.iter().all(|k| k.is_finite()), "{stage}: non-finite curvature");
        if e == 0.0 {
            assert!(kappa.iter().all(|&k| k == 0.0), "a straight fibre has no curvature");
        } else {
            // e = V_b L/EI with V_b = (EI/2)∫κ² ds (eq 6), L = 1 m: the RMS curvature is sqrt(2e)/L.
            let rms = (kappa.iter().map(|k| k * k).sum::<f64>() / kappa.len() as f64).sqrt();
            assert!((rms - (2.0 * e).sqrt()).abs() < 1e-6 * rms, "RMS curvature {rms}");
        }
    }
}

/// Spectra: a cut-off at the Nyquist bin cannot be represented; it is refused up front.
#[test]
fn spectra_cutoff_at_nyquist_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_pipeline(
        dir.path(),
        "pipeline: hard\narchive: hard.h5\nstages:\n  \
         - {name: nyquist, kind: spectra, params: {cutoff_number: 500, points_per_segment: 1000}}\n",
    );
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("cutoff_number") && err.contains("Nyquist"), "{err}");
    assert!(!dir.path().join("hard.h5").exists(), "nothing written for a refused pipeline");
}
