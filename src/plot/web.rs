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
    let mut figures = vec![Figure::new("fibres", "Web: stored fibres with one highlighted", panels, 2)];
    if d.has("example_input_fibre") {
        figures.push(shape_figure(d, &fibres, &index)?);
    }
    Ok(figures)
}

/// Per point, a laid fibre of the input beside one generated segment of the same length,
/// both with the belt motion removed and centred: what the generator keeps of the laid
/// shape (the Fig 8 comparison), with the mean S of each.
fn shape_figure(d: &StageData, fibres: &ndarray::Array5<f64>, index: &ndarray::Array2<f64>) -> Result<Figure> {
    let example = d.f64("example_input_fibre")?.into_dimensionality::<ndarray::Ix3>()?;
    let points_per_segment = d.f64("points_per_segment")?;
    let (c, ds) = (d.f64("belt_speed_ratio")?, d.f64("node_spacing")?);
    let (s_in, s_gen) = (d.f64("input_radius_of_gyration")?, d.f64("generated_radius_of_gyration")?);
    let generator = if d.has("generator") { d.strings("generator")? } else { vec![] };
    let mut panels = vec![];
    for p in 0..fibres.dim().0.min(4) {
        let input: Vec<[f64; 2]> = example.index_axis(Axis(0), p).outer_iter().map(|q| [q[0], q[1]]).filter(|q| q[0].is_finite()).collect();
        let Some(f) = (0..fibres.dim().2).find(|&f| index[[p, f]] >= 0.0) else { continue };
        let n = (points_per_segment[[p]] as usize + 1).min(fibres.dim().3);
        let drift = c[[p]] * ds[[p]];
        let segment: Vec<[f64; 2]> = (0..n).map(|k| [fibres[[p, 0, f, k, 0]] - k as f64 * drift, fibres[[p, 0, f, k, 1]]]).collect();
        let segment = crate::geometry::centred(&segment);
        // Side by side: each curve centred, the generated one shifted right by both half-widths.
        let half = |v: &[[f64; 2]]| v.iter().map(|q| q[0].abs()).fold(0.0, f64::max);
        let shift = 1.15 * (half(&input) + half(&segment));
        let mm = |v: &[[f64; 2]], dx: f64| v.iter().map(|q| ((q[0] + dx) * 1e3, q[1] * 1e3)).collect::<Vec<_>>();
        let name = generator.get(p).map(String::as_str).unwrap_or("random_phase");
        let label = d.point_label(p);
        panels.push(Panel::Lines(LinePanel {
            title: format!("{}laid fibre (S = {:.1} mm) | {name} segment (S = {:.1} mm)", if label.is_empty() { String::new() } else { format!("{label}: ") }, s_in[[p]] * 1e3, s_gen[[p]] * 1e3),
            x_label: "x, machine direction, belt removed (mm)".into(),
            y_label: "y, cross direction (mm)".into(),
            equal_aspect: true,
            series: vec![
                Series::new(Some("laid fibre (input)"), mm(&input, 0.0), Style::Line, 0),
                Series::new(Some(&format!("{name}, fibre {}", index[[p, f]])), mm(&segment, shift), Style::Line, 3).bold(),
            ],
            ..Default::default()
        }));
    }
    Ok(Figure::new("shape", "Web: laid fibre beside a generated segment (belt removed)", panels, 2))
}

