//! `step_error_estimate` (issue 15): every replicate again at half its time step, on the
//! same random stream (the same imperfections and oscillation phase). At 10 m/s the
//! default step (0.1 of the coil time ℓ_c/v_f at the coil-resolved mesh) reads e several
//! per cent low and the step bounded in coil times (`coil_step: 0.04`) about 1 % low
//! (pipelines/studies/FIBRE_SPEED.md): the half-step change has to tell the two apart.
mod common;
use common::*;
use laydown::archive::{hdf, Archive};

const PIPELINE: &str = "pipeline: step
archive: step.h5
seed: 7
stages:
  - name: with
    kind: laydown
    params: {start: fed, fibre_speed: 10.0, air_speed: 30.0, belt_speed: 0.4, oscillation_frequency: 20.0, mesh_error_estimate: false, step_error_estimate: true}
    sweep: {coil_step: [0.0, 0.04]}
    replicates: 12
  - name: without
    kind: laydown
    params: {start: fed, fibre_speed: 10.0, air_speed: 30.0, belt_speed: 0.4, oscillation_frequency: 20.0, mesh_error_estimate: false}
    sweep: {coil_step: [0.0, 0.04]}
    replicates: 12
";

#[test]
fn the_half_step_change_tells_the_coarse_step_from_the_step_bounded_in_coil_times() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    let out = run_in(dir.path(), &["run", "-j", "2", "p.yaml"]);
    let stderr = text(&out).1;
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    // the default step (point 0) is flagged for e, and its change is the larger; the
    // coil_step point's e change (+1.5 ± 0.5 % on this seed, 1.3 % over 24 replicates of
    // seed 2024) is beside the 1 % of the flag and flagged here too, so the flag alone
    // does not tell the two apart: the changes below do
    let flag = stderr.lines().find(|l| l.contains("e changes by more than 1 % when the time step is halved")).unwrap_or_else(|| panic!("no flag: {stderr}"));
    assert!(flag.starts_with("with: warning: e changes by more than 1 % when the time step is halved at ") && flag.contains("point(s), most at point 0"), "{flag}");
    assert!(flag.contains("bending_energy_step_change") && flag.contains("coil_step: 0.04"), "names the dataset and the remedy: {flag}");

    let a = Archive::open_read(&dir.path().join("step.h5")).unwrap();
    let with = a.version("with", None).unwrap().open().unwrap();
    let without = a.version("without", None).unwrap().open().unwrap();
    let read = |g: &hdf5::Group, name: &str| hdf::read_f64(g, name).unwrap();
    let used = hdf::read_u8(&with, "used").unwrap();
    for name in ["radius_of_gyration", "bending_energy", "radius_of_gyration_belt_removed", "bending_energy_belt_removed"] {
        let (fine, half) = (read(&with, name), read(&with, &format!("{name}_half_step"))); // (point, replicate)
        let (change, se) = (read(&with, &format!("{name}_step_change")), read(&with, &format!("{name}_step_change_std")));
        for p in 0..2 {
            // the stored change is the paired mean difference over the stored replicates
            let paired: Vec<usize> = (0..12).filter(|&r| used[[p, r]] != 0 && half[[p, r]].is_finite()).collect();
            assert!(paired.len() >= 8, "{name} point {p}: {} pairs", paired.len());
            assert_eq!(hdf::read_i64(&with, &format!("{name}_step_change_pairs")).unwrap()[[p]], paired.len() as i64, "{name} point {p}");
            let n = paired.len() as f64;
            let mean = |f: &dyn Fn(usize) -> f64| paired.iter().map(|&r| f(r)).sum::<f64>() / n;
            let (m_fine, m_diff) = (mean(&|r| fine[[p, r]]), mean(&|r| half[[p, r]] - fine[[p, r]]));
            assert!((change[[p]] - m_diff / m_fine).abs() < 1e-12, "{name} point {p}: stored {}, from the stored runs {}", change[[p]], m_diff / m_fine);
            // its standard error, from the scatter of the paired differences
            let var_diff = paired.iter().map(|&r| (half[[p, r]] - fine[[p, r]] - m_diff).powi(2)).sum::<f64>() / (n - 1.0);
            let expected_se = (var_diff / n).sqrt() / m_fine.abs();
            assert!((se[[p]] - expected_se).abs() < 1e-12 && se[[p]] > 0.0, "{name} point {p}: s.e. {} against {expected_se}", se[[p]]);
        }
        // The fibres themselves do not depend on the estimate.
        let bits = |a: ndarray::ArrayD<f64>| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(fine), bits(read(&without, name)), "{name}");
        assert!(!without.link_exists(&format!("{name}_step_change")) && !without.link_exists(&format!("{name}_half_step")), "{name}");
    }
    let (s, e) = (read(&with, "radius_of_gyration_step_change"), read(&with, "bending_energy_step_change"));
    let e_se = read(&with, "bending_energy_step_change_std");
    eprintln!("S change {s:?}, e change {e:?} ± {e_se:?}");
    // the default step: e rises when the step is halved, by more than 2 % and 3 s.e.
    assert!(e[[0]] > 0.02 && e[[0]] > 3.0 * e_se[[0]], "default step: e change {} ± {}", e[[0]], e_se[[0]]);
    // the step bounded in coil times: within 2 %, and well below the default's
    assert!(e[[1]].abs() < 0.02 && e[[0]] - e[[1]] > 2.0 * (e_se[[0]].powi(2) + e_se[[1]].powi(2)).sqrt(), "coil_step 0.04: e change {} ± {}", e[[1]], e_se[[1]]);
    // S hardly moves at 10 m/s either way
    assert!(s[[0]].abs() < 0.02 && s[[1]].abs() < 0.02, "S change {s:?}");
    assert!(read(&with, "wall_seconds_half_step").iter().all(|w| w.is_nan() || *w > 0.0));
}

/// A step factor that cannot be halved within its range is refused before anything runs,
/// at the line and column where it is written.
#[test]
fn a_step_too_small_to_halve_is_refused_where_it_is_written() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", "pipeline: x\narchive: x.h5\nstages:\n  - name: a\n    kind: laydown\n    params: {time_step_factor: 0.0015, step_error_estimate: true}\n");
    for args in [&["validate", "p.yaml"][..], &["run", "p.yaml"]] {
        let out = run_in(dir.path(), args);
        let stderr = text(&out).1;
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("p.yaml:6:32: stages[0].params.time_step_factor: 0.0015 is too small for step_error_estimate") && stderr.contains("allowed at least 0.002"), "{stderr}");
        assert!(!dir.path().join("x.h5").exists(), "nothing written");
    }
    // without the estimate the same factor is valid
    write_pipeline(dir.path(), "q.yaml", "pipeline: x\narchive: x.h5\nstages:\n  - name: a\n    kind: laydown\n    params: {time_step_factor: 0.0015}\n");
    assert_eq!(run_in(dir.path(), &["validate", "q.yaml"]).status.code(), Some(0));
}
