//! A small figure model (line panels and colour maps) and one renderer for PNG and SVG.
//!
//! Stage plots only describe *what* to draw ([`Figure`] of [`Panel`]s); this module
//! draws it with `plotters`, so every figure of every stage looks alike and the two
//! output formats never diverge.
use anyhow::{anyhow, Context, Result};
use ndarray::Array2;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Output format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Png,
    Svg,
}

impl Format {
    pub fn extension(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Svg => "svg",
        }
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Line,
    Dashed,
    Markers,
    LineMarkers,
}

/// One curve of a line panel; `error` gives symmetric error bars (one per point).
#[derive(Debug, Clone)]
pub struct Series {
    pub label: Option<String>,
    pub points: Vec<(f64, f64)>,
    pub error: Option<Vec<f64>>,
    pub style: Style,
    /// Index into the palette; series with the same colour belong together
    /// (e.g. a quantity and its belt-removed, dashed twin).
    pub colour: usize,
    /// Thicker line (a highlighted fibre).
    pub bold: bool,
}

impl Series {
    pub fn new(label: Option<&str>, points: Vec<(f64, f64)>, style: Style, colour: usize) -> Self {
        Series { label: label.map(str::to_string), points, error: None, style, colour, bold: false }
    }
    pub fn with_error(mut self, error: Vec<f64>) -> Self {
        self.error = Some(error);
        self
    }
    pub fn bold(mut self) -> Self {
        self.bold = true;
        self
    }
}

/// A 2-D line or scatter plot.
#[derive(Debug, Clone, Default)]
pub struct LinePanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    /// Same scale on both axes (fibre shapes).
    pub equal_aspect: bool,
    pub series: Vec<Series>,
}

/// A colour map of `values[(row, col)]` where rows run along y and columns along x.
#[derive(Debug, Clone)]
pub struct MapPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// (x_min, x_max, y_min, y_max) of the whole array.
    pub extent: (f64, f64, f64, f64),
    pub values: Array2<f64>,
    pub colour_label: String,
    /// Grey levels (images) instead of viridis (densities, spectra).
    pub grey: bool,
}

#[derive(Debug, Clone)]
pub enum Panel {
    Lines(LinePanel),
    Map(MapPanel),
}

/// Panels on a grid of `columns`, each `panel_size` pixels, under a title.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File stem, e.g. `radius_of_gyration`.
    pub name: String,
    pub title: String,
    pub panels: Vec<Panel>,
    pub columns: usize,
    pub panel_size: (u32, u32),
}

impl Figure {
    pub fn new(name: &str, title: &str, panels: Vec<Panel>, columns: usize) -> Self {
        Figure { name: name.into(), title: title.into(), panels, columns: columns.max(1), panel_size: (520, 400) }
    }

    /// Write the figure to `dir/<name>.<ext>` and return the path.
    pub fn save(&self, dir: &Path, format: Format) -> Result<PathBuf> {
        ensure_font()?;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(format!("{}.{}", self.name, format.extension()));
        let size = self.canvas_size();
        match format {
            Format::Png => {
                let mut buffer = vec![255u8; size.0 as usize * size.1 as usize * 3];
                {
                    let root = BitMapBackend::with_buffer(&mut buffer, size).into_drawing_area();
                    self.draw(&root, format)?;
                    root.present().map_err(plot_err)?;
                }
                image::save_buffer(&path, &buffer, size.0, size.1, image::ExtendedColorType::Rgb8)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            Format::Svg => {
                let root = SVGBackend::new(&path, size).into_drawing_area();
                self.draw(&root, format)?;
                root.present().map_err(plot_err)?;
            }
        }
        Ok(path)
    }

    fn canvas_size(&self) -> (u32, u32) {
        let rows = self.panels.len().div_ceil(self.columns.min(self.panels.len().max(1))) as u32;
        let (pw, ph) = self.panel_size;
        // Wide enough for the title (about 11 px a character at 22 px).
        let columns = self.columns.min(self.panels.len().max(1)) as u32;
        let width = (pw * columns).max(self.title.chars().count() as u32 * 11 + 40);
        (width, ph * rows + TITLE_HEIGHT)
    }

    /// Draw onto a recording backend and return where everything went (for layout checks).
    pub fn inspect(&self) -> Result<super::inspect::Record> {
        ensure_font()?;
        super::inspect::record(self.canvas_size(), |root| self.draw(root, Format::Png))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, format: Format) -> Result<()> {
        root.fill(&WHITE).map_err(plot_err)?;
        let body = root.titled(&self.title, (FONT, 22)).map_err(plot_err)?;
        let columns = self.columns.min(self.panels.len().max(1));
        let rows = self.panels.len().div_ceil(columns);
        let cells = body.split_evenly((rows, columns));
        for (panel, area) in self.panels.iter().zip(cells.iter()) {
            match panel {
                Panel::Lines(p) => draw_lines(area, p)?,
                Panel::Map(p) => draw_map(area, p, format)?,
            }
        }
        Ok(())
    }
}

const TITLE_HEIGHT: u32 = 34;
const FONT: &str = "sans-serif";

/// Colours for series (matplotlib's tab10, so figures look familiar).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

pub fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn plot_err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

/// Labels need a TrueType font: `LAYDOWN_FONT`, else the usual system locations.
fn ensure_font() -> Result<()> {
    static FONT_STATE: OnceLock<Result<(), String>> = OnceLock::new();
    FONT_STATE
        .get_or_init(|| {
            let mut candidates: Vec<PathBuf> = vec![];
            if let Ok(p) = std::env::var("LAYDOWN_FONT") {
                candidates.push(p.into());
            }
            for p in [
                "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
                "/usr/share/fonts/TTF/DejaVuSans.ttf",
                "/usr/share/fonts/dejavu/DejaVuSans.ttf",
                "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
                "/Library/Fonts/Arial.ttf",
                "/System/Library/Fonts/Supplemental/Arial.ttf",
                "C:\\Windows\\Fonts\\arial.ttf",
            ] {
                candidates.push(p.into());
            }
            for path in &candidates {
                if let Ok(bytes) = std::fs::read(path) {
                    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                    if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
                        return Ok(());
                    }
                }
            }
            Err(format!(
                "no TrueType font for plot labels: install one (Debian: apt-get install fonts-dejavu-core) \
                 or set LAYDOWN_FONT=/path/to/font.ttf; looked in {}",
                candidates.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
            ))
        })
        .clone()
        .map_err(|e| anyhow!(e))
}

/// The label font, registered (unit tests).
#[cfg(test)]
pub fn ensure_font_for_tests() {
    ensure_font().unwrap()
}

/// Finite range of `values` padded by 5 % (or ±1 around a single value).
fn padded_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return None;
    }
    let span = hi - lo;
    let pad = if span > 0.0 { 0.05 * span } else if lo != 0.0 { 0.1 * lo.abs() } else { 1.0 };
    Some((lo - pad, hi + pad))
}

/// Engineering-style tick label.
pub fn tick(v: f64) -> String {
    let a = v.abs();
    if a < 1e-12 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

/// Range of finite values (positive ones only on a log axis), padded: 5 % of the span
/// on a linear axis, a factor 1.2 on a log axis.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    if !log {
        return padded_range(values);
    }
    let (lo, hi) = finite_range(values.filter(|v| *v > 0.0))?;
    // At least a decade, so the axis has labelled ticks.
    let widen = (10.0 / (hi / lo)).max(1.0).sqrt();
    Some((lo / 1.2 / widen, hi * 1.2 * widen))
}

fn draw_lines<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &LinePanel) -> Result<()> {
    // Ranges from the points that can be drawn on both axes (a zero has no place on a log axis).
    let usable = |x: f64, log: bool| x.is_finite() && (!log || x > 0.0);
    let drawable = |&&(x, y): &&(f64, f64)| usable(x, p.log_x) && usable(y, p.log_y);
    let all_x = p.series.iter().flat_map(|s| s.points.iter().filter(drawable).map(|&(x, _)| x));
    let all_y = p.series.iter().flat_map(|s| {
        s.points.iter().enumerate().filter(|(_, q)| drawable(q)).flat_map(move |(i, &(_, y))| {
            let e = s.error.as_ref().map(|e| e[i]).filter(|e| e.is_finite()).unwrap_or(0.0);
            [y - e, y + e, y]
        })
    });
    let (Some(mut xr), Some(mut yr)) = (axis_range(all_x, p.log_x), axis_range(all_y, p.log_y)) else {
        area.draw(&Text::new(format!("{}: no finite data", p.title), (20, 20), (FONT, 16))).map_err(plot_err)?;
        return Ok(());
    };
    let (w, h) = area.dim_in_pixel();
    if p.equal_aspect && !p.log_x && !p.log_y {
        let (pw, ph) = ((w as f64 - 100.0).max(10.0), (h as f64 - 90.0).max(10.0));
        let scale = ((xr.1 - xr.0) / pw).max((yr.1 - yr.0) / ph);
        let (cx, cy) = ((xr.0 + xr.1) / 2.0, (yr.0 + yr.1) / 2.0);
        xr = (cx - scale * pw / 2.0, cx + scale * pw / 2.0);
        yr = (cy - scale * ph / 2.0, cy + scale * ph / 2.0);
    }
    let mut builder = ChartBuilder::on(area);
    builder.caption(&p.title, (FONT, 16)).margin(10).x_label_area_size(40).y_label_area_size(64);
    let (x, y) = (xr.0..xr.1, yr.0..yr.1);
    match (p.log_x, p.log_y) {
        (false, false) => draw_series_into(builder.build_cartesian_2d(x, y).map_err(plot_err)?, p),
        (true, false) => draw_series_into(builder.build_cartesian_2d(x.log_scale(), y).map_err(plot_err)?, p),
        (false, true) => draw_series_into(builder.build_cartesian_2d(x, y.log_scale()).map_err(plot_err)?, p),
        (true, true) => {
            draw_series_into(builder.build_cartesian_2d(x.log_scale(), y.log_scale()).map_err(plot_err)?, p)
        }
    }
}

/// Draw the series of a line panel into a chart of any (linear or log) f64 axes.
fn draw_series_into<'a, DB, X, Y>(mut chart: ChartContext<'a, DB, Cartesian2d<X, Y>>, p: &LinePanel) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let usable = |x: f64, log: bool| x.is_finite() && (!log || x > 0.0);
    chart
        .configure_mesh()
        .x_desc(&p.x_label)
        .y_desc(&p.y_label)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, 13))
        .light_line_style(RGBColor(238, 238, 238))
        .draw()
        .map_err(plot_err)?;
    let mut labelled = false;
    for s in &p.series {
        let c = colour(s.colour);
        let style = ShapeStyle::from(&c).stroke_width(if s.bold { 3 } else { 1 });
        // Split at unusable points so gaps stay gaps.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![vec![]];
        for &(x, y) in &s.points {
            if usable(x, p.log_x) && usable(y, p.log_y) {
                runs.last_mut().unwrap().push((x, y));
            } else if !runs.last().unwrap().is_empty() {
                runs.push(vec![]);
            }
        }
        let dashed = s.style == Style::Dashed;
        let markers_only = s.style == Style::Markers;
        let legend = move |(x, y): (i32, i32)| -> DynElement<'static, DB, (i32, i32)> {
            if markers_only {
                Circle::new((x + 8, y), 3, style.color.filled()).into_dyn()
            } else if dashed {
                PathElement::new(vec![(x, y), (x + 6, y)], style).into_dyn()
            } else {
                PathElement::new(vec![(x, y), (x + 16, y)], style).into_dyn()
            }
        };
        let mut first = true;
        for run in runs.into_iter().filter(|r| !r.is_empty()) {
            let label = if first { s.label.as_deref() } else { None };
            first = false;
            labelled |= label.is_some();
            if !markers_only {
                let anno = if dashed {
                    chart.draw_series(DashedLineSeries::new(run.clone(), 6, 4, style)).map_err(plot_err)?
                } else {
                    chart.draw_series(LineSeries::new(run.clone(), style)).map_err(plot_err)?
                };
                if let Some(l) = label {
                    anno.label(l).legend(legend);
                }
            }
            if matches!(s.style, Style::Markers | Style::LineMarkers) {
                let anno = chart.draw_series(run.iter().map(|&q| Circle::new(q, 3, c.filled()))).map_err(plot_err)?;
                if let (Some(l), true) = (label, markers_only) {
                    anno.label(l).legend(legend);
                }
            }
        }
        if let Some(err) = &s.error {
            let bars = s.points.iter().zip(err).filter_map(|(&(x, y), &e)| {
                (usable(x, p.log_x) && usable(y - e, p.log_y) && usable(y + e, p.log_y))
                    .then(|| ErrorBar::new_vertical(x, y - e, y, y + e, style, 8))
            });
            chart.draw_series(bars).map_err(plot_err)?;
        }
    }
    if labelled {
        let corner = legend_corner(&chart, p);
        chart
            .configure_series_labels()
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .position(corner)
            .draw()
            .map_err(plot_err)?;
    }
    Ok(())
}

/// The corner of the plotting area whose quarter holds the fewest data points (upper
/// right on a tie), so the legend hides as little as possible.
fn legend_corner<'a, DB, X, Y>(chart: &ChartContext<'a, DB, Cartesian2d<X, Y>>, p: &LinePanel) -> SeriesLabelPosition
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let (xm, ym) = ((xs.start + xs.end) / 2, (ys.start + ys.end) / 2);
    let mut counts = [0usize; 4]; // upper right, upper left, lower right, lower left
    for (x, y) in p.series.iter().flat_map(|s| s.points.iter()) {
        if !(x.is_finite() && y.is_finite()) {
            continue;
        }
        let (px, py) = chart.backend_coord(&(*x, *y));
        let (right, upper) = (px >= xm, py <= ym);
        counts[match (upper, right) {
            (true, true) => 0,
            (true, false) => 1,
            (false, true) => 2,
            (false, false) => 3,
        }] += 1;
    }
    let best = (0..4).min_by_key(|&i| (counts[i], i)).unwrap_or(0);
    [SeriesLabelPosition::UpperRight, SeriesLabelPosition::UpperLeft, SeriesLabelPosition::LowerRight, SeriesLabelPosition::LowerLeft][best].clone()
}

/// Block-average `values` so neither side exceeds `max_side` cells.
fn downsample(values: &Array2<f64>, max_side: usize) -> Array2<f64> {
    let (rows, cols) = values.dim();
    let f = rows.max(cols).div_ceil(max_side).max(1);
    if f == 1 {
        return values.clone();
    }
    let (r2, c2) = (rows.div_ceil(f), cols.div_ceil(f));
    let mut sum = Array2::<f64>::zeros((r2, c2));
    let mut n = Array2::<f64>::zeros((r2, c2));
    for ((i, j), &v) in values.indexed_iter() {
        if v.is_finite() {
            sum[(i / f, j / f)] += v;
            n[(i / f, j / f)] += 1.0;
        }
    }
    ndarray::Zip::from(&mut sum).and(&n).for_each(|s, &k| *s = if k > 0.0 { *s / k } else { f64::NAN });
    sum
}

fn draw_map<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &MapPanel, format: Format) -> Result<()> {
    use plotters::style::colors::colormaps::ViridisRGB;
    let (w, _) = area.dim_in_pixel();
    let (main, bar) = area.split_horizontally(w.saturating_sub(110));
    // SVG gets at most 160 cells a side (file size); PNG at most one cell per pixel.
    let max_side = match format {
        Format::Svg => 160,
        Format::Png => (w as usize).max(16),
    };
    let values = downsample(&p.values, max_side);
    let Some((vmin, vmax)) = finite_range(values.iter().copied()) else {
        main.draw(&Text::new(format!("{}: no finite data", p.title), (20, 20), (FONT, 16))).map_err(plot_err)?;
        return Ok(());
    };
    let vmax = if vmax > vmin { vmax } else { vmin + 1.0 };
    let paint = |v: f64| -> RGBColor {
        if !v.is_finite() {
            return RGBColor(255, 255, 255);
        }
        let t = ((v - vmin) / (vmax - vmin)).clamp(0.0, 1.0);
        if p.grey {
            let g = (255.0 * t).round() as u8;
            RGBColor(g, g, g)
        } else {
            ViridisRGB.get_color(t as f32)
        }
    };
    let (x0, x1, y0, y1) = p.extent;
    let mut chart = ChartBuilder::on(&main)
        .caption(&p.title, (FONT, 16))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(&p.x_label)
        .y_desc(&p.y_label)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, 13))
        .draw()
        .map_err(plot_err)?;
    let (rows, cols) = values.dim();
    let (dx, dy) = ((x1 - x0) / cols as f64, (y1 - y0) / rows as f64);
    chart
        .draw_series(values.indexed_iter().map(|((i, j), &v)| {
            let (xa, ya) = (x0 + j as f64 * dx, y0 + i as f64 * dy);
            Rectangle::new([(xa, ya), (xa + dx, ya + dy)], paint(v).filled())
        }))
        .map_err(plot_err)?;
    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(36)
        .margin_bottom(50)
        .margin_right(6)
        .y_label_area_size(78)
        .build_cartesian_2d(0.0..1.0, vmin..vmax)
        .map_err(plot_err)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(&p.colour_label)
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, 12))
        .draw()
        .map_err(plot_err)?;
    let steps = 64;
    cb.draw_series((0..steps).map(|k| {
        let a = vmin + (vmax - vmin) * k as f64 / steps as f64;
        let b = vmin + (vmax - vmin) * (k + 1) as f64 / steps as f64;
        Rectangle::new([(0.0, a), (1.0, b)], paint((a + b) / 2.0).filled())
    }))
    .map_err(plot_err)?;
    Ok(())
}

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo <= hi).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsample_averages_blocks_and_skips_nan() {
        let a = Array2::from_shape_fn((4, 4), |(i, j)| if (i, j) == (0, 0) { f64::NAN } else { (i * 4 + j) as f64 });
        let d = downsample(&a, 2);
        assert_eq!(d.dim(), (2, 2));
        assert_eq!(d[(0, 0)], (1.0 + 4.0 + 5.0) / 3.0);
        assert_eq!(d[(1, 1)], (10.0 + 11.0 + 14.0 + 15.0) / 4.0);
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(2e-5), "2.0e-5");
        assert_eq!(tick(12.0), "12");
    }
}
