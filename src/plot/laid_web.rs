//! Laid-web figures: the laid web from above with one fibre highlighted beside its
//! areal-density map (1 mm cells over the whole laid belt, CD folded onto the period),
//! the belt-removed S and e of the fibres (against the swept parameter, or per
//! fibre), and with fibre contact the web's height: the highest laid fibre in each cell
//! beside the highest and median laid node along the belt.

// NaN-safe checks are written as negated comparisons on purpose (`!(x < limit)`).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use super::figure::{Figure, LinePanel, MapPanel, Panel, Series, Style};
use super::{lines_along, sweep_axis, StageData};
use anyhow::Result;
use ndarray::{Array2, ArrayD, Ix3, Ix4};

/// Cell side of the density map (m).
const MAP_CELL: f64 = 1e-3;

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let laid = d.f64("laid_positions")?.into_dimensionality::<Ix4>()?;
    let start = d.f64("fibre_node_start")?.into_dimensionality::<Ix3>()?;
    let count = d.f64("fibre_laid_nodes")?.into_dimensionality::<Ix3>()?;
    let period = d.f64("cd_period")?;
    let mass = (d.f64("mass_per_length")?, d.f64("element_length")?);
    let (points, nf) = (laid.shape()[0], start.shape()[2]);
    let mut figs = vec![];
    let mut panels = vec![];
    for p in 0..points.min(3) {
        let fibre = |j: usize| -> Vec<(f64, f64)> {
            let a = start[[p, 0, j]];
            if !(a >= 0.0) {
                return vec![];
            }
            let a = a as usize;
            (a..a + count[[p, 0, j]] as usize).map(|k| (laid[[p, 0, k, 0]] * 1e3, laid[[p, 0, k, 1]] * 1e3)).collect()
        };
        let highlight = nf / 2;
        let mut series: Vec<Series> = (0..nf).filter(|&j| j != highlight).map(|j| Series::new(None, fibre(j), Style::Line, 7)).collect();
        series.push(Series::new(Some(&format!("fibre {highlight}")), fibre(highlight), Style::Line, 3).bold());
        let label = replicate_label(d, p);
        panels.push(Panel::Lines(LinePanel {
            title: format!("laid web, {label}"),
            x_label: "x, machine direction on the belt (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            equal_aspect: true,
            series,
            ..Default::default()
        }));
        // density map over the laid extent, CD folded onto [−P/2, P/2)
        let cells = Cells::new(&laid, &start, &count, p, period[[p]]);
        let node_mass = mass.0[[p]] * mass.1[[p]];
        let mut map = Array2::<f64>::zeros((cells.ny, cells.nx));
        cells.each_node(|ix, iy, _| map[[iy, ix]] += node_mass / (MAP_CELL * cells.cell_y) * 1e3);
        panels.push(cells.map_panel(format!("areal density, {label}"), map, "areal density (g/m²)"));
    }
    figs.push(Figure::new("laid_web", "Web laid by the fibre physics (one fibre highlighted) and its areal density", panels, 2));

    // with fibre contact the web has a thickness: how high laid fibre stands
    let contact = d.param("fibre_contact").as_deref() == Some("true") || d.swept().iter().any(|s| s.parameter == "fibre_contact");
    if contact {
        let mut height_panels = vec![];
        for p in 0..points.min(3) {
            let label = replicate_label(d, p);
            let cells = Cells::new(&laid, &start, &count, p, period[[p]]);
            let mut highest = Array2::<f64>::zeros((cells.ny, cells.nx));
            let mut along: Vec<Vec<f64>> = vec![Vec::new(); cells.nx];
            cells.each_node(|ix, iy, z| {
                if !z.is_finite() {
                    return;
                }
                let z = z * 1e6;
                highest[[iy, ix]] = highest[[iy, ix]].max(z);
                along[ix].push(z);
            });
            height_panels.push(cells.map_panel(format!("highest laid fibre, {label}"), highest, "height (µm)"));
            let bin = |ix: usize| (ix as f64 + 0.5) * MAP_CELL * 1e3;
            let (mut top, mut median) = (vec![], vec![]);
            for (ix, zs) in along.iter_mut().enumerate() {
                if zs.is_empty() {
                    continue;
                }
                zs.sort_by(f64::total_cmp);
                top.push((bin(ix), zs[zs.len() - 1]));
                median.push((bin(ix), zs[zs.len() / 2]));
            }
            height_panels.push(Panel::Lines(LinePanel {
                title: format!("height along the belt, {label}"),
                x_label: "x, machine direction on the belt (mm)".into(),
                y_label: "centreline height (µm)".into(),
                series: vec![Series::new(Some("highest laid node per mm"), top, Style::Line, 0), Series::new(Some("median laid node per mm"), median, Style::Line, 1)],
                ..Default::default()
            }));
        }
        figs.push(Figure::new("web_height", "Height of the laid web (fibre contact): highest laid fibre per 1 mm cell, and along the belt", height_panels, 2));
    }

    // S and e of the fibres (belt motion removed)
    let valid = d.f64("valid")?.into_dimensionality::<Ix3>()?;
    let swept = d.swept();
    let quantities = [
        ("radius_of_gyration_belt_removed", "coil size: radius of gyration", "S, belt motion removed (mm)", 1e3),
        ("bending_energy", "bending energy", "e = V_b L / EI", 1.0),
    ];
    let mut metric_panels = vec![];
    for (name, title, label, scale) in quantities {
        let series = if let Some(s) = swept.first() {
            let (mean, std): (ArrayD<f64>, ArrayD<f64>) = (d.f64(&format!("{name}_mean"))?, d.f64(&format!("{name}_std"))?);
            let axis = sweep_axis(s);
            lines_along(&swept, s)
                .into_iter()
                .enumerate()
                .map(|(i, (key, ps))| {
                    let lab = if key.is_empty() { "mean over valid fibres".to_string() } else { format!("mean over valid fibres, {key}") };
                    Series::new(Some(&lab), ps.iter().map(|&p| (axis.x[p], mean[[p]] * scale)).collect(), Style::LineMarkers, i)
                        .with_error(ps.iter().map(|&p| std[[p]] * scale).collect())
                })
                .collect()
        } else {
            let v = d.f64(name)?.into_dimensionality::<Ix3>()?;
            let reps = v.shape()[1];
            (0..reps)
                .map(|r| {
                    let pts = (0..nf).filter(|&j| valid[[0, r, j]] != 0.0).map(|j| (j as f64, v[[0, r, j]] * scale)).collect();
                    Series::new(Some(&format!("replicate {r}")), pts, Style::Markers, r)
                })
                .collect()
        };
        let axis = swept.first().map(sweep_axis);
        let x_label = axis.as_ref().map_or_else(|| "fibre".into(), |a| a.label.text.clone());
        let categories = axis.map(|a| a.categories).unwrap_or_default();
        metric_panels.push(Panel::Lines(LinePanel { title: title.into(), x_label, y_label: label.into(), series, integer_x: swept.is_empty(), categories, ..Default::default() }));
    }
    figs.push(Figure::new("fibre_shapes", "Coil size and bending energy of the laid fibres (valid fibres)", metric_panels, 2));
    Ok(figs)
}

/// "replicate 0" of point `p`, after the point's swept values if any.
fn replicate_label(d: &StageData, p: usize) -> String {
    match d.point_label(p) {
        s if s.is_empty() => "replicate 0".to_string(),
        s => format!("{s}, replicate 0"),
    }
}

/// The 1 mm cells of point `p`'s laid web over its laid extent (MD from 0, CD folded onto
/// [−P/2, P/2)), and the laid nodes of replicate 0 that fall in them.
struct Cells<'a> {
    laid: &'a ndarray::Array4<f64>,
    start: &'a ndarray::Array3<f64>,
    count: &'a ndarray::Array3<f64>,
    p: usize,
    period: f64,
    nx: usize,
    ny: usize,
    cell_y: f64,
}

impl<'a> Cells<'a> {
    fn new(laid: &'a ndarray::Array4<f64>, start: &'a ndarray::Array3<f64>, count: &'a ndarray::Array3<f64>, p: usize, period: f64) -> Self {
        let x_max = (0..laid.shape()[2]).map(|k| laid[[p, 0, k, 0]]).filter(|x| x.is_finite()).fold(0.0f64, f64::max);
        let (nx, ny) = (((x_max / MAP_CELL).ceil() as usize).max(1), ((period / MAP_CELL).round() as usize).max(1));
        Cells { laid, start, count, p, period, nx, ny, cell_y: period / ny as f64 }
    }

    /// A map of `values` (one per cell, CD by MD) over the cells.
    fn map_panel(&self, title: String, values: Array2<f64>, colour_label: &str) -> Panel {
        Panel::Map(MapPanel {
            title,
            x_label: "x, machine direction on the belt (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            extent: (0.0, self.nx as f64 * MAP_CELL * 1e3, -0.5 * self.period * 1e3, 0.5 * self.period * 1e3),
            values,
            colour_label: colour_label.into(),
            grey: false,
        })
    }

    /// Calls `f(ix, iy, z)` for every laid node but each fibre's last (one per segment)
    /// that falls in a cell.
    fn each_node(&self, mut f: impl FnMut(usize, usize, f64)) {
        let (p, w) = (self.p, self.period);
        for j in 0..self.start.shape()[2] {
            let a = self.start[[p, 0, j]];
            if !(a >= 0.0) {
                continue;
            }
            let (a, n) = (a as usize, self.count[[p, 0, j]] as usize);
            for k in a..(a + n).saturating_sub(1) {
                let (x, y, z) = (self.laid[[p, 0, k, 0]], self.laid[[p, 0, k, 1]], self.laid[[p, 0, k, 2]]);
                let fy = (y + 0.5 * w).rem_euclid(w);
                let (ix, iy) = ((x / MAP_CELL).floor(), (fy / self.cell_y).floor());
                if ix >= 0.0 && (ix as usize) < self.nx && (iy as usize) < self.ny {
                    f(ix as usize, iy as usize, z);
                }
            }
        }
    }
}
