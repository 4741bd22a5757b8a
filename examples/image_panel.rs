//! Writes a Figure-12-like panel for a rendered bonded web: `cargo run --release --example image_panel -- out.png`
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, panel::write_panel_png, ImageParams};
fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| "fig12_synthetic.png".into());
    let px = 297e-3 / 871.0;
    let web = random_fibre_web(300, 420, px, 30.0, 10e-3, 1e-3, Some(35.0), 3);
    let bonds = BondPattern { angle_deg: 20.0, angle_between_deg: 60.0, shape: BondShape::Circle { diameter: 1.4e-3 }, contrast: 0.35, zero_mean: false, ..Default::default() };
    let img = render(&web, px, &RenderParams { bonds: Some(bonds), bits: 8, ..Default::default() }).unwrap().grey;
    let a = analyze(&img, px, &ImageParams::default()).unwrap();
    write_panel_png(std::path::Path::new(&out), &a, 7.0).unwrap();
    println!("{out}: cv_raw {:.4} cv_corr {:.4} compensated {:.4} one-sided {:?}, {} peaks", a.cv_raw, a.cv_corr, a.cv_corr_compensated, a.cv_corr_one_sided, a.peaks.len());
}
