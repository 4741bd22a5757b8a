use super::*;
use crate::stages::spectra::{CurvatureSpectrum, SquareWaveParams};
use std::sync::Mutex;

fn preset(name: &str) -> CurvatureSpectrum {
    SquareWaveParams::preset(name).unwrap().spectrum().unwrap()
}

fn small(n_w: usize, n_l: usize) -> WebParams {
    WebParams { fibres_across: n_w, segments_per_fibre: n_l, belt_speed_ratio: 0.05, ..WebParams::default() }
}

#[test]
fn random_phases_keep_the_spectrum() {
    // A non-flat spectrum (like an FE fibre's) with odd n_l so the unpaired last segment is covered.
    let n = 512;
    let mut k = vec![num_complex::Complex64::new(0.0, 0.0); n];
    k[0].re = -3.0; // negative mean curvature must keep its sign
    for r in 1..n / 2 {
        let m = 40.0 / (1.0 + (r as f64 / 15.0).powi(2));
        k[r] = num_complex::Complex64::from_polar(m, 0.1 * r as f64);
        k[n - r] = k[r].conj();
    }
    k[n / 2].re = 0.5;
    let spectrum = CurvatureSpectrum::new(0.5, k.clone()).unwrap();
    let web = Web::new(small(3, 5), vec![spectrum.clone()]).unwrap();
    let (_, kappa) = web.fibre_curvature(4, 1);
    assert_eq!(kappa.len(), 5 * n);
    for seg in kappa.chunks(n) {
        let got = CurvatureSpectrum::from_curvature(seg, 0.5).unwrap();
        for r in 0..n {
            let (a, b) = (got.coefficients()[r].norm(), k[r].norm());
            assert!((a - b).abs() < 1e-10 * 40.0, "bin {r}: {a} vs {b}");
        }
        assert!((got.coefficients()[0].re + 3.0).abs() < 1e-10);
        assert!((got.coefficients()[n / 2].re - 0.5).abs() < 1e-10);
        assert!((got.bending_energy() - spectrum.bending_energy()).abs() < 1e-9 * spectrum.bending_energy());
    }
    // Phases are random: two segments differ.
    assert!(kappa[..n].iter().zip(&kappa[n..2 * n]).any(|(a, b)| (a - b).abs() > 1.0));
}

#[test]
fn generated_fibres_have_the_documented_bending_energy() {
    // Square-wave convention: e is exact per segment by Parseval (2n_c+1 bins incl. r = 0),
    // and the polyline measure of the generated nodes (c = 0) agrees within its spread.
    for name in ["spectrum1", "spectrum2"] {
        let p = SquareWaveParams::preset(name).unwrap();
        let s = p.spectrum().unwrap();
        let params = WebParams { belt_speed_ratio: 0.0, ..small(8, 1) };
        let web = Web::new(params, vec![s.clone()]).unwrap();
        let mut geometric = Vec::new();
        for j in 0..8 {
            let (_, kappa) = web.fibre_curvature(0, j);
            let e = CurvatureSpectrum::from_curvature(&kappa, 1.0).unwrap().bending_energy();
            assert!((e - p.bending_energy).abs() < 1e-9 * e, "{name}: e = {e}");
            let nodes: Vec<[f64; 3]> = web.generate_fibre(0, j).iter().map(|q| [q[0], q[1], 0.0]).collect();
            geometric.push(crate::geometry::bending_energy(&nodes));
        }
        let mean = geometric.iter().sum::<f64>() / 8.0;
        let sd = (geometric.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / 7.0).sqrt();
        // Node turning angles are trapezoid averages of κ: a small low-pass loss for κΔs < 0.3.
        assert!((mean - p.bending_energy).abs() < 3.0 * sd / 8f64.sqrt() + 0.03 * p.bending_energy, "{name}: {mean} ± {sd}");
    }
}

#[test]
fn single_fibre_regenerates_bit_for_bit() {
    let web = Web::new(small(6, 3), vec![preset("spectrum2")]).unwrap();
    let seen = Mutex::new(vec![Vec::new(); 6]);
    web.par_for_each_fibre(2, |j, nodes| seen.lock().unwrap()[j] = nodes.to_vec());
    let seen = seen.into_inner().unwrap();
    for j in 0..6 {
        assert_eq!(seen[j], web.generate_fibre(2, j), "fibre {j}");
    }
    // Other realisations and seeds give other fibres.
    assert_ne!(seen[3], web.generate_fibre(3, 3));
    let other = Web::new(WebParams { seed: 9, ..small(6, 3) }, vec![preset("spectrum2")]).unwrap();
    assert_ne!(seen[3], other.generate_fibre(2, 3));
}

#[test]
fn fibres_are_joined_continuously_and_drift() {
    let web = Web::new(small(3, 4), vec![preset("spectrum1")]).unwrap();
    let nodes = web.generate_fibre(0, 0);
    assert_eq!(nodes.len(), 4001);
    assert_eq!(nodes[0], [0.0, -2.5e-3]);
    // Steps are at most Δs(1 + c) everywhere, including across the joints at 1000, 2000, 3000.
    let max_step = nodes.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).fold(0.0, f64::max);
    assert!(max_step <= 1e-3 * 1.05 + 1e-15, "{max_step}");
    // c > 1: dx/ds = cos θ + c > 0, x strictly increasing.
    let fast = Web::new(WebParams { belt_speed_ratio: 1.5, ..small(1, 2) }, vec![preset("spectrum1")]).unwrap();
    let f = fast.generate_fibre(0, 0);
    assert!(f.windows(2).all(|w| w[1][0] > w[0][0]));
    assert!((f.last().unwrap()[0] - 1.5 * 2.0).abs() < 2.0);
}

#[test]
fn per_segment_selection_uses_the_whole_set() {
    let a = SquareWaveParams { bending_energy: 100.0, cutoff_number: 5, ..Default::default() }.spectrum().unwrap();
    let b = SquareWaveParams { bending_energy: 900.0, cutoff_number: 5, ..Default::default() }.spectrum().unwrap();
    let params = WebParams { spectrum_selection: SpectrumSelection::PerSegment, ..small(2, 40) };
    let web = Web::new(params, vec![a, b]).unwrap();
    let (_, kappa) = web.fibre_curvature(0, 1);
    let energies: Vec<f64> =
        kappa.chunks(1000).map(|s| CurvatureSpectrum::from_curvature(s, 1.0).unwrap().bending_energy()).collect();
    let low = energies.iter().filter(|e| (**e - 100.0).abs() < 1e-6).count();
    let high = energies.iter().filter(|e| (**e - 900.0).abs() < 1e-6).count();
    assert_eq!(low + high, 40);
    assert!(low >= 8 && high >= 8, "{low} / {high}");
}

#[test]
fn invalid_inputs_are_named() {
    let err = Web::new(WebParams { fibre_spacing: 0.0, ..small(2, 2) }, vec![preset("spectrum1")]).unwrap_err();
    assert!(err.to_string().contains("fibre_spacing"), "{err}");
    let err = Web::new(WebParams { belt_speed_ratio: -0.1, ..small(2, 2) }, vec![preset("spectrum1")]).unwrap_err();
    assert!(err.to_string().contains("belt_speed_ratio"), "{err}");
    let err = Web::new(small(2, 2), vec![]).unwrap_err();
    assert!(err.to_string().contains("no spectra"), "{err}");
    let other = SquareWaveParams { points_per_segment: 500, ..Default::default() }.spectrum().unwrap();
    let err = Web::new(small(2, 2), vec![preset("spectrum1"), other]).unwrap_err();
    assert!(err.to_string().contains("share N and L"), "{err}");
    assert_eq!(SpectrumSelection::from_name("mean").unwrap_err().to_string(), "`mean` is not a SpectrumSelection; allowed: single, per_segment");
    // The table's defaults are the Default impl's, and the stage's rows its typed parameters.
    crate::params::assert_table_matches(WEB_PARAMS, &WebParams::default());
    let d = WebParams::default();
    let stage = super::stage::WebStageParams {
        preset: "none".into(),
        points_per_segment: 1000,
        input_point: None,
        fibres_across: d.fibres_across,
        segments_per_fibre: d.segments_per_fibre,
        fibre_spacing: d.fibre_spacing,
        belt_speed_ratio: None,
        fibre_diameter: None,
        fibre_density: None,
        spectrum_selection: d.spectrum_selection,
        generator: d.generator,
        mirror: d.mirror,
        segment_join: d.segment_join,
        sde_potential_length: None,
        sde_noise: None,
        segment_length: 1.0,
        store_all_max_points: 2_000_000,
        sample_fibres: 8,
    };
    crate::params::assert_table_matches(&crate::stages::Stage::params(&super::WebStage), &stage);
}
