//! Laid-web figures: the laid web from above with one fibre highlighted beside its
//! areal-density map (1 mm cells over the whole laid belt, CD folded onto the period),
//! and the belt-removed S and e of the fibres (against the swept parameter, or per
//! fibre).

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
        let label = match d.point_label(p) {
            s if s.is_empty() => "replicate 0".to_string(),
            s => format!("{s}, replicate 0"),
        };
        panels.push(Panel::Lines(LinePanel {
            title: format!("laid web, {label}"),
            x_label: "x, machine direction on the belt (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            equal_aspect: true,
            series,
            ..Default::default()
        }));
        // density map over the laid extent, CD folded onto [−P/2, P/2)
        let w = period[[p]];
        let x_max = (0..laid.shape()[2]).map(|k| laid[[p, 0, k, 0]]).filter(|x| x.is_finite()).fold(0.0f64, f64::max);
        let (nx, ny) = (((x_max / MAP_CELL).ceil() as usize).max(1), ((w / MAP_CELL).round() as usize).max(1));
        let cell_y = w / ny as f64;
        let node_mass = mass.0[[p]] * mass.1[[p]];
        let mut map = Array2::<f64>::zeros((ny, nx));
        for j in 0..nf {
            let a = start[[p, 0, j]];
            if !(a >= 0.0) {
                continue;
            }
            let (a, n) = (a as usize, count[[p, 0, j]] as usize);
            for k in a..(a + n).saturating_sub(1) {
                let (x, y) = (laid[[p, 0, k, 0]], laid[[p, 0, k, 1]]);
                let fy = (y + 0.5 * w).rem_euclid(w);
                let (ix, iy) = ((x / MAP_CELL).floor(), (fy / cell_y).floor());
                if ix >= 0.0 && (ix as usize) < nx && (iy as usize) < ny {
                    map[[iy as usize, ix as usize]] += node_mass / (MAP_CELL * cell_y) * 1e3;
                }
            }
        }
        panels.push(Panel::Map(MapPanel {
            title: format!("areal density, {label}"),
            x_label: "x, machine direction on the belt (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            extent: (0.0, nx as f64 * MAP_CELL * 1e3, -0.5 * w * 1e3, 0.5 * w * 1e3),
            values: map,
            colour_label: "areal density (g/m²)".into(),
            grey: false,
        }));
    }
    figs.push(Figure::new("laid_web", "Web laid by the fibre physics (one fibre highlighted) and its areal density", panels, 2));

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
