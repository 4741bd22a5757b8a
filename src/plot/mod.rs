//! `laydown plot`: figures of a stage version, read back from the archive.
//!
//! Plots are made from what the archive holds (not from in-memory results), so a
//! published archive can be plotted by anyone with the `laydown` binary, no Python
//! needed. Each stage kind has one module that turns its datasets into a
//! [`figure::Figure`]; [`figure`] draws every figure alike, as PNG or SVG.
//!
//! ```no_run
//! use laydown::plot::{plot_stage, figure::Format};
//! let paths = plot_stage("results/quickstart.h5".as_ref(), "fibre", None, Format::Png).unwrap();
//! for p in paths { println!("{}", p.display()); }
//! ```
pub mod figure;
pub mod inspect;
mod accuracy;
mod grid;
mod image;
mod laid_web;
mod laydown;
mod spectra;
mod web;

use crate::archive::data::Attr;
use crate::archive::{hdf, Archive, VersionInfo};
use anyhow::{anyhow, bail, Context, Result};
use figure::{Figure, Format};
use ndarray::ArrayD;
use std::path::{Path, PathBuf};

/// A stage version opened for plotting.
pub struct StageData {
    pub info: VersionInfo,
    group: hdf5::Group,
}

pub use crate::archive::hdf::Swept;

impl StageData {
    pub fn kind(&self) -> &str {
        self.info.attr_str("stage_kind").unwrap_or("?")
    }
    pub fn has(&self, name: &str) -> bool {
        self.group.link_exists(name)
    }
    pub fn f64(&self, name: &str) -> Result<ArrayD<f64>> {
        hdf::read_f64(&self.group, name).with_context(|| format!("{}: dataset `{name}`", self.info.group_path()))
    }
    pub fn strings(&self, name: &str) -> Result<Vec<String>> {
        hdf::read_strings(&self.group, name).with_context(|| format!("{}: dataset `{name}`", self.info.group_path()))
    }
    /// A dataset attribute as text (`units`, `long_name`, ...).
    pub fn attr(&self, dataset: &str, key: &str) -> String {
        self.group
            .dataset(dataset)
            .ok()
            .and_then(|d| hdf::read_attrs(&d).ok())
            .and_then(|a| match a.get(key) {
                Some(Attr::Str(s)) => Some(s.clone()),
                _ => None,
            })
            .unwrap_or_default()
    }
    /// A resolved parameter of the version (from its canonical `params_yaml`).
    pub fn param(&self, name: &str) -> Option<String> {
        let yaml: serde_yaml_ng::Value = serde_yaml_ng::from_str(self.info.attr_str("params_yaml")?).ok()?;
        let mut v = &yaml;
        for part in name.split('.') {
            v = v.get(part)?;
        }
        match v {
            serde_yaml_ng::Value::String(s) => Some(s.clone()),
            serde_yaml_ng::Value::Number(n) => Some(n.to_string()),
            serde_yaml_ng::Value::Bool(b) => Some(b.to_string()),
            _ => None,
        }
    }
    /// Swept parameters (coordinates along `point` carrying a `parameter` attribute).
    pub fn swept(&self) -> Vec<Swept> {
        hdf::swept_coordinates(&self.group)
    }
    /// An image version's first numeric `condition_<param>` coordinate: (parameter, value per condition).
    pub fn swept_conditions(&self) -> Option<(String, Vec<f64>)> {
        let name = self.group.member_names().ok()?.into_iter().find(|n| n.starts_with("condition_") && n != "condition_samples")?;
        let values = self.f64(&name).ok()?;
        Some((name.trim_start_matches("condition_").to_string(), values.iter().copied().collect()))
    }
    /// Short text naming sweep point `p` (e.g. `friction_coefficient = 0.5`).
    pub fn point_label(&self, p: usize) -> String {
        hdf::point_label(&self.swept(), p)
    }
}

/// `name (units)`, or just `name` for dimensionless quantities.
pub fn labelled(name: &str, units: &str) -> String {
    match units {
        "" | "1" => name.to_string(),
        u => format!("{name} ({u})"),
    }
}

/// Open `stage_ref` (`STAGE` or `STAGE@vN`) of an archive.
pub fn open(archive: &Path, stage_ref: &str) -> Result<StageData> {
    let (stage, number) = crate::cli::parse_stage_ref(stage_ref)?;
    let archive = Archive::open_read(archive)?;
    let info = archive.version(&stage, number)?;
    // Figures are drawn only from a version whose stored hashes check out.
    info.check()?;
    let group = info.open()?;
    Ok(StageData { info, group })
}

/// The figures of one stage version, without writing them.
pub fn figures(data: &StageData) -> Result<Vec<Figure>> {
    match data.kind() {
        "laydown" => laydown::figures(data),
        "laid_web" => laid_web::figures(data),
        "spectra" => spectra::figures(data),
        "web" => web::figures(data),
        "grid" => grid::figures(data),
        "image" => image::figures(data),
        "accuracy" => accuracy::figures(data),
        other => bail!("no plots for stage kind `{other}` yet"),
    }
}

/// Plot a stage version into `dir` (default: [`crate::archive::figure_dir`]); returns the files written.
pub fn plot_stage(archive: &Path, stage_ref: &str, dir: Option<&Path>, format: Format) -> Result<Vec<PathBuf>> {
    let data = open(archive, stage_ref)?;
    let dir = dir.map(Path::to_path_buf).unwrap_or_else(|| crate::archive::figure_dir(archive, &data.info.stage, data.info.number));
    let figs = figures(&data)?;
    if figs.is_empty() {
        return Err(anyhow!("{}: nothing to plot", data.info.group_path()));
    }
    figs.iter().map(|f| f.save(&dir, format)).collect()
}
