//! Error of each corrected CV against the known web CV on bonded synthetic webs
//! (617 × 871 px, 3 seeds per lattice): the evidence behind the reported `cv_corr`
//! (`CV_CORR_RULE` in src/stages/image/mod.rs) and what the notch growth, the censoring
//! correction and the edge band cost. `cargo run --release --example image_estimators`.
//!
//! Per image: the errors (%) of the raw CV, the plain CV (the paper's), `cv_corr`
//! (compensated) and the one-sided estimate with the default parameters; the share of
//! saturated pixels and of the web variance under the notches; `cv_corr` again with the
//! method as it was before issue 17 (`notch_growth` and `censoring_correction` off, an
//! edge band of one period) and the wall time of both analyses of the image, measured
//! alternately in this run. The last lines summarise per case and the cost ratio.
//! `NOCLIP=1` renders the bonds without clipping grey levels to [0, 1] (the filter's own
//! error, without saturated pixels).
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
use laydown::uniformity::coefficient_of_variation;
use std::time::Instant;

fn main() {
    let px = 297e-3 / 871.0;
    let cases: Vec<(&str, BondPattern)> = vec![
        ("accuracy default 4.2mm 45deg c0.15", BondPattern { period1: 4.2e-3, period2: 4.2e-3, angle_deg: 45.0, contrast: 0.15, shape: BondShape::Circle { diameter: 1.5e-3 }, ..Default::default() }),
        ("strong off-grid 4.1mm c0.5", BondPattern { period1: 4.1e-3, period2: 4.1e-3, contrast: 0.5, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() }),
        ("rotated 30 rect ellipse c0.5", BondPattern { period1: 5e-3, period2: 3.5e-3, angle_deg: 30.0, contrast: 0.5, shape: BondShape::Ellipse { major: 1.8e-3, minor: 1.1e-3, angle_deg: 30.0 }, ..Default::default() }),
        ("large ellipse 3x1.6 c0.4", BondPattern { period1: 5.3e-3, period2: 5.3e-3, angle_deg: 10.0, contrast: 0.4, shape: BondShape::Ellipse { major: 3.0e-3, minor: 1.6e-3, angle_deg: 35.0 }, ..Default::default() }),
        ("staggered 60 rect c-0.4", BondPattern { period1: 4.5e-3, period2: 4.5e-3, angle_deg: 15.0, angle_between_deg: 60.0, contrast: -0.4, shape: BondShape::Rectangle { width: 1.6e-3, height: 1.1e-3, angle_deg: 15.0 }, ..Default::default() }),
    ];
    let noclip = std::env::var("NOCLIP").is_ok();
    let (rows, cols) = (617, 871);
    let now = ImageParams::default();
    let before = ImageParams { notch_growth: false, censoring_correction: false, edge_margin_periods: 1.0, ..Default::default() };
    // Warm-up (FFT plans, thread pool).
    let warm = render(&random_fibre_web(rows, cols, px, 20.0, 10e-3, 1e-3, Some(35.0), 1), px, &RenderParams::default()).unwrap().grey;
    analyze(&warm, px, &now).unwrap();
    println!("case,seed,truth,raw_err_%,plain_err_%,compensated_err_%,one_sided_err_%,saturated_%,notched_web_variance_fraction,grown_bins,before_cv_corr_err_%,seconds,before_seconds");
    let (mut t_now, mut t_before) = (0.0, 0.0);
    let mut summary: Vec<(String, f64, f64, f64, f64)> = Vec::new();
    for (name, b) in &cases {
        let (mut lo, mut hi, mut blo, mut bhi) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for seed in 0..3u64 {
            let web = random_fibre_web(rows, cols, px, 20.0, 10e-3, 1e-3, Some(35.0), 100 + seed);
            let plain = render(&web, px, &RenderParams::default()).unwrap();
            let truth = coefficient_of_variation(plain.grey.iter().copied());
            let bonded = render(&web, px, &RenderParams { bonds: Some(b.clone()), ..Default::default() }).unwrap();
            let img = if noclip { &plain.grey + &bonded.bond } else { bonded.grey };
            let run = |p: &ImageParams| {
                let t = Instant::now();
                let a = analyze(&img, px, p).unwrap();
                (a, t.elapsed().as_secs_f64())
            };
            // Alternate the order so neither configuration always runs second.
            let ((a, s), (ab, sb)) = if seed % 2 == 0 {
                let x = run(&now);
                (x, run(&before))
            } else {
                let y = run(&before);
                (run(&now), y)
            };
            t_now += s;
            t_before += sb;
            let e = |v: f64| 100.0 * (v / truth - 1.0);
            let frac = a.web_variance_notched / (a.cv_corr_compensated * a.mean).powi(2);
            let sat = 100.0 * img.iter().filter(|&&g| g <= 0.0 || g >= 1.0).count() as f64 / img.len() as f64;
            println!(
                "{name},{seed},{truth:.5},{:+.2},{:+.2},{:+.2},{:+.2},{sat:.2},{frac:.4},{},{:+.2},{s:.3},{sb:.3}",
                e(a.cv_raw),
                e(a.cv_corr_plain),
                e(a.cv_corr_compensated),
                e(a.cv_corr_one_sided.unwrap_or(f64::NAN)),
                a.grown_bins,
                e(ab.cv_corr)
            );
            (lo, hi) = (lo.min(e(a.cv_corr)), hi.max(e(a.cv_corr)));
            (blo, bhi) = (blo.min(e(ab.cv_corr)), bhi.max(e(ab.cv_corr)));
        }
        summary.push((name.to_string(), blo, bhi, lo, hi));
    }
    println!("\ncase,before_cv_corr_err_% (min..max),cv_corr_err_% (min..max)");
    for (name, blo, bhi, lo, hi) in &summary {
        println!("{name},{blo:+.2}..{bhi:+.2},{lo:+.2}..{hi:+.2}");
    }
    println!("\nwall per image (2 threads): {:.3} s now, {:.3} s before: ratio {:.2}", t_now / 15.0, t_before / 15.0, t_now / t_before);
}
