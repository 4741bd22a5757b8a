//! Image figures: raw and filtered images with their log energy spectra before and after
//! notching (Fig 12), CV per condition, and CV against zone size.
use super::figure::{Figure, LinePanel, MapPanel, Panel, Series, Style};
use super::StageData;
use anyhow::Result;
use ndarray::{Axis, Ix1, Ix2, Ix3};

pub fn figures(d: &StageData) -> Result<Vec<Figure>> {
    let mut figs = vec![];
    if d.has("raw_image") {
        let stored = d.f64("stored_sample")?.into_dimensionality::<Ix1>()?;
        let pixel = d.f64("pixel_size")?.into_dimensionality::<Ix1>()?;
        let groups = d.strings("group")?;
        let names = ["raw_image", "filtered_image", "log_spectrum_raw", "log_spectrum_notched"];
        let titles = ["raw", "bond pattern removed", "log10 energy spectrum, raw", "log10 energy spectrum, notched"];
        let arrays: Vec<ndarray::Array3<f64>> =
            names.iter().map(|n| d.f64(n).and_then(|a| Ok(a.into_dimensionality::<Ix3>()?))).collect::<Result<_>>()?;
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
                    Panel::Map(MapPanel {
                        title: title.into(),
                        x_label: if spectrum { "frequency bin (centred)".into() } else { "x (mm)".into() },
                        y_label: if spectrum { "frequency bin (centred)".into() } else { "y (mm)".into() },
                        extent: if spectrum {
                            (-(cols as f64) / 2.0, cols as f64 / 2.0, -(rows as f64) / 2.0, rows as f64 / 2.0)
                        } else {
                            (0.0, cols as f64 * mm, 0.0, rows as f64 * mm)
                        },
                        values,
                        colour_label: if spectrum { "log10 energy".into() } else { "grey level".into() },
                        grey: true,
                    })
                })
                .collect();
            figs.push(Figure::new(&format!("sample{sample:03}"), &format!("Sample {sample} ({})", groups[sample]), panels, 2));
        }
    }
    // CV per condition.
    let conditions = d.strings("condition")?;
    let x: Vec<f64> = (0..conditions.len()).map(|i| i as f64).collect();
    let (x, x_label) = match d.swept_conditions() {
        Some((name, values)) => (values, name),
        None => (x, format!("condition ({})", conditions.join(", "))),
    };
    let mut series = vec![];
    for (i, (name, label)) in [("cv_raw", "CV raw"), ("cv_corr", "CV_corr"), ("cv_web", "CV of the web (truth)")].iter().enumerate() {
        let (m, s) = (d.f64(&format!("{name}_mean"))?, d.f64(&format!("{name}_std"))?);
        if m.iter().all(|v| !v.is_finite()) {
            continue;
        }
        series.push(
            Series::new(Some(label), x.iter().zip(m.iter()).map(|(&a, &b)| (a, b)).collect(), if i == 2 { Style::Dashed } else { Style::LineMarkers }, i)
                .with_error(s.iter().copied().collect()),
        );
    }
    let zone = d.f64("zone_size")?;
    let raw = d.f64("zone_cv_raw")?.into_dimensionality::<Ix2>()?;
    let filtered = d.f64("zone_cv_filtered")?.into_dimensionality::<Ix2>()?;
    let zone_series = |a: &ndarray::Array2<f64>, label: &str, style, colour| {
        Series::new(Some(label), zone.iter().zip(a.mean_axis(Axis(0)).unwrap().iter()).map(|(&z, &c)| (z * 1e3, c)).collect(), style, colour)
    };
    figs.push(Figure::new(
        "cv",
        "Uniformity of the images (mean ± std per condition)",
        vec![
            Panel::Lines(LinePanel { title: "CV per condition".into(), x_label, y_label: "CV of grey levels".into(), series, ..Default::default() }),
            Panel::Lines(LinePanel {
                title: "CV against zone size, mean over samples".into(),
                x_label: "zone size (mm)".into(),
                y_label: "CV".into(),
                log_x: true,
                log_y: true,
                series: vec![zone_series(&raw, "raw", Style::LineMarkers, 0), zone_series(&filtered, "bond pattern removed", Style::LineMarkers, 1)],
                ..Default::default()
            }),
        ],
        2,
    ));
    Ok(figs)
}
