//! The image analysis parameters ([`ImageParams`], their table [`PARAMETERS`] and
//! checks) and where a sample's pixel size comes from ([`PixelSource`]).

use super::{GreyImage, ImageError};

/// Parameters of the image analysis. All lengths in the YAML/CLI are in millimetres;
/// [`ImageParams::pixel_size_m`] converts to SI. See [`PARAMETERS`] for units and ranges.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImageParams {
    /// Pixel size (mm). Give this or `dpi` (either overrides a file's own); with neither,
    /// the size a file declares, else [`DEFAULT_PIXEL_SIZE_MM`].
    pub pixel_size_mm: Option<f64>,
    /// Scan resolution (dots per inch); pixel size = 25.4/dpi mm.
    pub dpi: Option<f64>,
    /// Expected number of false peaks per image. Default 1e-3.
    pub false_alarm_rate: f64,
    /// Gaussian notch standard deviation (frequency bins). Default 1.5.
    pub notch_sigma_bins: f64,
    /// Notch widening for peaks between bins: σ·(1 + w·2·max|δ|). Default 1.
    pub off_grid_widening: f64,
    /// Radius of the excluded DC disc (bins). Default 8.
    pub dc_exclusion_bins: f64,
    /// Smallest peak share of the image variance searched for. Default 1e-5.
    pub min_peak_fraction: f64,
    /// Angular sectors of the background model over 180°. Default 8.
    pub background_sectors: usize,
    /// Smallest radial half-width (annuli) of a background pool. Default 1.
    pub background_smoothing: usize,
    /// Bins a background pool aims for (median precision 1/(ln2·√pool)). Default 256.
    pub background_pool: usize,
    /// Detection passes (each searches the residual after the previous notches). Default 3.
    pub max_passes: usize,
    /// Maximum number of peaks (half plane) notched. Default 400.
    pub max_peaks: usize,
    /// Use the periodic-plus-smooth decomposition before the FFT. Default true.
    pub periodic_decomposition: bool,
    /// Smallest zone side of the CV-per-zone curves (mm). Default 0.5.
    pub zone_min_mm: f64,
    /// Largest zone side (mm). Default 16.
    pub zone_max_mm: f64,
    /// Zone sizes per doubling. Default 2.
    pub zones_per_octave: usize,
    /// Edge band left out of the filtered statistics, in longest bond periods. Default 1.
    pub edge_margin_periods: f64,
}

/// How the reported `cv_corr` is chosen among the corrected CVs (stored as the version
/// attribute `cv_corr_rule`).
pub const CV_CORR_RULE: &str = "cv_corr = cv_corr_compensated: the CV of the notch-filtered interior with the web variance the notches removed (background model) added back; cv_corr_plain (the paper's CV_corr) and cv_corr_one_sided are stored beside it; without notches all equal cv_raw";

/// Default pixel size: an A4 sheet's long side (297 mm) over 871 pixels, the paper's scans.
pub const DEFAULT_PIXEL_SIZE_MM: f64 = 297.0 / 871.0;

impl Default for ImageParams {
    fn default() -> Self {
        ImageParams {
            pixel_size_mm: None,
            dpi: None,
            false_alarm_rate: 1e-3,
            notch_sigma_bins: 1.5,
            off_grid_widening: 1.0,
            dc_exclusion_bins: 8.0,
            min_peak_fraction: 1e-5,
            background_sectors: 8,
            background_smoothing: 1,
            background_pool: 256,
            max_passes: 3,
            max_peaks: 400,
            periodic_decomposition: true,
            zone_min_mm: 0.5,
            zone_max_mm: 16.0,
            zones_per_octave: 2,
            edge_margin_periods: 1.0,
        }
    }
}

pub use crate::param_table::{ParamDefault, ParamSpec};

/// The image stage's parameters: name, unit, default, range, meaning.
pub const PARAMETERS: &[ParamSpec] = &[
    ParamSpec { name: "pixel_size_mm", unit: "mm", default: ParamDefault::Unset, min: 1e-4, max: 100.0, choices: &[],
        doc: "Pixel size; give this or dpi (not both); overrides the file's own. Neither: the file's (PNG pHYs, TIFF resolution, JPEG JFIF density), else 297/871 mm (A4 at 871 px, the paper's scans)." },
    ParamSpec { name: "dpi", unit: "1/inch", default: ParamDefault::Unset, min: 1.0, max: 1e5, choices: &[],
        doc: "Scan resolution; pixel size = 25.4/dpi mm. Give this or pixel_size_mm; overrides the file's own." },
    ParamSpec { name: "false_alarm_rate", unit: "peaks/image", default: ParamDefault::Real(1e-3), min: 1e-12, max: 0.5, choices: &[],
        doc: "Expected number of false peaks per bond-free image; sets the Exp(1) threshold ln(M·passes/α)." },
    ParamSpec { name: "notch_sigma_bins", unit: "bins", default: ParamDefault::Real(1.5), min: 0.5, max: 10.0, choices: &[],
        doc: "Standard deviation of the circular Gaussian notches, in frequency bins." },
    ParamSpec { name: "off_grid_widening", unit: "1", default: ParamDefault::Real(1.0), min: 0.0, max: 5.0, choices: &[],
        doc: "Notch widening for peaks between bins (period not dividing the image): σ·(1 + w·2·max|δ|)." },
    ParamSpec { name: "dc_exclusion_bins", unit: "bins", default: ParamDefault::Real(8.0), min: 1.0, max: 200.0, choices: &[],
        doc: "Radius of the disc around DC that is never searched (web scale, not bonds)." },
    ParamSpec { name: "min_peak_fraction", unit: "1", default: ParamDefault::Real(1e-5), min: 0.0, max: 0.1, choices: &[],
        doc: "A peak (with its conjugate) must hold at least this share of the image variance above background." },
    ParamSpec { name: "background_sectors", unit: "count", default: ParamDefault::Integer(8), min: 1.0, max: 64.0, choices: &[],
        doc: "Angular sectors (over 180°) of the median background model; 1 = purely radial." },
    ParamSpec { name: "background_smoothing", unit: "annuli", default: ParamDefault::Integer(1), min: 0.0, max: 20.0, choices: &[],
        doc: "Smallest radial half-width of the pools whose median is the background." },
    ParamSpec { name: "background_pool", unit: "bins", default: ParamDefault::Integer(256), min: 16.0, max: 100000.0, choices: &[],
        doc: "Bins a background pool aims for; pools grow radially (within ±17 % of the radius) to reach it." },
    ParamSpec { name: "max_passes", unit: "count", default: ParamDefault::Integer(3), min: 1.0, max: 10.0, choices: &[],
        doc: "Detection passes; each searches the residual after the previous notches." },
    ParamSpec { name: "max_peaks", unit: "count", default: ParamDefault::Integer(400), min: 1.0, max: 100000.0, choices: &[],
        doc: "Upper bound on notched peaks (half plane); reaching it adds a warning." },
    ParamSpec { name: "periodic_decomposition", unit: "bool", default: ParamDefault::Bool(true), min: 0.0, max: 1.0, choices: &[],
        doc: "Periodic-plus-smooth decomposition (Moisan) before the FFT, against edge-jump artefacts." },
    ParamSpec { name: "zone_min_mm", unit: "mm", default: ParamDefault::Real(0.5), min: 1e-4, max: 1000.0, choices: &[],
        doc: "Smallest zone side of the CV-per-zone-size curves." },
    ParamSpec { name: "zone_max_mm", unit: "mm", default: ParamDefault::Real(16.0), min: 1e-4, max: 1000.0, choices: &[],
        doc: "Largest zone side of the CV-per-zone-size curves (≥ zone_min_mm)." },
    ParamSpec { name: "zones_per_octave", unit: "count", default: ParamDefault::Integer(2), min: 1.0, max: 16.0, choices: &[],
        doc: "Zone sizes per doubling of the zone side." },
    ParamSpec { name: "edge_margin_periods", unit: "bond periods", default: ParamDefault::Real(1.0), min: 0.0, max: 10.0, choices: &[],
        doc: "Edge band left out of the filtered-image CVs, in longest detected bond periods (0 = whole image)." },
];

fn spec(name: &str) -> &'static ParamSpec {
    PARAMETERS.iter().find(|p| p.name == name).expect("parameter in table")
}

fn check(name: &'static str, v: f64) -> Result<(), ImageError> {
    let s = spec(name);
    if v.is_finite() && v >= s.min && v <= s.max {
        Ok(())
    } else {
        Err(ImageError::InvalidParam {
            name,
            value: v.to_string(),
            allowed: format!("{} to {} {}", s.min, s.max, s.unit),
        })
    }
}

impl ImageParams {
    /// Checks every parameter against [`PARAMETERS`]; the error names the parameter and
    /// its allowed range.
    pub fn validate(&self) -> Result<(), ImageError> {
        if let Some(v) = self.pixel_size_mm {
            check("pixel_size_mm", v)?;
        }
        if let Some(v) = self.dpi {
            check("dpi", v)?;
        }
        if let (Some(mm), Some(dpi)) = (self.pixel_size_mm, self.dpi) {
            return Err(ImageError::InvalidParam {
                name: "dpi",
                value: format!("{dpi} (with pixel_size_mm = {mm})"),
                allowed: "only one of pixel_size_mm and dpi".into(),
            });
        }
        check("false_alarm_rate", self.false_alarm_rate)?;
        check("notch_sigma_bins", self.notch_sigma_bins)?;
        check("off_grid_widening", self.off_grid_widening)?;
        check("dc_exclusion_bins", self.dc_exclusion_bins)?;
        check("min_peak_fraction", self.min_peak_fraction)?;
        check("background_sectors", self.background_sectors as f64)?;
        check("background_smoothing", self.background_smoothing as f64)?;
        check("background_pool", self.background_pool as f64)?;
        check("max_passes", self.max_passes as f64)?;
        check("max_peaks", self.max_peaks as f64)?;
        check("zone_min_mm", self.zone_min_mm)?;
        check("zone_max_mm", self.zone_max_mm)?;
        check("zones_per_octave", self.zones_per_octave as f64)?;
        check("edge_margin_periods", self.edge_margin_periods)?;
        if self.zone_max_mm < self.zone_min_mm {
            return Err(ImageError::InvalidParam {
                name: "zone_max_mm",
                value: self.zone_max_mm.to_string(),
                allowed: format!("≥ zone_min_mm = {}", self.zone_min_mm),
            });
        }
        Ok(())
    }

    /// Pixel size in metres, from `pixel_size_mm`, `dpi` or the default.
    pub fn pixel_size_m(&self) -> f64 {
        self.pixel_size_given().map(|(m, _)| m).unwrap_or(DEFAULT_PIXEL_SIZE_MM * 1e-3)
    }

    /// Where [`ImageParams::pixel_size_m`] comes from when no file is involved.
    pub fn pixel_source(&self) -> PixelSource {
        self.pixel_size_given().map(|(_, s)| s).unwrap_or(PixelSource::Default)
    }

    /// The pixel size (m) given as a parameter, if any.
    fn pixel_size_given(&self) -> Option<(f64, PixelSource)> {
        match (self.pixel_size_mm, self.dpi) {
            (Some(mm), _) => Some((mm * 1e-3, PixelSource::PixelSize)),
            (None, Some(dpi)) => Some((25.4e-3 / dpi, PixelSource::Dpi)),
            (None, None) => None,
        }
    }

    /// The pixel size (m) of an image read from a file, and where it came from:
    /// `pixel_size_mm` or `dpi` when given (they override the file), else the size the
    /// file declares, else [`DEFAULT_PIXEL_SIZE_MM`].
    ///
    /// A declared size that is used must be readable, square (x and y within 0.1 %) and
    /// within the range of `pixel_size_mm`; otherwise [`ImageError::BadResolution`] names
    /// the file.
    pub fn pixel_size_for(&self, img: &GreyImage) -> Result<(f64, PixelSource), ImageError> {
        if let Some(given) = self.pixel_size_given() {
            return Ok(given);
        }
        let bad = |message: String| ImageError::BadResolution { path: img.path.clone(), message };
        if let Some(e) = &img.resolution_error {
            return Err(bad(format!("its resolution metadata cannot be read ({e})")));
        }
        let Some(r) = &img.resolution else {
            return Ok((DEFAULT_PIXEL_SIZE_MM * 1e-3, PixelSource::Default));
        };
        if (r.x / r.y - 1.0).abs() > 1e-3 {
            return Err(bad(format!(
                "the file declares non-square pixels, {:.6} mm wide and {:.6} mm high ({}); the analysis needs square pixels",
                r.x * 1e3,
                r.y * 1e3,
                r.tag
            )));
        }
        let s = spec("pixel_size_mm");
        if !(r.x * 1e3 >= s.min && r.x * 1e3 <= s.max) {
            return Err(bad(format!("the file declares a pixel size of {} mm ({}); allowed {} to {} mm", r.x * 1e3, r.tag, s.min, s.max)));
        }
        Ok((r.x, PixelSource::File))
    }
}

/// Where a sample's pixel size came from (dataset `pixel_size_source`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelSource {
    /// Declared by the image file (PNG pHYs, TIFF resolution tags, JPEG JFIF density).
    File,
    /// The `dpi` parameter.
    Dpi,
    /// The `pixel_size` parameter.
    PixelSize,
    /// Neither file nor parameter: [`DEFAULT_PIXEL_SIZE_MM`].
    Default,
    /// The `cell_size` of the grid an image was rendered from.
    Grid,
}

impl PixelSource {
    pub fn as_str(self) -> &'static str {
        match self {
            PixelSource::File => "file",
            PixelSource::Dpi => "dpi",
            PixelSource::PixelSize => "pixel_size",
            PixelSource::Default => "default",
            PixelSource::Grid => "grid",
        }
    }
}
