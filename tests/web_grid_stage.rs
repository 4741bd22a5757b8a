//! The web and grid stages through the pipeline: mass conservation, spectrum kept by
//! the random phases, thread-count independence, bit-exact regeneration of stored
//! fibres, and the edge cases (c = 0, c > 1, n_l = 1, window larger than the web,
//! Δh not dividing H, missing spectrum) as a correct answer or exit code 2.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};
use laydown::stages::spectra::CurvatureSpectrum;
use laydown::stages::web::web_from_input;
use laydown::stages::Input;
use std::path::Path;

fn pipeline(web: &str, grid: &str, reps: usize) -> String {
    format!(
        "pipeline: wg
archive: wg.h5
seed: 11
stages:
  - name: web
    kind: web
    params: {{{web}}}
  - name: grid
    kind: grid
    input: web
    params: {{{grid}}}
    replicates: {reps}
"
    )
}

fn web_pipeline(web: &str) -> String {
    format!("pipeline: wg\narchive: wg.h5\nseed: 11\nstages:\n  - name: web\n    kind: web\n    params: {{{web}}}\n")
}

fn run_ok(dir: &Path, yaml: &str, threads: usize) {
    write_pipeline(dir, "p.yaml", yaml);
    let out = run_in_with_threads(dir, threads, &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
}

fn run_bad(yaml: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", yaml);
    let out = run_in(tmp.path(), &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{o}{e}");
    e
}

fn read(dir: &Path, stage: &str, name: &str) -> ndarray::ArrayD<f64> {
    let a = Archive::open_read(&dir.join("wg.h5")).unwrap();
    hdf::read_f64(&a.version(stage, None).unwrap().open().unwrap(), name).unwrap()
}

fn web_input(dir: &Path) -> Input {
    let a = Archive::open_read(&dir.join("wg.h5")).unwrap();
    Input { name: "web".into(), kind: "web".into(), version: a.version("web", None).unwrap() }
}

/// On a torus that the window covers exactly, every node's mass Δm = ρ(πd²/4)Δs lands
/// in the window: ρ_av = n_w·n_l·L·ρπd²/4 / H². With H = c·n_l·L = n_wΔw this is
/// ρπd²/4 / (Δw·c), the interior density the mass per length, Δw and c imply. Exact
/// binary values make the comparison exact up to the deposit's quantisation (2⁻³²Δm).
#[test]
fn mass_is_conserved_for_c_below_and_above_one() {
    // (Δw, c, H): n_w = 128, n_l = 4, L = 1 m.
    for (dw, c, h) in [(0.001953125, 0.0625, 0.25), (0.0625, 2.0, 8.0)] {
        let tmp = tempfile::tempdir().unwrap();
        let web = format!("preset: spectrum1, points_per_segment: 200, fibres_across: 128, segments_per_fibre: 4, fibre_spacing: {dw}, belt_speed_ratio: {c}");
        let grid = format!("window_side: {h}, cell_size: {}, boundary: periodic", h / 256.0);
        run_ok(tmp.path(), &pipeline(&web, &grid, 2), 2);
        let rho = read(tmp.path(), "grid", "mean_areal_density");
        let expected = 950.0 * std::f64::consts::PI * 20e-6f64.powi(2) / 4.0 / (dw * c) * 1e3;
        assert!((read(tmp.path(), "grid", "expected_interior_density")[[0]] / expected - 1.0).abs() < 1e-12);
        for v in rho.iter() {
            assert!((v / expected - 1.0).abs() < 1e-9, "c = {c}: ρ_av {v} g/m² vs {expected}");
        }
        let density = read(tmp.path(), "grid", "density");
        assert_eq!(density.shape(), &[1, 2, 256, 256]);
    }
}

/// Open web, as laid: inside the window (kept 3 spreads from every edge) the mean areal
/// density matches ρπd²/4/(Δw·c) within its sampling error.
#[test]
fn interior_density_of_an_open_web_matches_mass_per_length() {
    let tmp = tempfile::tempdir().unwrap();
    let web = "preset: spectrum3, points_per_segment: 500, fibres_across: 400, segments_per_fibre: 20, belt_speed_ratio: 0.1";
    run_ok(tmp.path(), &pipeline(web, "window_side: 0.1, cell_size: 0.002", 4), 2);
    let rho = read(tmp.path(), "grid", "mean_areal_density");
    let expected = read(tmp.path(), "grid", "expected_interior_density")[[0]];
    let n = rho.len() as f64;
    let mean = rho.iter().sum::<f64>() / n;
    let sd = (rho.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!((mean - expected).abs() < 4.0 * sd / n.sqrt() + 0.02 * expected, "ρ_av {mean} ± {sd} vs {expected}: {rho}");
}

/// The DFT of every generated segment's curvature has the input magnitudes |K_r|.
#[test]
fn random_phases_keep_the_spectrum() {
    let tmp = tempfile::tempdir().unwrap();
    run_ok(tmp.path(), &web_pipeline("preset: spectrum2, points_per_segment: 256, fibres_across: 3, segments_per_fibre: 3"), 1);
    let webs = web_from_input(&web_input(tmp.path()));
    let web = &webs.unwrap()[0];
    let re = read(tmp.path(), "web", "spectrum_real");
    let im = read(tmp.path(), "web", "spectrum_imag");
    let n = web.points_per_segment();
    let scale = (0..n).map(|r| re[[0, 0, r]].hypot(im[[0, 0, r]])).fold(0.0, f64::max);
    for fibre in 0..3 {
        let (_, kappa) = web.fibre_curvature(1, fibre);
        for seg in kappa.chunks(n) {
            let s = CurvatureSpectrum::from_curvature(seg, web.segment_length()).unwrap();
            for (r, k) in s.coefficients().iter().enumerate() {
                let want = re[[0, 0, r]].hypot(im[[0, 0, r]]);
                assert!((k.norm() - want).abs() < 1e-9 * scale, "bin {r}: |K| {} vs {want}", k.norm());
            }
        }
    }
}

/// 1 and 2 threads give bit-identical webs and grids; the grid stage regenerates the
/// stored fibres bit for bit, and so does the library from the archive alone.
#[test]
fn threads_do_not_change_results_and_stored_fibres_regenerate() {
    let (one, two) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let yaml = pipeline(
        "preset: spectrum1, points_per_segment: 500, fibres_across: 64, segments_per_fibre: 6, belt_speed_ratio: 0.05",
        "window_side: 0.1, boundary: periodic, deposit: segment_clipping",
        2,
    );
    run_ok(one.path(), &yaml, 1);
    run_ok(two.path(), &yaml, 2);
    for (stage, name) in [("web", "fibre_positions"), ("grid", "density"), ("grid", "cv"), ("grid", "cv_zone"), ("grid", "formation_number")] {
        let (a, b) = (read(one.path(), stage, name), read(two.path(), stage, name));
        assert_eq!(a.shape(), b.shape());
        assert!(a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits()), "{stage}/{name} differs between 1 and 2 threads");
    }
    let a = Archive::open_read(&two.path().join("wg.h5")).unwrap();
    let check = a.version("grid", None).unwrap().attr_str("regeneration_check").map(str::to_string);
    let g = a.version("grid", None).unwrap().open().unwrap();
    let attrs = hdf::read_attrs(&g).unwrap();
    let msg = format!("{:?}{:?}", check, attrs.get("regeneration_check"));
    assert!(msg.contains("64 stored fibres of realisation 0 regenerated bit-identically"), "{msg}");
    let webs = web_from_input(&web_input(two.path())).unwrap();
    let stored = read(two.path(), "web", "fibre_positions");
    for j in [0, 17, 63] {
        let nodes = webs[0].generate_fibre(0, j);
        assert_eq!(nodes.len(), stored.shape()[3]);
        for (k, n) in nodes.iter().enumerate() {
            assert_eq!(n[0].to_bits(), stored[[0, 0, j, k, 0]].to_bits());
            assert_eq!(n[1].to_bits(), stored[[0, 0, j, k, 1]].to_bits());
        }
    }
}

/// A large web stores a sample of fibres, evenly spread, not the whole web.
#[test]
fn large_webs_store_a_sample_of_fibres() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = web_pipeline("preset: spectrum1, points_per_segment: 100, fibres_across: 50, segments_per_fibre: 2, store_all_max_points: 1000, sample_fibres: 4");
    run_ok(tmp.path(), &yaml, 2);
    let a = Archive::open_read(&tmp.path().join("wg.h5")).unwrap();
    let idx = hdf::read_i64(&a.version("web", None).unwrap().open().unwrap(), "sample_fibre_index").unwrap();
    assert_eq!(idx.iter().copied().collect::<Vec<_>>(), vec![6, 18, 31, 43]);
}

/// A web sweep gives one grid point per web point, with the web's sweep coordinate.
#[test]
fn a_web_sweep_gives_one_grid_point_per_web_point() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = "pipeline: wg
archive: wg.h5
stages:
  - name: web
    kind: web
    params: {preset: spectrum1, points_per_segment: 200, fibres_across: 64, segments_per_fibre: 4}
    sweep: {belt_speed_ratio: [0.05, 0.1]}
  - name: grid
    kind: grid
    input: web
    params: {window_side: 0.1, boundary: periodic, store_density: false}
    replicates: 2
";
    run_ok(tmp.path(), yaml, 2);
    assert_eq!(read(tmp.path(), "grid", "belt_speed_ratio").iter().copied().collect::<Vec<_>>(), vec![0.05, 0.1]);
    let rho = read(tmp.path(), "grid", "mean_areal_density_mean");
    assert!(rho[[0]] > 1.5 * rho[[1]], "doubling c roughly halves ρ_av: {rho}");
    // The grid may not sweep on top of a swept web.
    let e = run_bad(&yaml.replace("store_density: false}", "store_density: false}\n    sweep: {cell_size: [0.001, 0.002]}"));
    assert!(e.contains("cannot have a sweep of its own"), "{e}");
}

/// The web reads a spectra stage: one point chosen by input_point, spectra drawn per segment.
#[test]
fn web_reads_a_spectra_stage() {
    let tmp = tempfile::tempdir().unwrap();
    let yaml = "pipeline: wg
archive: wg.h5
stages:
  - name: spectra
    kind: spectra
    sweep: {preset: [spectrum1, spectrum2]}
    replicates: 3
  - name: web
    kind: web
    input: spectra
    params: {input_point: 1, spectrum_selection: per_segment, fibres_across: 8, segments_per_fibre: 3}
";
    run_ok(tmp.path(), yaml, 2);
    let a = Archive::open_read(&tmp.path().join("wg.h5")).unwrap();
    let g = a.version("web", None).unwrap().open().unwrap();
    assert_eq!(hdf::read_i64(&g, "spectrum_count").unwrap()[[0]], 3);
    // Without input_point the choice is ambiguous.
    let e = run_bad(&yaml.replace("input_point: 1, ", ""));
    assert!(e.contains("has 2 points; choose one with `input_point"), "{e}");
}

#[test]
fn stationary_belt_is_bad_input() {
    let e = run_bad(&pipeline("preset: spectrum1, points_per_segment: 100, fibres_across: 10, segments_per_fibre: 2, belt_speed_ratio: 0.0", "window_side: 0.01", 1));
    assert!(e.contains("stationary belt"), "{e}");
}

#[test]
fn one_segment_per_fibre_works() {
    let tmp = tempfile::tempdir().unwrap();
    run_ok(tmp.path(), &pipeline("preset: spectrum1, points_per_segment: 200, fibres_across: 20, segments_per_fibre: 1", "window_side: 0.04, boundary: periodic", 1), 2);
    assert_eq!(read(tmp.path(), "web", "fibre_positions").shape(), &[1, 1, 20, 201, 2]);
}

#[test]
fn window_larger_than_the_web_is_bad_input() {
    let e = run_bad(&pipeline("preset: spectrum1, points_per_segment: 100, fibres_across: 10, segments_per_fibre: 2", "window_side: 0.5", 1));
    assert!(e.contains("does not lie inside the web"), "{e}");
}

#[test]
fn window_too_close_to_the_edges_is_bad_input() {
    let e = run_bad(&pipeline("preset: spectrum1, points_per_segment: 200, fibres_across: 100, segments_per_fibre: 4", "window_side: 0.05", 1));
    assert!(e.contains("less than 3 × the fibre spread"), "{e}");
}

#[test]
fn cell_not_dividing_the_window_is_bad_input() {
    let e = run_bad(&pipeline("preset: spectrum1", "window_side: 0.5, cell_size: 0.003", 1));
    assert!(e.contains("does not divide"), "{e}");
}

#[test]
fn web_without_a_spectrum_is_bad_input() {
    let e = run_bad(&pipeline("fibres_across: 10", "window_side: 0.01", 1));
    assert!(e.contains("a web needs a spectrum"), "{e}");
}
