//! `belt_removal` (issue 15): the belt travel taken off since each node was fed is a smooth
//! drift c·s, so it leaves the laid curve's shape intact where the landing-time definition
//! adds node-scale jitter; the dynamics and the laid fibre do not depend on the choice.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};

const PIPELINE: &str = "pipeline: removal
archive: removal.h5
seed: 4
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.3, elements: 300, belt_speed: 2.5}
    sweep: {belt_removal: [landing, feed]}
    replicates: 2
  - name: spectra
    kind: spectra
    input: fibre
";

#[test]
fn feed_removal_takes_off_a_smooth_drift_and_keeps_the_dynamics() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    let out = run_in(dir.path(), &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    // The half-mesh estimate flags the landing point's belt-removed e (it does not
    // converge) and names the definition that does; the feed point is never flagged.
    let stderr = text(&out).1;
    let flag = stderr.lines().find(|l| l.contains("e with the belt removed by landing time")).unwrap_or_else(|| panic!("no flag: {stderr}"));
    assert!(flag.contains("at 1 of 2 point(s), most at point 0") && flag.contains("belt_removal: feed"), "{flag}");
    let a = Archive::open_read(&dir.path().join("removal.h5")).unwrap();
    let g = a.version("fibre", None).unwrap().open().unwrap();
    let read = |name: &str| hdf::read_f64(&g, name).unwrap();
    let (laid, removed) = (read("laid_positions"), read("laid_positions_belt_removed")); // (point, replicate, node, xyz)
    // The same fibres laid: the choice only changes what is measured.
    let bits = |p: usize| laid.index_axis(ndarray::Axis(0), p).iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(0), bits(1));
    // Feed: x_removed − x_laid = c·s + const along every fibre, s = iΔs the material
    // coordinate of the laid node's rod node i (c = 2.5/5, Δs = 1 mm; a node still in the
    // air at the end is skipped, its neighbours keep their own s).
    let (c, ds) = (0.5, 0.3 / 300.0);
    let landing = read("landing_time"); // (point, replicate, node)
    for r in 0..2 {
        let rod_nodes: Vec<usize> = (0..landing.shape()[2]).filter(|&i| landing[[1, r, i]].is_finite()).collect();
        assert!(rod_nodes.len() > 100, "{} laid nodes", rod_nodes.len());
        let offset = |k: usize| removed[[1, r, k, 0]] - laid[[1, r, k, 0]] - c * rod_nodes[k] as f64 * ds;
        for k in 0..rod_nodes.len() {
            assert!((offset(k) - offset(0)).abs() < 1e-12, "replicate {r} laid node {k}: {} vs {}", offset(k), offset(0));
            assert_eq!(removed[[1, r, k, 1]], laid[[1, r, k, 1]]);
        }
    }
    // At v_b/v_f = 0.5 the landing-time jitter dominates the belt-removed e.
    let e = read("bending_energy_belt_removed"); // (point, replicate)
    for r in 0..2 {
        assert!(e[[0, r]] > 2.0 * e[[1, r]], "replicate {r}: e by landing {}, by feed {}", e[[0, r]], e[[1, r]]);
    }
    // The spectra analyse the stored belt-removed nodes of each definition.
    let s = a.version("spectra", None).unwrap().open().unwrap();
    let resampled = hdf::read_f64(&s, "resampled_position").unwrap(); // (point, fibre, node, xy)
    for p in 0..2 {
        assert!((resampled[[p, 0, 0, 0]] - removed[[p, 0, 0, 0]]).abs() < 1e-12, "point {p}");
    }
}

/// `mesh_error_estimate` (issue 15): every replicate again at half its elements; the
/// stored estimate is the first-order Richardson error of the stored means, and switching
/// it off removes the run and its datasets, leaving the fibres bit for bit.
#[test]
fn the_mesh_error_is_stated_next_to_each_mean() {
    let dir = tempfile::tempdir().unwrap();
    let yaml = "pipeline: mesh
archive: mesh.h5
seed: 2
stages:
  - name: with
    kind: laydown
    params: {length: 0.3, elements: 200, coil_resolution: 0}
    replicates: 3
  - name: without
    kind: laydown
    params: {length: 0.3, elements: 200, coil_resolution: 0, mesh_error_estimate: false}
    replicates: 3
";
    write_pipeline(dir.path(), "p.yaml", yaml);
    let out = run_in(dir.path(), &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let a = Archive::open_read(&dir.path().join("mesh.h5")).unwrap();
    let with = a.version("with", None).unwrap().open().unwrap();
    let without = a.version("without", None).unwrap().open().unwrap();
    let read = |g: &hdf5::Group, name: &str| hdf::read_f64(g, name).unwrap();
    for name in ["radius_of_gyration", "bending_energy", "radius_of_gyration_belt_removed", "bending_energy_belt_removed"] {
        let (fine, half) = (read(&with, name), read(&with, &format!("{name}_half_mesh"))); // (point, replicate)
        let used = hdf::read_u8(&with, "used").unwrap();
        // Over the replicates where both runs are valid.
        let paired: Vec<usize> = (0..3).filter(|&r| used[[0, r]] != 0 && half[[0, r]].is_finite()).collect();
        let mean = |a: &ndarray::ArrayD<f64>| paired.iter().map(|&r| a[[0, r]]).sum::<f64>() / paired.len() as f64;
        let stored = read(&with, &format!("{name}_mesh_error"))[[0]];
        let expected = (mean(&fine) - mean(&half)) / mean(&fine);
        assert!((stored - expected).abs() < 1e-12, "{name}: stored {stored}, from the stored means {expected}");
        assert!(read(&with, &format!("{name}_mesh_error_std"))[[0]] > 0.0);
        assert!(!without.link_exists(&format!("{name}_mesh_error")) && !without.link_exists(&format!("{name}_half_mesh")), "{name}");
        // The fibres themselves do not depend on the estimate.
        let bits = |a: ndarray::ArrayD<f64>| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(fine), bits(read(&without, name)), "{name}");
    }
    assert!(read(&with, "wall_seconds_half_mesh").iter().all(|w| *w > 0.0));
}
