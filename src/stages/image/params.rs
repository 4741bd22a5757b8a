//! The image analysis parameters ([`ImageParams`], their table [`PARAMETERS`] and
//! checks) and where a sample's pixel size comes from ([`PixelSource`]).

use super::{GreyImage, ImageError};

/// Parameters of the image analysis, SI (lengths in m); the names are the image stage's
/// YAML keys. See [`PARAMETERS`] for units and ranges.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImageParams {
    /// Pixel size (m). Give this or `dpi` (either overrides a file's own); with neither,
    /// the size a file declares, else [`DEFAULT_PIXEL_SIZE`].
    pub pixel_size: Option<f64>,
    /// Scan resolution (dots per inch); pixel size = 0.0254/dpi m.
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
    /// Smallest zone side of the CV-per-zone curves (m). Default 0.5 mm.
    pub zone_min: f64,
    /// Largest zone side (m). Default 16 mm.
    pub zone_max: f64,
    /// Zone sizes per doubling. Default 2.
    pub zones_per_octave: usize,
    /// Edge band left out of the filtered statistics, in longest bond periods. Default 2.
    pub edge_margin_periods: f64,
    /// Grow each notch over its leakage ridge by hysteresis ([`super::grow`]). Default true.
    pub notch_growth: bool,
    /// Restore the web under saturated pixels from the lattice ([`super::censor`]). Default true.
    pub censoring_correction: bool,
}

/// How the reported `cv_corr` is chosen among the corrected CVs (stored as the version
/// attribute `cv_corr_rule`).
pub const CV_CORR_RULE: &str = "cv_corr = cv_corr_compensated: the CV of the notch-filtered interior with the web variance the notches removed (background model) added back, pixels saturated at 0 or 1 first restored from the lattice (censoring_correction); cv_corr_plain (the paper's CV_corr) and cv_corr_one_sided are stored beside it; without notches all equal cv_raw";

/// Default pixel size (m): an A4 sheet's long side (297 mm) over 871 pixels, the paper's scans.
pub const DEFAULT_PIXEL_SIZE: f64 = 297.0 / 871.0 * 1e-3;

impl Default for ImageParams {
    fn default() -> Self {
        ImageParams {
            pixel_size: None,
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
            zone_min: 0.5e-3,
            zone_max: 16e-3,
            zones_per_octave: 2,
            edge_margin_periods: 2.0,
            notch_growth: true,
            censoring_correction: true,
        }
    }
}

use crate::params::ParamSpec;

/// The image analysis parameters, rows of the image stage (same names, SI units; "1"
/// dimensionless, "" for switches): name, unit, default, range, meaning.
pub const PARAMETERS: &[ParamSpec] = &[
    ParamSpec::auto_float("pixel_size", "m", 1e-7, 0.1, "pixel size of the files, overriding what each file declares; give this or dpi; neither: each file's own (PNG pHYs, TIFF resolution tags, JPEG JFIF density), else 297/871 mm (A4 at 871 px) with a warning; grid input: the grid's cell_size"),
    ParamSpec::auto_float("dpi", "inch-1", 1.0, 1e5, "scan resolution of the files (pixel size 0.0254/dpi m), overriding what each file declares; give this or pixel_size"),
    ParamSpec::float("zone_min", "m", 0.5e-3, 1e-7, 1.0, "smallest zone side of the CV-per-zone-size curves"),
    ParamSpec::float("zone_max", "m", 16e-3, 1e-7, 1.0, "largest zone side of the CV-per-zone-size curves (≥ zone_min)"),
    ParamSpec::float("false_alarm_rate", "1", 1e-3, 1e-12, 0.5, "Expected number of false peaks per bond-free image; sets the Exp(1) threshold ln(M·passes/α)."),
    ParamSpec::float("notch_sigma_bins", "1", 1.5, 0.5, 10.0, "Standard deviation of the circular Gaussian notches, in frequency bins."),
    ParamSpec::float("off_grid_widening", "1", 1.0, 0.0, 5.0, "Notch widening for peaks between bins (period not dividing the image): σ·(1 + w·2·max|δ|)."),
    ParamSpec::float("dc_exclusion_bins", "1", 8.0, 1.0, 200.0, "Radius of the disc around DC that is never searched (web scale, not bonds)."),
    ParamSpec::float("min_peak_fraction", "1", 1e-5, 0.0, 0.1, "A peak (with its conjugate) must hold at least this share of the image variance above background."),
    ParamSpec::int("background_sectors", "1", 8, 1, 64, "Angular sectors (over 180°) of the median background model; 1 = purely radial."),
    ParamSpec::int("background_smoothing", "1", 1, 0, 20, "Smallest radial half-width of the pools whose median is the background."),
    ParamSpec::int("background_pool", "1", 256, 16, 100_000, "Bins a background pool aims for; pools grow radially (within ±17 % of the radius) to reach it."),
    ParamSpec::int("max_passes", "1", 3, 1, 10, "Detection passes; each searches the residual after the previous notches."),
    ParamSpec::int("max_peaks", "1", 400, 1, 100_000, "Upper bound on notched peaks (half plane); reaching it adds a warning."),
    ParamSpec::flag("periodic_decomposition", true, "Periodic-plus-smooth decomposition (Moisan) before the FFT, against edge-jump artefacts."),
    ParamSpec::int("zones_per_octave", "1", 2, 1, 16, "Zone sizes per doubling of the zone side."),
    ParamSpec::float("edge_margin_periods", "1", 2.0, 0.0, 10.0, "Edge band left out of the filtered-image CVs, in longest detected bond periods (0 = whole image); the notches leave part of an off-grid harmonic within about two periods of the edges."),
    ParamSpec::flag("notch_growth", true, "Grow each notch by hysteresis over the connected significant bins of its leakage ridge (threshold ln(n/α) over the n bins tested); their web power is added back by the compensation."),
    ParamSpec::flag("censoring_correction", true, "Restore the web under pixels saturated at 0 or 1 from the lattice (pattern level per lattice phase matched on the unclipped pixels) before the compensated CV."),
];

fn check(name: &'static str, v: f64) -> Result<(), ImageError> {
    ParamSpec::find(PARAMETERS, name).check_number(v).map_err(|e| ImageError::InvalidParam { name, value: e.value, allowed: e.allowed })
}

impl ImageParams {
    /// Checks every parameter against [`PARAMETERS`]; the error names the parameter and
    /// its allowed range.
    pub fn validate(&self) -> Result<(), ImageError> {
        if let Some(v) = self.pixel_size {
            check("pixel_size", v)?;
        }
        if let Some(v) = self.dpi {
            check("dpi", v)?;
        }
        if let (Some(size), Some(dpi)) = (self.pixel_size, self.dpi) {
            return Err(ImageError::InvalidParam {
                name: "dpi",
                value: format!("{dpi} (with pixel_size = {size} m)"),
                allowed: "only one of pixel_size and dpi".into(),
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
        check("zone_min", self.zone_min)?;
        check("zone_max", self.zone_max)?;
        check("zones_per_octave", self.zones_per_octave as f64)?;
        check("edge_margin_periods", self.edge_margin_periods)?;
        if self.zone_max < self.zone_min {
            return Err(ImageError::InvalidParam {
                name: "zone_max",
                value: format!("{} m", self.zone_max),
                allowed: format!("≥ zone_min = {} m", self.zone_min),
            });
        }
        Ok(())
    }

    /// Pixel size (m) when no file is involved: `pixel_size`, 0.0254/`dpi`, else
    /// [`DEFAULT_PIXEL_SIZE`].
    pub fn pixel_size_or_default(&self) -> f64 {
        self.pixel_size_given().map(|(m, _)| m).unwrap_or(DEFAULT_PIXEL_SIZE)
    }

    /// Where [`ImageParams::pixel_size_or_default`] comes from.
    pub fn pixel_source(&self) -> PixelSource {
        self.pixel_size_given().map(|(_, s)| s).unwrap_or(PixelSource::Default)
    }

    /// The pixel size (m) given as a parameter, if any.
    fn pixel_size_given(&self) -> Option<(f64, PixelSource)> {
        match (self.pixel_size, self.dpi) {
            (Some(size), _) => Some((size, PixelSource::PixelSize)),
            (None, Some(dpi)) => Some((25.4e-3 / dpi, PixelSource::Dpi)),
            (None, None) => None,
        }
    }

    /// The pixel size (m) of an image read from a file, and where it came from:
    /// `pixel_size` or `dpi` when given (they override the file), else the size the
    /// file declares, else [`DEFAULT_PIXEL_SIZE`].
    ///
    /// A declared size that is used must be readable, square (x and y within 0.1 %) and
    /// within the range of `pixel_size`; otherwise [`ImageError::BadResolution`] names
    /// the file. Messages give sizes in mm.
    pub fn pixel_size_for(&self, img: &GreyImage) -> Result<(f64, PixelSource), ImageError> {
        if let Some(given) = self.pixel_size_given() {
            return Ok(given);
        }
        let bad = |message: String| ImageError::BadResolution { path: img.path.clone(), message };
        if let Some(e) = &img.resolution_error {
            return Err(bad(format!("its resolution metadata cannot be read ({e})")));
        }
        let Some(r) = &img.resolution else {
            return Ok((DEFAULT_PIXEL_SIZE, PixelSource::Default));
        };
        if (r.x / r.y - 1.0).abs() > 1e-3 {
            return Err(bad(format!(
                "the file declares non-square pixels, {:.6} mm wide and {:.6} mm high ({}); the analysis needs square pixels",
                r.x * 1e3,
                r.y * 1e3,
                r.tag
            )));
        }
        let row = ParamSpec::find(PARAMETERS, "pixel_size");
        if row.check_number(r.x).is_err() {
            return Err(bad(format!("the file declares a pixel size of {} mm ({}); allowed {}, the range of pixel_size", r.x * 1e3, r.tag, ParamSpec { auto: false, ..*row }.allowed())));
        }
        Ok((r.x, PixelSource::File))
    }
}

crate::params::choice_enum! {
    /// Where a sample's pixel size came from (dataset `pixel_size_source`, by its words).
    pub enum PixelSource {
        /// Declared by the image file (PNG pHYs, TIFF resolution tags, JPEG JFIF density).
        File = "file",
        /// The `dpi` parameter.
        Dpi = "dpi",
        /// The `pixel_size` parameter.
        PixelSize = "pixel_size",
        /// Neither file nor parameter: [`DEFAULT_PIXEL_SIZE`].
        #[default]
        Default = "default",
        /// The `cell_size` of the grid an image was rendered from.
        Grid = "grid",
    }
}

