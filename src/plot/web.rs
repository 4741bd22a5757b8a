//! Web figures: the stored fibres of a realisation with one highlighted (Fig 8).
use super::figure::{Figure, LinePanel, Panel, Series, Style};
use super::StageData;
use anyhow::Result;
use ndarray::{Axis, Ix2, Ix5};

/// At most this many fibres and nodes per fibre are drawn (the figure stays light).
const MAX_FIBRES: usize = 60;
const MAX_NODES: usize = 3000;

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let fibres = d.f64("fibre_positions")?.into_dimensionality::<Ix5>()?;
    let index = d.f64("sample_fibre_index")?.into_dimensionality::<Ix2>()?;
    let (points, _, stored, nodes, _) = fibres.dim();
    let mut panels = vec![];
    for p in 0..points.min(4) {
        let web = fibres.index_axis(Axis(0), p).index_axis(Axis(0), 0).to_owned();
        let present: Vec<usize> = (0..stored).filter(|&f| index[[p, f]] >= 0.0).collect();
        let step = present.len().div_ceil(MAX_FIBRES).max(1);
        let node_step = nodes.div_ceil(MAX_NODES).max(1);
        let drawn: Vec<usize> = present.iter().copied().step_by(step).collect();
        let highlight = drawn.get(drawn.len() / 2).copied();
        let mut series = vec![];
        for &f in &drawn {
            let pts: Vec<(f64, f64)> = (0..nodes)
                .step_by(node_step)
                .chain(std::iter::once(nodes - 1))
                .map(|k| (web[[f, k, 0]] * 1e3, web[[f, k, 1]] * 1e3))
                .collect();
            if Some(f) == highlight {
                continue;
            }
            series.push(Series::new(None, pts, Style::Line, 7));
        }
        if let Some(f) = highlight {
            let pts = (0..nodes).map(|k| (web[[f, k, 0]] * 1e3, web[[f, k, 1]] * 1e3)).collect();
            series.push(Series::new(Some(&format!("fibre {}", index[[p, f]])), pts, Style::Line, 3).bold());
        }
        let label = d.point_label(p);
        panels.push(Panel::Lines(LinePanel {
            title: format!(
                "{}{} of {} stored fibres, realisation 0",
                if label.is_empty() { String::new() } else { format!("{label}: ") },
                drawn.len(),
                present.len()
            ),
            x_label: "x, machine direction (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            equal_aspect: true,
            series,
            ..Default::default()
        }));
    }
    Ok(vec![Figure::new("fibres", "Web: stored fibres with one highlighted", panels, 2)])
}
