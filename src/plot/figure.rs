//! A small figure model (line panels and colour maps) and one renderer for PNG, SVG and PDF.
//!
//! Stage plots only describe *what* to draw ([`Figure`] of [`Panel`]s); this module
//! lays it out and draws it with `plotters`, so every figure of every stage looks alike
//! and the output formats never diverge (PDF is the SVG, converted).
//!
//! Layout is in points at print size ([`RenderOptions`]: page width, dpi, font): a
//! figure is as wide as the page width and as tall as its panels need. Panel titles
//! wrap to their panel's width; legends sit under their plot, never on the data; maps
//! keep the aspect ratio of their extent and share one colour scale per quantity across
//! the figure; every axis gets its ticks from [`super::ticks`], bounded by the room
//! their labels take. A figure of maps on a page too narrow for its panels side by side
//! goes on a compact sheet (`sheet`: shared colour bars and axis labels) rather than
//! stacking. [`Figure::inspect`] draws onto a recording backend for layout checks
//! ([`super::inspect`]).
use super::inspect::{self, Record};

mod sheet;
use super::ticks;
use anyhow::{anyhow, Context, Result};
use ndarray::Array2;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontTransform;
use std::path::{Path, PathBuf};

/// Output format of a figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Png,
    Svg,
    Pdf,
}

impl Format {
    pub fn extension(self) -> &'static str {
        match self {
            Format::Png => "png",
            Format::Svg => "svg",
            Format::Pdf => "pdf",
        }
    }
}

/// Print size and type of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Width of the figure on the page (mm); None: one journal column (85 mm) for a
    /// figure of one panel, the two-column page (180 mm) for more.
    pub width_mm: Option<f64>,
    /// PNG resolution at that width (dots per inch).
    pub dpi: f64,
    /// Size of axis labels, titles and legends (pt); tick labels are 0.9 of it.
    pub font_pt: f64,
    /// TrueType font file; default: `LAYDOWN_FONT`, else a system sans-serif.
    pub font: Option<PathBuf>,
}

/// Page widths (mm) of one journal column and of the two-column page.
pub const ONE_COLUMN_MM: f64 = 85.0;
pub const TWO_COLUMNS_MM: f64 = 180.0;

impl RenderOptions {
    /// The width `figure` is drawn at (mm): the one asked for, else by its panel count.
    pub fn width_for(&self, figure: &Figure) -> f64 {
        self.width_mm.unwrap_or(if figure.panels.len() == 1 { ONE_COLUMN_MM } else { TWO_COLUMNS_MM })
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions { width_mm: None, dpi: 300.0, font_pt: 8.0, font: None }
    }
}

/// Where a figure comes from, written into each file's metadata.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Provenance {
    /// Absolute path of the archive.
    pub archive: String,
    /// `stage@vN`.
    pub stage: String,
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

/// Drop the legend labels of `later` that `shown` (a panel before it in the same figure)
/// already gives with the same colour and style, so that one legend serves panels that
/// plot the same lines (ρ_av beside CV): a label repeated under every panel is read once
/// and takes room from the plots. Labels of its own (measured values only one panel has)
/// stay.
pub fn drop_repeated_labels(shown: &[Series], later: &mut [Series]) {
    for s in later.iter_mut() {
        if shown.iter().any(|f| f.label.is_some() && f.label == s.label && f.colour == s.colour && f.style == s.style) {
            s.label = None;
        }
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
    /// x takes whole numbers only (replicate, fibre): integer ticks.
    pub integer_x: bool,
    /// x is categorical: x = i is labelled `categories[i]`.
    pub categories: Vec<String>,
    pub series: Vec<Series>,
}

/// A colour map of `values[(row, col)]` where rows run along y and columns along x.
#[derive(Debug, Clone)]
pub struct MapPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// (x_min, x_max, y_min, y_max) of the whole array; drawn at this aspect ratio.
    pub extent: (f64, f64, f64, f64),
    pub values: Array2<f64>,
    /// Maps of one figure with the same colour label share one colour scale.
    pub colour_label: String,
    /// Grey levels (images) instead of viridis (densities, spectra).
    pub grey: bool,
}

#[derive(Debug, Clone)]
pub enum Panel {
    Lines(LinePanel),
    Map(MapPanel),
}

/// Panels on a grid of `columns` under a title.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File stem, e.g. `radius_of_gyration`.
    pub name: String,
    pub title: String,
    pub panels: Vec<Panel>,
    pub columns: usize,
}

impl Figure {
    pub fn new(name: &str, title: &str, panels: Vec<Panel>, columns: usize) -> Self {
        Figure { name: name.into(), title: title.into(), panels, columns: columns.max(1) }
    }

    /// Write the figure to `dir/<name>.<ext>` and return the path.
    pub fn save(&self, dir: &Path, format: Format, opts: &RenderOptions, provenance: &Provenance) -> Result<PathBuf> {
        let font = ensure_font(opts.font.as_deref())?;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(format!("{}.{}", self.name, format.extension()));
        let sc = Scale::new(opts, format, opts.width_for(self));
        let layout = self.layout(&sc);
        let size = layout.size;
        let meta = super::output::Metadata { title: self.title.clone(), provenance: provenance.clone() };
        match format {
            Format::Png => {
                let mut buffer = vec![255u8; size.0 as usize * size.1 as usize * 3];
                {
                    let root = BitMapBackend::with_buffer(&mut buffer, size).into_drawing_area();
                    self.draw(&root, &layout, &sc)?;
                    root.present().map_err(plot_err)?;
                }
                super::output::write_png(&path, &buffer, size, opts.dpi, &meta)?;
            }
            Format::Svg | Format::Pdf => {
                let mut svg = String::new();
                {
                    let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
                    self.draw(&root, &layout, &sc)?;
                    root.present().map_err(plot_err)?;
                }
                let page = (size.0 as f64 / sc.u, size.1 as f64 / sc.u);
                let bytes = if format == Format::Svg {
                    super::output::svg_with_metadata(&svg, page, &meta).into_bytes()
                } else {
                    super::output::pdf_from_svg(&svg, page, font, &meta)?
                };
                std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
            }
        }
        Ok(path)
    }

    /// Draw at `opts`' print size (as PNG) onto a recording backend and return where
    /// everything went, for layout checks.
    pub fn inspect(&self, opts: &RenderOptions) -> Result<Record> {
        ensure_font(opts.font.as_deref())?;
        let sc = Scale::new(opts, Format::Png, opts.width_for(self));
        let layout = self.layout(&sc);
        let mut maps = vec![];
        let mut record = inspect::record(layout.size, |root| {
            maps = self.draw(root, &layout, &sc)?;
            Ok(())
        })?;
        record.maps = maps;
        Ok(record)
    }

    /// Rows and columns of panels: the figure's columns, fewer when the page is too
    /// narrow for panels of at least [`MIN_PANEL_EMS`] label sizes (one journal column
    /// stacks the panels).
    fn grid(&self, sc: &Scale) -> (usize, usize) {
        let fit = ((sc.width / (MIN_PANEL_EMS * sc.font)).floor() as usize).max(1);
        let columns = self.columns.min(fit).min(self.panels.len()).max(1);
        (self.panels.len().div_ceil(columns), columns)
    }

    /// Canvas size, title lines, row heights and colour ranges; maps too many for the
    /// page width side by side as panels go on a compact [`sheet::Sheet`].
    fn layout(&self, sc: &Scale) -> Layout {
        let width = sc.width;
        let (rows, columns) = self.grid(sc);
        let cell_w = width / columns as f64;
        let title_lines = wrap(&self.title, sc.title, width - 2.0 * sc.m);
        let title_h = title_lines.len() as f64 * sc.title * 1.3 + sc.m;
        let colour_ranges = self.colour_ranges();
        if let Some(sheet) = sheet::Sheet::new(self, sc, title_h, &colour_ranges) {
            let size = (width.ceil() as u32, sheet.height.ceil() as u32);
            return Layout { size, title_lines, title_h, rows: vec![], cell_w, colour_ranges, sheet: Some(sheet) };
        }
        // Panels of a row share the caption and legend heights, so their plots line up.
        let mut rows_out = vec![Row::default(); rows];
        let mut plots = vec![0.0f64; rows];
        for (i, panel) in self.panels.iter().enumerate() {
            let (height, caption_h, legend_h) = match panel {
                Panel::Lines(p) => {
                    let l = LineLayout::new(p, sc, cell_w, None);
                    (l.height, l.caption_h, l.legend_h)
                }
                Panel::Map(p) => {
                    let l = MapLayout::new(p, sc, cell_w, None, colour_ranges[i]);
                    (l.height, l.caption_h, 0.0)
                }
            };
            let r = &mut rows_out[i / columns];
            r.caption_h = r.caption_h.max(caption_h);
            r.legend_h = r.legend_h.max(legend_h);
            plots[i / columns] = plots[i / columns].max(height - caption_h - legend_h);
        }
        for (r, plot) in rows_out.iter_mut().zip(plots) {
            r.height = r.caption_h + plot + r.legend_h;
        }
        let height = title_h + rows_out.iter().map(|r| r.height).sum::<f64>();
        Layout { size: (width.ceil() as u32, height.ceil() as u32), title_lines, title_h, rows: rows_out, cell_w, colour_ranges, sheet: None }
    }

    /// Per panel, the colour range of a map: over every map of the figure with the
    /// same colour label, so maps of one quantity can be compared.
    fn colour_ranges(&self) -> Vec<Option<(f64, f64)>> {
        self.panels
            .iter()
            .map(|p| match p {
                Panel::Map(m) => {
                    let same = self.panels.iter().filter_map(|q| match q {
                        Panel::Map(n) if n.colour_label == m.colour_label => Some(n.values.iter().copied()),
                        _ => None,
                    });
                    finite_range(same.flatten()).map(|(lo, hi)| if hi > lo { (lo, hi) } else { (lo - 0.5, lo + 0.5) })
                }
                Panel::Lines(_) => None,
            })
            .collect()
    }

    /// Draw the figure; returns the plotting areas of its maps `(x0, y0, x1, y1)`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, layout: &Layout, sc: &Scale) -> Result<Vec<Rect>> {
        root.fill(&WHITE).map_err(plot_err)?;
        let (w, _) = root.dim_in_pixel();
        for (k, line) in layout.title_lines.iter().enumerate() {
            let y = sc.m + (k as f64 + 0.5) * sc.title * 1.3;
            draw_text(root, line, sc.title, (w as f64 / 2.0, y), Pos::new(HPos::Center, VPos::Center), FontTransform::None)?;
        }
        if let Some(sheet) = &layout.sheet {
            return sheet.draw(root, self, &layout.colour_ranges, sc);
        }
        let mut maps = vec![];
        let (_, columns) = self.grid(sc);
        let mut y = layout.title_h;
        for (r, row) in layout.rows.iter().enumerate() {
            let h = row.height;
            for c in 0..columns {
                let i = r * columns + c;
                let Some(panel) = self.panels.get(i) else { break };
                let x = c as f64 * layout.cell_w;
                let cell = root.clone().shrink((x.round() as u32, y.round() as u32), (layout.cell_w.floor() as u32, h.floor() as u32));
                match panel {
                    Panel::Lines(p) => draw_lines(&cell, p, &LineLayout::new(p, sc, layout.cell_w, Some(row)), sc)?,
                    Panel::Map(p) => maps.extend(draw_map(&cell, p, &MapLayout::new(p, sc, layout.cell_w, Some(row), layout.colour_ranges[i]), sc)?),
                }
            }
            y += h;
        }
        Ok(maps)
    }
}

/// Heights of a row of panels: the whole row, its captions, its legends.
#[derive(Debug, Clone, Copy, Default)]
struct Row {
    height: f64,
    caption_h: f64,
    legend_h: f64,
}

struct Layout {
    size: (u32, u32),
    title_lines: Vec<String>,
    title_h: f64,
    rows: Vec<Row>,
    cell_w: f64,
    colour_ranges: Vec<Option<(f64, f64)>>,
    /// Maps laid out compactly (then `rows` is empty).
    sheet: Option<sheet::Sheet>,
}

/// A rectangle `(x0, y0, x1, y1)` in canvas units.
type Rect = (i32, i32, i32, i32);

/// Canvas units of one output: `u` units per point, and the sizes every figure uses.
struct Scale {
    u: f64,
    /// Canvas width.
    width: f64,
    /// Label font (axis titles, panel titles, legends), tick-label and figure-title font.
    font: f64,
    tick_font: f64,
    title: f64,
    /// Margin, and length of tick marks.
    m: f64,
    tick_len: f64,
    /// Most map cells a side (file size of vector output).
    max_map_cells: usize,
}

impl Scale {
    fn new(opts: &RenderOptions, format: Format, width_mm: f64) -> Self {
        // PNG: pixels at `dpi`; SVG and PDF: two units a point (text and lines placed on a half-point grid).
        let u = match format {
            Format::Png => opts.dpi / 72.0,
            Format::Svg | Format::Pdf => 2.0,
        };
        // plotters sizes text by its line height and writes SVG font-size as size / 1.24
        // (DejaVu's line height is 1.16 em): size at 1.24 × the point size makes the SVG's
        // em exactly `font_pt` (PNG glyphs come out about 6 % larger)
        // (plotters' axis styles take whole units: sizes are rounded up, never down)
        let font = (opts.font_pt * PLOTTERS_EM * u).ceil();
        Scale {
            u,
            width: width_mm / 25.4 * 72.0 * u,
            font,
            tick_font: (0.9 * font).ceil(),
            title: (1.15 * font).ceil(),
            m: 0.6 * font,
            tick_len: 0.35 * font,
            max_map_cells: if format == Format::Png { usize::MAX } else { 200 },
        }
    }
    /// A line width of `pt` points, in whole canvas units.
    fn stroke(&self, pt: f64) -> u32 {
        (pt * self.u).round().max(1.0) as u32
    }
    /// Space under a panel, before the next row's captions.
    fn bottom(&self) -> f64 {
        0.8 * self.font
    }
    /// Height of the x-axis label area: tick marks, tick labels, axis title.
    fn x_area(&self) -> f64 {
        2.0 * self.tick_len + 1.25 * self.tick_font + 0.3 * self.font + 1.25 * self.font
    }
    /// Width of the y-axis label area for tick labels at most `label_w` wide.
    fn y_area(&self, label_w: f64) -> f64 {
        1.25 * self.font + 0.4 * self.font + label_w + 2.0 * self.tick_len
    }
}

/// The ticks and labels of one axis.
#[derive(Debug, Clone)]
struct Axis {
    range: (f64, f64),
    log: bool,
    ticks: Vec<f64>,
    labels: Vec<String>,
}

impl Axis {
    /// Ticks along an axis `length` units long: as many as fit (`horizontal`: side by
    /// side with a gap; vertical: stacked with a gap).
    fn new(range: (f64, f64), log: bool, integer: bool, length: f64, horizontal: bool, sc: &Scale) -> Self {
        let mut chosen = None;
        for n in (2..=10).rev() {
            let t = if log { ticks::log(range.0, range.1, n) } else { ticks::linear(range.0, range.1, n, integer) };
            let labels = ticks::format(&t);
            let fits = if horizontal {
                let widest = labels.iter().map(|l| text_width(l, sc.tick_font)).fold(0.0, f64::max);
                t.len() as f64 * (widest + 1.2 * sc.font) <= length
            } else {
                t.len() as f64 * 2.2 * sc.tick_font <= length
            };
            chosen = Some((t, labels));
            if fits {
                break;
            }
        }
        let (mut ticks, mut labels) = chosen.unwrap_or_default();
        // A short axis left with one tick: the fewest ticks past one, if their labels
        // stand apart (the count bound above is stricter than the spacing needs).
        if ticks.len() < 2 && !log && range.1 > range.0 {
            if let Some(t) = (3..=10).map(|n| ticks::linear(range.0, range.1, n, integer)).find(|t| t.len() >= 2) {
                let l = ticks::format(&t);
                let spacing = length * (t[1] - t[0]) / (range.1 - range.0);
                let need = if horizontal { l.iter().map(|l| text_width(l, sc.tick_font)).fold(0.0, f64::max) + 0.5 * sc.font } else { 1.5 * sc.tick_font };
                if spacing >= need {
                    (ticks, labels) = (t, l);
                }
            }
        }
        Axis { range, log, ticks, labels }
    }
    fn categorical(categories: &[String]) -> Self {
        let n = categories.len().max(1) as f64;
        Axis { range: (-0.5, n - 0.5), log: false, ticks: (0..categories.len()).map(|i| i as f64).collect(), labels: categories.to_vec() }
    }
    fn widest(&self, sc: &Scale) -> f64 {
        self.labels.iter().map(|l| text_width(l, sc.tick_font)).fold(0.0, f64::max)
    }
    fn label_of(&self, v: f64) -> String {
        let tol = 1e-9 * (self.range.1 - self.range.0).abs().max(v.abs());
        self.ticks.iter().position(|t| (t - v).abs() <= tol.max(1e-300)).map(|i| self.labels[i].clone()).unwrap_or_default()
    }
}

/// A linear or log coordinate whose key points are an [`Axis`]' ticks (plotters' own
/// tick choice is not used).
struct Ticked {
    range: (f64, f64),
    log: bool,
    ticks: Vec<f64>,
}

impl Ticked {
    fn new(a: &Axis) -> Self {
        Ticked { range: a.range, log: a.log, ticks: a.ticks.clone() }
    }
    /// Position of `v` in [0, 1] along the axis.
    fn fraction(&self, v: f64) -> f64 {
        let (lo, hi) = self.range;
        if self.log {
            (v.ln() - lo.ln()) / (hi.ln() - lo.ln())
        } else {
            (v - lo) / (hi - lo)
        }
    }
}

impl Ranged for Ticked {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;
    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = self.fraction(*v);
        let f = if f.is_finite() { f.clamp(-10.0, 11.0) } else { -10.0 };
        (limit.0 as f64 + f * (limit.1 - limit.0) as f64).round() as i32
    }
    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        // grid lines and labels at the ticks only: no unlabelled light lines
        if hint.weight().allow_light_points() {
            vec![]
        } else {
            self.ticks.clone()
        }
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.range.0..self.range.1
    }
}

/// A legend entry's sample and the gap after it, before its label (in font sizes).
const LEGEND_SAMPLE: f64 = 2.4;
/// Distance between two legend lines (in font sizes).
const LEGEND_LINE: f64 = 1.35;

/// Where the parts of a line panel go inside its cell.
struct LineLayout {
    caption: Vec<String>,
    caption_h: f64,
    legend: Vec<Vec<(usize, f64)>>,
    /// Each series' label in the lines it is drawn in (more than one where it is wider
    /// than the panel).
    legend_labels: Vec<Vec<String>>,
    legend_h: f64,
    x: Option<Axis>,
    y: Option<Axis>,
    y_area: f64,
    /// Plot size (inside the axes).
    plot: (f64, f64),
    height: f64,
}

impl LineLayout {
    /// The layout in a cell `cw` wide; `row`: the heights of its row, or None to find
    /// the height the panel needs.
    fn new(p: &LinePanel, sc: &Scale, cw: f64, row: Option<&Row>) -> Self {
        let height = row.map(|r| r.height);
        let caption = wrap(&p.title, sc.font, cw - 2.0 * sc.m);
        let caption_h = row.map_or(caption.len() as f64 * 1.25 * sc.font + 0.3 * sc.font, |r| r.caption_h);
        // a label wider than the panel wraps under its own sample, so that it never runs
        // into the next panel
        let width = cw - 2.0 * sc.m;
        let sample = LEGEND_SAMPLE * sc.font;
        let legend_labels: Vec<Vec<String>> = p
            .series
            .iter()
            .map(|s| match &s.label {
                Some(l) if sample + text_width(l, sc.font) > width => wrap(l, sc.font, width - sample),
                Some(l) => vec![l.clone()],
                None => vec![],
            })
            .collect();
        let entries: Vec<(usize, f64, usize)> = legend_labels
            .iter()
            .enumerate()
            .filter(|(_, l)| !l.is_empty())
            .map(|(i, l)| (i, sample + l.iter().map(|t| text_width(t, sc.font)).fold(0.0, f64::max) + 1.2 * sc.font, l.len()))
            .collect();
        let legend = flow(&entries, width);
        // with the space under the panel
        let legend_h = row.map_or(legend.len() as f64 * LEGEND_LINE * sc.font + sc.bottom(), |r| r.legend_h);
        let (xr, yr) = data_ranges(p);
        let x_area = sc.x_area();
        let chart_h = |plot_h: f64| plot_h + x_area + sc.m;
        // y axis first at a provisional height, for the width of its labels
        let provisional_h = match height {
            Some(h) => h - caption_h - legend_h - x_area - sc.m,
            None => 0.55 * cw,
        };
        let (Some(mut xr), Some(mut yr)) = (xr, yr) else {
            let height = height.unwrap_or(caption_h + 4.0 * sc.font);
            return LineLayout { caption, caption_h, legend, legend_labels, legend_h, x: None, y: None, y_area: 0.0, plot: (0.0, 0.0), height };
        };
        let y0 = Axis::new(yr, p.log_y, false, provisional_h, false, sc);
        let y_area = sc.y_area(y0.widest(sc));
        let plot_w = (cw - y_area - 2.0 * sc.m).max(10.0);
        // the last x tick label is centred on the plot's right edge: room for its half
        let overhang = if p.categories.is_empty() { Axis::new(xr, p.log_x, p.integer_x, plot_w, true, sc).widest(sc) / 2.0 - sc.m } else { 0.0 };
        let plot_w = (plot_w - overhang.max(0.0)).max(10.0);
        let plot_h = match height {
            Some(h) => (h - caption_h - legend_h - x_area - sc.m).max(10.0),
            None if p.equal_aspect && !p.log_x && !p.log_y => (plot_w * (yr.1 - yr.0) / (xr.1 - xr.0)).clamp(0.25 * plot_w, 0.8 * plot_w),
            None => 0.62 * plot_w,
        };
        if p.equal_aspect && !p.log_x && !p.log_y {
            let scale = ((xr.1 - xr.0) / plot_w).max((yr.1 - yr.0) / plot_h);
            let (cx, cy) = ((xr.0 + xr.1) / 2.0, (yr.0 + yr.1) / 2.0);
            xr = (cx - scale * plot_w / 2.0, cx + scale * plot_w / 2.0);
            yr = (cy - scale * plot_h / 2.0, cy + scale * plot_h / 2.0);
        }
        let x = if p.categories.is_empty() { Axis::new(xr, p.log_x, p.integer_x, plot_w, true, sc) } else { Axis::categorical(&p.categories) };
        let y = Axis::new(yr, p.log_y, false, plot_h, false, sc);
        let y_area = sc.y_area(y.widest(sc)).max(y_area);
        let height = height.unwrap_or(caption_h + chart_h(plot_h) + legend_h);
        LineLayout { caption, caption_h, legend, legend_labels, legend_h, x: Some(x), y: Some(y), y_area, plot: (plot_w, plot_h), height }
    }
}

/// Ranges of the drawable data of a line panel (a zero has no place on a log axis),
/// padded by 5 % of the span (on a log axis, of the span of the logarithms).
fn data_ranges(p: &LinePanel) -> (Option<(f64, f64)>, Option<(f64, f64)>) {
    let usable = |x: f64, log: bool| x.is_finite() && (!log || x > 0.0);
    let drawable = |&&(x, y): &&(f64, f64)| usable(x, p.log_x) && usable(y, p.log_y);
    let all_x = p.series.iter().flat_map(|s| s.points.iter().filter(drawable).map(|&(x, _)| x));
    let all_y = p.series.iter().flat_map(|s| {
        s.points.iter().enumerate().filter(|(_, q)| drawable(q)).flat_map(move |(i, &(_, y))| {
            let e = s.error.as_ref().and_then(|e| e.get(i).copied()).filter(|e| e.is_finite()).unwrap_or(0.0);
            [y - e, y + e, y].into_iter().filter(move |v| usable(*v, p.log_y))
        })
    });
    let x = if p.categories.is_empty() { axis_range(all_x, p.log_x) } else { Some((-0.5, p.categories.len() as f64 - 0.5)) };
    (x, axis_range(all_y, p.log_y))
}

fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    let (lo, hi) = finite_range(values.filter(|v| !log || *v > 0.0))?;
    if log {
        // 5 % of the span in log space, at least a factor 1.15, so no marker sits on an axis
        let f = (hi / lo).powf(0.05).max(1.15);
        return Some(if hi > lo { (lo / f, hi * f) } else { (lo / 2.0, lo * 2.0) });
    }
    let span = hi - lo;
    let pad = if span > 0.0 { 0.05 * span } else if lo != 0.0 { 0.1 * lo.abs() } else { 1.0 };
    Some((lo - pad, hi + pad))
}

/// Group legend entries `(index, width, text lines)` into lines no wider than `width`;
/// an entry of several text lines stands alone, followed by a blank line for each further
/// text line.
fn flow(entries: &[(usize, f64, usize)], width: f64) -> Vec<Vec<(usize, f64)>> {
    let mut lines: Vec<Vec<(usize, f64)>> = vec![];
    let mut x = 0.0;
    for &(i, w, text_lines) in entries {
        if lines.is_empty() || (x + w > width && x > 0.0) || text_lines > 1 {
            lines.push(vec![]);
            x = 0.0;
        }
        lines.last_mut().unwrap().push((i, x));
        x += w;
        if text_lines > 1 {
            lines.extend(std::iter::repeat_with(Vec::new).take(text_lines - 1));
            // nothing may follow on the entry's last text line
            x = f64::INFINITY;
        }
    }
    lines
}

/// Greedy word wrap of `text` at `size` into lines at most `width` wide (a word longer
/// than the width gets a line of its own).
fn wrap(text: &str, size: f64, width: f64) -> Vec<String> {
    let mut lines: Vec<String> = vec![];
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        match lines.last_mut() {
            Some(line) if text_width(&format!("{line} {word}"), size) <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

fn text_width(text: &str, size: f64) -> f64 {
    FontDesc::new(FontFamily::Name(FONT), size, FontStyle::Normal).box_size(text).map(|(w, _)| w as f64).unwrap_or(0.6 * size * text.chars().count() as f64)
}

fn draw_text<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, text: &str, size: f64, at: (f64, f64), pos: Pos, t: FontTransform) -> Result<()> {
    let style = TextStyle::from(FontDesc::new(FontFamily::Name(FONT), size, FontStyle::Normal).transform(t)).pos(pos);
    area.draw_text(text, &style, (at.0.round() as i32, at.1.round() as i32)).map_err(plot_err)
}

/// Draw `lines` centred, one under the other, from the top of `area`; returns the area below.
fn draw_caption<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, lines: &[String], height: f64, sc: &Scale) -> Result<DrawingArea<DB, Shift>> {
    let (w, _) = area.dim_in_pixel();
    for (k, line) in lines.iter().enumerate() {
        let y = 0.3 * sc.font + (k as f64 + 0.5) * 1.25 * sc.font;
        draw_text(area, line, sc.font, (w as f64 / 2.0, y), Pos::new(HPos::Center, VPos::Center), FontTransform::None)?;
    }
    Ok(area.split_vertically(height.round() as u32).1)
}

const FONT: &str = "sans-serif";
/// Narrowest panel, in label font sizes (about 60 mm at 8 pt).
const MIN_PANEL_EMS: f64 = 17.0;
/// Ratio of a plotters font size to the em size it writes into SVG.
const PLOTTERS_EM: f64 = 1.24;

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

/// Register the label font (`path`, else `LAYDOWN_FONT`, else the usual system
/// locations) and return its bytes (embedded into PDFs).
fn ensure_font(path: Option<&Path>) -> Result<&'static [u8]> {
    use std::collections::HashMap;
    use std::sync::Mutex;
    static LOADED: Mutex<Option<HashMap<PathBuf, &'static [u8]>>> = Mutex::new(None);
    let mut candidates: Vec<PathBuf> = vec![];
    if let Some(p) = path {
        candidates.push(p.to_path_buf());
    } else {
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
    }
    let mut loaded = LOADED.lock().unwrap_or_else(|e| e.into_inner());
    let loaded = loaded.get_or_insert_with(HashMap::new);
    for p in &candidates {
        let bytes = match loaded.get(p) {
            Some(b) => *b,
            None => match std::fs::read(p) {
                Ok(bytes) => {
                    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                    loaded.insert(p.clone(), bytes);
                    bytes
                }
                Err(_) => continue,
            },
        };
        if plotters::style::register_font(FONT, FontStyle::Normal, bytes).is_ok() {
            return Ok(bytes);
        }
        if path.is_some() {
            anyhow::bail!("--font {}: not a TrueType font", p.display());
        }
    }
    Err(anyhow!(
        "no TrueType font for plot labels: install one (Debian: apt-get install fonts-dejavu-core) \
         or set LAYDOWN_FONT=/path/to/font.ttf; looked in {}",
        candidates.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    ))
}

/// The label font, registered (unit tests).
#[cfg(test)]
pub fn ensure_font_for_tests() {
    ensure_font(None).unwrap();
}

fn draw_lines<DB: DrawingBackend>(cell: &DrawingArea<DB, Shift>, p: &LinePanel, l: &LineLayout, sc: &Scale) -> Result<()> {
    let body = draw_caption(cell, &l.caption, l.caption_h, sc)?;
    let (Some(x), Some(y)) = (&l.x, &l.y) else {
        draw_text(&body, "no finite data", sc.font, (2.0 * sc.m, sc.font), Pos::new(HPos::Left, VPos::Center), FontTransform::None)?;
        return Ok(());
    };
    let (w, h) = body.dim_in_pixel();
    let (chart_area, legend_area) = body.split_vertically((h as f64 - l.legend_h).max(1.0).round() as u32);
    let mut builder = ChartBuilder::on(&chart_area);
    builder
        .margin_top(sc.m.round() as u32)
        .margin_left(sc.m.round() as u32)
        .margin_right((w as f64 - sc.m - l.y_area - l.plot.0).max(0.0).round() as u32)
        .margin_bottom(0)
        .x_label_area_size(sc.x_area().round() as u32)
        .y_label_area_size(l.y_area.round() as u32);
    draw_series_into(builder.build_cartesian_2d(Ticked::new(x), Ticked::new(y)).map_err(plot_err)?, p, x, y, sc)?;
    draw_legend(&legend_area, p, l, sc)
}

/// The axes of a chart: key points from `x` and `y`, labels in their notation.
fn draw_axes<'a, DB, X, Y>(chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>, x_label: &str, y_label: &str, x: &Axis, y: &Axis, grid: bool, sc: &Scale) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let (fx, fy) = (|v: &f64| x.label_of(*v), |v: &f64| y.label_of(*v));
    let (px, py) = chart.plotting_area().get_pixel_range();
    let (x_label, y_label) = (fit_axis_label(x_label, (px.end - px.start) as f64, sc), fit_axis_label(y_label, (py.end - py.start) as f64, sc));
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .label_style((FONT, sc.tick_font))
        .axis_desc_style((FONT, sc.font))
        .set_all_tick_mark_size(sc.tick_len.round() as i32)
        .axis_style(ShapeStyle::from(&BLACK).stroke_width(sc.stroke(0.6)))
        .bold_line_style(ShapeStyle::from(&RGBColor(232, 232, 232)).stroke_width(sc.stroke(0.4)))
        .light_line_style(TRANSPARENT);
    if !grid {
        mesh.disable_mesh();
    }
    mesh.draw().map_err(plot_err)
}

/// An axis title that fits along an axis `length` long: as it is, or without its
/// description when too long (`y, cross direction (mm)` → `y (mm)`).
fn fit_axis_label(label: &str, length: f64, sc: &Scale) -> String {
    if text_width(label, sc.font) <= length {
        return label.to_string();
    }
    match label.split_once(", ") {
        Some((symbol, rest)) => match rest.rfind(" (") {
            Some(i) if rest.ends_with(')') => format!("{symbol}{}", &rest[i..]),
            _ => symbol.to_string(),
        },
        None => label.to_string(),
    }
}

/// A polyline cut into pieces of at most [`LINE_PIECE`] points, each starting at the
/// last point of the one before, so that no piece crosses itself.
fn line_pieces(run: &[(f64, f64)]) -> impl Iterator<Item = &[(f64, f64)]> {
    let step = LINE_PIECE - 1;
    (0..run.len().saturating_sub(1).max(1)).step_by(step).map(move |start| &run[start..(start + LINE_PIECE).min(run.len())])
}

/// Points per piece of a drawn polyline (see [`line_pieces`]).
const LINE_PIECE: usize = 4;

/// Draw the series of a line panel into a chart of any (linear or log) f64 axes.
fn draw_series_into<'a, DB, X, Y>(mut chart: ChartContext<'a, DB, Cartesian2d<X, Y>>, p: &LinePanel, x: &Axis, y: &Axis, sc: &Scale) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    draw_axes(&mut chart, &p.x_label, &p.y_label, x, y, true, sc)?;
    let usable = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    for s in &p.series {
        let c = colour(s.colour);
        let style = ShapeStyle::from(&c).stroke_width(sc.stroke(if s.bold { 1.8 } else { 0.9 }));
        let points = &s.points;
        // Split at unusable points so gaps stay gaps.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![vec![]];
        for &(a, b) in points {
            if usable(a, p.log_x) && usable(b, p.log_y) {
                runs.last_mut().unwrap().push((a, b));
            } else if !runs.last().unwrap().is_empty() {
                runs.push(vec![]);
            }
        }
        let radius = (1.8 * sc.u).round().max(1.0) as u32;
        // Categories (a preset, an integrator) have no order between them: no joining lines;
        // a dashed twin becomes hollow markers.
        let categorical = !p.categories.is_empty();
        for run in runs.into_iter().filter(|r| !r.is_empty()) {
            if categorical {
                match s.style {
                    Style::Dashed => chart.draw_series(run.iter().map(|&q| Circle::new(q, radius + 1, style))).map_err(plot_err)?,
                    _ => chart.draw_series(run.iter().map(|&q| Circle::new(q, radius, c.filled()))).map_err(plot_err)?,
                };
                continue;
            }
            match s.style {
                Style::Dashed => {
                    let (dash, gap) = ((3.5 * sc.u).round() as u32, (2.0 * sc.u).round() as u32);
                    chart.draw_series(DashedLineSeries::new(run.clone(), dash, gap, style)).map_err(plot_err)?;
                }
                Style::Line | Style::LineMarkers => {
                    // A thick line is filled as one polygon (even-odd): where a long path
                    // crosses itself (a laid fibre's loops) the crossing would be left
                    // blank. Short overlapping pieces cannot cross themselves.
                    for piece in line_pieces(&run) {
                        chart.draw_series(LineSeries::new(piece.iter().copied(), style)).map_err(plot_err)?;
                    }
                }
                Style::Markers => {}
            }
            if matches!(s.style, Style::Markers | Style::LineMarkers) {
                chart.draw_series(run.iter().map(|&q| Circle::new(q, radius, c.filled()))).map_err(plot_err)?;
            }
        }
        if let Some(err) = &s.error {
            let bars = points
                .iter()
                .zip(err)
                .filter(|&(&(a, b), &e)| e.is_finite() && e > 0.0 && usable(a, p.log_x) && usable(b - e, p.log_y) && usable(b + e, p.log_y))
                .map(|(&(a, b), &e)| ErrorBar::new_vertical(a, b - e, b, b + e, style, (3.0 * sc.u).round() as u32));
            chart.draw_series(bars).map_err(plot_err)?;
        }
    }
    Ok(())
}

/// A legend label's text lines beside its sample at (x, y), one under the other.
fn draw_label<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, lines: &[String], sc: &Scale, x: f64, y: f64) -> Result<()> {
    for (j, line) in lines.iter().enumerate() {
        draw_text(area, line, sc.font, (x + LEGEND_SAMPLE * sc.font, y + j as f64 * LEGEND_LINE * sc.font), Pos::new(HPos::Left, VPos::Center), FontTransform::None)?;
    }
    Ok(())
}

/// The legend under a plot: a sample of each labelled series and its label, in lines.
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &LinePanel, l: &LineLayout, sc: &Scale) -> Result<()> {
    for (k, line) in l.legend.iter().enumerate() {
        let y = 0.3 * sc.font + (k as f64 + 0.5) * LEGEND_LINE * sc.font;
        for &(i, x) in line {
            let s = &p.series[i];
            let x = sc.m + x;
            let c = colour(s.colour);
            let style = ShapeStyle::from(&c).stroke_width(sc.stroke(if s.bold { 1.8 } else { 0.9 }));
            let (a, b, yi) = (x.round() as i32, (x + 1.8 * sc.font).round() as i32, y.round() as i32);
            let radius = (1.8 * sc.u).round().max(1.0) as u32;
            if !p.categories.is_empty() {
                match s.style {
                    Style::Dashed => area.draw(&Circle::new(((a + b) / 2, yi), radius + 1, style)).map_err(plot_err)?,
                    _ => area.draw(&Circle::new(((a + b) / 2, yi), radius, c.filled())).map_err(plot_err)?,
                }
                draw_label(area, &l.legend_labels[i], sc, x, y)?;
                continue;
            }
            match s.style {
                Style::Dashed => {
                    let third = (b - a) / 3;
                    area.draw(&PathElement::new(vec![(a, yi), (a + third, yi)], style)).map_err(plot_err)?;
                    area.draw(&PathElement::new(vec![(b - third, yi), (b, yi)], style)).map_err(plot_err)?;
                }
                Style::Line | Style::LineMarkers => area.draw(&PathElement::new(vec![(a, yi), (b, yi)], style)).map_err(plot_err)?,
                Style::Markers => {}
            }
            if matches!(s.style, Style::Markers | Style::LineMarkers) {
                area.draw(&Circle::new(((a + b) / 2, yi), (1.8 * sc.u).round().max(1.0) as u32, c.filled())).map_err(plot_err)?;
            }
            draw_label(area, &l.legend_labels[i], sc, x, y)?;
        }
    }
    Ok(())
}

/// Where the parts of a map panel go inside its cell.
struct MapLayout {
    caption: Vec<String>,
    caption_h: f64,
    x: Axis,
    y: Axis,
    colour: Option<Axis>,
    /// The colour bar's title in lines (rotated, side by side).
    colour_title: Vec<String>,
    y_area: f64,
    plot: (f64, f64),
    height: f64,
}

impl MapLayout {
    fn new(p: &MapPanel, sc: &Scale, cw: f64, row: Option<&Row>, range: Option<(f64, f64)>) -> Self {
        let height = row.map(|r| r.height);
        let caption = wrap(&p.title, sc.font, cw - 2.0 * sc.m);
        let caption_h = row.map_or(caption.len() as f64 * 1.25 * sc.font + 0.3 * sc.font, |r| r.caption_h);
        let (x0, x1, y0, y1) = p.extent;
        let aspect = ((y1 - y0) / (x1 - x0)).abs();
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let provisional = Axis::new((y0, y1), false, false, 0.5 * cw, false, sc);
        let y_area = sc.y_area(provisional.widest(sc));
        let avail_h = match height {
            Some(h) => (h - caption_h - sc.x_area() - sc.m - sc.bottom()).max(10.0),
            None => 1.1 * cw,
        };
        // the largest plot of the extent's aspect ratio that fits beside its colour bar,
        // whose title wraps to the bar's height (a flat map has a short bar)
        let fit = |label_lines: usize| {
            let colour = range.map(|r| Axis::new(r, false, false, 0.6 * cw, false, sc));
            let bar_w = colour.as_ref().map_or(0.0, |c| colour_bar_width(c, label_lines, sc));
            let avail_w = (cw - y_area - 2.0 * sc.m - bar_w).max(10.0);
            let plot_w = avail_w.min(avail_h / aspect);
            (plot_w, plot_w * aspect)
        };
        let mut plot = fit(1);
        let mut colour_title = wrap(&p.colour_label, sc.font, plot.1);
        if colour_title.len() > 1 {
            plot = fit(colour_title.len());
            colour_title = wrap(&p.colour_label, sc.font, plot.1);
        }
        let x = Axis::new((x0, x1), false, false, plot.0, true, sc);
        let y = Axis::new((y0, y1), false, false, plot.1, false, sc);
        let colour = range.map(|r| Axis::new(r, false, false, plot.1, false, sc));
        let y_area = sc.y_area(y.widest(sc));
        let height = height.unwrap_or(caption_h + sc.m + plot.1 + sc.x_area() + sc.bottom());
        MapLayout { caption, caption_h, x, y, colour, colour_title, y_area, plot, height }
    }
}

/// Room a colour bar takes right of its map: gap, bar, ticks, labels, title.
fn colour_bar_width(c: &Axis, label_lines: usize, sc: &Scale) -> f64 {
    0.8 * sc.font + 0.9 * sc.font + 2.0 * sc.tick_len + c.widest(sc) + 0.5 * sc.font + 1.25 * sc.font * label_lines as f64 + sc.m
}

/// Block-average `values` so neither side exceeds `max_side` cells.
fn downsample(values: &Array2<f64>, max_side: usize) -> Array2<f64> {
    let (rows, cols) = values.dim();
    let f = rows.max(cols).div_ceil(max_side.max(1)).max(1);
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

/// Colour of `t` in [0, 1]: grey levels, or viridis.
fn paint(t: f64, grey: bool) -> RGBColor {
    use plotters::style::colors::colormaps::ViridisRGB;
    if !t.is_finite() {
        return RGBColor(255, 255, 255);
    }
    let t = t.clamp(0.0, 1.0);
    if grey {
        let g = (255.0 * t).round() as u8;
        RGBColor(g, g, g)
    } else {
        ViridisRGB.get_color(t as f32)
    }
}

/// Draw a map panel in its cell; returns its plotting area.
fn draw_map<DB: DrawingBackend>(cell: &DrawingArea<DB, Shift>, p: &MapPanel, l: &MapLayout, sc: &Scale) -> Result<Option<Rect>> {
    let body = draw_caption(cell, &l.caption, l.caption_h, sc)?;
    let Some(colour) = &l.colour else {
        draw_text(&body, "no finite data", sc.font, (2.0 * sc.m, sc.font), Pos::new(HPos::Left, VPos::Center), FontTransform::None)?;
        return Ok(None);
    };
    let (w, h) = body.dim_in_pixel();
    let right = w as f64 - sc.m - l.y_area - l.plot.0;
    let mut chart = ChartBuilder::on(&body)
        .margin_top(sc.m.round() as u32)
        .margin_left(sc.m.round() as u32)
        .margin_right(right.max(0.0).round() as u32)
        .margin_bottom((h as f64 - sc.m - l.plot.1 - sc.x_area()).max(0.0).round() as u32)
        .x_label_area_size(sc.x_area().round() as u32)
        .y_label_area_size(l.y_area.round() as u32)
        .build_cartesian_2d(Ticked::new(&l.x), Ticked::new(&l.y))
        .map_err(plot_err)?;
    draw_axes(&mut chart, &p.x_label, &p.y_label, &l.x, &l.y, false, sc)?;
    paint_map(&mut chart, p, colour.range, l.plot, sc)?;
    let (vmin, vmax) = colour.range;
    // The colour bar, right of the plot, as tall as it.
    let (px, py) = chart.plotting_area().get_pixel_range();
    let plot_rect = (px.start, py.start, px.end, py.end);
    let (ox, oy) = cell.get_base_pixel();
    let (bx, top, bottom) = ((px.end - ox) as f64 + 0.8 * sc.font, (py.start - oy) as f64, (py.end - oy) as f64);
    let bar_w = 0.9 * sc.font;
    let steps = 128;
    for k in 0..steps {
        let (a, b) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
        let (ya, yb) = (bottom - a * (bottom - top), bottom - b * (bottom - top));
        let rect = Rectangle::new([(bx.round() as i32, yb.floor() as i32), ((bx + bar_w).round() as i32, ya.ceil() as i32)], paint((a + b) / 2.0, p.grey).filled());
        cell.draw(&rect).map_err(plot_err)?;
    }
    let frame = ShapeStyle::from(&BLACK).stroke_width(sc.stroke(0.6));
    cell.draw(&Rectangle::new([(bx.round() as i32, top.round() as i32), ((bx + bar_w).round() as i32, bottom.round() as i32)], frame)).map_err(plot_err)?;
    let x_tick = bx + bar_w;
    for (t, label) in colour.ticks.iter().zip(&colour.labels) {
        let y = bottom - (t - vmin) / (vmax - vmin) * (bottom - top);
        cell.draw(&PathElement::new(vec![(x_tick.round() as i32, y.round() as i32), ((x_tick + sc.tick_len).round() as i32, y.round() as i32)], frame)).map_err(plot_err)?;
        draw_text(cell, label, sc.tick_font, (x_tick + 2.0 * sc.tick_len, y), Pos::new(HPos::Left, VPos::Center), FontTransform::None)?;
    }
    let label_x = x_tick + 2.0 * sc.tick_len + colour.widest(sc) + 0.5 * sc.font;
    for (k, line) in l.colour_title.iter().enumerate() {
        draw_text(cell, line, sc.font, (label_x + k as f64 * 1.25 * sc.font, (top + bottom) / 2.0), Pos::new(HPos::Center, VPos::Top), FontTransform::Rotate270)?;
    }
    Ok(Some(plot_rect))
}

/// Paint the values of a map into its chart, coloured over `range` (`plot`: the plot's
/// size, which bounds the cells drawn).
fn paint_map<DB: DrawingBackend>(chart: &mut ChartContext<'_, DB, Cartesian2d<Ticked, Ticked>>, p: &MapPanel, range: (f64, f64), plot: (f64, f64), sc: &Scale) -> Result<()> {
    let (x0, x1, y0, y1) = p.extent;
    let max_side = sc.max_map_cells.min(plot.0.max(plot.1).ceil() as usize).max(16);
    let values = downsample(&p.values, max_side);
    let (vmin, vmax) = range;
    let (rows, cols) = values.dim();
    let (dx, dy) = ((x1 - x0) / cols as f64, (y1 - y0) / rows as f64);
    chart
        .draw_series(values.indexed_iter().map(|((i, j), &v)| {
            let (xa, ya) = (x0 + j as f64 * dx, y0 + i as f64 * dy);
            Rectangle::new([(xa, ya), (xa + dx, ya + dy)], paint((v - vmin) / (vmax - vmin), p.grey).filled())
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
    fn line_pieces_draw_every_segment_once_and_are_short() {
        for n in [1usize, 2, 3, 4, 5, 7, 10, 101] {
            let run: Vec<(f64, f64)> = (0..n).map(|i| (i as f64, 0.0)).collect();
            let pieces: Vec<&[(f64, f64)]> = line_pieces(&run).collect();
            assert!(pieces.iter().all(|p| !p.is_empty() && p.len() <= LINE_PIECE), "{n}");
            let mut segments: Vec<usize> = pieces.iter().flat_map(|p| p.windows(2).map(|w| w[0].0 as usize)).collect();
            segments.sort();
            assert_eq!(segments, (0..n.saturating_sub(1)).collect::<Vec<_>>(), "{n}: each segment drawn exactly once");
            assert_eq!(pieces.concat().first(), run.first());
        }
    }

    #[test]
    fn downsample_averages_blocks_and_skips_nan() {
        let a = Array2::from_shape_fn((4, 4), |(i, j)| if (i, j) == (0, 0) { f64::NAN } else { (i * 4 + j) as f64 });
        let d = downsample(&a, 2);
        assert_eq!(d.dim(), (2, 2));
        assert_eq!(d[(0, 0)], (1.0 + 4.0 + 5.0) / 3.0);
        assert_eq!(d[(1, 1)], (10.0 + 11.0 + 14.0 + 15.0) / 4.0);
    }

    #[test]
    fn maps_of_one_quantity_share_a_colour_range_and_keep_their_aspect() {
        ensure_font_for_tests();
        let map = |scale: f64, label: &str| {
            Panel::Map(MapPanel {
                title: "m".into(),
                x_label: "x (mm)".into(),
                y_label: "y (mm)".into(),
                extent: (0.0, 871.0, 0.0, 617.0),
                values: Array2::from_shape_fn((62, 87), |(i, j)| scale * (i + j) as f64),
                colour_label: label.into(),
                grey: true,
            })
        };
        let fig = Figure::new("f", "t", vec![map(1.0, "a"), map(2.0, "a"), map(1.0, "b")], 3);
        let r = fig.colour_ranges();
        assert_eq!(r[0], r[1]);
        assert_eq!(r[0], Some((0.0, 2.0 * (61 + 86) as f64)));
        assert_eq!(r[2], Some((0.0, (61 + 86) as f64)));
        // three panels: the two-column page unless a width is asked for; one panel: a column
        let opts = RenderOptions::default();
        assert_eq!(opts.width_for(&fig), TWO_COLUMNS_MM);
        assert_eq!(opts.width_for(&Figure::new("g", "t", vec![map(1.0, "a")], 1)), ONE_COLUMN_MM);
        assert_eq!(RenderOptions { width_mm: Some(120.0), ..opts }.width_for(&fig), 120.0);
        let sc = Scale::new(&RenderOptions::default(), Format::Png, TWO_COLUMNS_MM);
        let Panel::Map(p) = &fig.panels[0] else { unreachable!() };
        let tall = Row { height: 2000.0, caption_h: 40.0, legend_h: 0.0 };
        for row in [None, Some(&tall)] {
            let l = MapLayout::new(p, &sc, 700.0, row, r[0]);
            assert!((l.plot.1 / l.plot.0 - 617.0 / 871.0).abs() < 1e-9, "{:?}", l.plot);
        }
    }

    #[test]
    fn print_size_gives_the_dpi_and_the_font_asked_for() {
        let sc = Scale::new(&RenderOptions::default(), Format::Png, TWO_COLUMNS_MM);
        // 180 mm at 300 dpi, 8 pt at 300 dpi
        assert_eq!(sc.width.round(), (180.0 / 25.4 * 300.0f64).round());
        assert!((sc.font / PLOTTERS_EM - 8.0 * 300.0 / 72.0).abs() < 1.0);
        assert!(sc.tick_font / PLOTTERS_EM / sc.u >= 7.0, "tick labels of at least 7 pt");
    }

    #[test]
    fn axis_titles_lose_their_description_when_the_axis_is_short() {
        ensure_font_for_tests();
        let sc = Scale::new(&RenderOptions::default(), Format::Png, TWO_COLUMNS_MM);
        assert_eq!(fit_axis_label("y, cross direction (mm)", 2000.0, &sc), "y, cross direction (mm)");
        assert_eq!(fit_axis_label("y, cross direction (mm)", 100.0, &sc), "y (mm)");
        assert_eq!(fit_axis_label("x, machine direction", 100.0, &sc), "x");
    }

    #[test]
    fn a_short_axis_keeps_two_ticks_when_their_labels_stand_apart() {
        ensure_font_for_tests();
        let sc = Scale::new(&RenderOptions::default(), Format::Png, ONE_COLUMN_MM);
        // a spectrum's ±Nyquist on a 29 mm map: −0.2, 0.0, 0.2 rather than 0 alone
        let a = Axis::new((-0.255, 0.245), false, false, 29.0 / 25.4 * 72.0 * sc.u, true, &sc);
        assert!(a.ticks.len() >= 2, "{:?}", a.labels);
        // too short for two labels apart: one tick
        let b = Axis::new((-0.255, 0.245), false, false, 3.0 * sc.font, true, &sc);
        assert_eq!(b.ticks.len(), 1, "{:?}", b.labels);
    }

    /// Only an exact repeat (same text, colour and style) of an earlier panel's label
    /// leaves the legend.
    #[test]
    fn a_label_another_panel_shows_alike_is_dropped() {
        let line = |label: &str, style, colour| Series::new(Some(label), vec![(0.0, 1.0), (1.0, 2.0)], style, colour);
        let shown = vec![line("c = 0.05", Style::LineMarkers, 0), line("c = 0.1", Style::LineMarkers, 1), line("measured (Table 4)", Style::Markers, 3)];
        let mut later = vec![
            line("c = 0.05", Style::LineMarkers, 0),
            line("c = 0.1", Style::LineMarkers, 2),
            line("measured CV_corr (Table 4)", Style::Markers, 3),
            line("c = 0.05", Style::Dashed, 0),
        ];
        drop_repeated_labels(&shown, &mut later);
        let labels: Vec<Option<&str>> = later.iter().map(|s| s.label.as_deref()).collect();
        // only the exact repeat goes: another colour, another style or another text stays
        assert_eq!(labels, [None, Some("c = 0.1"), Some("measured CV_corr (Table 4)"), Some("c = 0.05")]);
    }

    /// A legend label wider than its panel wraps under its sample instead of running into
    /// the next panel, and the legend grows by its extra lines; short labels still share a
    /// line.
    #[test]
    fn long_legend_labels_wrap_within_their_panel() {
        ensure_font_for_tests();
        let sc = Scale::new(&RenderOptions::default(), Format::Png, TWO_COLUMNS_MM);
        let long = "air speed = 10 m/s, v_b = 0.25 m/s, belt travel = 130 mm, v_f = 5 m/s, friction μ = 1";
        let series = |labels: &[&str]| labels.iter().enumerate().map(|(i, l)| Series::new(Some(l), vec![(0.0, 1.0), (1.0, 2.0)], Style::LineMarkers, i)).collect();
        let panel = |labels: &[&str]| LinePanel { title: "CV".into(), x_label: "f (Hz)".into(), y_label: "CV".into(), log_x: false, log_y: false, equal_aspect: false, integer_x: false, categories: vec![], series: series(labels) };
        let cw = 600.0;
        let l = LineLayout::new(&panel(&[long, "short", long]), &sc, cw, None);
        let inside = cw - 2.0 * sc.m;
        for (i, labels) in l.legend_labels.iter().enumerate() {
            assert!(labels.iter().all(|t| LEGEND_SAMPLE * sc.font + text_width(t, sc.font) <= inside), "label {i} runs out of the panel: {labels:?}");
        }
        let wrapped = l.legend_labels[0].len();
        assert!(wrapped > 1, "{:?}", l.legend_labels[0]);
        // each long label its own rows, the short one a row of its own between them
        assert_eq!(l.legend.len(), 2 * wrapped + 1);
        assert_eq!(l.legend[0], vec![(0, 0.0)]);
        assert_eq!(l.legend[wrapped], vec![(1, 0.0)]);
        let short = LineLayout::new(&panel(&["a", "b", "c"]), &sc, cw, None);
        assert_eq!(short.legend.len(), 1, "three short labels share one line");
    }

    #[test]
    fn long_titles_wrap_within_their_width() {
        ensure_font_for_tests();
        let lines = wrap("friction μ = 0.5, d = 30 µm, replicate 0, belt motion removed", 30.0, 400.0);
        assert!(lines.len() > 1);
        assert!(lines.iter().all(|l| text_width(l, 30.0) <= 400.0), "{lines:?}");
    }
}
