//! Maps on a compact sheet: the layout of a figure of maps only when the page is too
//! narrow for its columns of panels (one journal column for a 2 × 2 figure of maps).
//!
//! Side by side as panels, each map carries its own y axis and colour bar, and a panel
//! needs about [`MIN_PANEL_EMS`] label sizes; stacked, four maps are taller than a page.
//! On a sheet the maps keep the figure's columns and share what they have in common:
//! - one colour bar per quantity, under the rows of maps that show it (a sheet is made
//!   only when each row shows one quantity), as wide as the maps;
//! - y tick labels and title only left of a map whose left neighbour has another y extent
//!   or label (so only on the first column when a row's maps share their extent);
//! - x tick labels and title only under a map whose neighbour below has another x extent
//!   or label (so only under the last row of maps sharing theirs).
//!
//! Maps keep the aspect ratio of their extent, and are at least [`MIN_MAP_EMS`] label
//! sizes wide (else the figure keeps its panels, stacked).
use super::*;

/// Narrowest map of a sheet, in label font sizes (28 mm at 8 pt, 24.5 mm at 7 pt).
pub(super) const MIN_MAP_EMS: f64 = 8.0;
/// Tallest map of a sheet, in widths of its column (a tall extent is drawn narrower).
const MAX_MAP_ASPECT: f64 = 1.5;

/// Where every part of a sheet goes, in canvas units.
pub(super) struct Sheet {
    /// Bottom of the sheet: the canvas height.
    pub height: f64,
    cells: Vec<Cell>,
    bars: Vec<Bar>,
}

/// One map of a sheet.
struct Cell {
    /// Index of its panel in the figure.
    panel: usize,
    /// Plotting area: left, top, width, height.
    plot: (f64, f64, f64, f64),
    x: Axis,
    y: Axis,
    /// Height of its x label area and width of its y label area (0: not drawn).
    x_area: f64,
    y_area: f64,
    caption: Vec<String>,
    caption_top: f64,
}

/// A horizontal colour bar shared by the maps above it.
struct Bar {
    left: f64,
    right: f64,
    top: f64,
    axis: Axis,
    title: Vec<String>,
    grey: bool,
}

impl Sheet {
    /// A sheet for `fig` (its title `top` high), or None when its panels are laid out as
    /// they are: not all maps, fewer than two, the page wide enough for its columns of
    /// panels, a row of maps with two quantities, or maps narrower than [`MIN_MAP_EMS`].
    pub(super) fn new(fig: &Figure, sc: &Scale, top: f64, ranges: &[Option<(f64, f64)>]) -> Option<Self> {
        let maps: Vec<&MapPanel> = fig
            .panels
            .iter()
            .map(|p| match p {
                Panel::Map(m) => Some(m),
                Panel::Lines(_) => None,
            })
            .collect::<Option<_>>()?;
        let want = fig.columns.min(maps.len());
        if maps.len() < 2 || want < 2 || fig.grid(sc).1 >= want {
            return None;
        }
        (2..=want).rev().find_map(|c| Self::with_columns(&maps, c, sc, top, ranges))
    }

    fn with_columns(maps: &[&MapPanel], c: usize, sc: &Scale, top: f64, ranges: &[Option<(f64, f64)>]) -> Option<Self> {
        let n = maps.len();
        let rows = n.div_ceil(c);
        let row = |r: usize| r * c..((r + 1) * c).min(n);
        if (0..rows).any(|r| row(r).any(|i| maps[i].colour_label != maps[r * c].colour_label)) {
            return None;
        }
        let same_x = |a: &MapPanel, b: &MapPanel| (a.extent.0, a.extent.1) == (b.extent.0, b.extent.1) && a.x_label == b.x_label;
        let same_y = |a: &MapPanel, b: &MapPanel| (a.extent.2, a.extent.3) == (b.extent.2, b.extent.3) && a.y_label == b.y_label;
        let show_x: Vec<bool> = (0..n).map(|i| !(i + c < n && same_x(maps[i], maps[i + c]))).collect();
        let show_y: Vec<bool> = (0..n).map(|i| i % c == 0 || !same_y(maps[i], maps[i - 1])).collect();
        let aspect: Vec<f64> = maps
            .iter()
            .map(|m| {
                let (x0, x1, y0, y1) = m.extent;
                let a = ((y1 - y0) / (x1 - x0)).abs();
                if a.is_finite() && a > 0.0 { a } else { 1.0 }
            })
            .collect();
        // A row ends a colour group when the next row shows another quantity: its bar goes under it.
        let ends_group = |r: usize| r + 1 == rows || maps[(r + 1) * c].colour_label != maps[r * c].colour_label;
        let bar_range = |r: usize| ranges[r * c];

        // Map width, label areas and gaps depend on each other (ticks fit their axis'
        // length): from the widest maps down, a few rounds.
        let gap = 0.8 * sc.font;
        let mut w = (sc.width - 2.0 * sc.m) / c as f64;
        let geometry = |w: f64| {
            let plots: Vec<(f64, f64)> = aspect.iter().map(|&a| {
                let pw = w.min(MAX_MAP_ASPECT * w / a);
                (pw, pw * a)
            }).collect();
            let xs: Vec<Axis> = maps.iter().zip(&plots).map(|(m, p)| Axis::new((m.extent.0, m.extent.1), false, false, p.0, true, sc)).collect();
            let ys: Vec<Axis> = maps.iter().zip(&plots).map(|(m, p)| Axis::new((m.extent.2, m.extent.3), false, false, p.1, false, sc)).collect();
            // How far the x tick labels of each column reach beyond its maps, left and right.
            let (mut left, mut right, mut y_area) = (vec![0.0f64; c], vec![0.0f64; c], vec![0.0f64; c]);
            for i in 0..n {
                if show_x[i] {
                    let (l, r) = overhang(&xs[i], plots[i].0, sc);
                    left[i % c] = left[i % c].max(l);
                    right[i % c] = right[i % c].max(r);
                }
                if show_y[i] {
                    y_area[i % c] = y_area[i % c].max(sc.y_area(ys[i].widest(sc)));
                }
            }
            // Left of each column: its y label area, and room for the x tick labels
            // overhanging the maps' edges (of the column before, and of this one).
            let gutters: Vec<f64> = (0..c)
                .map(|k| match k {
                    0 => sc.m + y_area[0].max(left[0]),
                    _ if y_area[k] > 0.0 => right[k - 1] + 0.3 * sc.font + y_area[k].max(left[k]),
                    _ => gap.max(right[k - 1] + left[k] + 0.6 * sc.font),
                })
                .collect();
            // The colour bars span the maps; their end labels may overhang them too.
            let span = c as f64 * w + gutters[1..].iter().sum::<f64>();
            let bar_right = (0..rows)
                .filter(|&r| ends_group(r))
                .filter_map(bar_range)
                .map(|range| overhang(&Axis::new(range, false, false, span, true, sc), span, sc).1)
                .fold(0.0, f64::max);
            let margin = sc.m.max(right[c - 1].max(bar_right) + 0.3 * sc.font);
            (plots, xs, ys, y_area, gutters, margin)
        };
        for _ in 0..4 {
            let (_, _, _, _, gutters, right) = geometry(w);
            let next = (sc.width - gutters.iter().sum::<f64>() - right) / c as f64;
            let done = (next - w).abs() < 0.5;
            w = next;
            if done {
                break;
            }
        }
        let (mut plots, mut xs, mut ys, mut y_area, mut gutters, mut right) = geometry(w);
        // The last round's labels may be a little wider: shrink the maps to fit the page.
        let over = gutters.iter().sum::<f64>() + c as f64 * w + right - sc.width;
        if over > 0.0 {
            w -= over / c as f64;
            (plots, xs, ys, y_area, gutters, right) = geometry(w);
        }
        if w < MIN_MAP_EMS * sc.font {
            return None;
        }
        // Centre the maps on the page.
        let spare = (sc.width - gutters.iter().sum::<f64>() - c as f64 * w - right).max(0.0);
        let lefts: Vec<f64> = (0..c).map(|k| spare / 2.0 + gutters[..=k].iter().sum::<f64>() + k as f64 * w).collect();

        // A caption may be as wide as its map and the half gaps beside it (the page
        // margin at the sheet's edges), centred on the map.
        let caption_w = |i: usize| {
            let k = i % c;
            let (l, r) = (lefts[k], lefts[k] + plots[i].0);
            let before = if k == 0 { l - sc.m } else { (l - (lefts[k - 1] + w)) / 2.0 };
            let after = if k + 1 == c || i + 1 == n { sc.width - sc.m - r } else { (lefts[k + 1] - r) / 2.0 };
            plots[i].0 + 2.0 * before.min(after).max(0.0)
        };
        let mut cells = Vec::with_capacity(n);
        let mut bars = vec![];
        let mut y = top;
        let mut group_right = 0.0f64;
        for r in 0..rows {
            let captions: Vec<Vec<String>> = row(r).map(|i| wrap(&maps[i].title, sc.font, caption_w(i))).collect();
            let caption_h = captions.iter().map(Vec::len).max().unwrap_or(0) as f64 * 1.25 * sc.font + 0.3 * sc.font;
            let plot_top = y + caption_h + sc.m;
            let plot_h = row(r).map(|i| plots[i].1).fold(0.0, f64::max);
            let x_area = if row(r).any(|i| show_x[i]) { sc.x_area() } else { 0.0 };
            for (i, caption) in row(r).zip(captions) {
                let k = i % c;
                group_right = group_right.max(lefts[k] + plots[i].0);
                cells.push(Cell {
                    panel: i,
                    plot: (lefts[k], plot_top, plots[i].0, plots[i].1),
                    x: xs[i].clone(),
                    y: ys[i].clone(),
                    x_area: if show_x[i] { sc.x_area() } else { 0.0 },
                    y_area: if show_y[i] { y_area[k] } else { 0.0 },
                    caption,
                    caption_top: y,
                });
            }
            y = plot_top + plot_h + x_area;
            if ends_group(r) {
                if let Some(range) = bar_range(r) {
                    let (left, right) = (lefts[0], group_right);
                    let title = wrap(&maps[r * c].colour_label, sc.font, right - left);
                    let bar = Bar { left, right, top: y + 0.6 * sc.font, axis: Axis::new(range, false, false, right - left, true, sc), grey: maps[r * c].grey, title };
                    y = bar.bottom(sc);
                    bars.push(bar);
                }
                group_right = 0.0;
            }
            y += sc.bottom();
        }
        Some(Sheet { height: y, cells, bars })
    }

    /// Draw the maps, their captions and axes, and the colour bars; returns the maps'
    /// plotting areas.
    pub(super) fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, fig: &Figure, ranges: &[Option<(f64, f64)>], sc: &Scale) -> Result<Vec<Rect>> {
        let frame = ShapeStyle::from(&BLACK).stroke_width(sc.stroke(0.6));
        let mut out = vec![];
        for cell in &self.cells {
            let Panel::Map(p) = &fig.panels[cell.panel] else { continue };
            let (l, t, pw, ph) = cell.plot;
            for (k, line) in cell.caption.iter().enumerate() {
                let y = cell.caption_top + 0.3 * sc.font + (k as f64 + 0.5) * 1.25 * sc.font;
                draw_text(root, line, sc.font, (l + pw / 2.0, y), Pos::new(HPos::Center, VPos::Center), FontTransform::None)?;
            }
            let Some(range) = ranges[cell.panel] else {
                draw_text(root, "no finite data", sc.font, (l, t + sc.font), Pos::new(HPos::Left, VPos::Center), FontTransform::None)?;
                continue;
            };
            // The chart: the y label area left of the plot, the x label area under it.
            let (x0, xp, x1) = ((l - cell.y_area).round() as i32, l.round() as i32, (l + pw).round() as i32);
            let (y0, y1) = (t.round() as i32, (t + ph).round() as i32);
            let x_area = cell.x_area.round() as i32;
            let area = root.clone().shrink((x0, y0), (x1 - x0, y1 - y0 + x_area));
            let mut chart = ChartBuilder::on(&area)
                .x_label_area_size(x_area as u32)
                .y_label_area_size((xp - x0) as u32)
                .build_cartesian_2d(Ticked::new(&cell.x), Ticked::new(&cell.y))
                .map_err(plot_err)?;
            draw_axes(&mut chart, &p.x_label, &p.y_label, &cell.x, &cell.y, false, sc)?;
            paint_map(&mut chart, p, range, (pw, ph), sc)?;
            let (px, py) = chart.plotting_area().get_pixel_range();
            root.draw(&Rectangle::new([(px.start, py.start), (px.end, py.end)], frame)).map_err(plot_err)?;
            out.push((px.start, py.start, px.end, py.end));
        }
        for bar in &self.bars {
            bar.draw(root, sc)?;
        }
        Ok(out)
    }
}

/// How far the tick labels of a horizontal axis drawn `length` long reach beyond its
/// ends (left, right): labels are centred on their ticks.
fn overhang(axis: &Axis, length: f64, sc: &Scale) -> (f64, f64) {
    let (lo, hi) = axis.range;
    let (mut left, mut right) = (0.0f64, 0.0f64);
    for (t, label) in axis.ticks.iter().zip(&axis.labels) {
        let x = (t - lo) / (hi - lo) * length;
        let half = text_width(label, sc.tick_font) / 2.0;
        left = left.max(half - x);
        right = right.max(x + half - length);
    }
    (left, right)
}

impl Bar {
    /// Thickness of the bar itself.
    fn thickness(sc: &Scale) -> f64 {
        0.8 * sc.font
    }
    /// Bottom of the bar's title.
    fn bottom(&self, sc: &Scale) -> f64 {
        self.labels_top(sc) + 1.25 * sc.tick_font + 0.1 * sc.font + self.title.len() as f64 * 1.25 * sc.font
    }
    fn labels_top(&self, sc: &Scale) -> f64 {
        self.top + Self::thickness(sc) + sc.tick_len + 0.25 * sc.font
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, sc: &Scale) -> Result<()> {
        let (left, right, top) = (self.left, self.right, self.top);
        let bottom = top + Self::thickness(sc);
        let (vmin, vmax) = self.axis.range;
        let steps = 128;
        for k in 0..steps {
            let (a, b) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
            let (xa, xb) = (left + a * (right - left), left + b * (right - left));
            let rect = Rectangle::new([(xa.floor() as i32, top.round() as i32), (xb.ceil() as i32, bottom.round() as i32)], paint((a + b) / 2.0, self.grey).filled());
            root.draw(&rect).map_err(plot_err)?;
        }
        let frame = ShapeStyle::from(&BLACK).stroke_width(sc.stroke(0.6));
        root.draw(&Rectangle::new([(left.round() as i32, top.round() as i32), (right.round() as i32, bottom.round() as i32)], frame)).map_err(plot_err)?;
        for (t, label) in self.axis.ticks.iter().zip(&self.axis.labels) {
            let x = left + (t - vmin) / (vmax - vmin) * (right - left);
            root.draw(&PathElement::new(vec![(x.round() as i32, bottom.round() as i32), (x.round() as i32, (bottom + sc.tick_len).round() as i32)], frame)).map_err(plot_err)?;
            draw_text(root, label, sc.tick_font, (x, self.labels_top(sc)), Pos::new(HPos::Center, VPos::Top), FontTransform::None)?;
        }
        let title_top = self.labels_top(sc) + 1.25 * sc.tick_font + 0.1 * sc.font;
        for (k, line) in self.title.iter().enumerate() {
            draw_text(root, line, sc.font, ((left + right) / 2.0, title_top + k as f64 * 1.25 * sc.font), Pos::new(HPos::Center, VPos::Top), FontTransform::None)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(colour_label: &str, extent: (f64, f64, f64, f64)) -> Panel {
        Panel::Map(MapPanel {
            title: "a map".into(),
            x_label: "x (mm)".into(),
            y_label: "y (mm)".into(),
            extent,
            values: Array2::from_shape_fn((20, 30), |(i, j)| (i + j) as f64),
            colour_label: colour_label.into(),
            grey: false,
        })
    }

    #[test]
    fn maps_go_on_a_sheet_only_when_the_page_is_too_narrow_for_their_panels() {
        ensure_font_for_tests();
        let (image, spectrum) = ((0.0, 87.0, 0.0, 62.0), (-1.0, 1.0, -1.0, 1.0));
        let four = Figure::new("f", "t", vec![map("grey", image), map("grey", image), map("energy", spectrum), map("energy", spectrum)], 2);
        let ranges = four.colour_ranges();
        let sc = |mm: f64| Scale::new(&RenderOptions::default(), Format::Png, mm);
        assert!(Sheet::new(&four, &sc(TWO_COLUMNS_MM), 0.0, &ranges).is_none(), "two columns of panels fit");
        let s = Sheet::new(&four, &sc(ONE_COLUMN_MM), 0.0, &ranges).expect("a sheet at one column");
        // one colour bar per quantity; y labels left of the first column only; x labels
        // under both rows (their extents differ); maps keep their aspect ratio
        assert_eq!(s.bars.len(), 2);
        assert_eq!(s.cells.iter().map(|c| c.y_area > 0.0).collect::<Vec<_>>(), [true, false, true, false]);
        assert!(s.cells.iter().all(|c| c.x_area > 0.0));
        assert!((s.cells[0].plot.3 / s.cells[0].plot.2 - 62.0 / 87.0).abs() < 1e-9);
        assert!(s.cells.iter().all(|c| c.plot.2 >= MIN_MAP_EMS * sc(ONE_COLUMN_MM).font));
        // four maps of one extent: x labels under the last row only, one bar
        let same = Figure::new("f", "t", (0..4).map(|_| map("density", image)).collect(), 2);
        let s = Sheet::new(&same, &sc(ONE_COLUMN_MM), 0.0, &same.colour_ranges()).unwrap();
        assert_eq!(s.bars.len(), 1);
        assert_eq!(s.cells.iter().map(|c| c.x_area > 0.0).collect::<Vec<_>>(), [false, false, true, true]);
        // a row showing two quantities, or a line panel among the maps: panels as they are
        let mixed = Figure::new("f", "t", vec![map("grey", image), map("energy", spectrum), map("grey", image), map("energy", spectrum)], 2);
        assert!(Sheet::new(&mixed, &sc(ONE_COLUMN_MM), 0.0, &mixed.colour_ranges()).is_none());
        let lines = Figure::new("f", "t", vec![map("grey", image), Panel::Lines(LinePanel::default())], 2);
        assert!(Sheet::new(&lines, &sc(ONE_COLUMN_MM), 0.0, &lines.colour_ranges()).is_none());
        // a page too narrow for two maps of MIN_MAP_EMS: stacked panels
        assert!(Sheet::new(&four, &sc(50.0), 0.0, &ranges).is_none());
    }
}
