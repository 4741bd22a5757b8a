//! `laydown plot`: figures of a stage version, read back from the archive.
//!
//! Plots are made from what the archive holds (not from in-memory results), so a
//! published archive can be plotted by anyone with the `laydown` binary, no Python
//! needed. Each stage kind has one module that turns its datasets into a
//! [`figure::Figure`]; [`figure`] lays out and draws every figure alike, as PNG, SVG or
//! PDF at print size (`output` writes the files with their provenance); [`labels`]
//! names quantities physically, [`ticks`] places and formats axis ticks, and [`inspect`]
//! checks a drawn figure's layout.
//!
//! ```no_run
//! use laydown::plot::{plot_stage, figure::{Format, RenderOptions}};
//! let paths = plot_stage("results/quickstart.h5".as_ref(), "fibre", None, &[Format::Png], &RenderOptions::default()).unwrap();
//! for p in paths { println!("{}", p.display()); }
//! ```
pub mod figure;
pub mod inspect;
pub mod labels;
mod output;
pub mod ticks;
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
use figure::{Figure, Format, Provenance, RenderOptions};
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
    /// Short text naming sweep point `p` in physical labels (e.g. `friction μ = 0.5,
    /// d = 30 µm`): every swept parameter whose value differs between points, or only
    /// those that differ from the majority when parameters are swept together one at a
    /// time (as [`hdf::point_label`] chooses).
    pub fn point_label(&self, p: usize) -> String {
        point_label(&self.swept(), p)
    }
}

/// [`hdf::point_label`] with physical labels and units ([`labels::value_text`]).
pub fn point_label(swept: &[Swept], p: usize) -> String {
    let physical: Vec<Swept> = swept
        .iter()
        .map(|s| Swept {
            parameter: labels::label(&s.parameter, &s.units, &s.values).symbol,
            labels: (0..s.labels.len()).map(|q| labels::value_only(&s.parameter, &s.units, s.values.get(q).copied().unwrap_or(f64::NAN), &s.labels[q], &s.values)).collect(),
            ..s.clone()
        })
        .collect();
    hdf::point_label(&physical, p)
}

/// A swept parameter as an x axis: its label, each point's x, and for a parameter with
/// text values (`preset`, `integrator`) the categories x = 0, 1, ... stand for.
pub struct SweepAxis {
    pub label: labels::Label,
    pub x: Vec<f64>,
    pub categories: Vec<String>,
}

pub fn sweep_axis(s: &Swept) -> SweepAxis {
    let label = axis_label(s);
    let categories = categories(s);
    let scale = if categories.is_empty() { label.scale } else { 1.0 };
    let x = (0..s.labels.len()).map(|p| position(s, p) * scale).collect();
    SweepAxis { label, x, categories }
}

/// The physical axis label of a swept parameter and the factor to its display unit.
pub fn axis_label(s: &Swept) -> labels::Label {
    labels::label(&s.parameter, &s.units, &s.values)
}

/// The points of a sweep as lines along swept parameter `s` (each sorted by `s`): one
/// line per combination of the other swept parameters that vary independently of `s`
/// (a cartesian sweep), named by their values (`""` when there are none); parameters
/// swept together with `s` (zip) are no separate lines.
pub fn lines_along(swept: &[Swept], s: &Swept) -> Vec<(String, Vec<usize>)> {
    // numeric values in order; text values (a categorical parameter) in order of appearance
    let mut order: Vec<usize> = (0..s.labels.len()).collect();
    order.sort_by(|&a, &b| position(s, a).total_cmp(&position(s, b)));
    let others: Vec<&Swept> = swept.iter().filter(|t| t.name != s.name && !determined_by(s, t)).collect();
    let mut lines: Vec<(String, Vec<usize>)> = vec![];
    for &p in &order {
        let key = others
            .iter()
            .map(|t| labels::value_text(&t.parameter, &t.units, t.values.get(p).copied().unwrap_or(f64::NAN), &t.labels[p], &t.values))
            .collect::<Vec<_>>()
            .join(", ");
        match lines.iter_mut().find(|(k, _)| *k == key) {
            Some((_, ps)) => ps.push(p),
            None => lines.push((key, vec![p])),
        }
    }
    lines
}

/// Where point `p` sits along swept parameter `s`: its value, or for a parameter with
/// text values (`preset`) the index of its value among the distinct ones ([`categories`]).
pub fn position(s: &Swept, p: usize) -> f64 {
    match s.values.get(p) {
        Some(v) if v.is_finite() => *v,
        _ => categories(s).iter().position(|c| *c == s.labels[p]).map_or(f64::NAN, |i| i as f64),
    }
}

/// The distinct text values of a swept parameter in order of appearance (empty for a
/// numeric parameter).
pub fn categories(s: &Swept) -> Vec<String> {
    if s.values.iter().all(|v| v.is_finite()) {
        return vec![];
    }
    let mut out: Vec<String> = vec![];
    for l in &s.labels {
        if !out.contains(l) {
            out.push(l.clone());
        }
    }
    out
}

/// Whether `t`'s value at every point follows from `s`'s (swept together, `zip`).
fn determined_by(s: &Swept, t: &Swept) -> bool {
    let n = s.labels.len().min(t.labels.len());
    (0..n).all(|p| (0..n).all(|q| s.labels[p] != s.labels[q] || t.labels[p] == t.labels[q]))
}

/// Open `stage_ref` (`STAGE` or `STAGE@vN`) of an archive.
pub fn open(archive: &Path, stage_ref: &str) -> Result<StageData> {
    let (stage, number) = crate::archive::parse_stage_ref(stage_ref)?;
    let archive = Archive::open_read(archive)?;
    let info = archive.version(&stage, number)?;
    // Figures are drawn only from a version whose stored hashes check out.
    info.check()?;
    let group = info.open()?;
    Ok(StageData { info, group })
}

/// The figures of each stage kind, by the kind's name in [`crate::stages::registry`]
/// (which it must cover: tested).
const FIGURES: &[(&str, fn(&StageData) -> Result<Vec<Figure>>)] = &[
    ("laydown", laydown::figures),
    ("laid_web", laid_web::figures),
    ("spectra", spectra::figures),
    ("web", web::figures),
    ("grid", grid::figures),
    ("image", image::figures),
    ("accuracy", accuracy::figures),
];

/// The figures of one stage version, without writing them.
pub fn figures(data: &StageData) -> Result<Vec<Figure>> {
    match FIGURES.iter().find(|(kind, _)| *kind == data.kind()) {
        Some((_, draw)) => draw(data),
        None => bail!("no plots for stage kind `{}` yet", data.kind()),
    }
}

/// Plot a stage version into `dir` (default: [`crate::archive::figure_dir`]) in each
/// of `formats`; returns the files written.
pub fn plot_stage(archive: &Path, stage_ref: &str, dir: Option<&Path>, formats: &[Format], opts: &RenderOptions) -> Result<Vec<PathBuf>> {
    let data = open(archive, stage_ref)?;
    let dir = dir.map(Path::to_path_buf).unwrap_or_else(|| crate::archive::figure_dir(archive, &data.info.stage, data.info.number));
    let figs = figures(&data)?;
    if figs.is_empty() {
        return Err(anyhow!("{}: nothing to plot", data.info.group_path()));
    }
    let absolute = std::path::absolute(archive).unwrap_or_else(|_| archive.to_path_buf());
    let provenance = Provenance { archive: absolute.display().to_string(), stage: format!("{}@v{}", data.info.stage, data.info.number) };
    let mut written = vec![];
    for f in &figs {
        for &format in formats {
            written.push(f.save(&dir, format, opts, &provenance)?);
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registered_stage_kind_has_figures_and_no_other_kind_does() {
        let mut drawn: Vec<&str> = FIGURES.iter().map(|(kind, _)| *kind).collect();
        let mut registered = crate::stages::kinds();
        drawn.sort_unstable();
        registered.sort_unstable();
        assert_eq!(drawn, registered);
    }

    fn swept(name: &str, labels: &[&str]) -> Swept {
        let values = labels.iter().map(|l| l.parse().unwrap_or(f64::NAN)).collect();
        Swept { name: name.into(), parameter: name.into(), values, labels: labels.iter().map(|s| s.to_string()).collect(), units: "1".into() }
    }

    #[test]
    fn zipped_parameters_are_one_line_and_a_product_is_one_line_per_value() {
        let c = swept("belt_speed_ratio", &["0.02", "0.05", "0.02", "0.05"]);
        let preset = swept("preset", &["s1", "s1", "s2", "s2"]);
        let zipped = swept("dw", &["1", "2", "1", "2"]);
        assert!(!determined_by(&c, &preset), "a grid sweep: one line per preset");
        assert!(determined_by(&c, &zipped), "swept together with c: not a separate line");
        assert!(determined_by(&preset, &swept("n", &["1", "1", "2", "2"])));
        let lines = lines_along(&[c.clone(), preset.clone(), zipped], &c);
        assert_eq!(lines, vec![("spectrum = s1".to_string(), vec![0, 1]), ("spectrum = s2".to_string(), vec![2, 3])]);
        assert_eq!(point_label(&[c.clone(), preset.clone()], 2), "v_b/v_f = 0.02, spectrum = s2");
        // a parameter with text values: its categories in order of appearance
        assert_eq!(categories(&preset), ["s1", "s2"]);
        assert_eq!((position(&preset, 2), position(&c, 1)), (1.0, 0.05));
        assert_eq!(lines_along(&[c.clone(), preset.clone()], &preset), vec![("v_b/v_f = 0.02".to_string(), vec![0, 2]), ("v_b/v_f = 0.05".to_string(), vec![1, 3])]);
    }
}
