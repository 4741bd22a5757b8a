//! `kind: image` — the pipeline stage around the image numerics (§3.4, Table 4, Figs 11-12):
//! CV of a bonded nonwoven's grey levels, raw and after notching the bond lattice.
//!
//! Three sources, exactly one per stage:
//! * **files**: `files:` lists paths or globs (relative to the pipeline file), read as
//!   grey levels (PNG/TIFF/JPEG, 8/16 bit, RGB → BT.601 luma). `groups:` (optional, same
//!   length) labels each entry with its condition, e.g. one glob of 8 scans per belt speed;
//!   without it every entry is its own group, labelled by [`default_groups`] (the file
//!   stem, or a whole-directory glob's directory). Pixel size per image: `pixel_size` (m) or
//!   `dpi` if given (they override the file), else what the file declares (PNG pHYs, TIFF
//!   resolution tags, JPEG JFIF density; [`super::io`]), else 297/871 mm (A4 at 871 px, the
//!   paper's scans) with a warning naming the files. Each sample's size and its source
//!   (`pixel_size_source`: file, dpi, pixel_size, default, grid) are stored.
//! * **a grid stage** (`input:`): its `density` (point, realisation, md, cd) in g/m² with
//!   scalar `cell_size` (m) is rendered per (point, realisation) as a transmission image
//!   (`render.*`: Beer–Lambert, rows = MD, columns = CD) with the bond lattice `bonds.*`
//!   overlaid; the group is the grid point (labelled by the grid's swept parameters).
//!   `cv_web` is then the CV of the same rendering without bonds: the truth the filter
//!   should recover.
//! * **synthetic test images** (`synthetic.kind: constant | noise`, `synthetic.*`): constant
//!   grey or smoothed noise of a known CV, `synthetic.count` images of
//!   `synthetic.rows` × `synthetic.cols` px (default 617 × 871, the paper's scans), with
//!   `bonds.*` overlaid; `cv_web` is the CV without bonds. For calibration (sweep
//!   `false_alarm_rate` on noise and count the peaks) and the hard cases
//!   (pipelines/stability/images.yaml).
//!
//! Results: the datasets of schemas/archive_layout.md; a Table-4-like summary rounded to
//! 0.01 % on stderr, and `laydown run` prints the full-precision per-condition table
//! (`laydown table`, [`crate::table`]) on stdout.
//!
//! **Sweeps** of the analysis, `render.*`, `bonds.*` or `synthetic.mean/cv/correlation`
//! run every point on the same samples; each result gains a leading `point` dimension
//! (schemas/archive_layout.md).
//!
//! Bad input (exit 2, nothing written): missing/unreadable/corrupt files, empty globs,
//! images under 16 px, an image with a non-positive mean (black), NaN density.
//! Documented results: a constant grey image gives CV 0 and no notches (warning on
//! stderr); a lattice whose period exceeds the image is not detected and the image is
//! returned unchanged (`notches` = 0, `cv_corr` = `cv_raw`).
//!
//! **Memory** ([`Stage::estimate_memory`]): each thread reads or renders and analyses
//! one image at a time (`ANALYSIS_BYTES_PER_PIXEL`); the first `max_stored_images`
//! images of every point are kept until written (`STORED_BYTES_PER_PIXEL`); a grid
//! input's density maps are read whole. Image files count with the size in their
//! header (one that cannot be read there counts nothing; reading it is checked later).
use crate::error::InvalidParam;
use super::render::{render, render_with_coverage, BondPattern, BondShape, RenderParams};
use super::{analyze, read_grey, GroupStats, ImageAnalysis, ImageParams, MeanStd, PixelSource, PARAMETERS};
use crate::archive::data::{Attr, Output, Values};
use crate::memory::Estimate;
use crate::params::{ParamSet, ParamSpec};
use crate::stages::{concurrent, BadInput, Declared, Input, InputRule, RunContext, Stage};
use anyhow::{anyhow, Result};
use ndarray::{s, Array1, Array2, Array3, Axis};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub struct ImageStage;

crate::params::choice_enum! {
    /// The bond shape of the lattice overlaid on rendered images (`bonds.shape`).
    pub enum BondShapeKind {
        #[default]
        None = "none",
        Circle = "circle",
        Ellipse = "ellipse",
        Rectangle = "rectangle",
    }
}

crate::params::choice_enum! {
    /// Synthetic test images instead of files or a grid (`synthetic.kind`).
    pub enum SyntheticKind {
        #[default]
        None = "none",
        /// Constant grey.
        Constant = "constant",
        /// Uniform white noise smoothed by a Gaussian.
        Noise = "noise",
    }
}

/// An image point's parameters ([`ParamSet::to_typed`] of the stage's table): the
/// source (`files`, `synthetic.*` or a grid input rendered by `render.*` with `bonds.*`
/// overlaid), the analysis ([`ImageParams`]) and what is stored.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImageStageParams {
    pub files: Vec<String>,
    pub groups: Vec<String>,
    pub synthetic: SyntheticParams,
    #[serde(flatten)]
    pub analysis: ImageParams,
    pub max_stored_images: usize,
    pub panels: bool,
    pub render: RenderRows,
    pub bonds: BondRows,
}

/// `synthetic.*`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SyntheticParams {
    pub kind: SyntheticKind,
    pub count: usize,
    pub rows: usize,
    pub cols: usize,
    pub mean: f64,
    pub cv: f64,
    pub correlation: f64,
}

/// `render.*`: how a grid's density maps become grey images.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderRows {
    pub attenuation: f64,
    pub white: f64,
    pub black: f64,
    pub bits: u8,
}

/// `bonds.*`: the bond lattice overlaid on rendered images.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BondRows {
    pub shape: BondShapeKind,
    pub period1: f64,
    pub period2: f64,
    pub angle: f64,
    pub angle_between: f64,
    pub size1: f64,
    pub size2: f64,
    pub shape_angle: f64,
    pub offset_cd: f64,
    pub offset_md: f64,
    pub contrast: f64,
    pub zero_mean: bool,
    pub supersample: usize,
}

impl ImageStageParams {
    /// A point's typed parameters (its rows were checked against the table).
    pub fn of(p: &ParamSet) -> Self {
        p.to_typed().expect("the image table and ImageStageParams agree (tested)")
    }
}
/// Bytes per pixel of one image being analysed: the image and its copy, its spectra
/// (complex, with the periodic decomposition), power, background fit, notch mask,
/// filtered image and FFT scratch: the peak resident memory of a 3000 × 3000 synthetic
/// noise image was 97 B per pixel (one or two at once), rounded up.
const ANALYSIS_BYTES_PER_PIXEL: f64 = 128.0;
/// Bytes per pixel of a stored image: raw, filtered and two log spectra, kept and
/// placed in the output (8 B each).
const STORED_BYTES_PER_PIXEL: f64 = 64.0;
/// Spectrum range of the PNG panels (decades below the largest non-DC value).
const PANEL_DECADES: f64 = 6.0;

/// One image to analyse, with where it came from. Images are read or rendered only
/// when analysed, so a batch never holds more than a few images at a time.
struct Sample {
    group: String,
    file: String,
    source: Source,
    /// Pixel size (m) and its source; for files, decided when the file is read.
    pixel: f64,
    pixel_source: PixelSource,
    grid_point: i64,
    realisation: i64,
}

enum Source {
    File(PathBuf),
    /// A synthetic test image (`synthetic.*`) drawn from this seed.
    Synthetic(u64),
    /// (point, realisation) of the grid input.
    Grid(usize, usize),
}

/// The grid input, read once, and how its maps become images.
struct GridData {
    from: String,
    density: ndarray::ArrayD<f64>,
    cell: f64,
}

impl GridData {
    /// The bonded rendering of one map and the CV of the bond-free one (the truth).
    ///
    /// `coverage`: the lattice's bond coverage of a map (all maps of a grid have one size).
    fn render(&self, pt: usize, r: usize, bonded: &RenderParams, plain: &RenderParams, coverage: Option<&Array2<f64>>) -> Result<(Array2<f64>, f64)> {
        let map: Array2<f64> =
            self.density.index_axis(Axis(0), pt).index_axis(Axis(0), r).to_owned().into_dimensionality().map_err(|e| anyhow!("{e}"))?;
        let bad = |e: super::ImageError| anyhow::Error::new(BadInput(format!("grid {} point {pt} realisation {r}: {e}", self.from)));
        let image = render_with_coverage(&map, self.cell, bonded, coverage).map_err(bad)?.grey;
        let web = render(&map, self.cell, plain).map_err(bad)?.grey;
        Ok((image, crate::uniformity::coefficient_of_variation(web.iter().copied())))
    }
}

/// What is kept of one analysis (images only for the first `max_stored_images`).
struct Kept {
    a: ImageAnalysis,
    store: bool,
    rows: usize,
    cols: usize,
    /// Grid source: CV of the bond-free rendering; NaN for files.
    cv_web: f64,
    /// Wall time of reading or rendering and analysing the image.
    wall_seconds: f64,
    /// Pixel size used (m) and where it came from.
    pixel: f64,
    pixel_source: PixelSource,
    /// Pixel size the file declares (m; NaN: none, or not a file).
    file_pixel: f64,
}

impl Stage for ImageStage {
    fn kind(&self) -> &'static str {
        "image"
    }
    fn summary(&self) -> &'static str {
        "CV of a bonded nonwoven image, raw and after FFT notch removal of the bond lattice (§3.4, Table 4, Figs 11-12)"
    }
    fn cache_version(&self) -> u32 {
        // 2: pixel size from the image file (pixel_size_source, file_pixel_size); zone
        // curves on the sides used; default group labels are file stems; cv_corr is the
        // compensated CV (cv_corr_plain the paper's).
        2
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["grid"], min: 0, max: 1 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v = vec![
            ParamSpec::text_list("files", "image files or glob patterns (PNG, TIFF, JPEG; 8/16 bit; grey or RGB), relative to the pipeline file; empty with a grid input"),
            ParamSpec::choice("synthetic.kind", SyntheticKind::NAMES, "none", "synthetic test images instead of files or a grid: constant grey, or noise (uniform white noise smoothed by a Gaussian of synthetic.correlation pixels, scaled to synthetic.mean and synthetic.cv); bonds.* may be overlaid; for calibration (false alarms on noise) and hard cases"),
            ParamSpec::int("synthetic.count", "1", 8, 1, 10_000, "synthetic images (one condition; each its own random stream of the stage's seed)"),
            ParamSpec::int("synthetic.rows", "1", 617, 16, 20_000, "synthetic image height (pixels); default 617, the paper's A4 scans at 871 px wide"),
            ParamSpec::int("synthetic.cols", "1", 871, 16, 20_000, "synthetic image width (pixels)"),
            ParamSpec::float("synthetic.mean", "1", 0.5, 0.0, 1.0, "mean grey level of a synthetic image (full scale 1)"),
            ParamSpec::float("synthetic.cv", "1", 0.2, 0.0, 10.0, "CV of the noise before clipping to [0, 1]"),
            ParamSpec::float("synthetic.correlation", "1", 1.0, 0.0, 100.0, "standard deviation (pixels) of the Gaussian that smooths the noise; 0 = white"),
            ParamSpec::text_list("groups", "condition label of each `files` entry (same length; quote numbers); empty: each entry is its own group, labelled by its file stem (a glob of a whole directory, v020/*.png: the directory)"),
        ];
        // The analysis parameters: the library's rows as they are (names, SI units).
        v.extend_from_slice(PARAMETERS);
        v.extend([
            ParamSpec::int("max_stored_images", "1", 4, 0, 10_000, "images (raw, filtered, log spectra) stored in the archive and drawn as PNG panels: the first N samples"),
            ParamSpec::flag("panels", true, "write Fig-12-like PNG panels (raw, filtered, spectrum, notched spectrum) to <archive stem>_figures/<stage>/v<N>/"),
            ParamSpec::float("render.attenuation", "m2 g-1", 0.02, 0.0, 10.0, "grid input: mass attenuation k of the transmission T = exp(−k ρ)"),
            ParamSpec::float("render.white", "1", 1.0, 0.0, 1.0, "grid input: grey level of an empty pixel"),
            ParamSpec::float("render.black", "1", 0.0, 0.0, 1.0, "grid input: grey level of an opaque pixel"),
            ParamSpec::int("render.bits", "1", 0, 0, 16, "grid input: quantisation bits (0 = none)"),
            ParamSpec::choice("bonds.shape", BondShapeKind::NAMES, "none", "grid input: bond shape of the overlaid lattice; none = no bonds"),
            ParamSpec::float("bonds.period1", "m", 4e-3, 1e-6, 1.0, "|a1|, first bond repeat distance"),
            ParamSpec::float("bonds.period2", "m", 4e-3, 1e-6, 1.0, "|a2|, second bond repeat distance"),
            ParamSpec::float("bonds.angle", "degree", 0.0, -360.0, 360.0, "direction of a1 from +CD (image columns) towards +MD (rows)"),
            ParamSpec::float("bonds.angle_between", "degree", 90.0, 1.0, 179.0, "angle from a1 to a2 (90 rectangular, 60 staggered)"),
            ParamSpec::float("bonds.size1", "m", 1e-3, 1e-6, 1.0, "bond diameter (circle), major axis (ellipse) or width (rectangle)"),
            ParamSpec::float("bonds.size2", "m", 0.5e-3, 1e-6, 1.0, "minor axis (ellipse) or height (rectangle)"),
            ParamSpec::float("bonds.shape_angle", "degree", 0.0, -360.0, 360.0, "orientation of an ellipse or rectangle"),
            ParamSpec::float("bonds.offset_cd", "m", 0.0, -1.0, 1.0, "CD position of one bond centre from the image corner"),
            ParamSpec::float("bonds.offset_md", "m", 0.0, -1.0, 1.0, "MD position of one bond centre from the image corner"),
            ParamSpec::float("bonds.contrast", "1", 0.2, -1.0, 1.0, "grey-level change inside a bond (fraction of full scale; > 0 brighter)"),
            ParamSpec::flag("bonds.zero_mean", true, "subtract the pattern's mean so it adds no mean grey level (a one-sided pattern biases CV_corr low)"),
            ParamSpec::int("bonds.supersample", "1", 4, 1, 16, "point samples per pixel side for the bond area fraction"),
        ]);
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), InvalidParam> {
        let p = &ImageStageParams::of(p);
        if p.analysis.pixel_size.is_some() && p.analysis.dpi.is_some() {
            return Err(InvalidParam::new("dpi".into(), "give pixel_size or dpi, not both".into()));
        }
        let (files, groups) = (&p.files, &p.groups);
        if !groups.is_empty() && groups.len() != files.len() {
            return Err(InvalidParam::new(
                "groups".into(),
                format!("{} group labels for {} `files` entries; allowed: one label per entry, or none", groups.len(), files.len()),
            ));
        }
        if !files.is_empty() && p.synthetic.kind != SyntheticKind::None {
            return Err(InvalidParam::new("synthetic.kind".into(), "give `files` or a synthetic source, not both; allowed with `files`: none".into()));
        }
        if !files.is_empty() && p.bonds.shape != BondShapeKind::None {
            return Err(InvalidParam::new(
                "bonds.shape".into(),
                "bonds.* overlay the images rendered from a grid input; image files are analysed as they are; allowed with `files`: none".into(),
            ));
        }
        if p.analysis.zone_max < p.analysis.zone_min {
            return Err(InvalidParam::new("zone_max".into(), format!("zone_max is below zone_min = {}", p.analysis.zone_min)));
        }
        Ok(())
    }
    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let p = &ImageStageParams::of(&stage.points[0]);
        // (images, largest pixels per image, bytes of the input read whole, the drivers)
        let own = |names: &[&str]| names.iter().map(|n| (stage.name.clone(), n.to_string())).collect::<Vec<_>>();
        let (count, pixels, read, mut params) = match stage.inputs.first() {
            Some(grid) => {
                let g = crate::stages::grid::grid_params(&grid.points[0]);
                let cells = (g.window_side / g.cell_size).round();
                let web_points = grid.inputs.first().map(|w| w.points.len()).unwrap_or(1);
                let maps = (web_points.max(grid.points.len()) * grid.replicates) as f64;
                let params = vec![(grid.name.clone(), "window_side".to_string())];
                (maps, cells * cells, maps * cells * cells * 8.0, params)
            }
            None if p.synthetic.kind != SyntheticKind::None => {
                let px = (p.synthetic.rows * p.synthetic.cols) as f64;
                (p.synthetic.count as f64, px, 0.0, own(&["synthetic.rows", "synthetic.cols"]))
            }
            None => {
                let files = expand(p, &stage.pipeline_dir).unwrap_or_default();
                let px = files.iter().filter_map(|(f, _)| image::image_dimensions(f).ok()).map(|(w, h)| w as f64 * h as f64).fold(0.0, f64::max);
                (files.len() as f64, px, 0.0, own(&["files"]))
            }
        };
        let stored = count.min(p.max_stored_images as f64) * stage.points.len() as f64;
        let analysis = concurrent(count) * pixels * ANALYSIS_BYTES_PER_PIXEL;
        let kept = stored * pixels * STORED_BYTES_PER_PIXEL;
        if kept > analysis {
            params.insert(0, (stage.name.clone(), "max_stored_images".into()));
        }
        let what = format!(
            "{} images of up to {pixels} pixels analysed at once, {ANALYSIS_BYTES_PER_PIXEL} B per pixel, and {stored} stored, {STORED_BYTES_PER_PIXEL} B per pixel",
            concurrent(count)
        );
        Some(Estimate { bytes: analysis + kept + read, what, params, inverse: vec![] })
    }
    fn input_files(&self, p: &ParamSet, dir: &Path) -> Result<Vec<PathBuf>> {
        Ok(expand(&ImageStageParams::of(p), dir)?.into_iter().map(|(f, _)| f).collect())
    }

    fn check_files(&self, p: &ParamSet, dir: &Path) -> std::result::Result<(), InvalidParam> {
        const ALLOWED: &str = "allowed: existing image files or globs matching at least one, relative to the pipeline file";
        for (i, f) in ImageStageParams::of(p).files.iter().enumerate() {
            let path = if Path::new(f).is_absolute() { PathBuf::from(f) } else { dir.join(f) };
            let spec = super::InputSpec { pattern: path.display().to_string(), group: String::new() };
            let msg = match super::expand_inputs(&[spec]) {
                Ok(_) => continue,
                Err(super::ImageError::NoFiles { .. }) => format!("`{f}` matches no file (looked for {}); {ALLOWED}", path.display()),
                Err(super::ImageError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
                    format!("`{f}` does not exist (looked for {}); {ALLOWED}", path.display())
                }
                Err(e) => format!("`{f}`: {e}; {ALLOWED}"),
            };
            return Err(InvalidParam::new(format!("files[{i}]"), msg));
        }
        Ok(())
    }

    fn run(&self, ctx: &RunContext) -> Result<Output> {
        if ctx.replicates != 1 {
            return Err(BadInput(format!("an image stage is deterministic; replicates must be 1, not {}", ctx.replicates)).into());
        }
        if let Some((name, _)) = ctx.sweep.iter().find(|(n, _)| NOT_SWEPT.contains(&n.as_str())) {
            return Err(BadInput(format!(
                "`{name}` cannot be swept in an image stage: it decides which images are read or how results are laid out; sweep the analysis (e.g. notch_sigma_bins, false_alarm_rate), render.* or bonds.*, or sweep the grid stage it reads"
            ))
            .into());
        }
        let points: Vec<ImageStageParams> = ctx.points.iter().map(ImageStageParams::of).collect();
        for p in &points {
            p.analysis.validate().map_err(|e| BadInput(e.to_string()))?;
        }
        let p = &points[0];
        let (samples, grid_sweep, grid) = match ctx.inputs.first() {
            Some(input) => {
                if !p.files.is_empty() {
                    return Err(BadInput("give `files` or a grid `input`, not both".into()).into());
                }
                if p.analysis.pixel_size.is_some() || p.analysis.dpi.is_some() {
                    return Err(BadInput("with a grid input the pixel size is the grid's cell_size; remove pixel_size/dpi".into()).into());
                }
                if p.synthetic.kind != SyntheticKind::None {
                    return Err(BadInput("give a grid `input` or a synthetic source (synthetic.kind), not both".into()).into());
                }
                grid_samples(input)?
            }
            None if p.synthetic.kind != SyntheticKind::None => (synthetic_samples(ctx, p), vec![], None),
            None => {
                if p.files.is_empty() {
                    return Err(BadInput("an image stage needs `files` (paths or globs), an `input` grid stage or a synthetic source (synthetic.kind)".into()).into());
                }
                if points.iter().any(|p| p.bonds.shape != BondShapeKind::None) {
                    return Err(BadInput("bonds.* overlay rendered grid images; image files are analysed as they are (set bonds.shape: none)".into()).into());
                }
                (file_samples(ctx, p)?, vec![], None)
            }
        };
        let max_store = p.max_stored_images;
        // Sweep points one after another, the samples of a point in parallel.
        let mut per_point = Vec::with_capacity(ctx.points.len());
        for (k, p) in points.iter().enumerate() {
            let point = if ctx.sweep.is_empty() { String::new() } else { format!("point {}: ", k) };
            let kept = analyse_point(&samples, grid.as_ref(), p, max_store)?;
            for (smp, k) in samples.iter().zip(&kept) {
                for w in &k.a.warnings {
                    let what = if smp.file.is_empty() { format!("group {}", smp.group) } else { smp.file.clone() };
                    eprintln!("{}: warning: {point}{what}: {w}", ctx.stage_name);
                }
            }
            if k == 0 {
                report_pixel_sizes(&ctx.stage_name, &samples, &kept);
            }
            let groups = group_stats(&samples, &kept);
            let label = if ctx.sweep.is_empty() { ctx.stage_name.clone() } else { format!("{} point {}", ctx.stage_name, k) };
            crate::info!("{}", table(&label, &groups, &kept).trim_end());
            per_point.push(kept);
        }
        // One peak-table width for all points, so that the points stack.
        let peaks = per_point.iter().flatten().map(|k| k.a.peaks.len()).max().unwrap_or(0);
        let parts: Vec<Output> = per_point
            .iter()
            .zip(&points)
            .map(|(kept, p)| assemble(&samples, kept, p, &grid_sweep, peaks))
            .collect();
        let mut out = stack_points(parts, !ctx.sweep.is_empty())?;
        if p.panels && per_point.iter().flatten().any(|k| k.store) {
            for (k, kept) in per_point.iter().enumerate() {
                let prefix = if ctx.sweep.is_empty() { String::new() } else { format!("point{:03}_", k) };
                for (i, (smp, kp)) in samples.iter().zip(kept).enumerate().filter(|(_, (_, kp))| kp.store) {
                    let png = super::panel::panel_png(&kp.a, PANEL_DECADES).map_err(|e| anyhow!("panel of {}: {e}", smp.file))?;
                    out.file(format!("{prefix}sample{i:03}_{}.png", sanitise(&smp.group)), png);
                }
            }
            out.set_attr("figure_dir", ctx.figure_dir.display().to_string());
        }
        Ok(out)
    }
}

/// Parameters that decide which images are read or how the results are laid out; the
/// same at every point of a sweep, so that the points' datasets stack.
const NOT_SWEPT: &[&str] = &[
    "files",
    "groups",
    "pixel_size",
    "dpi",
    "zone_min",
    "zone_max",
    "zones_per_octave",
    "max_stored_images",
    "panels",
    "synthetic.kind",
    "synthetic.count",
    "synthetic.rows",
    "synthetic.cols",
];

/// Variables that describe the samples and conditions, not their analysis: the same at
/// every sweep point, stored once.
const SAMPLE_DESCRIPTORS: &[&str] =
    &["sample", "grid_point", "realisation", "pixel_size", "file_pixel_size", "rows", "cols", "condition_samples", "stored_sample", "zone_size", "zone_cells"];

/// Says on stderr which pixel sizes the files were analysed at and where they came from;
/// a warning names the files that declare none when no parameter gives one.
fn report_pixel_sizes(stage: &str, samples: &[Sample], kept: &[Kept]) {
    if !samples.iter().any(|s| matches!(s.source, Source::File(_))) {
        return;
    }
    // Per source, the distinct sizes (to the µm/1000 shown) and how many images have each.
    let mut seen: Vec<(PixelSource, Vec<(String, usize)>)> = Vec::new();
    for k in kept {
        let size = format!("{:.6}", k.pixel * 1e3);
        let sizes = match seen.iter_mut().find(|(s, _)| *s == k.pixel_source) {
            Some((_, v)) => v,
            None => {
                seen.push((k.pixel_source, Vec::new()));
                &mut seen.last_mut().expect("just pushed").1
            }
        };
        match sizes.iter_mut().find(|(s, _)| *s == size) {
            Some(e) => e.1 += 1,
            None => sizes.push((size, 1)),
        }
    }
    for (source, sizes) in &seen {
        let from = match source {
            PixelSource::File => "declared by the file",
            PixelSource::Dpi => "from dpi",
            PixelSource::PixelSize => "from pixel_size",
            PixelSource::Default => "assumed",
            PixelSource::Grid => "the grid's cell_size",
        };
        let list: Vec<String> = sizes.iter().map(|(s, n)| format!("{s} mm ({n} image{})", if *n == 1 { "" } else { "s" })).collect();
        crate::info!("{stage}: pixel size {from}: {}", list.join(", "));
    }
    // 72 and 96 dpi are what many programs write when they know no resolution (within
    // 0.1 %: PNG stores whole pixels per metre, 2835 for 72 dpi).
    let placeholder: Vec<&str> = samples
        .iter()
        .zip(kept)
        .filter(|(_, k)| k.pixel_source == PixelSource::File && [72.0, 96.0].iter().any(|d| (0.0254 / k.pixel / d - 1.0).abs() < 1e-3))
        .map(|(s, _)| s.file.as_str())
        .collect();
    if !placeholder.is_empty() {
        let shown = placeholder.iter().take(5).copied().collect::<Vec<_>>().join(", ");
        let more = if placeholder.len() > 5 { format!(" and {} more", placeholder.len() - 5) } else { String::new() };
        eprintln!("{stage}: warning: {shown}{more}: the file declares 72 or 96 dpi, what many programs write when they know no resolution; if the scan's resolution differs, give dpi");
    }
    let missing: Vec<&str> = samples.iter().zip(kept).filter(|(_, k)| k.pixel_source == PixelSource::Default).map(|(s, _)| s.file.as_str()).collect();
    if !missing.is_empty() {
        let shown = missing.iter().take(5).copied().collect::<Vec<_>>().join(", ");
        let more = if missing.len() > 5 { format!(" and {} more", missing.len() - 5) } else { String::new() };
        eprintln!(
            "{stage}: warning: {shown}{more}: no pixel size in the file (PNG pHYs, TIFF resolution tags, JPEG JFIF density) and neither pixel_size nor dpi given; assuming {:.4} mm per pixel (A4 at 871 px, the paper's scans)",
            super::DEFAULT_PIXEL_SIZE * 1e3
        );
    }
}

/// Analyses every sample with the parameters of one sweep point, in parallel; only the
/// first `max_store` keep their images.
fn analyse_point(samples: &[Sample], grid: Option<&GridData>, p: &ImageStageParams, max_store: usize) -> Result<Vec<Kept>> {
    let ip = p.analysis.clone();
    let (bonded, plain) = render_params(p);
    // The bond coverage of the map size, once for all maps (grid maps, synthetic images).
    let size = match (grid, samples.first().map(|s| &s.source)) {
        (Some(g), _) => Some((g.density.shape()[2], g.density.shape()[3], g.cell)),
        (None, Some(Source::Synthetic(_))) => Some((p.synthetic.rows, p.synthetic.cols, samples[0].pixel)),
        _ => None,
    };
    let coverage = size.and_then(|(rows, cols, pixel)| bonded.bonds.as_ref().map(|b| b.coverage(rows, cols, pixel)));
    samples
        .par_iter()
        .enumerate()
        .map(|(i, smp)| {
            let started = std::time::Instant::now();
            let (mut pixel, mut pixel_source, mut file_pixel) = (smp.pixel, smp.pixel_source, f64::NAN);
            let (image, cv_web) = match (&smp.source, grid) {
                (Source::File(path), _) => {
                    let img = read_grey(path).map_err(|e| BadInput(e.to_string()))?;
                    (pixel, pixel_source) = ip.pixel_size_for(&img).map_err(|e| BadInput(e.to_string()))?;
                    file_pixel = img.resolution.as_ref().map(|r| r.x).unwrap_or(f64::NAN);
                    (img.data, f64::NAN)
                }
                (Source::Grid(pt, r), Some(g)) => g.render(*pt, *r, &bonded, &plain, coverage.as_ref())?,
                (Source::Grid(..), None) => unreachable!("grid samples come with the grid"),
                (Source::Synthetic(seed), _) => synthetic_image(p, *seed, smp.pixel, &bonded, &plain, coverage.as_ref())?,
            };
            let (rows, cols) = image.dim();
            let a = analyze(&image, pixel, &ip).map_err(|e| {
                let what = if smp.file.is_empty() { format!("group {} sample {i}", smp.group) } else { smp.file.clone() };
                anyhow::Error::new(BadInput(format!("{what}: {e}")))
            })?;
            drop(image);
            let store = i < max_store;
            let a = if store { a } else { strip(a) };
            Ok(Kept { a, store, rows, cols, cv_web, wall_seconds: started.elapsed().as_secs_f64(), pixel, pixel_source, file_pixel })
        })
        .collect()
}

/// The output of a sweep from the outputs of its points: every analysis result gains a
/// leading `point` dimension; coordinates, text and the [`SAMPLE_DESCRIPTORS`] are
/// stored once (they must agree between points). Without a sweep, the one point's output.
fn stack_points(mut parts: Vec<Output>, swept: bool) -> Result<Output> {
    if !swept {
        return parts.pop().ok_or_else(|| anyhow!("an image stage ran no point"));
    }
    for part in &mut parts {
        for v in &mut part.variables {
            let shared = SAMPLE_DESCRIPTORS.contains(&v.name.as_str())
                || v.attrs.contains_key("grid_parameter")
                || v.dims.len() == 1 && v.dims[0] == v.name
                || matches!(v.values, Values::Str(_));
            if shared {
                continue;
            }
            v.dims.insert(0, "point".into());
            v.values = match std::mem::replace(&mut v.values, Values::U8(ndarray::ArrayD::zeros(ndarray::IxDyn(&[0])))) {
                Values::F64(a) => Values::F64(a.insert_axis(Axis(0))),
                Values::I64(a) => Values::I64(a.insert_axis(Axis(0))),
                Values::U8(a) => Values::U8(a.insert_axis(Axis(0))),
                Values::Str(_) => unreachable!("text is shared"),
            };
        }
    }
    crate::archive::gather::gather(&parts, &["point"])
}

/// Drops the large arrays of an analysis that is not stored.
fn strip(mut a: ImageAnalysis) -> ImageAnalysis {
    let e = Array2::zeros((0, 0));
    a.raw = e.clone();
    a.filtered = e.clone();
    a.log_spectrum_raw = e.clone();
    a.log_spectrum_notched = e;
    a
}

fn sanitise(s: &str) -> String {
    let t: String = s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' }).collect();
    t.chars().take(40).collect()
}

/// The bond lattice of the `bonds.*` parameters (None for `bonds.shape: none`).
pub fn bond_pattern(b: &BondRows) -> Option<BondPattern> {
    let (a, c, t) = (b.size1, b.size2, b.shape_angle);
    let shape = match b.shape {
        BondShapeKind::Circle => BondShape::Circle { diameter: a },
        BondShapeKind::Ellipse => BondShape::Ellipse { major: a, minor: c, angle_deg: t },
        BondShapeKind::Rectangle => BondShape::Rectangle { width: a, height: c, angle_deg: t },
        BondShapeKind::None => return None,
    };
    Some(BondPattern {
        period1: b.period1,
        period2: b.period2,
        angle_deg: b.angle,
        angle_between_deg: b.angle_between,
        offset: [b.offset_cd, b.offset_md],
        shape,
        contrast: b.contrast,
        zero_mean: b.zero_mean,
        supersample: b.supersample,
    })
}

/// The group label of each `files` entry when `groups` is not given: its file stem
/// (`scans/a01.png` → `a01`, `scans/w*.png` → `w*`), or for a glob naming every file of
/// a directory (`v020/*.png`, `v020/*`) that directory (`v020`). Entries whose labels
/// would coincide keep the whole entry, so that distinct entries stay distinct groups.
pub fn default_groups(files: &[String]) -> Vec<String> {
    let label = |f: &String| -> String {
        let path = Path::new(f);
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let only_glob = !stem.is_empty() && stem.chars().all(|c| matches!(c, '*' | '?'));
        if only_glob {
            let parent = path.parent().and_then(|p| p.file_name()).map(|s| s.to_string_lossy().into_owned());
            return parent.filter(|p| !p.contains(['*', '?', '['])).unwrap_or_else(|| f.clone());
        }
        if stem.is_empty() {
            f.clone()
        } else {
            stem
        }
    };
    let labels: Vec<String> = files.iter().map(label).collect();
    labels
        .iter()
        .zip(files)
        .map(|(l, f)| if files.iter().zip(&labels).any(|(g, m)| m == l && g != f) { f.clone() } else { l.clone() })
        .collect()
}

/// (file, group) of every `files` entry, globs expanded (sorted within a pattern),
/// relative paths taken from `dir`. Missing files and empty globs are bad input.
fn expand(p: &ImageStageParams, dir: &Path) -> Result<Vec<(PathBuf, String)>> {
    let (files, groups) = (&p.files, &p.groups);
    let groups = if groups.is_empty() { default_groups(files) } else { groups.to_vec() };
    let specs: Vec<super::InputSpec> = files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let path = if Path::new(f).is_absolute() { PathBuf::from(f) } else { dir.join(f) };
            super::InputSpec { pattern: path.display().to_string(), group: groups[i].clone() }
        })
        .collect();
    super::expand_inputs(&specs).map_err(|e| BadInput(e.to_string()).into())
}

fn file_samples(ctx: &RunContext, p: &ImageStageParams) -> Result<Vec<Sample>> {
    let files = expand(p, &ctx.pipeline_dir)?;
    let ip = p.analysis.clone();
    Ok(files
        .into_iter()
        .map(|(path, group)| Sample {
            group,
            // Relative to the pipeline file: results do not depend on the working directory.
            file: path.strip_prefix(&ctx.pipeline_dir).unwrap_or(&path).display().to_string(),
            source: Source::File(path),
            // Replaced by the file's own size unless a parameter gives one.
            pixel: ip.pixel_size_or_default(),
            pixel_source: ip.pixel_source(),
            grid_point: -1,
            realisation: -1,
        })
        .collect())
}

/// One image per `synthetic.count`, each with its own random stream of the stage seed.
fn synthetic_samples(ctx: &RunContext, p: &ImageStageParams) -> Vec<Sample> {
    let kind = p.synthetic.kind.name();
    let ip = p.analysis.clone();
    let pixel = ip.pixel_size_or_default();
    (0..p.synthetic.count)
        .map(|k| Sample {
            group: kind.to_string(),
            file: String::new(),
            source: Source::Synthetic(rand::RngCore::next_u64(&mut ctx.rng(k, 0))),
            pixel,
            pixel_source: ip.pixel_source(),
            grid_point: -1,
            realisation: k as i64,
        })
        .collect()
}

/// A synthetic test image with the bond lattice overlaid, and the CV of the same image
/// without bonds (the truth, after clipping to [0, 1]).
fn synthetic_image(p: &ImageStageParams, seed: u64, pixel: f64, bonded: &RenderParams, plain: &RenderParams, coverage: Option<&Array2<f64>>) -> Result<(Array2<f64>, f64)> {
    let (rows, cols, mean) = (p.synthetic.rows, p.synthetic.cols, p.synthetic.mean);
    let grey = match p.synthetic.kind {
        SyntheticKind::Constant => crate::memory::try_array((rows, cols), mean, "a synthetic image")?,
        _ => super::render::try_smoothed_noise(rows, cols, p.synthetic.correlation, mean, p.synthetic.cv, seed)?,
    };
    let bad = |e: super::ImageError| anyhow::Error::new(BadInput(format!("synthetic image: {e}")));
    let web = super::render::overlay(grey.clone(), pixel, plain, None).map_err(bad)?.grey;
    let image = super::render::overlay(grey, pixel, bonded, coverage).map_err(bad)?.grey;
    Ok((image, crate::uniformity::coefficient_of_variation(web.iter().copied())))
}

/// How grid maps become images: (with the bond lattice, without it).
fn render_params(p: &ImageStageParams) -> (RenderParams, RenderParams) {
    let bonded = RenderParams {
        attenuation: p.render.attenuation,
        white: p.render.white,
        black: p.render.black,
        bits: p.render.bits,
        bonds: bond_pattern(&p.bonds),
    };
    let plain = RenderParams { bonds: None, ..bonded.clone() };
    (bonded, plain)
}

/// A grid point's swept parameters, read from the grid version (1-D variables along
/// `point` with a `parameter` attribute): (name, unit, values).
type GridSweep = Vec<(String, String, Vec<f64>)>;

fn grid_sweep(input: &Input, npoints: usize) -> Result<GridSweep> {
    let g = input.version.open()?;
    Ok(crate::archive::hdf::swept_coordinates(&g)
        .into_iter()
        .filter(|s| s.values.len() == npoints && s.values.iter().all(|v| v.is_finite()))
        .map(|s| (s.name, s.units, s.values))
        .collect())
}

fn grid_samples(input: &Input) -> Result<(Vec<Sample>, GridSweep, Option<GridData>)> {
    let from = input.version.group_path();
    let need = |name: &str| {
        if input.has(name) {
            Ok(())
        } else {
            Err(anyhow::Error::new(BadInput(format!("grid {from} has no `{name}`; an image stage reads `density` (point, realisation, md, cd) and `cell_size`"))))
        }
    };
    need("density")?;
    need("cell_size")?;
    let density = input.read_f64("density")?;
    let cell = input.read_f64("cell_size")?.iter().next().copied().unwrap_or(f64::NAN);
    if density.ndim() != 4 {
        return Err(BadInput(format!("grid {from}: `density` has {} dimensions; expected (point, realisation, md, cd)", density.ndim())).into());
    }
    if !(cell > 0.0 && cell.is_finite()) {
        return Err(BadInput(format!("grid {from}: cell_size {cell} is not a positive length")).into());
    }
    let (npoints, nreal) = (density.shape()[0], density.shape()[1]);
    let sweep = grid_sweep(input, npoints)?;
    let samples = (0..npoints)
        .flat_map(|pt| (0..nreal).map(move |r| (pt, r)))
        .map(|(pt, r)| Sample {
            group: if sweep.is_empty() {
                format!("point {pt}")
            } else {
                sweep.iter().map(|(n, _, v)| format!("{n}={}", crate::params::format_float(v[pt]))).collect::<Vec<_>>().join(", ")
            },
            file: String::new(),
            source: Source::Grid(pt, r),
            pixel: cell,
            pixel_source: PixelSource::Grid,
            grid_point: pt as i64,
            realisation: r as i64,
        })
        .collect();
    Ok((samples, sweep, Some(GridData { from, density, cell })))
}

fn group_stats(samples: &[Sample], kept: &[Kept]) -> Vec<(GroupStats, MeanStd)> {
    let sums: Vec<super::Summary> = kept.iter().map(|k| k.a.summary()).collect();
    let stats = super::group_statistics(samples.iter().zip(&sums).map(|(s, m)| (s.group.as_str(), m)));
    stats
        .into_iter()
        .map(|g| {
            let web: Vec<f64> =
                samples.iter().zip(kept).filter(|(s, k)| s.group == g.group && k.cv_web.is_finite()).map(|(_, k)| k.cv_web).collect();
            let w = if web.is_empty() { MeanStd { mean: f64::NAN, std: f64::NAN } } else { MeanStd::of(&web) };
            (g, w)
        })
        .collect()
}

/// The Table-4-like summary: per group n, CV raw, the reported CV_corr and the paper's
/// plain CV_corr as mean ± std (per cent).
fn table(stage: &str, groups: &[(GroupStats, MeanStd)], kept: &[Kept]) -> String {
    let has_web = kept.iter().any(|k| k.cv_web.is_finite());
    let width = groups.iter().map(|(g, _)| g.group.chars().count()).max().unwrap_or(5).max(5);
    let mut t = format!("{stage}: CV of grey levels, mean ± std over the samples of each group (per cent)\n");
    t += &format!("{stage}: {:<width$}  {:>3}  {:>14}  {:>14}  {:>14}  {:>7}", "group", "n", "CV raw", "CV_corr", "CV_corr plain", "notches");
    if has_web {
        t += &format!("  {:>14}", "CV web (truth)");
    }
    t += "\n";
    let pm = |m: &MeanStd| format!("{:6.2} ± {:5.2}", 100.0 * m.mean, 100.0 * m.std);
    for (g, w) in groups {
        t += &format!(
            "{stage}: {:<width$}  {:>3}  {:>14}  {:>14}  {:>14}  {:>7.1}",
            g.group,
            g.n,
            pm(&g.cv_raw),
            pm(&g.cv_corr),
            pm(&g.cv_corr_plain),
            g.notch_count.mean
        );
        if has_web {
            t += &format!("  {:>14}", pm(w));
        }
        t += "\n";
    }
    t
}

fn nan_if_none(v: Option<f64>) -> f64 {
    v.unwrap_or(f64::NAN)
}

/// The datasets of one sweep point; the peak table is `peaks` wide.
fn assemble(samples: &[Sample], kept: &[Kept], p: &ImageStageParams, sweep: &GridSweep, peaks: usize) -> Output {
    let n = samples.len();
    let nan = f64::NAN;
    let mut out = Output::new();
    let col = |f: &dyn Fn(&ImageAnalysis) -> f64| Array1::from_iter(kept.iter().map(|k| f(&k.a)));
    out.i64("sample", &["sample"], Array1::from_iter(0..n as i64), "1", "sample index").describe("sample index (files in list order, globs sorted; or grid point × realisation)");
    out.strings("group", "sample", samples.iter().map(|s| s.group.clone()).collect(), "condition (group) of each sample");
    out.strings("file", "sample", samples.iter().map(|s| s.file.clone()).collect(), "image file (empty for rendered grid samples)");
    out.i64("grid_point", &["sample"], Array1::from_iter(samples.iter().map(|s| s.grid_point)), "1", "grid point of the sample").describe("grid point index of a rendered sample (−1 for files and synthetic images)");
    out.i64("realisation", &["sample"], Array1::from_iter(samples.iter().map(|s| s.realisation)), "1", "realisation of the sample").describe("grid realisation of a rendered sample, or index of a synthetic image (−1 for files)");
    out.f64("pixel_size", &["sample"], Array1::from_iter(kept.iter().map(|k| k.pixel)), "m", "pixel size used (see pixel_size_source)");
    out.strings(
        "pixel_size_source",
        "sample",
        kept.iter().map(|k| k.pixel_source.name().to_string()).collect(),
        "pixel size source",
    )
    .describe("where pixel_size came from: file (declared by the image file), dpi, pixel_size (parameters, overriding the file), default (297/871 mm), grid (the grid's cell_size)");
    out.f64("file_pixel_size", &["sample"], Array1::from_iter(kept.iter().map(|k| k.file_pixel)), "m", "declared pixel size").describe("pixel size the image file declares (NaN: none, or not a file)");
    out.i64("rows", &["sample"], Array1::from_iter(kept.iter().map(|k| k.rows as i64)), "1", "image height").describe("image height (pixels; rows = MD for grid samples)");
    out.i64("cols", &["sample"], Array1::from_iter(kept.iter().map(|k| k.cols as i64)), "1", "image width (pixels)");
    out.f64("mean_grey", &["sample"], col(&|a| a.mean), "1", "mean grey level").describe("mean grey level (full scale 1; kept by the filter)");
    out.f64("cv_raw", &["sample"], col(&|a| a.cv_raw), "1", "raw CV").describe("CV of the raw grey levels (population std / mean)");
    out.f64("cv_corr", &["sample"], col(&|a| a.cv_corr), "1", "CV_corr, reported").describe("CV_corr, the reported uniformity, chosen by the version attribute cv_corr_rule: cv_corr_compensated");
    out.f64("cv_corr_plain", &["sample"], col(&|a| a.cv_corr_plain), "1", "CV_corr, plain notch filter").describe("CV of the notch-filtered image, mean kept, interior only (the paper's CV_corr; biased low by the web variance under the notches)");
    out.f64("cv_corr_compensated", &["sample"], col(&|a| a.cv_corr_compensated), "1", "CV_corr, compensated").describe("CV_corr with the web variance removed under the notches added back (background model), saturated pixels first restored from the lattice (censored_fraction, censored_variance)");
    out.f64("cv_corr_one_sided", &["sample"], col(&|a| nan_if_none(a.cv_corr_one_sided)), "1", "CV_corr without one-sided bond brightening").describe("compensated CV about the mean without an estimated one-sided bond brightening (NaN when undefined)");
    out.f64("bond_mean_estimate", &["sample"], col(&|a| a.bond_mean_estimate), "1", "one-sided bond brightening").describe("grey level the bonds add on average if they are one-sided");
    out.f64("cv_web", &["sample"], Array1::from_iter(kept.iter().map(|k| k.cv_web)), "1", "CV without bonds (truth)").describe("CV of the same rendering without bonds: the truth (grid and synthetic samples; NaN for files)");
    out.i64("notches", &["sample"], Array1::from_iter(kept.iter().map(|k| k.a.notch_count as i64)), "1", "notches applied").describe("Gaussian notches applied (2 per peak: peak and conjugate)");
    out.i64("peak_count", &["sample"], Array1::from_iter(kept.iter().map(|k| k.a.peaks.len() as i64)), "1", "detected bond peaks (half plane)");
    out.f64("variance_removed_fraction", &["sample"], col(&|a| a.fraction_variance_removed), "1", "1 − Var(filtered)/Var(raw), whole images");
    out.f64("web_variance_notched", &["sample"], col(&|a| a.web_variance_notched), "1", "web variance removed by the notches").describe("expected web variance removed by the notches, Σ(1−g²)B/N²");
    out.f64("threshold", &["sample"], col(&|a| a.threshold), "1", "peak detection threshold").describe("whitened-power detection threshold ln(M·passes/α)");
    out.i64("edge_margin", &["sample"], Array1::from_iter(kept.iter().map(|k| k.a.margin_px as i64)), "1", "edge band left out").describe("edge band (pixels) left out of the filtered statistics");
    out.i64("grown_bins", &["sample"], Array1::from_iter(kept.iter().map(|k| k.a.grown_bins as i64)), "1", "bins added by notch growth").describe("spectrum bins added to the notches by the hysteresis growth over the leakage ridges (conjugates counted; 0 with notch_growth off)");
    out.f64("censored_fraction", &["sample"], col(&|a| a.censored_fraction), "1", "saturated pixels restored").describe("fraction of the pixels at 0 or 1 restored from the lattice by the censoring correction (0 when it did not run)");
    out.f64("censored_variance", &["sample"], col(&|a| a.censored_variance), "1", "conditional variance of restored pixels").describe("web variance the restored pixels cannot show (mean conditional variance over the interior), added to cv_corr_compensated");
    let lat = |f: &dyn Fn(&super::Lattice) -> Option<f64>| Array1::from_iter(kept.iter().map(|k| k.a.lattice.as_ref().and_then(f).unwrap_or(nan)));
    out.f64("lattice_period1", &["sample"], lat(&|l| l.periods.first().copied()), "m", "first bond repeat distance").describe("first detected bond repeat distance (NaN: no lattice)");
    out.f64("lattice_period2", &["sample"], lat(&|l| l.periods.get(1).copied()), "m", "second bond repeat distance").describe("second detected bond repeat distance (NaN: line pattern or none)");
    out.f64("lattice_angle1", &["sample"], lat(&|l| l.angles_deg.first().copied()), "degree", "first lattice vector direction").describe("direction of the first lattice vector from +x (columns) towards +y (rows)");
    out.f64("lattice_angle2", &["sample"], lat(&|l| l.angles_deg.get(1).copied()), "degree", "direction of the second lattice vector");
    out.f64("lattice_angle_between", &["sample"], lat(&|l| l.angle_between_deg), "degree", "angle between the lattice vectors");
    out.f64("wall_seconds", &["sample"], Array1::from_iter(kept.iter().map(|k| k.wall_seconds)), "s", "wall time of the image").describe("wall time of reading or rendering and analysing the image (on one thread of the pool)");
    out.i64("lattice_explained", &["sample"], Array1::from_iter(kept.iter().map(|k| k.a.lattice.as_ref().map(|l| l.explained as i64).unwrap_or(0))), "1", "peaks explained by the lattice");

    // Peak table, padded with NaN (pass −1).
    let np = peaks;
    let peak = |f: &dyn Fn(&super::Peak) -> f64| {
        Array2::from_shape_fn((n, np), |(i, j)| kept[i].a.peaks.get(j).map(f).unwrap_or(nan))
    };
    out.f64("peak_kx", &["sample", "peak"], peak(&|q| q.kx), "m-1", "peak frequency along x").describe("peak spatial frequency along x (columns), cycles per metre");
    out.f64("peak_ky", &["sample", "peak"], peak(&|q| q.ky), "m-1", "peak frequency along y").describe("peak spatial frequency along y (rows), cycles per metre");
    out.f64("peak_period", &["sample", "peak"], peak(&|q| q.period), "m", "fringe period 1/|k|");
    out.f64("peak_angle", &["sample", "peak"], peak(&|q| q.angle_deg), "degree", "wave-vector direction from +x towards +y");
    out.f64("peak_strength", &["sample", "peak"], peak(&|q| q.strength), "1", "whitened power |F|²/B at the peak bin");
    out.f64("peak_variance_fraction", &["sample", "peak"], peak(&|q| q.variance_fraction), "1", "variance share of the peak").describe("share of the image variance in the peak and its conjugate above background");
    out.f64("peak_notch_sigma", &["sample", "peak"], peak(&|q| q.notch_sigma), "1", "notch standard deviation (frequency bins)");
    out.i64("peak_pass", &["sample", "peak"], Array2::from_shape_fn((n, np), |(i, j)| kept[i].a.peaks.get(j).map(|q| q.pass as i64).unwrap_or(-1)), "1", "detection pass (−1: padding)");

    // Zone curves on the zone sides actually used (whole pixels, each once), padded at
    // the end only: a sample's curve fills zone 0..len, and the filtered interior may
    // lose its largest sizes.
    let nz = kept.iter().map(|k| k.a.zone_cv_raw.len().max(k.a.zone_cv_filtered.len())).max().unwrap_or(0);
    let longest = |k: &Kept| -> Vec<crate::uniformity::ZoneCv> {
        if k.a.zone_cv_raw.len() >= k.a.zone_cv_filtered.len() { k.a.zone_cv_raw.clone() } else { k.a.zone_cv_filtered.clone() }
    };
    let sizes: Vec<Vec<crate::uniformity::ZoneCv>> = kept.iter().map(longest).collect();
    let zc = |raw: bool| {
        Array2::from_shape_fn((n, nz), |(i, j)| {
            let c = if raw { &kept[i].a.zone_cv_raw } else { &kept[i].a.zone_cv_filtered };
            c.get(j).map(|z| z.cv).unwrap_or(nan)
        })
    };
    out.f64("zone_size", &["sample", "zone"], Array2::from_shape_fn((n, nz), |(i, j)| sizes[i].get(j).map(|z| z.zone_size).unwrap_or(nan)), "m", "zone size used").describe("zone side actually used: zone_cells × pixel_size, from zone_min to zone_max rounded to whole pixels, each size once (NaN padding after a sample's last size)");
    out.i64("zone_cells", &["sample", "zone"], Array2::from_shape_fn((n, nz), |(i, j)| sizes[i].get(j).map(|z| z.cells_per_side as i64).unwrap_or(0)), "1", "pixels per zone side (0: padding)");
    out.f64("zone_cv_raw", &["sample", "zone"], zc(true), "1", "raw CV at zone size").describe("CV of zone means of the raw image at zone_size (NaN padding: fewer than 4 zones fit)");
    out.f64("zone_cv_filtered", &["sample", "zone"], zc(false), "1", "filtered CV at zone size").describe("CV of zone means of the filtered image interior at zone_size (NaN padding: fewer than 4 zones fit the interior)");

    // Per-group statistics.
    let groups = group_stats(samples, kept);
    let g = groups.len();
    out.strings("condition", "condition", groups.iter().map(|(s, _)| s.group.clone()).collect(), "group (condition) label");
    out.i64("condition_samples", &["condition"], Array1::from_iter(groups.iter().map(|(s, _)| s.n as i64)), "1", "samples in the group");
    let gcol = |f: &dyn Fn(&(GroupStats, MeanStd)) -> f64| Array1::from_iter(groups.iter().map(f));
    out.f64("cv_raw_mean", &["condition"], gcol(&|s| s.0.cv_raw.mean), "1", "mean of cv_raw over the group");
    out.f64("cv_raw_std", &["condition"], gcol(&|s| s.0.cv_raw.std), "1", "sample std (n−1) of cv_raw over the group");
    out.f64("cv_corr_mean", &["condition"], gcol(&|s| s.0.cv_corr.mean), "1", "mean of cv_corr over the group");
    out.f64("cv_corr_std", &["condition"], gcol(&|s| s.0.cv_corr.std), "1", "sample std (n−1) of cv_corr over the group");
    out.f64("cv_corr_plain_mean", &["condition"], gcol(&|s| s.0.cv_corr_plain.mean), "1", "mean of cv_corr_plain");
    out.f64("cv_corr_plain_std", &["condition"], gcol(&|s| s.0.cv_corr_plain.std), "1", "sample std of cv_corr_plain");
    out.f64("cv_corr_compensated_mean", &["condition"], gcol(&|s| s.0.cv_corr_compensated.mean), "1", "mean of cv_corr_compensated");
    out.f64("cv_corr_compensated_std", &["condition"], gcol(&|s| s.0.cv_corr_compensated.std), "1", "sample std of cv_corr_compensated");
    out.f64("cv_web_mean", &["condition"], gcol(&|s| s.1.mean), "1", "mean of cv_web (NaN for files)");
    out.f64("cv_web_std", &["condition"], gcol(&|s| s.1.std), "1", "sample std of cv_web");
    out.f64("variance_removed_fraction_mean", &["condition"], gcol(&|s| s.0.fraction_variance_removed.mean), "1", "mean variance_removed_fraction");
    out.f64("notches_mean", &["condition"], gcol(&|s| s.0.notch_count.mean), "1", "mean number of notches");
    // The grid's swept parameters per condition (grid input: one condition per point).
    if g > 0 {
        for (name, unit, values) in sweep {
            let per: Vec<f64> = groups
                .iter()
                .map(|(s, _)| samples.iter().find(|x| x.group == s.group).map(|x| values[x.grid_point as usize]).unwrap_or(nan))
                .collect();
            let var = out.f64(&format!("condition_{name}"), &["condition"], Array1::from(per), if unit.is_empty() { "1" } else { unit.as_str() }, &format!("grid {name}")).describe(format!("the grid's coordinate {name} of the condition"));
            var.attrs.insert("grid_parameter".into(), Attr::Str(name.clone()));
        }
    }

    // Stored images (first max_stored_images samples), padded with NaN to the largest.
    let stored: Vec<usize> = (0..n).filter(|&i| kept[i].store).collect();
    if !stored.is_empty() {
        let h = stored.iter().map(|&i| kept[i].a.raw.nrows()).max().unwrap_or(0);
        let w = stored.iter().map(|&i| kept[i].a.raw.ncols()).max().unwrap_or(0);
        let stack = |f: &dyn Fn(&ImageAnalysis) -> &Array2<f64>| {
            let mut a = Array3::from_elem((stored.len(), h, w), nan);
            for (k, &i) in stored.iter().enumerate() {
                let src = f(&kept[i].a);
                a.slice_mut(s![k, ..src.nrows(), ..src.ncols()]).assign(src);
            }
            a
        };
        out.i64("stored_sample", &["stored"], Array1::from_iter(stored.iter().map(|&i| i as i64)), "1", "sample index of each stored image");
        out.f64("raw_image", &["stored", "row", "col"], stack(&|a| &a.raw), "1", "raw grey levels (NaN padding)");
        out.f64("filtered_image", &["stored", "row", "col"], stack(&|a| &a.filtered), "1", "notch-filtered grey levels (NaN padding)");
        out.f64("log_spectrum_raw", &["stored", "row", "col"], stack(&|a| &a.log_spectrum_raw), "1", "log10 energy spectrum before notching").describe("log10 energy spectrum |F|²/N² before notching, fftshifted (DC at row ⌊H/2⌋, col ⌊W/2⌋)");
        out.f64("log_spectrum_notched", &["stored", "row", "col"], stack(&|a| &a.log_spectrum_notched), "1", "log10 energy spectrum after notching, fftshifted");
    }
    out.set_attr("max_stored_images", p.max_stored_images as i64);
    out.set_attr("cv_corr_rule", super::CV_CORR_RULE);
    out.set_attr("background_model", "median of |F|² in polar cells / ln 2, divided out (whitening), not subtracted");
    out
}

#[cfg(test)]
mod tests;
