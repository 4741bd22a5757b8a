//! How the error of `cv_corr` against the web's known CV depends on the image size: two
//! lattices (the weak 4.2 mm default of the accuracy pipeline and dark staggered
//! rectangles at 4.5 mm, 60°) on 300 × 360, 450 × 540 and 617 × 871 px renderings at
//! 0.34 mm, 6 seeds each, with the method's defaults, a one-period edge band, without
//! notch growth, and as it was before issue 17. Prints mean ± std [min, max] in %.
//!
//! `cargo run --release --example image_size_accuracy`
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
use laydown::uniformity::coefficient_of_variation;
const PX: f64 = 0.34e-3;
fn main() {
    let cases = [
        ("weak", BondPattern { period1: 4.2e-3, period2: 4.2e-3, angle_deg: 45.0, contrast: 0.15, shape: BondShape::Circle { diameter: 1.5e-3 }, ..Default::default() }),
        ("stag dark", BondPattern { period1: 4.5e-3, period2: 4.5e-3, angle_deg: 15.0, angle_between_deg: 60.0, contrast: -0.4, shape: BondShape::Rectangle { width: 1.6e-3, height: 1.1e-3, angle_deg: 15.0 }, ..Default::default() }),
    ];
    let sizes: Vec<(usize, usize)> = vec![(300, 360), (450, 540), (617, 871)];
    for (name, b) in cases {
        for &(h, w) in &sizes {
            let mut e = vec![vec![]; 4];
            for seed in 0..6u64 {
                let d = random_fibre_web(h, w, PX, 20.0, 10e-3, 1e-3, Some(35.0), 100 + seed);
                let t = coefficient_of_variation(render(&d, PX, &RenderParams::default()).unwrap().grey.iter().copied());
                let img = render(&d, PX, &RenderParams { bonds: Some(b.clone()), ..Default::default() }).unwrap().grey;
                let ps = [ImageParams::default(), ImageParams { edge_margin_periods: 1.0, ..Default::default() }, ImageParams { notch_growth: false, ..Default::default() }, ImageParams { notch_growth: false, censoring_correction: false, edge_margin_periods: 1.0, ..Default::default() }];
                for (k, p) in ps.iter().enumerate() {
                    let a = analyze(&img, PX, p).unwrap();
                    e[k].push(100.0 * (a.cv_corr / t - 1.0));
                }
            }
            let s = |v: &Vec<f64>| { let m = v.iter().sum::<f64>() / v.len() as f64; let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt(); format!("{m:+.2}±{sd:.2} [{:+.2},{:+.2}]", v.iter().cloned().fold(f64::INFINITY, f64::min), v.iter().cloned().fold(f64::NEG_INFINITY, f64::max)) };
            println!("{name} {h}×{w} px: default {} | margin1 {} | nogrowth {} | old {}", s(&e[0]), s(&e[1]), s(&e[2]), s(&e[3]));
        }
    }
}
