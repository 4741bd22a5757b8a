//! A Figure-12-like 2×2 greyscale PNG panel: raw image (a), filtered image (b), raw log
//! energy spectrum (c), notched log energy spectrum (d), separated by white gaps.
//!
//! Images share one grey range (0.5 and 99.5 percentiles of the raw image); spectra share
//! one range, from `decades` below the largest non-DC value of the raw log spectrum to it.
//!
//! ```no_run
//! # use laydown::stages::image::{analyze, ImageParams, panel::write_panel_png};
//! # let img = ndarray::Array2::from_elem((32, 32), 0.5);
//! let a = analyze(&img, 0.34e-3, &ImageParams::default()).unwrap();
//! write_panel_png(std::path::Path::new("fig12.png"), &a, 7.0).unwrap();
//! ```
use std::path::Path;

use ndarray::{s, Array2};

use super::{ImageAnalysis, ImageError};

/// White gap between tiles (pixels).
pub const GAP: usize = 6;

fn percentile(v: &Array2<f64>, q: f64) -> f64 {
    let mut x: Vec<f64> = v.iter().copied().filter(|a| a.is_finite()).collect();
    if x.is_empty() {
        return 0.0;
    }
    let k = ((x.len() - 1) as f64 * q).round() as usize;
    let (_, m, _) = x.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    *m
}

/// Composes the four tiles as grey levels in [0, 1] (white gaps), shape
/// (2H + 3·GAP, 2W + 3·GAP).
pub fn panel_array(a: &ImageAnalysis, decades: f64) -> Array2<f64> {
    let (h, w) = a.raw.dim();
    let mut out = Array2::from_elem((2 * h + 3 * GAP, 2 * w + 3 * GAP), 1.0);
    let (lo, hi) = (percentile(&a.raw, 0.005), percentile(&a.raw, 0.995));
    let img_span = if hi > lo { hi - lo } else { 1.0 };
    let dc = (h / 2, w / 2);
    let smax = a
        .log_spectrum_raw
        .indexed_iter()
        .filter(|(ix, _)| *ix != dc)
        .map(|(_, v)| *v)
        .fold(f64::NEG_INFINITY, f64::max);
    let smax = if smax.is_finite() { smax } else { 0.0 };
    let smin = smax - decades.max(1.0);
    let tiles: [(&Array2<f64>, f64, f64); 4] = [
        (&a.raw, lo, img_span),
        (&a.filtered, lo, img_span),
        (&a.log_spectrum_raw, smin, smax - smin),
        (&a.log_spectrum_notched, smin, smax - smin),
    ];
    for (t, (src, base, span)) in tiles.iter().enumerate() {
        let (r0, c0) = (GAP + (t / 2) * (h + GAP), GAP + (t % 2) * (w + GAP));
        let mut dst = out.slice_mut(s![r0..r0 + h, c0..c0 + w]);
        dst.zip_mut_with(*src, |d, &v| *d = if v.is_finite() { ((v - base) / span).clamp(0.0, 1.0) } else { 0.0 });
    }
    out
}

/// Writes the 2×2 panel as an 8-bit greyscale PNG. `decades`: dynamic range of the
/// spectrum tiles (e.g. 7).
pub fn write_panel_png(path: &Path, a: &ImageAnalysis, decades: f64) -> Result<(), ImageError> {
    super::io::write_grey_png(path, &panel_array(a, decades), 0.0, 1.0, 8)
}

/// The 2×2 panel's PNG as bytes (see [`write_panel_png`]).
pub fn panel_png(a: &ImageAnalysis, decades: f64) -> Result<Vec<u8>, String> {
    super::io::encode_grey_png(&panel_array(a, decades), 0.0, 1.0, 8)
}
