//! What `pipelines/examples/image_uniformity.yaml` (web -> grid -> image) computes, using
//! the web and grid numerics directly until those stages are pipeline stages: bonded
//! webs at the paper's four v_b/v_f, rendered as transmission images, analysed by the
//! image method, summarised like Table 4.
//!
//! `cargo run --release --example image_table4 -- [realisations]`
use laydown::stages::grid::{grid_realisation, Boundary, GridParams};
use laydown::stages::image::render::{render, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, ImageParams, MeanStd};
use laydown::stages::spectra::SquareWaveParams;
use laydown::stages::web::{Web, WebParams};
use laydown::uniformity::coefficient_of_variation;

fn main() {
    let reps: u32 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(2);
    let t0 = std::time::Instant::now();
    let spectrum = SquareWaveParams::preset("spectrum1").unwrap().spectrum().unwrap();
    let grid = GridParams { cell_size: 0.5e-3, window_side: 0.1, boundary: Boundary::Periodic, ..GridParams::default() };
    let bonds = BondPattern {
        period1: 4.2e-3,
        period2: 4.2e-3,
        angle_deg: 45.0,
        shape: BondShape::Circle { diameter: 1.5e-3 },
        contrast: 0.15,
        ..Default::default()
    };
    let bonded = RenderParams { bonds: Some(bonds), ..Default::default() };
    let plain = RenderParams::default();
    println!("{:>7}  {:>9}  {:>14}  {:>14}  {:>14}  {:>14}  {:>7}", "v_b/v_f", "ρ (g/m²)", "CV raw %", "CV_corr plain %", "CV_corr %", "CV web %", "notches");
    for c in [0.020, 0.028, 0.050, 0.070] {
        let web = Web::new(
            WebParams { fibres_across: 400, fibre_spacing: 0.25e-3, segments_per_fibre: 10, fibre_diameter: 16.2e-6, belt_speed_ratio: c, ..WebParams::default() },
            vec![spectrum.clone()],
        )
        .unwrap();
        let (mut raw, mut corr, mut comp, mut truth, mut rho, mut notches) = (vec![], vec![], vec![], vec![], vec![], vec![]);
        for k in 0..reps {
            let r = grid_realisation(&web, &grid, k).unwrap();
            let gsm = r.density.mapv(|v| v * 1e3);
            rho.push(r.mean_areal_density_gsm);
            let img = render(&gsm, grid.cell_size, &bonded).unwrap().grey;
            let web_img = render(&gsm, grid.cell_size, &plain).unwrap().grey;
            let a = analyze(&img, grid.cell_size, &ImageParams::default()).unwrap();
            raw.push(a.cv_raw);
            corr.push(a.cv_corr_plain);
            comp.push(a.cv_corr_compensated);
            truth.push(coefficient_of_variation(web_img.iter().copied()));
            notches.push(a.notch_count as f64);
        }
        let pm = |v: &[f64]| {
            let m = MeanStd::of(v);
            format!("{:6.2} ± {:5.2}", 100.0 * m.mean, 100.0 * m.std)
        };
        println!(
            "{c:>7.3}  {:>9.1}  {:>14}  {:>14}  {:>14}  {:>14}  {:>7.0}",
            MeanStd::of(&rho).mean,
            pm(&raw),
            pm(&corr),
            pm(&comp),
            pm(&truth),
            MeanStd::of(&notches).mean
        );
    }
    println!("{reps} realisations per speed, 200×200 px of 0.5 mm, {:.1} s", t0.elapsed().as_secs_f64());
}
