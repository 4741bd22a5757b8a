//! Writes a rendered bonded web of the paper's scan size (871×617 px, 297/871 mm per
//! pixel, 8-bit grey PNG) for timing the image stage end to end:
//! `cargo run --release --example image_scan_png -- scan.png [seed]`
use laydown::stages::image::io::write_grey_png;
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, RenderParams};
fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| "scan.png".into());
    let seed: u64 = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(71);
    let px = 297e-3 / 871.0;
    let web = random_fibre_web(617, 871, px, 20.0, 10e-3, 1e-3, Some(35.0), seed);
    let rp = RenderParams { bonds: Some(BondPattern { contrast: 0.3, ..Default::default() }), bits: 8, ..Default::default() };
    let img = render(&web, px, &rp).unwrap().grey;
    write_grey_png(std::path::Path::new(&path), &img, 0.0, 1.0, 8).unwrap();
    println!("{path}: 871×617, 8 bit");
}
