//! Counts peaks detected in bond-free images (false alarms) against the nominal rate.
//! `cargo run --release --example image_false_alarms [images_per_kind] [false_alarm_rate]`
//! (rate 0.01 unless given; the method's default is 0.001).
use laydown::stages::image::render::{random_fibre_web, render, smoothed_noise, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
fn main() {
    let px = 0.34e-3;
    let n: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let alpha: f64 = std::env::args().nth(2).and_then(|a| a.parse().ok()).unwrap_or(1e-2);
    let p = ImageParams { false_alarm_rate: alpha, ..Default::default() };
    let kinds = ["white noise", "smoothed noise σ=2 px", "isotropic web", "MD web (35°)", "MD web 8 bit"];
    for (k, kind) in kinds.iter().enumerate() {
        let mut peaks = 0;
        let mut max_change: f64 = 0.0;
        for s in 0..n {
            let seed = 1000 * k as u64 + s;
            let img = match k {
                0 => smoothed_noise(256, 256, 0.0, 0.5, 0.2, seed),
                1 => smoothed_noise(256, 256, 2.0, 0.5, 0.15, seed),
                2 => render(&random_fibre_web(256, 256, px, 20.0, 10e-3, 1e-3, None, seed), px, &RenderParams::default()).unwrap().grey,
                3 => render(&random_fibre_web(256, 256, px, 20.0, 10e-3, 1e-3, Some(35.0), seed), px, &RenderParams::default()).unwrap().grey,
                _ => {
                    let rp = RenderParams { bits: 8, ..Default::default() };
                    render(&random_fibre_web(256, 256, px, 20.0, 10e-3, 1e-3, Some(35.0), seed), px, &rp).unwrap().grey
                }
            };
            let a = analyze(&img, px, &p).unwrap();
            peaks += a.peaks.len();
            if std::env::var("SHOW").is_ok() && !a.peaks.is_empty() {
                println!("  seed {seed}: cv_raw {:.4} cv_corr {:.4} margin {} mean {:.4} peaks {:?}", a.cv_raw, a.cv_corr, a.margin_px, a.mean, a.peaks);
            }
            max_change = max_change.max((a.cv_corr / a.cv_raw - 1.0).abs());
        }
        println!(
            "{kind:24}: {peaks} false peaks in {n} images of 256×256 (nominal {:.2}); largest CV change {:.2e}",
            p.false_alarm_rate * n as f64,
            max_change
        );
    }
}
