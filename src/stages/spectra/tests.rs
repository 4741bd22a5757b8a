use super::*;
use std::f64::consts::PI;

fn to3(p: &[[f64; 2]]) -> Vec<[f64; 3]> {
    p.iter().map(|q| [q[0], q[1], 0.0]).collect()
}

/// A smooth wiggly planar curve with varying curvature, sampled finely (0.1 mm).
fn wiggly(length: f64) -> Vec<[f64; 3]> {
    let n = 20_000;
    let ds = length / n as f64;
    let kappa = |s: f64| 8.0 + 30.0 * (2.0 * PI * 3.0 * s).sin() + 12.0 * (2.0 * PI * 7.3 * s + 0.4).cos();
    let mut theta = 0.3;
    let mut p = [0.01, -0.02];
    let mut out = vec![[p[0], p[1], 0.0]];
    for i in 0..n {
        let s = (i as f64 + 0.5) * ds;
        let t_mid = theta + 0.5 * kappa(s) * ds;
        p[0] += t_mid.cos() * ds;
        p[1] += t_mid.sin() * ds;
        theta += kappa(s) * ds;
        out.push([p[0], p[1], 0.0]);
    }
    out
}

#[test]
fn round_trip_reproduces_the_resampled_fibre() {
    let nodes = wiggly(1.0);
    let signal = sample_fibre(&nodes, 1e-3, None).unwrap();
    assert_eq!(signal.points(), 1000);
    let spectrum = signal.spectrum().unwrap();
    // Inverse DFT of K_r with its own phases, integrated by eq 13 ...
    let rebuilt = reconstruct(&spectrum, signal.tangent_angle_start, signal.start);
    // ... reproduces the sampled fibre (eq 13 of the samples) to 1e-9 relative ...
    let direct = signal.reconstruct();
    let extent = 1.0;
    let worst = rebuilt.iter().zip(&direct).map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1])).fold(0.0, f64::max);
    assert!(worst < 1e-9 * extent, "round trip error {worst}");
    let kappa = spectrum.curvature();
    for (a, b) in kappa.iter().zip(&signal.curvature) {
        assert!((a - b).abs() < 1e-9 * 50.0);
    }
    // ... and the input polyline at the resampled nodes to O((κΔs)²) (κ ≤ 50/m, Δs = 1 mm).
    let worst_geom = direct
        .iter()
        .zip(&signal.resampled)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max);
    assert!(worst_geom < 2e-4, "eq 13 rebuild vs resampled polyline: {worst_geom}");
}

#[test]
fn parseval_links_sample_and_spectrum_energy() {
    let signal = sample_fibre(&wiggly(1.0), 1e-3, None).unwrap();
    let e_samples = signal.bending_energy();
    let e_spectrum = signal.spectrum().unwrap().bending_energy();
    assert!((e_samples - e_spectrum).abs() < 1e-10 * e_samples, "{e_samples} vs {e_spectrum}");
    // And the sampled e agrees with the geometry module's polyline measure.
    let e_geom = crate::geometry::bending_energy(&to3(&signal.resampled));
    assert!((e_samples - e_geom).abs() < 0.01 * e_samples, "{e_samples} vs {e_geom}");
}

#[test]
fn circle_has_only_mean_curvature_and_straight_none() {
    let length = 1.0;
    let circle: Vec<[f64; 3]> = (0..=1000)
        .map(|i| {
            let a = 2.0 * PI * i as f64 / 1000.0;
            let r = length / (2.0 * PI);
            [r * a.sin(), r * (1.0 - a.cos()), 0.0]
        })
        .collect();
    // Sample at the polygon's own edge length so that L = NΔs covers the circle.
    let edge = 2.0 * (length / (2.0 * PI)) * (PI / 1000.0).sin();
    let sig = sample_fibre(&circle, edge, Some(1000)).unwrap();
    let s = sig.spectrum().unwrap();
    let energy = s.energy_spectrum();
    let k0 = s.coefficients()[0].re;
    assert!((k0 - 2.0 * PI / sig.segment_length()).abs() < 1e-9 * k0, "K_0 = {k0}");
    assert!(energy[1..].iter().all(|&x| x < 1e-20 * energy[0]), "energy outside r = 0");
    let e = s.bending_energy();
    assert!((e - 2.0 * PI * PI).abs() < 1e-9 * e, "e = {e}");

    let straight: Vec<[f64; 3]> = (0..=10).map(|i| [0.1 * i as f64, 0.05 * i as f64, 0.0]).collect();
    let s = sample_fibre(&straight, 1e-3, None).unwrap().spectrum().unwrap();
    assert!(s.energy_spectrum().iter().all(|&x| x < 1e-24));
    assert_eq!(s.bending_energy(), 0.0);
}

#[test]
fn frequencies_are_exact_multiples_of_two_pi_over_l() {
    let sig = sample_fibre(&wiggly(1.0), 1.3e-3, None).unwrap();
    let s = sig.spectrum().unwrap();
    let l = s.segment_length();
    assert!((l - s.points() as f64 * 1.3e-3).abs() < 1e-15);
    assert!((s.angular_frequency(5) - 10.0 * PI / l).abs() < 1e-12);
    assert!((s.angular_frequency(s.points() - 1) + 2.0 * PI / l).abs() < 1e-12);
}

#[test]
fn errors_are_clear() {
    assert!(matches!(sample_fibre(&[], 1e-3, None), Err(SpectraError::InvalidFibre(_))));
    let p = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]; // vertical only: zero projected length
    assert!(matches!(sample_fibre(&p, 1e-3, None), Err(SpectraError::InvalidFibre(_))));
    let q = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]];
    let err = sample_fibre(&q, 0.02, None).unwrap_err();
    assert!(matches!(err, SpectraError::SpacingLongerThanFibre { .. }), "{err}");
    assert!(matches!(sample_fibre(&q, 1e-3, Some(20)), Err(SpectraError::SpacingLongerThanFibre { .. })));
    let nan = [[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0]];
    assert!(matches!(sample_fibre(&nan, 1e-3, None), Err(SpectraError::InvalidFibre(_))));
    let bad = SquareWaveParams { cutoff_number: 500, ..Default::default() };
    let err = bad.spectrum().unwrap_err();
    assert!(matches!(err, SpectraError::CutoffBeyondNyquist { cutoff: 500, points: 1000 }), "{err}");
    let err = SpectraParams { sample_spacing: -1.0, ..Default::default() }.validate().unwrap_err();
    assert!(err.to_string().contains("sample_spacing"), "{err}");
}

#[test]
fn square_wave_conventions() {
    for &(name, e, nc) in &SQUARE_WAVE_PRESETS {
        let p = SquareWaveParams::preset(name).unwrap();
        let s = p.spectrum().unwrap();
        let energy = s.energy_spectrum();
        let nonzero = energy.iter().filter(|&&x| x > 0.0).count();
        assert_eq!(nonzero, 2 * nc + 1, "{name}: bins incl. r = 0");
        assert!((s.bending_energy() - e).abs() < 1e-9 * e);
        // Continuous eq A.5 density vs discrete bins: factor (2n_c+1)/(2n_c).
        let ratio = p.continuous_density() / (p.bin_energy() * p.segment_length.powi(2));
        assert!((ratio - (2 * nc + 1) as f64 / (2 * nc) as f64).abs() < 1e-12);
    }
}

#[test]
fn analyse_fibres_shares_n() {
    let a = wiggly(1.0);
    let b = wiggly(0.8);
    let out = analyse_fibres(&[a, b], &SpectraParams::default()).unwrap();
    assert_eq!(out[0].spectrum.points(), 800);
    assert_eq!(out[1].spectrum.points(), 800);
    let mean = CurvatureSpectrum::mean(&[out[0].spectrum.clone(), out[1].spectrum.clone()]).unwrap();
    let e_mean = 0.5 * (out[0].bending_energy_spectrum + out[1].bending_energy_spectrum);
    assert!((mean.bending_energy() - e_mean).abs() < 1e-9 * e_mean);
}

#[test]
fn stage_table_is_its_typed_parameters() {
    let square = SquareWaveParams::default();
    let stage = SpectraStageParams {
        preset: "none".into(),
        belt_removed: true,
        bending_energy: square.bending_energy,
        cutoff_number: square.cutoff_number,
        segment_length: square.segment_length,
        analysis: SpectraParams::default(),
    };
    crate::params::assert_table_matches(&crate::stages::Stage::params(&SpectraStage), &stage);
}
