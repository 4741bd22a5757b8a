//! Grid figures: density maps (Fig 9), CV and formation number against zone size with
//! the random-line reference, ρ_av and CV against the swept parameters (Fig 10d,e) and,
//! with `compare_with: table4`, against the paper's measured values (Fig 13).
use super::figure::{drop_repeated_labels, Figure, LinePanel, MapPanel, Panel, Series, Style};
use super::{lines_along, sweep_axis, StageData};
use anyhow::Result;
use ndarray::{Array2, ArrayD, Axis, Ix1, Ix3, Ix4};

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let mut figs = vec![];
    let points = d.f64("mean_areal_density_mean")?.len();
    let swept = d.swept();

    if d.has("density") {
        let density = d.f64("density")?.into_dimensionality::<Ix4>()?;
        let md = d.f64("md")?.into_dimensionality::<Ix1>()?;
        let cd = d.f64("cd")?.into_dimensionality::<Ix1>()?;
        let h = d.f64("cell_size")?.iter().next().copied().unwrap_or(0.0);
        // in mm
        let extent = |c: &ndarray::Array1<f64>| ((c[0] - h / 2.0) * 1e3, (c[c.len() - 1] + h / 2.0) * 1e3);
        let ((x0, x1), (y0, y1)) = (extent(&md), extent(&cd));
        let mut maps = vec![];
        for p in 0..points.min(4) {
            // density is (md, cd); a map's rows run along y = CD.
            let map: Array2<f64> = density.index_axis(Axis(0), p).index_axis(Axis(0), 0).t().to_owned();
            let label = d.point_label(p);
            maps.push(Panel::Map(MapPanel {
                title: if label.is_empty() { "realisation 0".into() } else { format!("{label}, realisation 0") },
                x_label: "x, machine direction (mm)".into(),
                y_label: "y, cross direction (mm)".into(),
                extent: (x0, x1, y0, y1),
                values: map,
                colour_label: "areal density (g/m²)".into(),
                grey: false,
            }));
        }
        figs.push(Figure::new("density", "Areal density on the grid (one colour scale)", maps, 2));
    }

    // CV and formation number against zone size, per point.
    let zone = d.f64("zone_size")?;
    let cv_zone = d.f64("cv_zone")?.into_dimensionality::<Ix3>()?;
    let random = d.f64("random_line_cv")?.into_dimensionality::<Ix3>()?;
    let formation = d.f64("formation_number")?.into_dimensionality::<Ix3>()?;
    let over_realisations = |a: &ndarray::Array3<f64>, p: usize| -> (Vec<f64>, Vec<f64>) {
        let s = a.index_axis(Axis(0), p);
        let n = s.shape()[0] as f64;
        let mean: Vec<f64> = s.mean_axis(Axis(0)).unwrap().to_vec();
        let std: Vec<f64> = if n > 1.0 { s.std_axis(Axis(0), 1.0).to_vec() } else { vec![f64::NAN; mean.len()] };
        (mean, std)
    };
    let mut cv_series = vec![];
    // each point's random-line reference dashed in its colour, after the points in the legend
    let mut random_series = vec![];
    let mut nf_series = vec![];
    for p in 0..points.min(8) {
        let name = match d.point_label(p) {
            s if s.is_empty() => "web".to_string(),
            s => s,
        };
        let xs: Vec<f64> = zone.iter().map(|z| z * 1e3).collect();
        let (m, s) = over_realisations(&cv_zone, p);
        cv_series.push(Series::new(Some(&name), xs.iter().copied().zip(m).collect(), Style::LineMarkers, p).with_error(s));
        let (r, _) = over_realisations(&random, p);
        random_series.push(Series::new(if p == 0 { Some("random lines (dashed, each in its colour)") } else { None }, xs.iter().copied().zip(r).collect(), Style::Dashed, p));
        let (f, fs) = over_realisations(&formation, p);
        nf_series.push(Series::new(Some(&name), xs.iter().copied().zip(f).collect(), Style::LineMarkers, p).with_error(fs));
    }
    nf_series.push(Series::new(Some("random lines (n_f = 1)"), zone.iter().map(|z| (z * 1e3, 1.0)).collect(), Style::Dashed, 7));
    drop_repeated_labels(&cv_series, &mut nf_series);
    figs.push(Figure::new(
        "zone_size",
        "Uniformity against zone size (mean ± std over realisations)",
        vec![
            Panel::Lines(LinePanel {
                title: "CV of zone densities".into(),
                x_label: "zone size (mm)".into(),
                y_label: "CV".into(),
                log_x: true,
                log_y: true,
                series: cv_series.into_iter().chain(random_series).collect(),
                ..Default::default()
            }),
            Panel::Lines(LinePanel {
                title: "formation number n_f = CV² / CV²(random lines)".into(),
                x_label: "zone size (mm)".into(),
                y_label: "n_f".into(),
                log_x: true,
                series: nf_series,
                ..Default::default()
            }),
        ],
        2,
    ));

    // ρ_av and CV against each swept parameter (Fig 10d,e); measured Table 4 values (Fig 13).
    let reference = d.has("reference_belt_speed_ratio");
    let mut lines_seen: Vec<Vec<Vec<usize>>> = vec![];
    for s in &swept {
        // One line per value of the other swept parameters (e.g. per spectrum in Fig 10d,e).
        let lines = lines_along(&swept, s);
        if lines.iter().all(|(_, ps)| ps.len() < 2) {
            continue;
        }
        // Parameters swept together (zip) give the same lines: one figure is enough.
        let groups: Vec<Vec<usize>> = lines.iter().map(|(_, ps)| { let mut g = ps.clone(); g.sort(); g }).collect();
        if lines_seen.contains(&groups) {
            continue;
        }
        lines_seen.push(groups);
        let axis = sweep_axis(s);
        let x = &axis.label;
        let series = |name: &str| -> Result<Vec<Series>> {
            let (m, sd): (ArrayD<f64>, ArrayD<f64>) = (d.f64(&format!("{name}_mean"))?, d.f64(&format!("{name}_std"))?);
            Ok(lines
                .iter()
                .enumerate()
                .map(|(i, (key, ps))| {
                    let label = if key.is_empty() { "simulated" } else { key.as_str() };
                    Series::new(Some(label), ps.iter().map(|&p| (axis.x[p], m[[p]])).collect(), Style::LineMarkers, if i >= 3 { i + 1 } else { i })
                        .with_error(ps.iter().map(|&p| sd[[p]]).collect())
                })
                .collect())
        };
        let mut rho = series("mean_areal_density")?;
        let mut cv = series("cv")?;
        if reference && s.parameter == "belt_speed_ratio" {
            let c = d.f64("reference_belt_speed_ratio")?;
            let r = d.f64("reference_areal_density")?;
            let cv_corr = d.f64("reference_cv_corr")?;
            let cv_raw = d.f64("reference_cv_raw")?;
            let pts = |a: &ArrayD<f64>, scale: f64| c.iter().zip(a.iter()).map(|(&v, &y)| (v * x.scale, y * scale)).collect();
            rho.push(Series::new(Some("measured (Table 4)"), pts(&r, 1.0), Style::Markers, 3));
            cv.push(Series::new(Some("measured CV_corr (Table 4)"), pts(&cv_corr, 0.01), Style::Markers, 3));
            cv.push(Series::new(Some("measured CV raw (Table 4)"), pts(&cv_raw, 0.01), Style::Markers, 1));
        }
        drop_repeated_labels(&rho, &mut cv);
        figs.push(Figure::new(
            &format!("uniformity_vs_{}", s.name),
            &format!("Areal density and CV against {} (mean ± std over realisations)", x.symbol),
            vec![
                Panel::Lines(LinePanel { title: "ρ_av (eq 16)".into(), x_label: x.text.clone(), y_label: "ρ_av (g/m²)".into(), series: rho, categories: axis.categories.clone(), ..Default::default() }),
                Panel::Lines(LinePanel { title: "CV of cell densities".into(), x_label: x.text.clone(), y_label: "CV".into(), series: cv, categories: axis.categories.clone(), ..Default::default() }),
            ],
            2,
        ));
    }
    Ok(figs)
}
