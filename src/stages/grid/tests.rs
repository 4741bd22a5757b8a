use super::*;
use crate::stages::spectra::SquareWaveParams;
use crate::stages::web::{Web, WebParams};

fn web(name: &str, points: usize, n_w: usize, n_l: usize, c: f64) -> Web {
    let s = SquareWaveParams { points_per_segment: points, ..SquareWaveParams::preset(name).unwrap() }.spectrum().unwrap();
    Web::new(WebParams { fibres_across: n_w, segments_per_fibre: n_l, belt_speed_ratio: c, ..WebParams::default() }, vec![s])
        .unwrap()
}

#[test]
fn mass_is_conserved_exactly_on_the_torus() {
    // Window = whole torus (n_wΔw = c·n_l·L = 0.5 m): every node's mass is inside, so
    // ρ_av = n_w·n_l·L·ρA / area = ρA/(Δw·c) up to round-off, for both deposits.
    let w = web("spectrum2", 500, 200, 10, 0.05);
    let expected = w.params().interior_areal_density();
    for deposit in [Deposit::PointMass, Deposit::SegmentClipping] {
        let g = GridParams { window_side: 0.5, cell_size: 2e-3, boundary: Boundary::Periodic, deposit, ..GridParams::default() };
        let r = grid_realisation(&w, &g, 0).unwrap();
        assert!((r.mean_areal_density / expected - 1.0).abs() < 1e-9, "{deposit:?}: {} vs {expected}", r.mean_areal_density);
        assert!((r.expected_interior_density - expected).abs() < 1e-15);
    }
}

#[test]
fn interior_density_of_an_open_web_matches_mass_balance() {
    // ρ_int = ρ(πd²/4)/(Δw·c): 2.388 g/m² for d = 20 µm, Δw = 2.5 mm, c = 0.05. A web large
    // enough for the default 3-spread margins around a 0.1 m window; four realisations.
    let w = web("spectrum3", 500, 560, 40, 0.05);
    let g = GridParams { window_side: 0.1, ..GridParams::default() };
    let rho: Vec<f64> = (0..4).map(|k| grid_realisation(&w, &g, k).unwrap().mean_areal_density).collect();
    let mean = rho.iter().sum::<f64>() / 4.0;
    let sd = (rho.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 3.0).sqrt();
    let expected = w.params().interior_areal_density();
    assert!((expected * 1e3 - 2.388).abs() < 1e-3);
    assert!((mean - expected).abs() < 3.0 * sd / 2.0 + 0.01 * expected, "ρ_av {mean} ± {sd} vs {expected}");
}

#[test]
fn bit_identical_for_one_and_two_threads() {
    let w = web("spectrum1", 1000, 300, 12, 0.05);
    for deposit in [Deposit::PointMass, Deposit::SegmentClipping] {
        let g = GridParams { window_side: 0.2, deposit, edge_margin_spreads: 0.0, ..GridParams::default() };
        let run = |threads| {
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| grid_realisation(&w, &g, 3).unwrap())
        };
        let (a, b) = (run(1), run(2));
        assert!(a.density.iter().zip(b.density.iter()).all(|(x, y)| x.to_bits() == y.to_bits()));
        assert_eq!(a.cv.to_bits(), b.cv.to_bits());
        assert_eq!(a.spreads, b.spreads);
        assert!(a.mean_areal_density > 0.0);
    }
}

#[test]
fn segment_clipping_splits_chords_exactly() {
    let grid = DensityGrid::new(0.0, 0.0, 1.0, 4);
    // Horizontal chord from x = 0.5 to 2.5 at y = 0.5: quarters, a half, a quarter.
    grid.deposit_fibre(&[[0.5, 0.5], [2.5, 0.5]], Deposit::SegmentClipping);
    let m = grid.masses(1.0);
    assert_eq!(m[[0, 0]], 0.25);
    assert_eq!(m[[1, 0]], 0.5);
    assert_eq!(m[[2, 0]], 0.25);
    // A diagonal chord crossing x = 1 at its middle, then a vertical one through three cells.
    let grid = DensityGrid::new(0.0, 0.0, 1.0, 4);
    grid.deposit_fibre(&[[0.2, 0.2], [1.8, 0.6], [1.8, 3.0]], Deposit::SegmentClipping);
    let m = grid.masses(1.0);
    assert!((m[[0, 0]] - 0.5).abs() < 1e-9 && (m[[1, 0]] - 0.5 - 0.4 / 2.4).abs() < 1e-9, "{m:?}");
    assert!((m[[1, 1]] - 1.0 / 2.4).abs() < 1e-9 && (m[[1, 2]] - 1.0 / 2.4).abs() < 1e-9, "{m:?}");
    assert_eq!(grid.total_quanta(), 2 * QUANTA_PER_POINT as u128);
    // A chord leaving the window keeps only its inside part: (3.5, 0.5) → (5.5, 0.5).
    let grid = DensityGrid::new(0.0, 0.0, 1.0, 4);
    grid.deposit_fibre(&[[3.5, 0.5], [5.5, 0.5]], Deposit::SegmentClipping);
    assert_eq!(grid.masses(1.0)[[3, 0]], 0.25);
    assert_eq!(grid.total_quanta(), QUANTA_PER_POINT as u128 / 4);
}

#[test]
fn edge_cases_give_clear_errors() {
    let g = GridParams::default();
    // Stationary belt: no interior.
    let still = web("spectrum1", 1000, 10, 2, 0.0);
    assert_eq!(grid_realisation(&still, &g, 0).unwrap_err(), GridError::StationaryBelt);
    // n_l = 1: the drift (c·L = 5 cm) is shorter than the window.
    let short = web("spectrum1", 1000, 400, 1, 0.05);
    assert!(matches!(grid_realisation(&short, &g, 0).unwrap_err(), GridError::WindowOutsideWeb { .. }));
    // Window wider than the web (n_wΔw = 25 mm).
    let narrow = web("spectrum1", 1000, 10, 50, 0.05);
    let e = grid_realisation(&narrow, &g, 0).unwrap_err();
    assert!(matches!(e, GridError::WindowOutsideWeb { .. }), "{e}");
    // Δh not dividing H.
    let e = GridParams { cell_size: 0.3e-3, window_side: 0.5, ..g }.validate().unwrap_err();
    assert!(matches!(e, GridError::CellDoesNotDivideWindow { .. }), "{e}");
    assert!(GridParams { cell_size: 0.25e-3, ..g }.validate().is_ok());
    // Window too close to the CD edges for the fibres' wander.
    let w = web("spectrum1", 1000, 120, 12, 0.05);
    let e = grid_realisation(&w, &GridParams { window_side: 0.2, ..g }, 0).unwrap_err();
    assert!(matches!(e, GridError::WindowTooCloseToEdge { .. }), "{e}");
    assert!(e.to_string().contains("edge_margin_spreads"));
    // Named parameter errors.
    let e = GridParams { window_side: -1.0, ..g }.validate().unwrap_err();
    assert!(e.to_string().contains("window_side"), "{e}");
}

#[test]
fn fast_belt_and_single_segment_fibres_work() {
    // c > 1 (x strictly increasing) and n_l = 1, periodic so the window sees the interior.
    let w = web("spectrum2", 500, 80, 1, 2.5);
    let g = GridParams { window_side: 0.2, boundary: Boundary::Periodic, ..GridParams::default() };
    let r = grid_realisation(&w, &g, 0).unwrap();
    let expected = w.params().interior_areal_density();
    assert!((r.mean_areal_density / expected - 1.0).abs() < 0.1, "{} vs {expected}", r.mean_areal_density);
}

#[test]
fn zone_curve_and_formation_number() {
    let w = web("spectrum2", 1000, 200, 12, 0.05);
    let g = GridParams { window_side: 0.2, boundary: Boundary::Periodic, ..GridParams::default() };
    let r = grid_realisation(&w, &g, 0).unwrap();
    // 0.5 mm is below the cell and skipped; 1 mm .. 16 mm on a log scale remain.
    assert_eq!(r.zone_curve.first().unwrap().cells_per_side, 1);
    assert_eq!(r.zone_curve.last().unwrap().cells_per_side, 16);
    assert!(r.zone_curve.windows(2).all(|z| z[1].cv < z[0].cv));
    assert_eq!(r.zone_curve[0].cv, r.cv);
    // At the cell scale the web is close to a random line network (n_f of order 1).
    assert!(r.zone_curve[0].formation_number > 0.8 && r.zone_curve[0].formation_number < 2.0, "{:?}", r.zone_curve[0]);
    let la = r.mean_areal_density / w.params().mass_per_length();
    assert!((r.fibre_length_per_area - la).abs() < 1e-9 * la);
    for z in &r.zone_curve {
        let random = (crate::uniformity::E1 / (std::f64::consts::PI * la * z.zone_size)).sqrt();
        assert!((z.random_line_cv - random).abs() < 1e-12);
        assert!((z.formation_number - (z.cv / random).powi(2)).abs() < 1e-9);
        assert!(z.formation_number > 0.5 && z.formation_number < 20.0, "{z:?}");
    }
}

#[test]
fn first_preset_cv_is_in_the_plausible_range() {
    // spectrum1, c = 0.05, N = 1000 on a reduced (periodic) web: REFERENCE.md quotes
    // CV ≈ 0.38 for the interior of a paper-size web at N = 1000 (0.50 at N = 500).
    let w = web("spectrum1", 1000, 400, 40, 0.05);
    let g = GridParams { window_side: 0.3, boundary: Boundary::Periodic, ..GridParams::default() };
    let r = grid_realisation(&w, &g, 0).unwrap();
    assert!(r.cv > 0.33 && r.cv < 0.47, "CV {}", r.cv);
    let rel = r.mean_areal_density / w.params().interior_areal_density();
    assert!(rel > 0.85 && rel < 1.15, "ρ_av / interior = {rel}");
}

#[test]
fn parameter_tables_match_the_defaults() {
    use crate::params::assert_table_matches;
    use crate::stages::Stage;
    let own = super::stage::GridStageParams { grid: GridParams::default(), store_density: true, compare_with: super::stage::CompareWith::None };
    assert_table_matches(&GridStage.params(), &own);
    assert_table_matches(crate::stages::spectra::SQUARE_WAVE_PARAMS, &SquareWaveParams::default());
    assert_table_matches(crate::stages::spectra::SPECTRA_PARAMS, &crate::stages::spectra::SpectraParams::default());
}
