//! Image figures: raw and filtered images with their log energy spectra before and after
//! notching (Fig 12), CV per condition, and CV against zone size.
use super::figure::{Figure, LinePanel, MapPanel, Panel, Series, Style};
use super::StageData;
use anyhow::Result;
use ndarray::{Axis, Ix1, Ix2, Ix3};

/// `a` at sweep point `p` (a swept image stage stores its results with a leading
/// `point` dimension); `a` itself for an unswept stage.
fn at(a: &ndarray::ArrayD<f64>, swept: bool, p: usize) -> ndarray::ArrayD<f64> {
    if swept {
        a.index_axis(Axis(0), p).to_owned()
    } else {
        a.clone()
    }
}

/// A group label in physical terms: `belt_speed_ratio=0.05` (an image of a grid's sweep
/// point) reads `v_b/v_f = 0.05`; any other label as it is.
fn group_text(group: &str) -> String {
    match group.split_once('=').map(|(k, v)| (k.trim(), v.trim(), v.trim().parse::<f64>())) {
        Some((name, text, Ok(v))) if !name.is_empty() && !name.contains(' ') => super::labels::value_text(name, "1", v, text, &[v]),
        _ => group.to_string(),
    }
}

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let mut figs = vec![];
    // A sweep of the analysis (notch width, threshold, bonds...) adds a leading point dimension.
    let swept = d.f64("cv_corr")?.ndim() == 2;
    let points = if swept { d.f64("cv_corr")?.shape()[0] } else { 1 };
    if d.has("raw_image") {
        let stored = d.f64("stored_sample")?.into_dimensionality::<Ix1>()?;
        let pixel = d.f64("pixel_size")?.into_dimensionality::<Ix1>()?;
        let groups = d.strings("group")?;
        let names = ["raw_image", "filtered_image", "log_spectrum_raw", "log_spectrum_notched"];
        let titles = ["raw image", "bond pattern removed", "energy spectrum, raw", "energy spectrum, bond peaks notched"];
        let all: Vec<ndarray::ArrayD<f64>> = names.iter().map(|n| d.f64(n)).collect::<Result<_>>()?;
        for p in 0..points {
            let arrays: Vec<ndarray::Array3<f64>> = all.iter().map(|a| Ok(at(a, swept, p).into_dimensionality::<Ix3>()?)).collect::<Result<_>>()?;
            let (prefix, title_suffix) = if swept { (format!("point{p:03}_"), format!(", {}", d.point_label(p))) } else { (String::new(), String::new()) };
            for (k, &sample) in stored.iter().enumerate() {
                let sample = sample as usize;
                let mm = pixel[sample] * 1e3;
                let panels = arrays
                    .iter()
                    .zip(titles)
                    .enumerate()
                    .map(|(i, (a, title))| {
                        // Drop the NaN padding of smaller images.
                        let img = a.index_axis(Axis(0), k);
                        let rows = img.axis_iter(Axis(0)).take_while(|r| r.iter().any(|v| v.is_finite())).count();
                        let cols = (0..img.shape()[1]).take_while(|&j| img[[0, j]].is_finite()).count();
                        let values = img.slice(ndarray::s![..rows, ..cols]).to_owned();
                        // Image row 0 is the top: flip so the map's y axis runs upwards.
                        let values = values.slice(ndarray::s![..;-1, ..]).to_owned();
                        let spectrum = i >= 2;
                        // A centred spectrum runs from −Nyquist to Nyquist (1/(2 pixel)) on
                        // both axes: bins are 1/(cols·pixel) apart along x, 1/(rows·pixel) along y.
                        // Row i holds row frequency i − rows/2; flipped like the image, so f_y
                        // points up as y does.
                        let (fx, fy) = (1.0 / (cols as f64 * mm), 1.0 / (rows as f64 * mm));
                        let (cx, cy) = ((cols / 2) as f64, (rows / 2) as f64);
                        Panel::Map(MapPanel {
                            title: title.into(),
                            x_label: if spectrum { "f_x (cycles/mm)".into() } else { "x (mm)".into() },
                            y_label: if spectrum { "f_y (cycles/mm)".into() } else { "y (mm)".into() },
                            extent: if spectrum {
                                ((-cx - 0.5) * fx, (cols as f64 - cx - 0.5) * fx, -(rows as f64 - cy - 0.5) * fy, (cy + 0.5) * fy)
                            } else {
                                (0.0, cols as f64 * mm, 0.0, rows as f64 * mm)
                            },
                            values,
                            colour_label: if spectrum { "log₁₀ energy".into() } else { "grey level".into() },
                            grey: !spectrum,
                        })
                    })
                    .collect();
                figs.push(Figure::new(
                    &format!("{prefix}sample{sample:03}"),
                    &format!("Sample {sample} ({}{title_suffix})", group_text(&groups[sample])),
                    panels,
                    2,
                ));
            }
        }
    }
    // CV per condition, or against the swept parameter.
    let conditions = d.strings("condition")?;
    let metrics = [("cv_raw", "CV raw"), ("cv_corr", "CV_corr"), ("cv_corr_plain", "CV_corr plain (paper)"), ("cv_web", "CV of the web (truth)")];
    // The x values and one line per condition (swept: a line along the points for each
    // condition; unswept: one line across the conditions).
    let mut categories = vec![];
    let (x, x_label, log_x, lines): (Vec<f64>, String, bool, Vec<(String, Option<usize>)>) = if swept {
        let sweep = d.swept();
        let first = sweep.iter().find(|s| s.values.iter().all(|v| v.is_finite()));
        let label = first.map(super::axis_label);
        let x: Vec<f64> = match (first, &label) {
            (Some(s), Some(l)) => s.values.iter().map(|v| v * l.scale).collect(),
            _ => (0..points).map(|p| p as f64).collect(),
        };
        // A threshold swept over decades reads best on a log axis.
        let (lo, hi) = x.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        let lines = conditions.iter().enumerate().map(|(c, name)| (if conditions.len() > 1 { format!(", {name}") } else { String::new() }, Some(c))).collect();
        (x, label.map(|l| l.text).unwrap_or_else(|| "sweep point".into()), lo > 0.0 && hi / lo > 100.0, lines)
    } else {
        let (x, label) = match d.swept_conditions() {
            Some((name, values)) => {
                let l = super::labels::label(&name, "", &values);
                (values.iter().map(|v| v * l.scale).collect(), l.text)
            }
            None => {
                // conditions without a numeric value: labelled categories
                categories = conditions.clone();
                ((0..conditions.len()).map(|i| i as f64).collect(), "condition".into())
            }
        };
        (x, label, false, vec![(String::new(), None)])
    };
    let mut series = vec![];
    for (k, (suffix, condition)) in lines.iter().enumerate() {
        for (i, (name, label)) in metrics.iter().enumerate() {
            if !d.has(&format!("{name}_mean")) {
                continue; // cv_corr_plain: versions written before it existed
            }
            let (m, s) = (d.f64(&format!("{name}_mean"))?, d.f64(&format!("{name}_std"))?);
            let (m, s) = match condition {
                Some(c) => (m.index_axis(Axis(1), *c).to_owned(), s.index_axis(Axis(1), *c).to_owned()),
                None => (m, s),
            };
            if m.iter().all(|v| !v.is_finite()) {
                continue;
            }
            let style = if i == 3 { Style::Dashed } else { Style::LineMarkers };
            let label = format!("{label}{suffix}");
            series.push(Series::new(Some(&label), x.iter().zip(m.iter()).map(|(&a, &b)| (a, b)).collect(), style, i + 4 * k).with_error(s.iter().copied().collect()));
        }
    }
    // Zone sides actually used are per sample (pixel sizes may differ): the mean over the
    // samples that share a side, at each side.
    let zone = d.f64("zone_size")?.into_dimensionality::<Ix2>()?;
    let (raw, filtered) = (d.f64("zone_cv_raw")?, d.f64("zone_cv_filtered")?);
    let zone_series = |a: ndarray::ArrayD<f64>, label: &str, style, colour| -> Result<Series> {
        let a = a.into_dimensionality::<Ix2>()?;
        let mut by_size: Vec<(f64, f64, usize)> = Vec::new();
        for (&z, &c) in zone.iter().zip(a.iter()) {
            if !(z.is_finite() && c.is_finite()) {
                continue;
            }
            match by_size.iter_mut().find(|(s, _, _)| (s / z - 1.0).abs() < 1e-9) {
                Some(e) => {
                    e.1 += c;
                    e.2 += 1;
                }
                None => by_size.push((z, c, 1)),
            }
        }
        by_size.sort_by(|x, y| x.0.total_cmp(&y.0));
        Ok(Series::new(Some(label), by_size.iter().map(|&(z, c, n)| (z * 1e3, c / n as f64)).collect(), style, colour))
    };
    let mut zones = vec![zone_series(at(&raw, swept, 0), "raw", Style::LineMarkers, 0)?];
    for p in 0..points {
        let label = if swept { format!("bond pattern removed, {}", d.point_label(p)) } else { "bond pattern removed".into() };
        zones.push(zone_series(at(&filtered, swept, p), &label, Style::LineMarkers, 1 + p)?);
    }
    figs.push(Figure::new(
        "cv",
        "Uniformity of the images (mean ± std per condition)",
        vec![
            Panel::Lines(LinePanel { title: if swept { "CV against the swept parameter".into() } else { "CV per condition".into() }, x_label, y_label: "CV of grey levels".into(), series, log_x, categories, ..Default::default() }),
            Panel::Lines(LinePanel {
                title: "CV against zone size, mean over samples".into(),
                x_label: "zone size (mm)".into(),
                y_label: "CV".into(),
                log_x: true,
                log_y: true,
                series: zones,
                ..Default::default()
            }),
        ],
        2,
    ));
    Ok(figs)
}

#[cfg(test)]
mod tests {
    #[test]
    fn group_labels_of_sweep_points_read_physically() {
        assert_eq!(super::group_text("belt_speed_ratio=0.05"), "v_b/v_f = 0.05");
        assert_eq!(super::group_text("v020"), "v020");
        assert_eq!(super::group_text("a b=1"), "a b=1");
    }
}
