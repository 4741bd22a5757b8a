//! Reading greyscale images (PNG, TIFF, JPEG; 8 or 16 bit; grey or RGB) and expanding
//! lists of paths and glob patterns into labelled samples.
//!
//! Grey levels are returned as `f64` in [0, 1]: the stored integer divided by its full
//! scale (255 or 65535; float TIFFs, grey or RGB, 32 or 64 bit, are taken as they are).
//! Colour images are converted
//! with the ITU-R BT.601 luma weights **0.299 R + 0.587 G + 0.114 B** applied to the stored
//! (gamma-encoded) values, as MATLAB's `rgb2gray` (the paper's tool) does. Alpha is ignored.
//!
//! The pixel size a file declares ([`FileResolution`]) is read with it: PNG `pHYs` in pixels
//! per metre (the `png` crate), TIFF `XResolution`/`YResolution` with `ResolutionUnit` inch
//! or centimetre (the `tiff` crate), JPEG JFIF `APP0` density in dots per inch or
//! centimetre (parsed here: neither `image` nor `zune-jpeg` exposes it). A file without
//! one, or with only an aspect ratio (pHYs unit unspecified, ResolutionUnit none, JFIF
//! units 0), declares none. EXIF resolution tags are not read. Malformed resolution tags
//! do not stop the image being read: they are kept in [`GreyImage::resolution_error`].
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
use std::io::Cursor;
use std::path::{Path, PathBuf};

use image::{DynamicImage, ImageFormat, ImageReader};
use ndarray::Array2;

use super::ImageError;

/// BT.601 luma weights for (R, G, B).
pub const LUMA_WEIGHTS: [f64; 3] = [0.299, 0.587, 0.114];

/// A decoded greyscale image.
#[derive(Debug, Clone)]
pub struct GreyImage {
    /// Grey levels in [0, 1], shape (rows, cols) = (height, width).
    pub data: Array2<f64>,
    /// Bits per channel of the stored file (8, 16, or 32/64 for float).
    pub bit_depth: u8,
    /// Whether the file held colour channels (converted with [`LUMA_WEIGHTS`]).
    pub was_colour: bool,
    /// Source file.
    pub path: PathBuf,
    /// The pixel size the file declares, if any.
    pub resolution: Option<FileResolution>,
    /// Why the file's resolution metadata could not be read (malformed tags); the image
    /// itself decoded. Only an error if the size is needed (no `dpi`/`pixel_size`).
    pub resolution_error: Option<String>,
}

/// The pixel size a file declares.
#[derive(Debug, Clone, PartialEq)]
pub struct FileResolution {
    /// Pixel width (m), along the image columns.
    pub x: f64,
    /// Pixel height (m), along the rows.
    pub y: f64,
    /// Where it was read, with the stored values, e.g. `PNG pHYs 11811 × 11811 px/m`.
    pub tag: String,
}

impl FileResolution {
    fn from_density(x_per_unit: f64, y_per_unit: f64, unit_m: f64, tag: String) -> Option<FileResolution> {
        (x_per_unit > 0.0 && y_per_unit > 0.0 && x_per_unit.is_finite() && y_per_unit.is_finite())
            .then(|| FileResolution { x: unit_m / x_per_unit, y: unit_m / y_per_unit, tag })
    }
}

/// Reads one image file as grey levels in [0, 1], with the pixel size it declares.
///
/// Errors: [`ImageError::Io`] (missing, unreadable), [`ImageError::Decode`] (corrupt or
/// unsupported format), [`ImageError::NonFinite`] (NaN/inf in a float TIFF), each naming the path.
pub fn read_grey(path: &Path) -> Result<GreyImage, ImageError> {
    let bytes = std::fs::read(path).map_err(|source| ImageError::Io { path: path.to_path_buf(), source })?;
    let decode_err = |message: String| ImageError::Decode { path: path.to_path_buf(), message };
    let reader = ImageReader::new(Cursor::new(&bytes[..]))
        .with_guessed_format()
        .map_err(|source| ImageError::Io { path: path.to_path_buf(), source })?;
    let format = reader.format();
    // Grey float TIFFs, which `image` refuses (it has no grey float pixel type).
    let float_tiff = if format == Some(ImageFormat::Tiff) { grey_float_tiff(&bytes).map_err(decode_err)? } else { None };
    let (data, bit_depth, was_colour) = match float_tiff {
        Some((data, bits)) => (data, bits, false),
        None => {
            let img = reader.decode().map_err(|e| decode_err(e.to_string()))?;
            let (bit_depth, was_colour) = bit_depth_and_colour(&img);
            (grey_levels(&img, was_colour), bit_depth, was_colour)
        }
    };
    let bad = data.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        return Err(ImageError::NonFinite { path: Some(path.to_path_buf()), count: bad });
    }
    let (resolution, resolution_error) = match match format {
        Some(ImageFormat::Png) => png_resolution(&bytes),
        Some(ImageFormat::Tiff) => tiff_resolution(&bytes),
        Some(ImageFormat::Jpeg) => jfif_resolution(&bytes),
        _ => Ok(None),
    } {
        Ok(r) => (r, None),
        Err(e) => (None, Some(e)),
    };
    Ok(GreyImage { data, bit_depth, was_colour, path: path.to_path_buf(), resolution, resolution_error })
}

fn bit_depth_and_colour(img: &DynamicImage) -> (u8, bool) {
    match img {
        DynamicImage::ImageLuma8(_) | DynamicImage::ImageLumaA8(_) => (8, false),
        DynamicImage::ImageLuma16(_) | DynamicImage::ImageLumaA16(_) => (16, false),
        DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_) => (8, true),
        DynamicImage::ImageRgb16(_) | DynamicImage::ImageRgba16(_) => (16, true),
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_) => (32, true),
        _ => (32, img.color().has_color()),
    }
}

fn grey_levels(img: &DynamicImage, was_colour: bool) -> Array2<f64> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    if !was_colour {
        match img {
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
    }
}

/// A one-channel IEEE float TIFF (32 or 64 bit) decoded with the `tiff` crate; None for
/// every other TIFF (left to `image`).
fn grey_float_tiff(bytes: &[u8]) -> Result<Option<(Array2<f64>, u8)>, String> {
    use tiff::decoder::{Decoder, DecodingResult};
    use tiff::tags::{SampleFormat, Tag};
    let mut d = Decoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let bits = match d.colortype().map_err(|e| e.to_string())? {
        tiff::ColorType::Gray(b @ (32 | 64)) => b,
        _ => return Ok(None),
    };
    let float = d.find_tag_unsigned_vec::<u16>(Tag::SampleFormat).map_err(|e| e.to_string())?;
    if float.is_none_or(|v| v.first() != Some(&SampleFormat::IEEEFP.to_u16())) {
        return Ok(None);
    }
    let (w, h) = d.dimensions().map_err(|e| e.to_string())?;
    let (w, h) = (w as usize, h as usize);
    let values: Vec<f64> = match d.read_image().map_err(|e| e.to_string())? {
        DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F64(v) => v,
        _ => return Err(format!("a {bits}-bit float TIFF decoded to integers")),
    };
    if values.len() != w * h {
        return Err(format!("{} samples for {w}×{h} pixels", values.len()));
    }
    Ok(Some((Array2::from_shape_vec((h, w), values).map_err(|e| e.to_string())?, bits)))
}

/// PNG `pHYs` with unit metre.
fn png_resolution(bytes: &[u8]) -> Result<Option<FileResolution>, String> {
    let reader = png::Decoder::new(Cursor::new(bytes)).read_info().map_err(|e| e.to_string())?;
    Ok(match reader.info().pixel_dims {
        Some(png::PixelDimensions { xppu, yppu, unit: png::Unit::Meter }) => {
            FileResolution::from_density(xppu as f64, yppu as f64, 1.0, format!("PNG pHYs {xppu} × {yppu} px/m"))
        }
        _ => None,
    })
}

/// TIFF `XResolution`, `YResolution` (pixels per `ResolutionUnit`; a missing unit is an
/// inch, as the TIFF 6.0 specification says; unit 1, none, is an aspect ratio only).
fn tiff_resolution(bytes: &[u8]) -> Result<Option<FileResolution>, String> {
    use tiff::decoder::ifd::Value;
    use tiff::tags::Tag;
    let mut d = tiff::decoder::Decoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let mut number = |tag: Tag| -> Result<Option<f64>, String> {
        Ok(match d.find_tag(tag).map_err(|e| e.to_string())? {
            None => None,
            Some(Value::Rational(n, den)) => Some(n as f64 / den as f64),
            Some(Value::Unsigned(n)) => Some(n as f64),
            Some(Value::Short(n)) => Some(n as f64),
            Some(Value::Float(v)) => Some(v as f64),
            Some(Value::Double(v)) => Some(v),
            Some(other) => return Err(format!("{tag:?} has an unexpected type: {other:?}")),
        })
    };
    let (x, y) = (number(Tag::XResolution)?, number(Tag::YResolution)?);
    let unit = number(Tag::ResolutionUnit)?.unwrap_or(2.0);
    let (unit_m, name) = match unit as u32 {
        2 => (0.0254, "inch"),
        3 => (0.01, "cm"),
        _ => return Ok(None),
    };
    Ok(match (x, y) {
        (Some(x), Some(y)) => FileResolution::from_density(x, y, unit_m, format!("TIFF XResolution × YResolution {x} × {y} px/{name}")),
        (Some(x), None) => FileResolution::from_density(x, x, unit_m, format!("TIFF XResolution {x} px/{name} (no YResolution)")),
        _ => None,
    })
}

/// JPEG JFIF `APP0` density (units 1: dots per inch, 2: per centimetre; 0: aspect ratio only).
fn jfif_resolution(bytes: &[u8]) -> Result<Option<FileResolution>, String> {
    if bytes.len() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8 {
        return Err("no JPEG start-of-image marker".into());
    }
    let mut i = 2;
    // Markers up to the first start of scan; APP0 comes first in a JFIF file.
    while i + 4 <= bytes.len() {
        if bytes[i] != 0xFF {
            return Ok(None);
        }
        let marker = bytes[i + 1];
        if marker == 0xFF {
            i += 1; // fill byte
            continue;
        }
        if marker == 0xDA || marker == 0xD9 {
            return Ok(None);
        }
        let len = u16::from_be_bytes([bytes[i + 2], bytes[i + 3]]) as usize;
        let seg = bytes.get(i + 4..i + 2 + len).unwrap_or(&[]);
        if marker == 0xE0 && seg.len() >= 12 && seg.starts_with(b"JFIF\0") {
            let (units, xd, yd) = (seg[7], u16::from_be_bytes([seg[8], seg[9]]), u16::from_be_bytes([seg[10], seg[11]]));
            return Ok(match units {
                1 => FileResolution::from_density(xd as f64, yd as f64, 0.0254, format!("JPEG JFIF density {xd} × {yd} dpi")),
                2 => FileResolution::from_density(xd as f64, yd as f64, 0.01, format!("JPEG JFIF density {xd} × {yd} px/cm")),
                _ => None,
            });
        }
        i += 2 + len;
    }
    Ok(None)
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
    encode_grey_png(img, lo, hi, bits)
        .and_then(|bytes| std::fs::write(path, bytes).map_err(|e| e.to_string()))
        .map_err(|message| ImageError::Write { path: path.to_path_buf(), message })
}

/// [`write_grey_png`]'s PNG as bytes.
pub fn encode_grey_png(img: &Array2<f64>, lo: f64, hi: f64, bits: u8) -> Result<Vec<u8>, String> {
    let (h, w) = img.dim();
    let span = if hi > lo { hi - lo } else { 1.0 };
    let norm = |v: f64| if v.is_finite() { ((v - lo) / span).clamp(0.0, 1.0) } else { 0.0 };
    let mut bytes = std::io::Cursor::new(Vec::new());
    let res = match bits {
        16 => {
            let buf = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w as u32, h as u32, |x, y| {
                image::Luma([(norm(img[[y as usize, x as usize]]) * 65535.0).round() as u16])
            });
            buf.write_to(&mut bytes, image::ImageFormat::Png)
        }
        _ => {
            let buf = image::GrayImage::from_fn(w as u32, h as u32, |x, y| {
                image::Luma([(norm(img[[y as usize, x as usize]]) * 255.0).round() as u8])
            });
            buf.write_to(&mut bytes, image::ImageFormat::Png)
        }
    };
    res.map(|_| bytes.into_inner()).map_err(|e| e.to_string())
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

    /// A 20 × 30 grey ramp, 8 bit.
    fn ramp() -> Vec<u8> {
        (0..600).map(|k| (k % 251) as u8).collect()
    }

    fn png_with(path: &Path, dims: Option<png::PixelDimensions>) {
        let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
        let mut e = png::Encoder::new(f, 30, 20);
        e.set_color(png::ColorType::Grayscale);
        e.set_depth(png::BitDepth::Eight);
        e.set_pixel_dims(dims);
        e.write_header().unwrap().write_image_data(&ramp()).unwrap();
    }

    fn tiff_with<C: tiff::encoder::colortype::ColorType>(path: &Path, data: &[C::Inner], res: Option<(tiff::tags::ResolutionUnit, u32, u32)>)
    where
        [C::Inner]: tiff::encoder::TiffValue,
    {
        let mut enc = tiff::encoder::TiffEncoder::new(std::fs::File::create(path).unwrap()).unwrap();
        let mut img = enc.new_image::<C>(30, 20).unwrap();
        if let Some((unit, x, y)) = res {
            img.resolution_unit(unit);
            img.x_resolution(tiff::encoder::Rational { n: x, d: 1 });
            img.y_resolution(tiff::encoder::Rational { n: y, d: 1 });
        }
        img.write_data(data).unwrap();
    }

    fn jpeg_with(path: &Path, density: Option<image::codecs::jpeg::PixelDensity>) {
        let mut f = std::fs::File::create(path).unwrap();
        let mut e = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut f, 95);
        if let Some(d) = density {
            e.set_pixel_density(d);
        }
        e.encode(&ramp(), 30, 20, image::ExtendedColorType::L8).unwrap();
    }

    fn close(a: f64, b: f64) -> bool {
        (a / b - 1.0).abs() < 1e-12
    }

    #[test]
    fn pixel_size_is_read_from_png_tiff_and_jpeg() {
        use image::codecs::jpeg::{PixelDensity, PixelDensityUnit};
        use tiff::encoder::colortype::{Gray32Float, Gray8};
        use tiff::tags::ResolutionUnit;
        let dir = tempfile::tempdir().unwrap();
        let at = |n: &str| dir.path().join(n);
        let res = |n: &str| read_grey(&at(n)).unwrap().resolution;

        png_with(&at("phys.png"), Some(png::PixelDimensions { xppu: 11811, yppu: 11811, unit: png::Unit::Meter }));
        let r = res("phys.png").unwrap();
        assert!(close(r.x, 1.0 / 11811.0) && close(r.y, r.x) && r.tag.contains("pHYs"), "{r:?}");
        png_with(&at("aspect.png"), Some(png::PixelDimensions { xppu: 2, yppu: 1, unit: png::Unit::Unspecified }));
        assert_eq!(res("aspect.png"), None, "an aspect ratio is no size");
        png_with(&at("none.png"), None);
        assert_eq!(res("none.png"), None);

        tiff_with::<Gray8>(&at("inch.tif"), &ramp(), Some((ResolutionUnit::Inch, 300, 600)));
        let r = res("inch.tif").unwrap();
        assert!(close(r.x, 0.0254 / 300.0) && close(r.y, 0.0254 / 600.0), "{r:?}");
        tiff_with::<Gray8>(&at("cm.tif"), &ramp(), Some((ResolutionUnit::Centimeter, 100, 100)));
        assert!(close(res("cm.tif").unwrap().x, 1e-4));
        tiff_with::<Gray8>(&at("unitless.tif"), &ramp(), Some((ResolutionUnit::None, 300, 300)));
        assert_eq!(res("unitless.tif"), None);
        // A malformed resolution tag does not stop the image being read; it is reported.
        {
            let mut enc = tiff::encoder::TiffEncoder::new(std::fs::File::create(at("bad_tag.tif")).unwrap()).unwrap();
            let mut img = enc.new_image::<Gray8>(30, 20).unwrap();
            img.encoder().write_tag(tiff::tags::Tag::XResolution, "300 dpi").unwrap();
            img.write_data(&ramp()).unwrap();
        }
        let g = read_grey(&at("bad_tag.tif")).unwrap();
        assert_eq!(g.resolution, None);
        assert!(g.resolution_error.as_deref().is_some_and(|e| e.contains("XResolution")), "{:?}", g.resolution_error);
        assert_eq!(read_grey(&at("inch.tif")).unwrap().resolution_error, None);

        // Grey 32-bit float: decoded (as it is, not scaled) and its resolution read.
        let floats: Vec<f32> = (0..600).map(|k| 0.25 + k as f32 / 1000.0).collect();
        tiff_with::<Gray32Float>(&at("float.tif"), &floats, Some((ResolutionUnit::Inch, 254, 254)));
        let g = read_grey(&at("float.tif")).unwrap();
        assert_eq!((g.data.dim(), g.bit_depth, g.was_colour), ((20, 30), 32, false));
        assert_eq!(g.data[[1, 2]], floats[32] as f64);
        assert!(close(g.resolution.unwrap().x, 1e-4));
        let mut nan = floats.clone();
        nan[7] = f32::NAN;
        tiff_with::<Gray32Float>(&at("nan.tif"), &nan, None);
        assert!(matches!(read_grey(&at("nan.tif")), Err(ImageError::NonFinite { count: 1, .. })));

        jpeg_with(&at("dpi.jpg"), Some(PixelDensity { density: (200, 200), unit: PixelDensityUnit::Inches }));
        let r = res("dpi.jpg").unwrap();
        assert!(close(r.x, 0.0254 / 200.0) && r.tag.contains("JFIF"), "{r:?}");
        jpeg_with(&at("cm.jpg"), Some(PixelDensity { density: (40, 40), unit: PixelDensityUnit::Centimeters }));
        assert!(close(res("cm.jpg").unwrap().x, 0.01 / 40.0));
        jpeg_with(&at("aspect.jpg"), None);
        assert_eq!(res("aspect.jpg"), None, "the encoder's default JFIF density is an aspect ratio 1:1");
        assert_eq!(read_grey(&at("dpi.jpg")).unwrap().data.dim(), (20, 30));
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
