//! Diagnostics of the image filter on a rendered bonded web (development aid).
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
use laydown::uniformity::coefficient_of_variation;
fn main() {
    let px = 0.34e-3;
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().unwrap()).collect();
    let (rows, cols, period_px, widen) = (args[0] as usize, args[1] as usize, args[2], args[3]);
    let web = random_fibre_web(rows, cols, px, 20.0, 10e-3, 1e-3, Some(35.0), 14);
    let truth = render(&web, px, &RenderParams::default()).unwrap().grey;
    let b = BondPattern { period1: period_px * px, period2: period_px * px, contrast: 0.4,
        shape: laydown::stages::image::render::BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() };
    let img = render(&web, px, &RenderParams { bonds: Some(b), ..Default::default() }).unwrap().grey;
    let p = ImageParams { off_grid_widening: widen, ..Default::default() };
    let a = analyze(&img, px, &p).unwrap();
    let cvt = coefficient_of_variation(truth.iter().copied());
    println!("truth {cvt:.4} raw {:.4} corr {:.4} ({:+.2}%) comp {:.4} ({:+.2}%) peaks {} thr {:.2}", a.cv_raw, a.cv_corr, 100.0*(a.cv_corr/cvt-1.0), a.cv_corr_compensated, 100.0*(a.cv_corr_compensated/cvt-1.0), a.peaks.len(), a.threshold);
    let d = &a.filtered - &truth;
    let m = d.mean().unwrap();
    let rv = d.mapv(|x| (x-m)*(x-m)).mean().unwrap();
    let tv = truth.mapv(|x| x).var(0.0);
    println!("residual var / truth var = {:.4}", rv / tv);
    let (h, w) = d.dim();
    let e = 12usize;
    let (mut se, mut ne, mut si, mut ni) = (0.0, 0usize, 0.0, 0usize);
    for ((i, j), v) in d.indexed_iter() {
        let r = (v - m) * (v - m);
        if i < e || j < e || i >= h - e || j >= w - e { se += r; ne += 1 } else { si += r; ni += 1 }
    }
    println!("residual var per px: edge band {:.3e} interior {:.3e} (truth var {:.3e})", se / ne as f64, si / ni as f64, tv);
    if std::env::var("PEAKS").is_ok() { for pk in &a.peaks { println!("pass {} v {:7.2} u {:7.2} W {:10.1} frac {:.2e} sigma {:.2} idx {:?}", pk.pass, pk.v, pk.u, pk.strength, pk.variance_fraction, pk.notch_sigma, pk.lattice_index); } }
}
#[allow(dead_code)]
fn unused() {}
