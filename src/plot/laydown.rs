//! Laydown figures: a laid fibre from above and the side (Fig 4a), the laid fibres at
//! the ends of each sweep (Fig 5 insets; all points of a small sweep), S and e against each swept parameter with
//! standard-deviation bars and the belt-removed values dashed (Figs 5, 6), and the
//! energy diagnostics over time.
use super::figure::{Figure, LinePanel, Panel, Series, Style};
use super::{labels, lines_along, sweep_axis, StageData};
use anyhow::Result;
use ndarray::{ArrayD, Axis, Ix4};

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let valid = d.f64("valid")?;
    let laid = d.f64("laid_positions")?.into_dimensionality::<Ix4>()?;
    let laid_removed = d.f64("laid_positions_belt_removed")?.into_dimensionality::<Ix4>()?;
    let positions = d.f64("positions")?.into_dimensionality::<Ix4>()?;
    let (points, replicates) = (laid.shape()[0], laid.shape()[1]);
    // The first valid replicate of a point, else its first replicate.
    let pick = |p: usize| (0..replicates).find(|&r| valid[[p, r]] != 0.0).unwrap_or(0);
    let mm = |a: ndarray::ArrayView2<f64>, i: usize, j: usize| -> Vec<(f64, f64)> {
        a.axis_iter(Axis(0)).map(|q| (q[i] * 1e3, q[j] * 1e3)).collect()
    };
    let mut figs = vec![];

    // Fig 4a: one laid fibre.
    let r = pick(0);
    let at = |a: &ndarray::Array4<f64>| a.index_axis(Axis(0), 0).index_axis(Axis(0), r).to_owned();
    let (top, top_removed, side) = (at(&laid), at(&laid_removed), at(&positions));
    let suffix = match d.point_label(0) {
        s if s.is_empty() => format!("replicate {r}"),
        s => format!("{s}, replicate {r}"),
    };
    let view = |title: &str, pts: Vec<(f64, f64)>, y: &str| {
        Panel::Lines(LinePanel {
            title: title.into(),
            x_label: "x, machine direction (mm)".into(),
            y_label: y.into(),
            equal_aspect: true,
            series: vec![Series::new(None, pts, Style::Line, 0)],
            ..Default::default()
        })
    };
    figs.push(Figure::new(
        "fibre",
        &format!("Laid fibre ({suffix})"),
        vec![
            view("top view, on the moving belt", mm(top.view(), 0, 1), "y, cross direction (mm)"),
            view("top view, belt motion removed", mm(top_removed.view(), 0, 1), "y, cross direction (mm)"),
            view("side view at the end of the run", mm(side.view(), 0, 2), "z (mm)"),
        ],
        3,
    ));

    // Fig 5 insets: laid fibres at the lowest and highest value of each swept parameter,
    // each point once (in a cartesian sweep the ends of two parameters can be one point);
    // a sweep of at most four points shows them all.
    let swept = d.swept();
    let mut shown: Vec<usize> = vec![];
    if !swept.is_empty() && points <= 4 {
        shown = (0..points).collect();
    } else {
        for s in &swept {
            let lo = (0..points).min_by(|&a, &b| s.values[a].total_cmp(&s.values[b])).unwrap_or(0);
            let hi = (0..points).max_by(|&a, &b| s.values[a].total_cmp(&s.values[b])).unwrap_or(0);
            for p in [lo, hi] {
                if !shown.contains(&p) {
                    shown.push(p);
                }
            }
        }
    }
    let mut inset_panels = vec![];
    for p in shown {
        let r = pick(p);
        let pts = laid_removed.index_axis(Axis(0), p).index_axis(Axis(0), r).to_owned();
        inset_panels.push(view(&d.point_label(p), mm(pts.view(), 0, 1), "y (mm)"));
    }
    if !inset_panels.is_empty() {
        figs.push(Figure::new("sweep_fibres", "Laid fibres (belt motion removed) across the sweep", inset_panels, 2));
    }

    // Figs 5 and 6: S and e with standard deviations, belt-removed dashed.
    let metric = |name: &str| -> Result<(ArrayD<f64>, ArrayD<f64>)> {
        Ok((d.f64(&format!("{name}_mean"))?, d.f64(&format!("{name}_std"))?))
    };
    let quantities = [
        ("radius_of_gyration", "radius of gyration S (mm)", 1e3),
        ("bending_energy", "bending energy e = V_b L / EI", 1.0),
    ];
    let mut metric_panels = vec![];
    if swept.is_empty() {
        // No sweep: every replicate, valid ones filled.
        for (name, label, scale) in quantities {
            let per = d.f64(name)?;
            let per_removed = d.f64(&format!("{name}_belt_removed"))?;
            let series = |a: &ArrayD<f64>, lab: &str, colour: usize| {
                let pts = (0..replicates)
                    .filter(|&r| valid[[0, r]] != 0.0)
                    .map(|r| (r as f64, a[[0, r]] * scale))
                    .collect();
                Series::new(Some(lab), pts, Style::Markers, colour)
            };
            metric_panels.push(Panel::Lines(LinePanel {
                title: format!("{label}, valid replicates"),
                x_label: "replicate".into(),
                y_label: label.into(),
                integer_x: true,
                series: vec![series(&per, "on the belt", 0), series(&per_removed, "belt motion removed", 1)],
                ..Default::default()
            }));
        }
    } else {
        for s in &swept {
            let axis = sweep_axis(s);
            let x = &axis.label;
            // one colour per line of the other swept parameters; belt-removed dashed
            let lines = lines_along(&swept, s);
            for (name, label, scale) in quantities {
                let (mean, std) = metric(name)?;
                let (mean_r, std_r) = metric(&format!("{name}_belt_removed"))?;
                let mut series = vec![];
                for (i, (key, ps)) in lines.iter().enumerate() {
                    let line = |m: &ArrayD<f64>, sd: &ArrayD<f64>, what: &str, style| {
                        let lab = if key.is_empty() { what.to_string() } else { format!("{what}, {key}") };
                        Series::new(Some(&lab), ps.iter().map(|&p| (axis.x[p], m[[p]] * scale)).collect(), style, i)
                            .with_error(ps.iter().map(|&p| sd[[p]] * scale).collect())
                    };
                    series.push(line(&mean, &std, "on the belt", Style::LineMarkers));
                    series.push(line(&mean_r, &std_r, "belt motion removed", Style::Dashed));
                }
                metric_panels.push(Panel::Lines(LinePanel {
                    title: format!("{label} against {}", x.symbol),
                    x_label: x.text.clone(),
                    y_label: label.into(),
                    categories: axis.categories.clone(),
                    series,
                    ..Default::default()
                }));
            }
        }
    }
    figs.push(Figure::new(
        "radius_of_gyration_bending_energy",
        "Radius of gyration and bending energy (mean ± standard deviation over valid replicates)",
        metric_panels,
        2,
    ));

    // Energy diagnostics of the plotted replicate.
    if d.has("energy_diagnostics") {
        let diag = d.f64("energy_diagnostics")?.into_dimensionality::<Ix4>()?;
        let names = d.strings("diagnostic")?;
        let rec = diag.index_axis(Axis(0), 0).index_axis(Axis(0), pick(0)).to_owned();
        if let Some(t) = names.iter().position(|n| n == "time") {
            let series = names
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != t)
                .map(|(i, n)| {
                    let pts = rec.axis_iter(Axis(0)).map(|row| (row[t], row[i])).filter(|q| q.0.is_finite()).collect();
                    Series::new(Some(&labels::label(n, "J", &[]).symbol), pts, Style::Line, i)
                })
                .collect();
            figs.push(Figure::new(
                "energy",
                &format!("Energy diagnostics ({suffix})"),
                vec![Panel::Lines(LinePanel {
                    title: "energies and work over time".into(),
                    x_label: "time (s)".into(),
                    y_label: "energy (J)".into(),
                    series,
                    ..Default::default()
                })],
                1,
            ));
        }
    }
    Ok(figs)
}
