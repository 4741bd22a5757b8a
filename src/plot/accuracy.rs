//! Accuracy figures: relative error of each metric against wall time per unit, one
//! series per candidate stage, log-log; in grey, twice each error's standard error (what
//! the replicates resolve: an error below its grey marker is not resolved).
use super::figure::{Figure, LinePanel, Panel, Series, Style};
use super::StageData;
use anyhow::Result;
use ndarray::Ix2;

/// Palette index of the standard errors' markers (grey).
const GREY: usize = 7;

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let metrics = d.strings("metric")?;
    let stages = d.strings("candidate_stage")?;
    let error = d.f64("relative_error")?.into_dimensionality::<Ix2>()?;
    let wall = d.f64("wall_seconds")?;
    // archives written before the accuracy stage recorded standard errors have none
    let standard_error = if d.has("relative_error_standard_error") { Some(d.f64("relative_error_standard_error")?.into_dimensionality::<Ix2>()?) } else { None };
    let mut names: Vec<String> = vec![];
    for s in &stages {
        if !names.contains(s) {
            names.push(s.clone());
        }
    }
    let panels = metrics
        .iter()
        .enumerate()
        .map(|(m, metric)| {
            let mut series: Vec<Series> = names
                .iter()
                .enumerate()
                .map(|(k, name)| {
                    let pts = (0..stages.len())
                        .filter(|&c| &stages[c] == name)
                        // An exact match has no place on a log axis: show it at 1e-6. NaN (no
                        // valid replicate) stays NaN and is not drawn.
                        .map(|c| {
                            let e = error[[c, m]].abs();
                            (wall[[c]], if e.is_nan() { e } else { e.max(1e-6) })
                        })
                        .collect();
                    // Markers only: candidates of one stage need not be ordered by cost.
                    Series::new(Some(name), pts, Style::Markers, k)
                })
                .collect();
            if let Some(se) = &standard_error {
                // an exact 0 (a candidate identical to the reference) at 10⁻⁶, as its error
                let pts = (0..stages.len()).map(|c| (wall[[c]], (2.0 * se[[c, m]]).max(1e-6))).collect();
                series.push(Series::new(Some("2 standard errors"), pts, Style::Markers, GREY));
            }
            Panel::Lines(LinePanel {
                title: format!("{}: error against cost", super::labels::label(metric, "", &[]).symbol),
                x_label: "wall time per unit (s)".into(),
                y_label: "|relative error| (exact: at 10⁻⁶)".into(),
                log_x: true,
                log_y: true,
                series,
                ..Default::default()
            })
        })
        .collect();
    Ok(vec![Figure::new("accuracy_cost", &format!("What accuracy costs (reference: {})", d.info.attr_str("reference").unwrap_or("?")), panels, 2)])
}
