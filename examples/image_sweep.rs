//! Development aid: CV_corr error vs notch parameters on the test lattices.
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
use laydown::uniformity::coefficient_of_variation;
fn main() {
    let px = 0.34e-3;
    let cases: Vec<(usize, usize, u64, BondPattern)> = vec![
        (240, 300, 11, BondPattern { contrast: 0.4, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() }),
        (256, 256, 12, BondPattern { period1: 5e-3, period2: 3.5e-3, angle_deg: 30.0, shape: BondShape::Ellipse { major: 1.8e-3, minor: 1.1e-3, angle_deg: 30.0 }, contrast: 0.4, ..Default::default() }),
        (231, 289, 13, BondPattern { period1: 4.5e-3, period2: 4.5e-3, angle_deg: 15.0, angle_between_deg: 60.0, shape: BondShape::Rectangle { width: 1.6e-3, height: 1.1e-3, angle_deg: 15.0 }, contrast: -0.4, ..Default::default() }),
        (192, 256, 14, BondPattern { period1: 16.0 * px, period2: 16.0 * px, shape: BondShape::Circle { diameter: 2e-3 }, contrast: 0.4, ..Default::default() }),
    ];
    let sig: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().unwrap()).collect();
    for &(s, wdn) in &[(sig[0], sig[1])] {
        let p = ImageParams { notch_sigma_bins: s, off_grid_widening: wdn, ..Default::default() };
        for (rows, cols, seed, b) in &cases {
            let web = random_fibre_web(*rows, *cols, px, 20.0, 10e-3, 1e-3, Some(35.0), *seed);
            let truth = render(&web, px, &RenderParams::default()).unwrap().grey;
            let img = render(&web, px, &RenderParams { bonds: Some(b.clone()), ..Default::default() }).unwrap().grey;
            let a = analyze(&img, px, &p).unwrap();
            let t = coefficient_of_variation(truth.iter().copied());
            let d = &a.filtered - &truth;
            let m = d.mean().unwrap();
            let (h, w) = d.dim();
            let e = 12usize;
            let (mut se, mut ne, mut si, mut ni) = (0.0, 0usize, 0.0, 0usize);
            for ((i, j), v) in d.indexed_iter() {
                let r = (v - m) * (v - m);
                if i < e || j < e || i >= h - e || j >= w - e { se += r; ne += 1 } else { si += r; ni += 1 }
            }
            let tv = truth.var(0.0);
            let mut extra = String::new();
            for e in [6usize, 12, 24] {
                let fi = a.filtered.slice(ndarray::s![e..h - e, e..w - e]);
                let ti = truth.slice(ndarray::s![e..h - e, e..w - e]);
                let cf = fi.std(0.0) / fi.mean().unwrap();
                let cvar = (fi.var(0.0) + a.web_variance_notched).sqrt() / fi.mean().unwrap();
                let ct = ti.std(0.0) / ti.mean().unwrap();
                extra += &format!(" | m{e}: plain {:+.2}% comp {:+.2}%", 100.0 * (cf / ct - 1.0), 100.0 * (cvar / ct - 1.0));
            }
            println!("σ {s} w {wdn} case {seed}: plain {:+.2}% comp {:+.2}% peaks {} resid edge {:.3} interior {:.3} (of truth var){extra}",
                100.0 * (a.cv_corr_plain / t - 1.0), 100.0 * (a.cv_corr_compensated / t - 1.0), a.peaks.len(), se / ne as f64 / tv, si / ni as f64 / tv);
        }
    }
}
