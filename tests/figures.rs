//! Every figure kind, drawn from small generated archives at print size, is laid out
//! cleanly: nothing drawn outside its canvas, no two text labels overlapping.
//!
//! The figures are drawn onto a recording backend (`laydown::plot::inspect`) that keeps
//! each primitive's extent and each text's box as the bitmap backend would fill it.
mod common;
use common::*;
use laydown::plot::figure::RenderOptions;

/// One archive with every stage kind, including two-parameter sweeps (whose panel titles
/// and legends are the longest), an image that is not square, and an accuracy stage.
const PIPELINE: &str = "\
pipeline: figures
archive: figures.h5
seed: 5
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.08, elements: 80, diagnostic_stride: 200}
    replicates: 3
  - name: fibres
    kind: laydown
    params: {length: 0.08, elements: 80}
    sweep:
      friction_coefficient: [0.5, 1.0]
      diameter: [3.0e-5, 5.0e-5]
    replicates: 2
  - name: mesh
    kind: laydown
    params: {length: 0.08}
    sweep: {elements: [40, 80]}
    replicates: 3
  - name: cost
    kind: accuracy
    input: [fibre, mesh]
  - name: spectra
    kind: spectra
    input: fibre
  - name: ideal
    kind: spectra
    sweep: {preset: [spectrum1, spectrum2]}
  - name: web
    kind: web
    params: {points_per_segment: 250, fibres_across: 100, fibre_spacing: 0.001, segments_per_fibre: 5}
    sweep:
      preset: [spectrum1, spectrum2]
      belt_speed_ratio: [0.05, 0.1]
  - name: grid
    kind: grid
    input: web
    params: {cell_size: 0.002, window_side: 0.1, boundary: periodic}
    replicates: 2
  - name: scans
    kind: image
    input: grid
    params:
      bonds: {shape: circle, size1: 0.003, period1: 0.009, period2: 0.009, angle: 45.0, angle_between: 90.0, contrast: 0.15, zero_mean: true}
  - name: flat
    kind: image
    params:
      synthetic: {kind: noise, count: 2, rows: 62, cols: 87}
      bonds: {shape: circle, size1: 0.0015, period1: 0.0042, period2: 0.0042, angle: 45.0, contrast: 0.15}
    sweep: {notch_sigma_bins: [1.5, 4.0]}
  - name: laid
    kind: laid_web
    params: {fibres_across: 3, fibre_spacing: 0.004, belt_travel: 0.03}
    sweep: {oscillation_amplitude: [0.005, 0.01]}
";

/// Run [`PIPELINE`] in `dir`; returns its archive.
fn run_pipeline(dir: &std::path::Path) -> std::path::PathBuf {
    write_pipeline(dir, "p.yaml", PIPELINE);
    let o = run_in(dir, &["run", "p.yaml"]);
    assert!(o.status.success(), "{:?}", text(&o));
    dir.join("figures.h5")
}

#[test]
fn every_figure_kind_is_laid_out_within_its_canvas_without_overlapping_labels_or_covering_data() {
    let dir = tempfile::tempdir().unwrap();
    let archive = run_pipeline(dir.path());

    let mut kinds = std::collections::BTreeSet::new();
    let mut problems = vec![];
    let (mut figures, mut data_marks) = (0, 0);
    for stage in ["fibre", "fibres", "mesh", "cost", "spectra", "ideal", "web", "grid", "scans", "flat", "laid"] {
        let data = laydown::plot::open(&archive, stage).unwrap();
        kinds.insert(data.kind().to_string());
        for fig in laydown::plot::figures(&data).unwrap() {
            figures += 1;
            // a two-column page (default) and one journal column at 7 pt
            for opts in [RenderOptions::default(), RenderOptions { width_mm: Some(85.0), font_pt: 7.0, ..Default::default() }] {
                let record = fig.inspect(&opts).unwrap();
                assert!(record.texts.len() > 5, "{stage}/{}: only {} texts drawn", fig.name, record.texts.len());
                data_marks += record.data.len();
                problems.extend(record.problems().into_iter().map(|p| format!("{stage}/{} at {} mm: {p}", fig.name, opts.width_for(&fig))));
            }
        }
    }
    assert_eq!(kinds.into_iter().collect::<Vec<_>>(), ["accuracy", "grid", "image", "laid_web", "laydown", "spectra", "web"]);
    assert!(figures >= 15, "{figures} figures");
    // The text-on-data check had data to check against.
    assert!(data_marks > 1000, "{data_marks} data segments recorded");
    assert!(problems.is_empty(), "{} layout problems:\n{}", problems.len(), problems.join("\n"));
}

/// Tallest figure of four maps in one journal column (mm): fits a page's text block.
const MAX_FOUR_MAP_HEIGHT_MM: f64 = 230.0;
/// Narrowest map there: width of each map's plotting area (mm), a third of the column
/// (maps keep their aspect ratio, so a wide map is less tall).
const MIN_MAP_WIDTH_MM: f64 = 28.0;

#[test]
fn four_maps_in_one_journal_column_fit_a_page_and_stay_legible() {
    let dir = tempfile::tempdir().unwrap();
    let archive = run_pipeline(dir.path());
    let mm = |units: i32, dpi: f64| units as f64 / dpi * 25.4;
    let mut checked = 0;
    let mut report = vec![];
    // square images and spectra (scans), a 62 × 87 image with its square spectra (flat),
    // and four density maps of one quantity (grid)
    for (stage, name) in [("scans", "sample000"), ("flat", "point000_sample000"), ("grid", "density")] {
        let data = laydown::plot::open(&archive, stage).unwrap();
        let fig = laydown::plot::figures(&data).unwrap().into_iter().find(|f| f.name == name).unwrap();
        assert_eq!(fig.panels.len(), 4, "{stage}/{name}");
        for font_pt in [7.0, 8.0] {
            let opts = RenderOptions { width_mm: Some(85.0), font_pt, ..Default::default() };
            let r = fig.inspect(&opts).unwrap();
            let height = mm(r.size.1 as i32, opts.dpi);
            report.push(format!("{stage}/{name} at 85 mm, {font_pt} pt: {height:.1} mm tall, maps {:?} mm", r.maps.iter().map(|m| (mm(m.2 - m.0, opts.dpi).round(), mm(m.3 - m.1, opts.dpi).round())).collect::<Vec<_>>()));
            assert!(height <= MAX_FOUR_MAP_HEIGHT_MM, "{}", report.last().unwrap());
            assert_eq!(r.maps.len(), 4, "{}", report.last().unwrap());
            for m in &r.maps {
                assert!(mm(m.2 - m.0, opts.dpi) >= MIN_MAP_WIDTH_MM, "{}", report.last().unwrap());
            }
            // the maps take a fair share of the page, not their labels
            let area: f64 = r.maps.iter().map(|m| mm(m.2 - m.0, opts.dpi) * mm(m.3 - m.1, opts.dpi)).sum();
            assert!(area >= 0.25 * 85.0 * height, "maps cover {:.0} % of the figure: {}", 100.0 * area / (85.0 * height), report.last().unwrap());
            assert!(r.problems().is_empty(), "{:?}", r.problems());
            checked += 1;
        }
    }
    assert_eq!(checked, 6);
    eprintln!("{}", report.join("\n"));
}
