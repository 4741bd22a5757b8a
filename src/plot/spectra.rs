//! Spectra figures: the energy spectrum S_r against ω_r (Fig 10a-c), mean and single
//! fibres, and the curvature κ(s) of a fibre.
use super::figure::{Figure, LinePanel, Panel, Series, Style};
use super::StageData;
use anyhow::Result;
use ndarray::{Axis, Ix2, Ix3};

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let omega = d.f64("angular_frequency")?.into_dimensionality::<Ix2>()?;
    let mean = d.f64("mean_energy_spectrum")?.into_dimensionality::<Ix2>()?;
    let single = d.f64("energy_spectrum")?.into_dimensionality::<Ix3>()?;
    let curvature = d.f64("curvature")?.into_dimensionality::<Ix3>()?;
    let arc = d.f64("arc_length")?.into_dimensionality::<Ix2>()?;
    let valid = d.f64("valid")?.into_dimensionality::<Ix2>()?;
    let points = omega.shape()[0];
    // each point's curve named by its own values, never one shared text
    let label = |p: usize| match d.point_label(p) {
        s if s.is_empty() && points == 1 => "mean over fibres".to_string(),
        s if s.is_empty() => format!("mean over fibres, point {p}"),
        s => format!("mean, {s}"),
    };
    // Positive frequencies r = 1 .. N/2 (the spectrum of a real κ is symmetric; r = 0 is the mean curvature).
    let positive = |p: usize, values: ndarray::ArrayView1<f64>| -> Vec<(f64, f64)> {
        (1..omega.shape()[1]).filter(|&r| omega[[p, r]] > 0.0).map(|r| (omega[[p, r]], values[r])).collect()
    };
    let mut spectrum = vec![];
    for p in 0..points {
        spectrum.push(Series::new(Some(&label(p)), positive(p, mean.row(p)), Style::Line, p).bold());
    }
    if points == 1 {
        if let Some(f) = (0..single.shape()[1]).find(|&f| valid[[0, f]] != 0.0) {
            let s = single.index_axis(Axis(0), 0).index_axis(Axis(0), f).to_owned();
            spectrum.push(Series::new(Some(&format!("fibre {f}")), positive(0, s.view()), Style::Line, 7));
        }
    }
    let spectrum_panel = |log_x: bool| {
        Panel::Lines(LinePanel {
            title: if log_x { "log-log".into() } else { "linear frequency".into() },
            x_label: "angular frequency ω_r (rad/m)".into(),
            y_label: "S_r = |K_r|² (1/m²)".into(),
            log_x,
            log_y: true,
            series: spectrum.clone(),
            ..Default::default()
        })
    };
    let mut curv = vec![];
    for p in 0..points {
        if let Some(f) = (0..curvature.shape()[1]).find(|&f| valid[[p, f]] != 0.0) {
            let pts = arc.row(p).iter().zip(curvature.index_axis(Axis(0), p).index_axis(Axis(0), f)).map(|(&s, &k)| (s * 1e3, k)).collect();
            let name = match d.point_label(p) {
                s if s.is_empty() => format!("fibre {f}"),
                s => format!("fibre {f}, {s}"),
            };
            curv.push(Series::new(Some(&name), pts, Style::Line, p));
        }
    }
    Ok(vec![
        Figure::new("energy_spectrum", "Curvature energy spectrum", vec![spectrum_panel(false), spectrum_panel(true)], 2),
        Figure::new(
            "curvature",
            "Curvature along the fibre",
            vec![Panel::Lines(LinePanel {
                title: "κ(s) of the first valid fibre".into(),
                x_label: "arc length s (mm)".into(),
                y_label: "curvature κ (1/m)".into(),
                series: curv,
                ..Default::default()
            })],
            1,
        ),
    ])
}
