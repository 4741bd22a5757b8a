//! Image stage numerics (paper §3.4, Table 4, Figs 11–12): the uniformity of a bonded
//! nonwoven from a greyscale image, raw and after removing the bond lattice by FFT
//! notch filtering.
//!
//! # Method
//! 1. **Raw CV** of the grey levels (population std / mean, [`crate::uniformity`]).
//! 2. **Spectrum.** The image is split into periodic + smooth components
//!    ([`periodic`], Moisan 2011) so the edge jumps of a scan do not paint a "+" of
//!    false peaks along the frequency axes; the 2D FFT ([`fft2`], rows then columns,
//!    any size, e.g. 871×617) of the periodic component gives the energy spectrum `|F|²`.
//! 3. **Broad central peak** (the random web), [`background`]: the median of the power
//!    pooled in polar cells (annulus × angular sector, pools grown radially to ~256
//!    bins), divided by ln 2, interpolated per bin in the log domain. The spectrum is
//!    **divided** by it (not subtracted), giving the whitened `W = |F|²/E|F|² ~ Exp(1)`,
//!    whose spread no longer depends on the radius.
//! 4. **Peak detection** ([`peaks`]): `W > t` with `t = ln(M·passes/α)`
//!    (α = `false_alarm_rate`, expected false peaks per image; `M` bins searched per
//!    pass), raised per bin for the estimation error of the background
//!    ([`background::corrected_threshold`]); outside a DC disc of `dc_exclusion_bins`;
//!    local maxima of `W` only; and only bins whose excess power is at least
//!    `min_peak_fraction` of the image variance (well above the noise floor, so the
//!    round-off tail of blurred noise-free images is never searched). Up to `max_passes`
//!    passes: each searches the residual after the previous notches, which catches the
//!    leakage of peaks whose period does not divide the image size.
//! 5. **Notches** ([`notch`]): circular Gaussians of `notch_sigma_bins` at the sub-bin
//!    peak position and its conjugate, widened to `σ·(1 + off_grid_widening·2·max|δ|)`
//!    where `δ` is the sub-bin offset (leakage is wider when the period does not divide
//!    the image size). The DC gain is kept at 1.
//! 6. **Growth over the leakage ridges** ([`grow`], `notch_growth`): a peak whose period
//!    does not divide the image leaks along the row and column of the spectrum through
//!    it, far beyond a Gaussian notch. Each notch grows by hysteresis from its peak over
//!    4-connected bins that are themselves significant, `W > ln(n/α)` over the `n` bins
//!    the growth tests (the detector's false-alarm rule on those bins), with gain 0. The
//!    background is then refitted without the grown bins and without bins above
//!    `ln(background_pool)` times the model (ridges inflate the pools' medians), for the
//!    compensation below.
//! 7. **Inverse FFT** of the notched image spectrum (the mask multiplies the spectra of
//!    both components) → filtered image with exactly the raw mean.
//! 8. **Lattice**: two basis vectors fitted to the peaks ([`peaks::fit_lattice`],
//!    least squares weighted by each peak's share of the variance), reported as reduced
//!    real-space vectors (periods, directions, angle between).
//! 9. **CV_corr** of the filtered image over the interior (`edge_margin_periods` = 2 of
//!    the longest bond period are left out along the edges: the notches cannot remove the
//!    part of an off-grid harmonic that wraps around the image, and the residue decays
//!    over about two periods; the paper saw pattern left at the image boundary), the
//!    fraction of variance removed, CV over zone sizes.
//!    The notches also remove the web's own power under them: the plain CV of the
//!    filtered image (`cv_corr_plain`, the paper's quantity) is therefore biased low by a
//!    few per cent, and `cv_corr_compensated` adds back the expected web variance
//!    `Σ(1 − g²)·B/N²` from the background model.
//! 10. **Saturated pixels** ([`censor`], `censoring_correction`): grey levels at exactly
//!     0 or 1 (images on that scale) are censored, the web under them unknown. Their
//!     values are restored from the lattice: the pattern level of each lattice phase is
//!     matched on its unclipped pixels against the web's distribution at unclipped
//!     phases, a clipped pixel becomes that level plus the web's conditional mean above
//!     (below) the clipping level, and the conditional variance it cannot show is added.
//!     The compensated statistics are those of this image filtered by the same notches.
//! 11. **The reported `cv_corr`** is chosen by [`CV_CORR_RULE`]: the compensated CV. On
//!     bonded renderings of known web CV (weak, strong, rotated, staggered and large
//!     elliptical lattices whose periods do not divide the image, strong and large bonds
//!     clipping 6–9 % of the pixels to white) it has the smaller worst-case and mean error
//!     and does not drift with the notch width as the plain CV does. It is within 1 % of
//!     the truth at the paper's scan size and over-estimates more on smaller images
//!     (pattern left below the growth threshold); the measurements and their commands are
//!     in the README, "What accuracy costs". Without notches all of them are the raw CV.
//!
//! # The mean pitfall
//! Notching never touches the DC bin, so the filtered image keeps the raw mean. If the
//! bond pattern has a non-zero mean (bonds are a one-sided brightening of `contrast·f`
//! on average, `f` the bond area fraction), `CV_corr = σ_web/(μ_web + contrast·f)` is
//! biased low. The image alone cannot tell a one-sided pattern from a zero-mean one
//! (they differ only by a constant), so the stage reports both:
//! * [`ImageAnalysis::cv_corr`] (= `cv_corr_compensated`) / [`ImageAnalysis::cv_corr_plain`]:
//!   mean kept (the paper's method; right for a zero-mean pattern);
//! * [`ImageAnalysis::cv_corr_one_sided`]: the removed pattern `raw − filtered` is zero
//!   mean, and its median is the level between bonds, i.e. `−contrast·f` when bonds cover
//!   less than half the area; subtracting that estimate ([`ImageAnalysis::bond_mean_estimate`])
//!   from the mean gives the (compensated) CV for a one-sided pattern (bonds added on
//!   top of the web).
//!
//! # Degenerate inputs
//! Typed [`ImageError`]s (with the file path where there is one): unreadable or corrupt
//! files, images under [`MIN_SIDE`] pixels, NaN/inf, a non-positive mean, invalid
//! parameters. Documented results: a constant image gives CV 0, no peaks and a warning;
//! a lattice whose period exceeds the image (inside the DC disc) is not detected and
//! the image is returned unchanged; clipped (saturated) bonds are notched as far as they
//! are periodic, the clipped web is restored from the lattice for `cv_corr` (step 10),
//! a warning reports the saturated fraction, and another the lattice phases clipped in
//! every pixel (their level is only bounded); CV_corr stays finite.
//! No output is ever NaN.
//!
//! # API
//! * [`analyze`] (array + pixel size in m), [`analyze_file`], [`analyze_files`] (list/globs
//!   with group labels, streaming) → [`ImageAnalysis`], [`Summary`], [`BatchSummary`],
//!   [`GroupStats`] ([`group_statistics`] for summaries gathered elsewhere);
//! * [`ImageParams`] (SI, lengths in m; serde, `validate()`), [`PARAMETERS`] (the image
//!   stage's rows: name, SI unit, default, range, doc);
//! * [`io`] (read PNG/TIFF/JPEG 8/16-bit or float, grey or RGB, with the declared pixel size), [`render`] (density map → image
//!   with bond lattice; synthetic webs), [`panel`] (Fig-12-like 2×2 PNG).
//!
//! # Example
//! ```
//! use laydown::stages::image::{analyze, ImageParams};
//! use laydown::stages::image::render::{render, random_fibre_web, BondPattern, BondShape, RenderParams};
//! let cell = 0.34e-3;
//! let web = random_fibre_web(128, 160, cell, 20.0, 10e-3, 1e-3, None, 7);
//! let truth = render(&web, cell, &RenderParams::default()).unwrap().grey;
//! let bonds = BondPattern { contrast: 0.4, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() };
//! let rp = RenderParams { bonds: Some(bonds), ..Default::default() };
//! let bonded = render(&web, cell, &rp).unwrap().grey;
//! let a = analyze(&bonded, cell, &ImageParams::default()).unwrap();
//! let cv_true = laydown::uniformity::coefficient_of_variation(truth.iter().copied());
//! assert!(a.cv_raw > 1.3 * cv_true);                              // bonds dominate the raw CV
//! assert!((a.cv_corr_compensated / cv_true - 1.0).abs() < 0.05); // the filter recovers the web
//! let lat = a.lattice.as_ref().unwrap();                          // 4 mm square lattice
//! assert!(lat.periods.iter().all(|p| (p - 4e-3).abs() < 0.1e-3));
//! ```
// `!(x > y)` is used on purpose throughout: it is also true when x is NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod background;
pub mod censor;
pub mod fft2;
pub mod grow;
pub mod io;
pub mod notch;
pub mod panel;
pub mod peaks;
pub mod periodic;
pub mod render;
pub mod stage;

mod analysis;
mod batch;
mod error;
mod params;
mod zones;
pub use analysis::*;
pub use batch::*;
pub use error::ImageError;
pub use params::*;
pub use zones::zone_curve;

pub use io::{expand_inputs, read_grey, FileResolution, GreyImage, InputSpec};
pub use peaks::{Lattice, Peak};

/// Smallest image side accepted (pixels).
pub const MIN_SIDE: usize = 16;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::uniformity::{cv_by_zone_size, log_zone_sizes};
    use ndarray::Array2;
    use std::path::PathBuf;

    #[test]
    fn parameters_override_the_file_pixel_size_and_bad_declared_sizes_name_the_file() {
        let img = |res: Option<(f64, f64)>| GreyImage {
            data: Array2::zeros((2, 2)),
            bit_depth: 8,
            was_colour: false,
            path: PathBuf::from("scan.png"),
            resolution: res.map(|(x, y)| FileResolution { x, y, tag: "test".into() }),
            resolution_error: None,
        };
        let p = ImageParams::default();
        assert_eq!(p.pixel_size_for(&img(Some((1e-4, 1e-4)))).unwrap(), (1e-4, PixelSource::File));
        assert_eq!(p.pixel_size_for(&img(None)).unwrap(), (DEFAULT_PIXEL_SIZE, PixelSource::Default));
        let dpi = ImageParams { dpi: Some(254.0), ..Default::default() };
        assert_eq!(dpi.pixel_size_for(&img(Some((1e-4, 3e-4)))).unwrap(), (25.4e-3 / 254.0, PixelSource::Dpi));
        let given = ImageParams { pixel_size: Some(0.2e-3), ..Default::default() };
        assert_eq!(given.pixel_size_for(&img(Some((1e-4, 1e-4)))).unwrap(), (0.2e-3, PixelSource::PixelSize));
        let e = p.pixel_size_for(&img(Some((1e-4, 2e-4)))).unwrap_err();
        assert!(matches!(e, ImageError::BadResolution { .. }) && e.to_string().contains("scan.png") && e.to_string().contains("non-square"), "{e}");
        let e = p.pixel_size_for(&img(Some((1.0, 1.0)))).unwrap_err();
        assert!(e.to_string().contains("1000 mm") && e.to_string().contains("override"), "{e}");
        let unreadable = GreyImage { resolution_error: Some("XResolution has an unexpected type".into()), ..img(None) };
        let e = p.pixel_size_for(&unreadable).unwrap_err();
        assert!(e.to_string().contains("cannot be read") && e.to_string().contains("scan.png"), "{e}");
        assert_eq!(dpi.pixel_size_for(&unreadable).unwrap().1, PixelSource::Dpi, "a parameter overrides unreadable metadata");
    }

    #[test]
    fn zone_curve_matches_uniformity_cv_by_zone_size() {
        let map = Array2::from_shape_fn((53, 71), |(i, j)| 1.0 + ((i * 37 + j * 11) % 17) as f64 / 7.0);
        let zones = log_zone_sizes(0.5e-3, 16e-3, 2);
        let a = zone_curve(&map, 0.34e-3, &zones, None);
        let b = cv_by_zone_size(map.view(), 0.34e-3, &zones);
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!((x.cells_per_side, x.zones), (y.cells_per_side, y.zones));
            assert_eq!(x.zone_size, x.cells_per_side as f64 * 0.34e-3, "the size actually used");
            assert!((x.cv - y.cv).abs() < 1e-11 * y.cv.max(1e-300), "{x:?} {y:?}");
        }
    }
}
