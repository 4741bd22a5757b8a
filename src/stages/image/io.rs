//! Reading greyscale images (PNG, TIFF, JPEG; 8 or 16 bit; grey or RGB) and expanding
//! lists of paths and glob patterns into labelled samples.
//!
//! Grey levels are returned as `f64` in [0, 1]: the stored integer divided by its full
//! scale (255 or 65535; float TIFFs are taken as they are). Colour images are converted
//! with the ITU-R BT.601 luma weights **0.299 R + 0.587 G + 0.114 B** applied to the stored
//! (gamma-encoded) values, as MATLAB's `rgb2gray` (the paper's tool) does. Alpha is ignored.
//!
//! ```
//! use laydown::stages::image::io::{read_grey, write_grey_png};
//! use ndarray::Array2;
//! let dir = std::env::temp_dir().join(format!("laydown-io-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("ramp.png");
//! let img = Array2::from_shape_fn((4, 6), |(i, j)| (i * 6 + j) as f64 / 23.0);
//! write_grey_png(&path, &img, 0.0, 1.0, 16).unwrap();
//! let back = read_grey(&path).unwrap();
//! assert_eq!(back.bit_depth, 16);
//! assert!(back.data.iter().zip(img.iter()).all(|(a, b)| (a - b).abs() < 1e-4));
//! # std::fs::remove_dir_all(&dir).ok();
//! ```
use std::path::{Path, PathBuf};

use image::{DynamicImage, ImageReader};
use ndarray::Array2;

use super::ImageError;

/// BT.601 luma weights for (R, G, B).
pub const LUMA_WEIGHTS: [f64; 3] = [0.299, 0.587, 0.114];

/// A decoded greyscale image.
#[derive(Debug, Clone)]
pub struct GreyImage {
    /// Grey levels in [0, 1], shape (rows, cols) = (height, width).
    pub data: Array2<f64>,
    /// Bits per channel of the stored file (8, 16 or 32 for float).
    pub bit_depth: u8,
    /// Whether the file held colour channels (converted with [`LUMA_WEIGHTS`]).
    pub was_colour: bool,
    /// Source file.
    pub path: PathBuf,
}

/// Reads one image file as grey levels in [0, 1].
///
/// Errors: [`ImageError::Io`] (missing, unreadable), [`ImageError::Decode`] (corrupt or
/// unsupported format), [`ImageError::NonFinite`] (NaN/inf in a float TIFF), each naming the path.
pub fn read_grey(path: &Path) -> Result<GreyImage, ImageError> {
    let reader = ImageReader::open(path)
        .map_err(|source| ImageError::Io { path: path.to_path_buf(), source })?
        .with_guessed_format()
        .map_err(|source| ImageError::Io { path: path.to_path_buf(), source })?;
    let img = reader
        .decode()
        .map_err(|e| ImageError::Decode { path: path.to_path_buf(), message: e.to_string() })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (bit_depth, was_colour) = match &img {
        DynamicImage::ImageLuma8(_) | DynamicImage::ImageLumaA8(_) => (8, false),
        DynamicImage::ImageLuma16(_) | DynamicImage::ImageLumaA16(_) => (16, false),
        DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_) => (8, true),
        DynamicImage::ImageRgb16(_) | DynamicImage::ImageRgba16(_) => (16, true),
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => (32, true),
        _ => (32, img.color().has_color()),
    };
    let data = if !was_colour {
        match &img {
            DynamicImage::ImageLuma8(b) => Array2::from_shape_fn((h, w), |(i, j)| b.get_pixel(j as u32, i as u32)[0] as f64 / 255.0),
            DynamicImage::ImageLuma16(b) => {
                Array2::from_shape_fn((h, w), |(i, j)| b.get_pixel(j as u32, i as u32)[0] as f64 / 65535.0)
            }
            other => {
                let b = other.to_luma32f();
                Array2::from_shape_fn((h, w), |(i, j)| b.get_pixel(j as u32, i as u32)[0] as f64)
            }
        }
    } else {
        let b = img.to_rgb32f();
        Array2::from_shape_fn((h, w), |(i, j)| {
            let p = b.get_pixel(j as u32, i as u32);
            LUMA_WEIGHTS[0] * p[0] as f64 + LUMA_WEIGHTS[1] * p[1] as f64 + LUMA_WEIGHTS[2] * p[2] as f64
        })
    };
    let bad = data.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        return Err(ImageError::NonFinite { path: Some(path.to_path_buf()), count: bad });
    }
    Ok(GreyImage { data, bit_depth, was_colour, path: path.to_path_buf() })
}

/// One entry of an input list: a file path or glob pattern, and the condition (group)
/// label its files belong to.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct InputSpec {
    /// A path, or a glob pattern (`*`, `?`, `[...]`, `**`).
    pub pattern: String,
    /// Group label, e.g. the belt-to-fibre velocity ratio "0.020".
    pub group: String,
}

/// Expands the specs into (path, group) pairs, in spec order and, within a pattern,
/// sorted by path. A pattern without glob characters must name an existing file; a glob
/// must match at least one file. Duplicate paths are kept once (first group wins).
pub fn expand_inputs(specs: &[InputSpec]) -> Result<Vec<(PathBuf, String)>, ImageError> {
    let mut out: Vec<(PathBuf, String)> = Vec::new();
    for spec in specs {
        let is_glob = spec.pattern.contains(['*', '?', '[']);
        let mut paths: Vec<PathBuf> = if is_glob {
            let it = glob::glob(&spec.pattern)
                .map_err(|e| ImageError::BadPattern { pattern: spec.pattern.clone(), message: e.to_string() })?;
            let mut v = Vec::new();
            for entry in it {
                match entry {
                    Ok(p) if p.is_file() => v.push(p),
                    Ok(_) => {}
                    Err(e) => {
                        let path = e.path().to_path_buf();
                        return Err(ImageError::Io { path, source: e.into() });
                    }
                }
            }
            v
        } else {
            let p = PathBuf::from(&spec.pattern);
            std::fs::metadata(&p).map_err(|source| ImageError::Io { path: p.clone(), source })?;
            vec![p]
        };
        if paths.is_empty() {
            return Err(ImageError::NoFiles { pattern: spec.pattern.clone() });
        }
        paths.sort();
        for p in paths {
            if !out.iter().any(|(q, _)| *q == p) {
                out.push((p, spec.group.clone()));
            }
        }
    }
    Ok(out)
}

/// Writes `img` as a greyscale PNG, mapping `lo..=hi` linearly to black..white (values
/// outside are clipped; NaN is written black). `bits` is 8 or 16.
pub fn write_grey_png(path: &Path, img: &Array2<f64>, lo: f64, hi: f64, bits: u8) -> Result<(), ImageError> {
    let (h, w) = img.dim();
    let span = if hi > lo { hi - lo } else { 1.0 };
    let norm = |v: f64| if v.is_finite() { ((v - lo) / span).clamp(0.0, 1.0) } else { 0.0 };
    let res = match bits {
        16 => {
            let buf = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w as u32, h as u32, |x, y| {
                image::Luma([(norm(img[[y as usize, x as usize]]) * 65535.0).round() as u16])
            });
            buf.save_with_format(path, image::ImageFormat::Png)
        }
        _ => {
            let buf = image::GrayImage::from_fn(w as u32, h as u32, |x, y| {
                image::Luma([(norm(img[[y as usize, x as usize]]) * 255.0).round() as u8])
            });
            buf.save_with_format(path, image::ImageFormat::Png)
        }
    };
    res.map_err(|e| ImageError::Write { path: path.to_path_buf(), message: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_uses_bt601_weights_and_errors_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.png");
        let buf = image::RgbImage::from_fn(3, 2, |x, _| if x == 0 { image::Rgb([255, 0, 0]) } else { image::Rgb([0, 255, 0]) });
        buf.save(&p).unwrap();
        let g = read_grey(&p).unwrap();
        assert!(g.was_colour);
        assert!((g.data[[0, 0]] - 0.299).abs() < 1e-6 && (g.data[[1, 2]] - 0.587).abs() < 1e-6);

        let bad = dir.path().join("corrupt.png");
        std::fs::write(&bad, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        let e = read_grey(&bad).unwrap_err();
        assert!(matches!(e, ImageError::Decode { .. }));
        assert!(e.to_string().contains("corrupt.png"), "{e}");

        let missing = dir.path().join("missing.tif");
        let e = read_grey(&missing).unwrap_err();
        assert!(matches!(e, ImageError::Io { .. }) && e.to_string().contains("missing.tif"), "{e}");
    }

    #[test]
    fn expands_globs_with_groups() {
        let dir = tempfile::tempdir().unwrap();
        for n in ["a1.png", "a2.png", "b1.png"] {
            std::fs::write(dir.path().join(n), b"x").unwrap();
        }
        let d = dir.path().display();
        let specs = vec![
            InputSpec { pattern: format!("{d}/a*.png"), group: "A".into() },
            InputSpec { pattern: format!("{d}/b1.png"), group: "B".into() },
        ];
        let v = expand_inputs(&specs).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v[2].1, "B");
        let none = expand_inputs(&[InputSpec { pattern: format!("{d}/z*.png"), group: "Z".into() }]);
        assert!(matches!(none, Err(ImageError::NoFiles { .. })));
    }
}
