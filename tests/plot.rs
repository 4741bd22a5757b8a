//! `laydown plot` draws every stage of a small pipeline as PNG and SVG, and says
//! clearly when it cannot.
mod common;
use common::*;

const PIPELINE: &str = "\
pipeline: plots
archive: plots.h5
seed: 3
stages:
  - name: fibre
    kind: laydown
    params: {length: 0.08, elements: 80}
    sweep:
      friction_coefficient: [0.5, 1.0]
    replicates: 2
  - name: spectra
    kind: spectra
    input: fibre
  - name: ideal
    kind: spectra
    params: {preset: spectrum1}
    replicates: 2
  - name: web
    kind: web
    params: {preset: spectrum1, points_per_segment: 250, fibres_across: 100, fibre_spacing: 0.001, segments_per_fibre: 5}
    sweep:
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
  - name: swept_scans
    kind: image
    params:
      synthetic: {kind: noise, count: 2, rows: 96, cols: 128}
      panels: false
      bonds: {shape: circle, size1: 0.0015, period1: 0.0042, period2: 0.0042, angle: 45.0, contrast: 0.15}
    sweep: {notch_sigma_bins: [1.5, 4.0]}
  - name: laid
    kind: laid_web
    params: {fibres_across: 3, fibre_spacing: 0.004, belt_travel: 0.03}
    sweep: {oscillation_amplitude: [0.005, 0.01]}
";

/// Distinct colours in a PNG: a blank or single-colour figure has one or two.
fn colours(path: &std::path::Path) -> usize {
    let img = image::open(path).unwrap().to_rgb8();
    let mut seen = std::collections::HashSet::new();
    for p in img.pixels() {
        seen.insert(p.0);
    }
    seen.len()
}

#[test]
fn every_stage_plots_as_png_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    let o = run_in(dir.path(), &["run", "p.yaml"]);
    assert!(o.status.success(), "{:?}", text(&o));

    let o = run_in(dir.path(), &["plot", "plots.h5"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let paths: Vec<&str> = out.lines().collect();
    for expected in ["fibre/v1/fibre.png", "fibre/v1/sweep_fibres.png", "fibre/v1/radius_of_gyration_bending_energy.png", "spectra/v1/energy_spectrum.png", "ideal/v1/curvature.png",
        "web/v1/fibres.png", "grid/v1/density.png", "grid/v1/zone_size.png", "grid/v1/uniformity_vs_belt_speed_ratio.png",
        "scans/v1/sample000.png", "scans/v1/cv.png", "swept_scans/v1/point001_sample000.png", "swept_scans/v1/cv.png",
        "laid/v1/laid_web.png", "laid/v1/fibre_shapes.png"] {
        let p = paths.iter().find(|p| p.ends_with(expected)).unwrap_or_else(|| panic!("{expected} missing from {out}"));
        let p = dir.path().join(p);
        assert!(p.starts_with(dir.path().join("plots_figures")), "{}", p.display());
        assert!(colours(&p) > 20, "{} looks blank", p.display());
    }
    // a web laid without fibre contact lies on the belt: no height figure
    assert!(!out.contains("web_height"), "{out}");

    let o = run_in(dir.path(), &["plot", "plots.h5", "fibre@v1", "--format", "svg", "--out", "svg"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let svg = std::fs::read_to_string(dir.path().join("svg/radius_of_gyration_bending_energy.svg")).unwrap();
    // physical labels, not parameter names
    assert!(svg.starts_with("<svg") && svg.contains("friction μ") && !svg.contains("friction_coefficient") && svg.contains("<polyline"), "{out}");
}

/// Print size, resolution and provenance: PNG pixels and pHYs from --width and --dpi,
/// the archive and stage@version in every file's metadata, PDF beside PNG and SVG.
#[test]
fn figures_carry_print_size_and_provenance_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    assert!(run_in(dir.path(), &["run", "p.yaml", "--only", "ideal"]).status.success());
    let o = run_in(dir.path(), &["plot", "plots.h5", "ideal", "--format", "png,svg,pdf", "--width", "85", "--dpi", "600", "--font-size", "7", "--out", "f"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(out.lines().count(), 6, "two figures in three formats: {out}");
    let archive = std::fs::canonicalize(dir.path().join("plots.h5")).unwrap().display().to_string();

    let png = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(dir.path().join("f/energy_spectrum.png")).unwrap())).read_info().unwrap();
    let info = png.info();
    assert_eq!(info.width, (85.0f64 / 25.4 * 600.0).ceil() as u32);
    let dims = info.pixel_dims.unwrap();
    assert_eq!(dims.xppu, (600.0f64 / 0.0254).round() as u32);
    let texts: String = info.uncompressed_latin1_text.iter().map(|t| format!("{}={}\n", t.keyword, t.text)).collect();
    assert!(texts.contains(&archive) && texts.contains("ideal@v1"), "{texts}");

    let svg = std::fs::read_to_string(dir.path().join("f/energy_spectrum.svg")).unwrap();
    // 85 mm = 240.9 pt (to the canvas' half-point grid)
    let width: f64 = svg.strip_prefix("<svg width=\"").and_then(|s| s.split("pt\"").next()).and_then(|w| w.parse().ok()).unwrap_or(0.0);
    assert!((width - 85.0 / 25.4 * 72.0).abs() <= 0.5, "{}", &svg[..200]);
    assert!(svg.contains("<metadata>") && svg.contains(&archive) && svg.contains("ideal@v1"));
    // text of at least 7 pt at the page width: 2 units a point in the SVG
    let smallest = svg.split("font-size=\"").skip(1).filter_map(|s| s.split('"').next()?.parse::<f64>().ok()).fold(f64::INFINITY, f64::min);
    assert!(smallest / 2.0 >= 0.9 * 7.0 - 1e-9, "{smallest}");

    let pdf = std::fs::read(dir.path().join("f/energy_spectrum.pdf")).unwrap();
    let pdf = String::from_utf8_lossy(&pdf);
    assert!(pdf.starts_with("%PDF-") && pdf.contains("/Stage (ideal@v1)") && pdf.contains(&archive) && pdf.contains("/FontFile2"), "{}", &pdf[..400.min(pdf.len())]);
}

#[test]
fn unknown_stage_or_version_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(dir.path(), "p.yaml", PIPELINE);
    assert!(run_in(dir.path(), &["run", "p.yaml", "--only", "ideal"]).status.success());
    for (stage, message) in [("nope", "nope"), ("ideal@v7", "v7"), ("ideal@7", "STAGE@vN")] {
        let o = run_in(dir.path(), &["plot", "plots.h5", stage]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(message), "{stage}: {err}");
    }
}

/// A web laid with fibre contact has a thickness: `laydown plot` adds the height of the
/// laid fibre (per cell, and along the belt).
#[test]
fn a_contact_web_plots_its_height() {
    let dir = tempfile::tempdir().unwrap();
    write_pipeline(
        dir.path(),
        "p.yaml",
        "pipeline: heights\narchive: h.h5\nseed: 3\nstages:\n  - name: laid\n    kind: laid_web\n    params: {fibres_across: 2, fibre_spacing: 0.002, belt_travel: 0.01, fibre_contact: true, oscillation_ramp: 0.01}\n",
    );
    let o = run_in(dir.path(), &["run", "p.yaml"]);
    assert!(o.status.success(), "{:?}", text(&o));
    let o = run_in(dir.path(), &["plot", "h.h5"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let p = out.lines().find(|p| p.ends_with("laid/v1/web_height.png")).unwrap_or_else(|| panic!("web_height.png missing from {out}"));
    assert!(colours(&dir.path().join(p)) > 20, "{p} looks blank");
}
