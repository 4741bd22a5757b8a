//! The laid_web stage through the pipeline and the grid: mass conservation in the
//! interior window, thread-count independence, and bad input as exit code 2.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};
use std::path::Path;

fn pipeline(laid: &str, grid: &str, reps: usize) -> String {
    format!(
        "pipeline: lw
archive: lw.h5
seed: 5
stages:
  - name: laid
    kind: laid_web
    params: {{{laid}}}
    replicates: {reps}
  - name: grid
    kind: grid
    input: laid
    params: {{{grid}}}
    replicates: {reps}
"
    )
}

fn run_ok(dir: &Path, yaml: &str, threads: usize) {
    write_pipeline(dir, "p.yaml", yaml);
    let out = run_in_with_threads(dir, threads, &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
}

fn read(dir: &Path, stage: &str, name: &str) -> ndarray::ArrayD<f64> {
    let a = Archive::open_read(&dir.join("lw.h5")).unwrap();
    hdf::read_f64(&a.version(stage, None).unwrap().open().unwrap(), name).unwrap()
}

/// Mass conservation: in a window that covers the whole CD period and two whole
/// oscillation periods of belt travel (v_b/f each: within one a fibre lays its coils in
/// bursts) inside the interior MD range, the fibre fed at v_f onto the belt at v_b from
/// every hole Δw apart leaves ρ_av = ρ(πd²/4)/(Δw·c), c = v_b/v_f, within 2 %.
#[test]
fn laid_web_conserves_mass_in_the_interior_window() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = pipeline(
        "fibres_across: 8, fibre_spacing: 0.0025, belt_travel: 0.1, oscillation_amplitude: 0.005, oscillation_frequency: 20.0",
        "window_side: 0.02, cell_size: 0.001, zone_size_min: 0.001, zone_size_max: 0.008",
        1,
    );
    run_ok(tmp.path(), &yaml, 2);
    let expected = read(tmp.path(), "grid", "expected_interior_density")[[0]];
    let rho = read(tmp.path(), "grid", "mean_areal_density")[[0, 0]];
    assert!((expected - 18.653).abs() < 0.01, "ρA/(Δw c) = {expected} g/m² (d = 50 µm, ρ = 950, Δw = 2.5 mm, c = 0.04)");
    assert!((rho / expected - 1.0).abs() < 0.02, "ρ_av {rho} g/m² against {expected} g/m²");
    let valid = read(tmp.path(), "laid", "valid_fibres");
    assert_eq!(valid[[0, 0]], 8.0);
    println!("ρ_av {rho} g/m² against {expected} g/m²");
    let laid = read(tmp.path(), "laid", "laid_positions");
    assert_eq!(laid.shape()[3], 3);
    let cv = read(tmp.path(), "grid", "cv")[[0, 0]];
    assert!(cv.is_finite() && cv > 0.0, "cv {cv}");
}

/// The same pipeline with 1 and 2 threads gives bit-identical laid webs and grids.
#[test]
fn laid_web_is_identical_for_one_and_two_threads() {
    let (one, two) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let yaml = pipeline(
        "fibres_across: 3, fibre_spacing: 0.004, belt_travel: 0.06, edge_margin_spreads: 0.5, frequency_jitter: 0.1",
        "window_side: 0.012, cell_size: 0.001, zone_size_min: 0.001, zone_size_max: 0.004",
        2,
    );
    run_ok(one.path(), &yaml, 1);
    run_ok(two.path(), &yaml, 2);
    for (stage, name) in [
        ("laid", "laid_positions"),
        ("laid", "landing_time"),
        ("laid", "bending_energy"),
        ("laid", "phase"),
        ("laid", "interior_md_max"),
        ("grid", "density"),
        ("grid", "cv_zone"),
    ] {
        let (a, b) = (read(one.path(), stage, name), read(two.path(), stage, name));
        assert_eq!(a.shape(), b.shape());
        assert!(a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits()), "{stage}/{name} differs between 1 and 2 threads");
    }
}

fn exit_2(yaml: &str, command: &str, expect: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", yaml);
    let out = run_in(tmp.path(), &[command, "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{o}{e}");
    for s in expect {
        assert!(e.contains(s), "`{s}` not in: {e}");
    }
    assert!(!tmp.path().join("lw.h5").exists() || command == "run", "validate wrote an archive");
}

#[test]
fn bad_laid_webs_are_refused_before_computing() {
    // a stationary belt has no belt travel to lay
    exit_2(&pipeline("belt_speed: 0.0", "", 1), "validate", &["belt_speed", "moving belt"]);
    // a flag that acts only with fibre contact is not silently ignored without it
    exit_2(&pipeline("self_contact: true", "", 1), "validate", &["self_contact", "needs fibre_contact: true"]);
    // a request too big for the machine is refused by validate, naming the estimate
    exit_2(&pipeline("fibres_across: 1000000, belt_travel: 100.0", "", 1), "validate", &["GiB", "fibres_across"]);
    // nothing is laid when the feed is shorter than the hanging part
    exit_2(&pipeline("belt_travel: 0.001", "", 1), "validate", &["belt_travel"]);
    // the window may not be wider than the CD period n_w·Δw
    exit_2(&pipeline("fibres_across: 2, belt_travel: 0.03", "window_side: 0.01", 1), "run", &["CD period"]);
}

/// The paper's surrogate built from exactly these laid fibres: spectra of every valid
/// fibre of the laid web (belt removed), a random-phase web from their mean spectrum,
/// gridded like the laid web.
#[test]
fn spectra_of_laid_web_fibres_feed_a_surrogate_web() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = "pipeline: lw
archive: lw.h5
seed: 5
stages:
  - name: laid
    kind: laid_web
    params: {fibres_across: 3, fibre_spacing: 0.004, belt_travel: 0.06}
    replicates: 2
  - name: spectra
    kind: spectra
    input: laid
    params: {points_per_segment: 200, sample_spacing: 0.001}
  - name: surrogate
    kind: web
    input: spectra
    params: {fibres_across: 20, fibre_spacing: 0.004, belt_speed_ratio: 0.04, fibre_diameter: 5.0e-5, fibre_density: 950.0, segments_per_fibre: 4}
  - name: grid
    kind: grid
    input: surrogate
    params: {window_side: 0.02, boundary: periodic}
";
    run_ok(tmp.path(), yaml, 2);
    let valid = read(tmp.path(), "laid", "valid_fibres");
    let e = read(tmp.path(), "spectra", "bending_energy_from_spectrum");
    let fibres = e.iter().filter(|v| v.is_finite()).count();
    assert_eq!(fibres as f64, valid.iter().sum::<f64>(), "one spectrum per valid laid fibre");
    assert!(e.iter().filter(|v| v.is_finite()).all(|&v| v > 0.0));
    let rho = read(tmp.path(), "grid", "mean_areal_density")[[0, 0]];
    assert!(rho.is_finite() && rho > 0.0);
}

/// The image method runs on a laid web rendered through its grid, and reads the
/// rendering's own CV back within a few per cent when no bonds are printed on it.
#[test]
fn image_renders_a_laid_web_grid() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = pipeline("fibres_across: 3, fibre_spacing: 0.004, belt_travel: 0.03, edge_margin_spreads: 0.0", "cell_size: 0.0005, window_side: 0.012, edge_margin_spreads: 0.0", 1)
        + "  - name: scans\n    kind: image\n    input: grid\n";
    run_ok(tmp.path(), &yaml, 2);
    let raw = read(tmp.path(), "scans", "cv_raw");
    let truth = read(tmp.path(), "scans", "cv_web");
    assert!(raw.iter().all(|v| v.is_finite() && *v > 0.0), "{raw}");
    assert!(truth.iter().all(|v| v.is_finite() && *v > 0.0), "{truth}");
}
