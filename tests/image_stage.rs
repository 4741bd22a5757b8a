//! End-to-end checks of the image stage numerics on rendered webs of known uniformity.
use laydown::stages::image::render::{random_fibre_web, render, smoothed_noise, BondPattern, BondShape, RenderParams};
use laydown::stages::image::{analyze, analyze_file, analyze_files, ImageError, ImageParams, InputSpec};
use laydown::uniformity::coefficient_of_variation;
use ndarray::Array2;

const PX: f64 = 0.34e-3;

fn web(rows: usize, cols: usize, seed: u64) -> Array2<f64> {
    // 20 g/m², 10 mm fibres, MD-biased orientation like a spunbond.
    random_fibre_web(rows, cols, PX, 20.0, 10e-3, 1e-3, Some(35.0), seed)
}

fn cv(a: &Array2<f64>) -> f64 {
    coefficient_of_variation(a.iter().copied())
}

fn bonded(density: &Array2<f64>, b: BondPattern) -> (Array2<f64>, Array2<f64>) {
    let truth = render(density, PX, &RenderParams::default()).unwrap().grey;
    let rp = RenderParams { bonds: Some(b), ..Default::default() };
    (truth, render(density, PX, &rp).unwrap().grey)
}

#[test]
fn bond_free_images_are_left_alone() {
    let p = ImageParams::default();
    let rp8 = RenderParams { bits: 8, ..Default::default() };
    let cases: Vec<(&str, Array2<f64>)> = vec![
        ("random fibre web", render(&web(240, 300, 1), PX, &RenderParams::default()).unwrap().grey),
        ("random fibre web, 8 bit", render(&web(251, 317, 2), PX, &rp8).unwrap().grey),
        ("isotropic web", render(&random_fibre_web(200, 256, PX, 20.0, 10e-3, 1e-3, None, 3), PX, &RenderParams::default()).unwrap().grey),
        // Blurred, noise-free: the spectrum falls to round-off (the REFERENCE pitfall).
        ("smoothed noise σ=3 px", smoothed_noise(256, 200, 3.0, 0.5, 0.15, 4)),
        ("smoothed noise σ=1 px", smoothed_noise(199, 256, 1.0, 0.5, 0.15, 5)),
        ("white noise", smoothed_noise(256, 256, 0.0, 0.5, 0.2, 6)),
    ];
    for (name, img) in cases {
        let a = analyze(&img, PX, &p).unwrap();
        let change = (a.cv_corr / a.cv_raw - 1.0).abs();
        println!("{name}: cv_raw {:.5} cv_corr {:.5} change {:.2e} peaks {}", a.cv_raw, a.cv_corr, change, a.peaks.len());
        assert!(change < 0.005, "{name}: CV changed by {change}");
        assert!(a.peaks.len() <= 1, "{name}: {} false peaks: {:?}", a.peaks.len(), &a.peaks[..a.peaks.len().min(5)]);
    }
}

fn lattice_case(name: &str, rows: usize, cols: usize, seed: u64, b: BondPattern) {
    let density = web(rows, cols, seed);
    let (truth, img) = bonded(&density, b.clone());
    let a = analyze(&img, PX, &ImageParams::default()).unwrap();
    let cv_true = cv(&truth);
    let err = a.cv_corr_compensated / cv_true - 1.0;
    let err_plain = a.cv_corr_plain / cv_true - 1.0;
    let lat = a.lattice.as_ref().expect("lattice");
    println!(
        "{name}: truth {:.4} raw {:.4} ({:+.0} %) corr {:.4} ({:+.2} %) compensated {:.4} ({:+.2} %) peaks {} notches {} removed {:.3} lattice {:?} mm at {:?}°, between {:?}",
        cv_true,
        a.cv_raw,
        100.0 * (a.cv_raw / cv_true - 1.0),
        a.cv_corr_plain,
        100.0 * err_plain,
        a.cv_corr_compensated,
        100.0 * err,
        a.peaks.len(),
        a.notch_count,
        a.fraction_variance_removed,
        lat.periods.iter().map(|p| p * 1e3).collect::<Vec<_>>(),
        lat.angles_deg,
        lat.angle_between_deg
    );
    // Notching keeps the image mean exactly.
    assert!((a.filtered.mean().unwrap() - a.mean).abs() < 1e-12 * a.mean);
    assert!(a.cv_raw > 1.4 * cv_true, "{name}: raw CV {} not far from truth {cv_true}", a.cv_raw);
    assert!(err.abs() < 0.05, "{name}: compensated CV_corr {} vs truth {cv_true}", a.cv_corr_compensated);
    // The plain CV of the filtered image is low by the web power under the notches.
    assert!(err_plain < 0.02 && err_plain > -0.12, "{name}: plain CV_corr {} vs truth {cv_true}", a.cv_corr_plain);
    // The reported CV_corr is the compensated one (CV_CORR_RULE).
    assert_eq!(a.cv_corr, a.cv_corr_compensated);
    // The fitted lattice has the rendered repeat distances.
    let mut want = [b.period1, b.period2];
    want.sort_by(|x, y| x.total_cmp(y));
    let mut got = lat.periods.clone();
    got.sort_by(|x, y| x.total_cmp(y));
    assert_eq!(got.len(), 2, "{name}");
    for (g, w) in got.iter().zip(want) {
        assert!((g / w - 1.0).abs() < 0.02, "{name}: period {g} vs {w}");
    }
}

#[test]
fn square_lattice_period_not_dividing_image() {
    // 4 mm = 11.76 px: not a divisor of 240 or 300.
    let b = BondPattern { contrast: 0.4, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() };
    lattice_case("square 4 mm, 0°", 240, 300, 11, b);
}

#[test]
fn rotated_rectangular_lattice() {
    let b = BondPattern {
        period1: 5e-3,
        period2: 3.5e-3,
        angle_deg: 30.0,
        shape: BondShape::Ellipse { major: 1.8e-3, minor: 1.1e-3, angle_deg: 30.0 },
        contrast: 0.5,
        ..Default::default()
    };
    lattice_case("rect 5×3.5 mm, 30°, elliptic", 256, 256, 12, b);
}

#[test]
fn staggered_lattice_with_rectangular_bonds() {
    let b = BondPattern {
        period1: 4.5e-3,
        period2: 4.5e-3,
        angle_deg: 15.0,
        angle_between_deg: 60.0,
        shape: BondShape::Rectangle { width: 1.6e-3, height: 1.1e-3, angle_deg: 15.0 },
        contrast: -0.4,
        ..Default::default()
    };
    lattice_case("staggered 4.5 mm 60°, 15°, rectangles", 231, 289, 13, b);
}

#[test]
fn lattice_period_dividing_the_image() {
    // 16 px period in a 256×192 image: every harmonic falls exactly on a bin.
    let b = BondPattern {
        period1: 16.0 * PX,
        period2: 16.0 * PX,
        shape: BondShape::Circle { diameter: 2e-3 },
        contrast: 0.4,
        ..Default::default()
    };
    lattice_case("square 16 px dividing the image", 192, 256, 14, b);
}

#[test]
fn one_sided_pattern_biases_cv_corr_and_the_one_sided_estimate_recovers_it() {
    let density = web(240, 240, 21);
    let b = BondPattern { contrast: 0.3, zero_mean: false, ..Default::default() };
    let (truth, img) = bonded(&density, b);
    let a = analyze(&img, PX, &ImageParams::default()).unwrap();
    let cv_true = cv(&truth);
    let os = a.cv_corr_one_sided.unwrap();
    println!(
        "one-sided bonds: truth {cv_true:.4} raw {:.4} corr (mean kept) {:.4} one-sided {:.4} bond mean est {:.4}",
        a.cv_raw, a.cv_corr, os, a.bond_mean_estimate
    );
    // Mean kept: biased low by the bond mean (compensated or not); the one-sided
    // estimate removes the bias.
    assert!(a.cv_corr < 0.99 * cv_true && a.cv_corr_plain < 0.97 * cv_true);
    assert!((os / cv_true - 1.0).abs() < (a.cv_corr / cv_true - 1.0).abs());
    assert!((os / cv_true - 1.0).abs() < 0.05, "{os} vs {cv_true}");
}

#[test]
fn saturated_bonds_give_a_finite_documented_result() {
    let density = web(200, 240, 31);
    // Bonds pushed far past white: clipped at 1.
    let b = BondPattern { contrast: 1.5, zero_mean: false, ..Default::default() };
    let (truth, img) = bonded(&density, b);
    let a = analyze(&img, PX, &ImageParams::default()).unwrap();
    println!("saturated: truth {:.4} raw {:.4} corr {:.4} one-sided {:?} warnings {:?}", cv(&truth), a.cv_raw, a.cv_corr, a.cv_corr_one_sided, a.warnings);
    assert!(a.cv_corr.is_finite() && a.cv_corr < a.cv_raw);
    assert!(a.warnings.iter().any(|w| w.contains("saturated")));
    assert!(a.filtered.iter().all(|v| v.is_finite()));
    // Every bond pixel is white: the censoring correction can only bound the pattern
    // there, and says so.
    assert!(a.censored_fraction > 0.05);
    assert!(a.warnings.iter().any(|w| w.contains("lattice phases are saturated")), "{:?}", a.warnings);
}

#[test]
fn period_larger_than_image_is_not_notched() {
    // A 40 mm lattice in a 64×64 px (22 mm) image: below the DC exclusion, looks like web.
    let density = web(64, 64, 41);
    let b = BondPattern { period1: 40e-3, period2: 40e-3, shape: BondShape::Circle { diameter: 8e-3 }, ..Default::default() };
    let (_, img) = bonded(&density, b);
    let a = analyze(&img, PX, &ImageParams::default()).unwrap();
    assert!(a.peaks.is_empty(), "{:?}", a.peaks);
    assert!((a.cv_corr - a.cv_raw).abs() < 1e-3 * a.cv_raw);
}

#[test]
fn degenerate_inputs_give_typed_errors_or_documented_results() {
    let p = ImageParams::default();
    // Constant grey: CV 0, no peaks, a warning; no NaN.
    let a = analyze(&Array2::from_elem((32, 40), 0.6), PX, &p).unwrap();
    assert_eq!((a.cv_raw, a.cv_corr, a.peaks.len()), (0.0, 0.0, 0));
    assert!(!a.warnings.is_empty());
    assert!(a.log_spectrum_raw.iter().all(|v| v.is_finite()));
    // Black image: mean 0.
    assert!(matches!(analyze(&Array2::zeros((32, 32)), PX, &p), Err(ImageError::NonPositiveMean { .. })));
    // Too small, NaN, bad parameter.
    assert!(matches!(analyze(&Array2::from_elem((8, 100), 0.5), PX, &p), Err(ImageError::TooSmall { .. })));
    let mut nan = Array2::from_elem((32, 32), 0.5);
    nan[[3, 3]] = f64::NAN;
    assert!(matches!(analyze(&nan, PX, &p), Err(ImageError::NonFinite { count: 1, .. })));
    let bad = ImageParams { notch_sigma_bins: 0.0, ..Default::default() };
    let e = analyze(&nan, PX, &bad).unwrap_err();
    assert!(e.to_string().contains("notch_sigma_bins") && e.to_string().contains("0.5 to 10"), "{e}");
    let both = ImageParams { pixel_size: Some(0.3e-3), dpi: Some(75.0), ..Default::default() };
    assert!(matches!(both.validate(), Err(ImageError::InvalidParam { name: "dpi", .. })));
    assert!((ImageParams { dpi: Some(254.0), ..Default::default() }.pixel_size_or_default() - 1e-4).abs() < 1e-15);
}

#[test]
fn files_in_groups_with_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let b = BondPattern { contrast: 0.3, ..Default::default() };
    // Two conditions, two files each, three formats and bit depths.
    for (k, (group, ext)) in [("a", "png"), ("a", "tif"), ("b", "png"), ("b", "jpg")].iter().enumerate() {
        let density = random_fibre_web(128, 160, PX, if *group == "a" { 30.0 } else { 12.0 }, 10e-3, 1e-3, Some(35.0), 50 + k as u64);
        let img = render(&density, PX, &RenderParams { bonds: Some(b.clone()), ..Default::default() }).unwrap().grey;
        let path = d.join(format!("{group}{k}.{ext}"));
        match *ext {
            "png" => laydown::stages::image::io::write_grey_png(&path, &img, 0.0, 1.0, 16).unwrap(),
            "tif" => image::GrayImage::from_fn(160, 128, |x, y| image::Luma([(img[[y as usize, x as usize]] * 255.0).round() as u8])).save(&path).unwrap(),
            _ => image::RgbImage::from_fn(160, 128, |x, y| {
                let g = (img[[y as usize, x as usize]] * 255.0).round() as u8;
                image::Rgb([g, g, g])
            })
            .save(&path)
            .unwrap(),
        }
    }
    let specs = vec![
        InputSpec { pattern: format!("{}/a*", d.display()), group: "0.020".into() },
        InputSpec { pattern: format!("{}/b*", d.display()), group: "0.070".into() },
    ];
    let params = ImageParams { pixel_size: Some(0.34e-3), ..Default::default() };
    let mut seen = 0;
    let batch = analyze_files(&specs, &params, |_, _, a| {
        seen += 1;
        assert!(!a.peaks.is_empty());
    })
    .unwrap();
    assert_eq!(seen, 4);
    assert_eq!(batch.groups.len(), 2);
    for g in &batch.groups {
        println!("group {}: n {} cv_raw {:?} cv_corr {:?}", g.group, g.n, g.cv_raw, g.cv_corr);
        assert_eq!(g.n, 2);
        assert!(g.cv_corr.mean < g.cv_raw.mean && g.cv_corr.std.is_finite());
    }
    // A corrupt file among them: a typed error with its path.
    let bad = d.join("a9.png");
    std::fs::write(&bad, b"not an image at all").unwrap();
    let e = analyze_files(&specs, &params, |_, _, _| {}).unwrap_err();
    assert!(matches!(e, ImageError::Decode { .. }) && e.to_string().contains("a9.png"), "{e}");
    // A tiny file: too small, with its path.
    let tiny = d.join("tiny.png");
    laydown::stages::image::io::write_grey_png(&tiny, &Array2::from_elem((4, 4), 0.5), 0.0, 1.0, 8).unwrap();
    let e = analyze_file(&tiny, &params).unwrap_err();
    assert!(matches!(e, ImageError::TooSmall { .. }) && e.to_string().contains("tiny.png"), "{e}");
}

#[test]
fn panel_png_has_the_2x2_layout() {
    let density = web(64, 80, 61);
    let (_, img) = bonded(&density, BondPattern::default());
    let a = analyze(&img, PX, &ImageParams::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fig12.png");
    laydown::stages::image::panel::write_panel_png(&path, &a, 7.0).unwrap();
    let back = laydown::stages::image::read_grey(&path).unwrap();
    let g = laydown::stages::image::panel::GAP;
    assert_eq!(back.data.dim(), (2 * 64 + 3 * g, 2 * 80 + 3 * g));
}

// ---------------------------------------------------------------------------------
// `kind: image` as a pipeline stage, through the `laydown` binary.
// ---------------------------------------------------------------------------------
mod common;
use common::{run_in, text, write_pipeline};
use laydown::stages::image::io::write_grey_png;
use std::path::Path;

fn read(archive: &Path, stage: &str, name: &str) -> Vec<f64> {
    let a = laydown::archive::Archive::open_read(archive).unwrap();
    let g = a.version(stage, None).unwrap().open().unwrap();
    if let Ok(v) = laydown::archive::hdf::read_f64(&g, name) {
        return v.iter().copied().collect();
    }
    laydown::archive::hdf::read_i64(&g, name).unwrap().iter().map(|&v| v as f64).collect()
}

fn read_strings(archive: &Path, stage: &str, name: &str) -> Vec<String> {
    let a = laydown::archive::Archive::open_read(archive).unwrap();
    let g = a.version(stage, None).unwrap().open().unwrap();
    laydown::archive::hdf::read_strings(&g, name).unwrap()
}

fn png(dir: &Path, name: &str, img: &Array2<f64>) {
    std::fs::create_dir_all(dir.join(name).parent().unwrap()).unwrap();
    write_grey_png(&dir.join(name), img, 0.0, 1.0, 16).unwrap();
}

const PIPE: &str = "pipeline: img\narchive: out/study.h5\nstages:\n  - name: scans\n    kind: image\n    params:\n";

fn pipeline(dir: &Path, params: &str) -> std::path::PathBuf {
    write_pipeline(dir, "p.yaml", &format!("{PIPE}{params}"))
}

#[test]
fn cli_bond_free_and_bonded_files_in_groups() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // Group "plain": bond-free webs. Group "bonded": the same webs with lattices at
    // several periods and angles, one period (4.1 mm = 12.06 px) not dividing the image.
    let lattices = [
        BondPattern { period1: 4.1e-3, period2: 4.1e-3, contrast: 0.45, shape: BondShape::Circle { diameter: 1.5e-3 }, ..Default::default() },
        BondPattern { period1: 3.4e-3, period2: 5e-3, angle_deg: 30.0, contrast: 0.45, shape: BondShape::Circle { diameter: 1.4e-3 }, ..Default::default() },
        BondPattern {
            period1: 4e-3,
            period2: 4e-3,
            angle_between_deg: 60.0,
            contrast: 0.4,
            shape: BondShape::Rectangle { width: 1.5e-3, height: 0.8e-3, angle_deg: 45.0 },
            ..Default::default()
        },
    ];
    let mut truth = vec![];
    for (i, b) in lattices.iter().enumerate() {
        let density = web(160, 200, 40 + i as u64);
        let (t, img) = bonded(&density, b.clone());
        png(d, &format!("plain/w{i}.png"), &t);
        png(d, &format!("bonded/w{i}.png"), &img);
        truth.push(cv(&t));
    }
    let p = pipeline(d, "      files: [plain/*.png, bonded/*.png]\n      groups: [plain, bonded]\n      pixel_size: 0.00034\n      max_stored_images: 2\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    let (o, e) = text(&out);
    println!("{o}\n{e}");
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(e.contains("scans: group") && e.contains("CV_corr"), "Table-4-like summary on stderr: {e}");
    let archive = d.join("out/study.h5");
    let (raw, corr, comp) = (read(&archive, "scans", "cv_raw"), read(&archive, "scans", "cv_corr"), read(&archive, "scans", "cv_corr_compensated"));
    let notches = read(&archive, "scans", "notches");
    assert_eq!(read_strings(&archive, "scans", "group"), ["plain", "plain", "plain", "bonded", "bonded", "bonded"]);
    assert!(read_strings(&archive, "scans", "file")[3].ends_with("bonded/w0.png"));
    for i in 0..3 {
        // Bond-free: no false notches, CV changed by less than 0.5 %.
        assert!((raw[i] / truth[i] - 1.0).abs() < 1e-3, "16-bit PNG round trip");
        assert!((corr[i] / raw[i] - 1.0).abs() < 0.005 && notches[i] == 0.0, "plain {i}: {} -> {}, {} notches", raw[i], corr[i], notches[i]);
        // Bonded: raw far off, the corrected CV within 5 % of the web's own.
        let j = i + 3;
        println!("lattice {i}: truth {:.4} raw {:.4} corr {:.4} comp {:.4}", truth[i], raw[j], corr[j], comp[j]);
        assert!(raw[j] > 1.3 * truth[i], "lattice {i}: raw {} truth {}", raw[j], truth[i]);
        assert!((comp[j] / truth[i] - 1.0).abs() < 0.05, "lattice {i}: compensated {} truth {}", comp[j], truth[i]);
        assert!(notches[j] >= 4.0);
    }
    // What the notch growth and the censoring correction did is stored per image:
    // nothing on bond-free images, growth over the leakage ridge of the off-grid lattice.
    let (grown, censored) = (read(&archive, "scans", "grown_bins"), read(&archive, "scans", "censored_fraction"));
    let censored_var = read(&archive, "scans", "censored_variance");
    assert!(grown[..3].iter().all(|&g| g == 0.0) && grown[3] > 0.0, "{grown:?}");
    assert!(censored[..3].iter().chain(&censored_var[..3]).all(|&c| c == 0.0), "{censored:?} {censored_var:?}");
    assert!(censored.iter().chain(&censored_var).all(|&c| (0.0..1.0).contains(&c)), "{censored:?} {censored_var:?}");
    let p1 = read(&archive, "scans", "lattice_period1");
    assert!(p1[3..].iter().all(|p| p.is_finite()) && p1[..3].iter().all(|p| p.is_nan()), "{p1:?}");
    assert_eq!(read_strings(&archive, "scans", "condition"), ["plain", "bonded"]);
    assert_eq!(read(&archive, "scans", "condition_samples"), [3.0, 3.0]);
    let m = read(&archive, "scans", "cv_raw_mean");
    assert!((m[1] - raw[3..].iter().sum::<f64>() / 3.0).abs() < 1e-12);
    assert_eq!(read(&archive, "scans", "stored_sample"), [0.0, 1.0]);
    assert_eq!(read(&archive, "scans", "raw_image").len(), 2 * 160 * 200);
    for i in 0..2 {
        let rel = format!("out/study_figures/scans/v1/sample{i:03}_plain.png");
        assert!(d.join(&rel).is_file() && e.contains(&rel), "{rel}");
    }

    // Unchanged files: cached. A changed file: rerun, and the reason names it.
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert!(text(&out).0.contains("scans: up to date (v1)"), "{:?}", text(&out));
    png(d, "plain/w1.png", &Array2::from_elem((160, 200), 0.5));
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(o.contains("scans: runs: input files: plain/w1.png changed"), "{o}");
    // The same pipeline run from another working directory is up to date: file paths
    // enter the fingerprint relative to the pipeline file.
    let sub = d.join("elsewhere");
    std::fs::create_dir_all(&sub).unwrap();
    let out = run_in(&sub, &["run", "../p.yaml", "--archive", d.join("out/study.h5").to_str().unwrap()]);
    assert!(text(&out).0.contains("scans: up to date (v2)"), "{:?}", text(&out));
    // Constant grey: a documented result (CV 0, no notches, a warning), not an error.
    assert_eq!(read(&archive, "scans", "cv_raw")[1], 0.0);
    assert_eq!(read(&archive, "scans", "cv_corr")[1], 0.0);
    assert!(e.contains("constant image"), "{e}");
}

#[test]
fn cli_bad_files_exit_2_and_leave_the_archive_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    png(d, "good.png", &render(&web(64, 64, 9), PX, &RenderParams::default()).unwrap().grey);
    let p = pipeline(d, "      files: [good.png]\n      dpi: 600\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let archive = d.join("out/study.h5");
    let before = std::fs::read(&archive).unwrap();
    std::fs::write(d.join("corrupt.png"), b"\x89PNG\r\n\x1a\n this is not an image").unwrap();
    let bytes = std::fs::read(d.join("good.png")).unwrap();
    std::fs::write(d.join("truncated.png"), &bytes[..bytes.len() / 2]).unwrap();
    png(d, "tiny.png", &Array2::from_elem((8, 40), 0.5));
    png(d, "black.png", &Array2::from_elem((32, 32), 0.0));
    let cases = [
        ("[good.png, corrupt.png]", "corrupt.png"),
        ("[truncated.png]", "truncated.png"),
        // Missing files and empty globs are found by validation, before the run.
        ("[missing.png]", "stages[0].params.files[0]: `missing.png` does not exist"),
        ("['nothing/*.tif']", "stages[0].params.files[0]: `nothing/*.tif` matches no file"),
        ("[tiny.png]", "8×40 pixels; at least 16×16"),
        ("[black.png]", "needs a positive mean"),
    ];
    for (files, expect) in cases {
        let p = pipeline(d, &format!("      files: {files}\n      dpi: 600\n"));
        let out = run_in(d, &["run", p.to_str().unwrap()]);
        let (_, e) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{files}: {e}");
        assert!(e.contains(expect) && (e.contains("stage `scans`") || e.contains("params.files")), "{files}: expected `{expect}` in {e}");
        assert_eq!(std::fs::read(&archive).unwrap(), before, "{files} changed the archive");
    }
    assert!(!d.join("out/study_figures/scans/v2").exists());
    // Neither files nor input: bad input too.
    let p = pipeline(d, "      dpi: 600\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("needs `files`"));
}

#[test]
fn cli_image_smaller_than_the_bond_period_is_returned_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // 40×40 px of 0.34 mm = 13.6 mm; bonds every 20 mm: at most one bond in view, no lattice.
    let b = BondPattern { period1: 20e-3, period2: 20e-3, offset: [6e-3, 6e-3], contrast: 0.3, shape: BondShape::Circle { diameter: 3e-3 }, ..Default::default() };
    let (_, img) = bonded(&web(40, 40, 3), b);
    png(d, "big_bonds.png", &img);
    let p = pipeline(d, "      files: big_bonds.png\n      pixel_size: 0.00034\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let archive = d.join("out/study.h5");
    assert_eq!(read(&archive, "scans", "notches"), [0.0]);
    assert_eq!(read(&archive, "scans", "cv_corr"), read(&archive, "scans", "cv_raw"));
    assert!(read(&archive, "scans", "lattice_period1")[0].is_nan());
    assert!(!d.join("out/study_figures").exists());
}

/// 8-bit grey levels of a rendered web (64 × 64 px).
fn web_bytes(seed: u64) -> Vec<u8> {
    let g = render(&web(64, 64, seed), PX, &RenderParams::default()).unwrap().grey;
    g.iter().map(|v| (v * 255.0).round().clamp(0.0, 255.0) as u8).collect()
}

fn png_phys(path: &Path, data: &[u8], xppu: u32, yppu: u32) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut e = png::Encoder::new(f, 64, 64);
    e.set_color(png::ColorType::Grayscale);
    e.set_depth(png::BitDepth::Eight);
    e.set_pixel_dims(Some(png::PixelDimensions { xppu, yppu, unit: png::Unit::Meter }));
    e.write_header().unwrap().write_image_data(data).unwrap();
}

fn tiff_res<C: tiff::encoder::colortype::ColorType>(path: &Path, data: &[C::Inner], unit: tiff::tags::ResolutionUnit, per_unit: u32)
where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let mut enc = tiff::encoder::TiffEncoder::new(std::fs::File::create(path).unwrap()).unwrap();
    let mut img = enc.new_image::<C>(64, 64).unwrap();
    img.resolution(unit, tiff::encoder::Rational { n: per_unit, d: 1 });
    img.write_data(data).unwrap();
}

#[test]
fn cli_pixel_size_from_the_file_with_its_source_and_parameters_override_it() {
    use image::codecs::jpeg::{JpegEncoder, PixelDensity, PixelDensityUnit};
    use tiff::encoder::colortype::{Gray32Float, Gray8};
    use tiff::tags::ResolutionUnit;
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    png_phys(&d.join("a.png"), &web_bytes(1), 11811, 11811);
    tiff_res::<Gray8>(&d.join("b.tif"), &web_bytes(2), ResolutionUnit::Inch, 300);
    let mut f = std::fs::File::create(d.join("c.jpg")).unwrap();
    let mut e = JpegEncoder::new_with_quality(&mut f, 95);
    e.set_pixel_density(PixelDensity { density: (200, 200), unit: PixelDensityUnit::Inches });
    e.encode(&web_bytes(3), 64, 64, image::ExtendedColorType::L8).unwrap();
    drop(f);
    let floats: Vec<f32> = web_bytes(4).iter().map(|&v| v as f32 / 255.0).collect();
    tiff_res::<Gray32Float>(&d.join("d.tif"), &floats, ResolutionUnit::Centimeter, 50);
    png(d, "e.png", &render(&web(64, 64, 5), PX, &RenderParams::default()).unwrap().grey);
    let want = [1.0 / 11811.0, 0.0254 / 300.0, 0.0254 / 200.0, 0.01 / 50.0];
    let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-12;

    // No parameter: each file's own size; the one without gets the default and a warning.
    let p = pipeline(d, "      files: [a.png, b.tif, c.jpg, d.tif, e.png]\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    let archive = d.join("out/study.h5");
    let px = read(&archive, "scans", "pixel_size");
    let declared = read(&archive, "scans", "file_pixel_size");
    for i in 0..4 {
        assert!(close(px[i], want[i]) && close(declared[i], want[i]), "sample {i}: {} {} want {}", px[i], declared[i], want[i]);
    }
    assert!(close(px[4], 297e-3 / 871.0) && declared[4].is_nan());
    assert_eq!(read_strings(&archive, "scans", "pixel_size_source"), ["file", "file", "file", "file", "default"]);
    // Without `groups`, each file is its own group, labelled by its stem; the run prints
    // the per-condition table on stdout at full precision.
    assert_eq!(read_strings(&archive, "scans", "group"), ["a", "b", "c", "d", "e"]);
    let o = text(&out).0;
    let cv = read(&archive, "scans", "cv_corr_mean");
    // The archive is named by its absolute path (`archive:` is relative to the pipeline file).
    assert!(o.contains(&format!("scans@v1 (laydown table {} scans@v1):\ncondition,condition_samples,", d.canonicalize().unwrap().join("out/study.h5").display())), "{o}");
    assert!(o.lines().any(|l| l.starts_with("c,1,") && l.contains(&format!(",{:?},", cv[2]))), "{o}");
    let warning: Vec<&str> = e.lines().filter(|l| l.contains("warning")).collect();
    assert!(warning.len() == 1 && warning[0].contains("e.png") && !warning[0].contains("a.png"), "{e}");
    assert!(e.contains("pixel size declared by the file: 0.084667 mm (2 images), 0.127000 mm (1 image), 0.200000 mm (1 image)"), "{e}");
    // The float TIFF was analysed as it is: its CV is the 8-bit data's.
    let cv_raw = read(&archive, "scans", "cv_raw");
    let bytes: Vec<f64> = web_bytes(4).iter().map(|&v| v as f64).collect();
    assert!((cv_raw[3] / coefficient_of_variation(bytes.iter().copied()) - 1.0).abs() < 1e-6);

    // Every file declares a size: no warning.
    let p = pipeline(d, "      files: [a.png, b.tif]\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    assert!(!text(&out).1.contains("warning"), "{}", text(&out).1);

    // dpi (or pixel_size) overrides the files; what they declare is still stored.
    let p = pipeline(d, "      files: [a.png, e.png]\n      dpi: 600\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    assert!(!text(&out).1.contains("warning"));
    assert_eq!(read(&archive, "scans", "pixel_size"), [0.0254 / 600.0; 2]);
    assert_eq!(read_strings(&archive, "scans", "pixel_size_source"), ["dpi", "dpi"]);
    assert!(close(read(&archive, "scans", "file_pixel_size")[0], want[0]));
    let p = pipeline(d, "      files: [a.png]\n      pixel_size: 0.0002\n      panels: false\n");
    assert_eq!(run_in(d, &["run", p.to_str().unwrap()]).status.code(), Some(0));
    assert_eq!(read_strings(&archive, "scans", "pixel_size_source"), ["pixel_size"]);
    assert_eq!(read(&archive, "scans", "pixel_size"), [0.0002]);

    // 72 dpi, a common software default, is used but flagged.
    png_phys(&d.join("screen.png"), &web_bytes(7), 2835, 2835);
    let p = pipeline(d, "      files: [screen.png, a.png]\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{e}");
    let warning: Vec<&str> = e.lines().filter(|l| l.contains("warning")).collect();
    assert!(warning.len() == 1 && warning[0].contains("screen.png: the file declares 72 or 96 dpi") && !warning[0].contains("a.png"), "{e}");
    assert_eq!(read_strings(&archive, "scans", "pixel_size_source"), ["file", "file"]);

    // Non-square pixels declared and no override: bad input naming the file.
    png_phys(&d.join("skew.png"), &web_bytes(6), 11811, 5906);
    let p = pipeline(d, "      files: [skew.png]\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(e.contains("skew.png") && e.contains("non-square") && e.contains("give pixel_size or dpi"), "{e}");
}

#[test]
fn cli_zone_curve_stores_the_zone_sizes_actually_used_without_holes() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // 1 mm pixels, zones asked from 0.5 to 16 mm: 0.5, 0.71, 1 and 1.41 mm are all the
    // one-pixel zone; the curve holds it once, as 1 mm.
    let big = render(&web(64, 64, 11), PX, &RenderParams::default()).unwrap().grey;
    let small = render(&web(20, 20, 12), PX, &RenderParams::default()).unwrap().grey;
    png(d, "big.png", &big);
    png(d, "small.png", &small);
    let p = pipeline(d, "      files: [big.png, small.png]\n      pixel_size: 0.001\n      zone_min: 0.0005\n      zone_max: 0.016\n      panels: false\n");
    let out = run_in(d, &["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let archive = d.join("out/study.h5");
    let cells = read(&archive, "scans", "zone_cells");
    let sizes = read(&archive, "scans", "zone_size");
    let (raw, filtered) = (read(&archive, "scans", "zone_cv_raw"), read(&archive, "scans", "zone_cv_filtered"));
    let want_cells = [1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0, 16.0];
    let nz = want_cells.len();
    assert_eq!(cells.len(), 2 * nz, "{cells:?}");
    assert_eq!(&cells[..nz], want_cells);
    for j in 0..nz {
        assert!((sizes[j] - want_cells[j] * 1e-3).abs() < 1e-15, "zone {j}: {} m", sizes[j]);
    }
    // Each CV is the CV of the block sums at that size, computed independently; the
    // first is the one-pixel CV.
    let img = laydown::stages::image::read_grey(&d.join("big.png")).unwrap().data;
    let zones: Vec<f64> = want_cells.iter().map(|k| k * 1e-3).collect();
    let direct = laydown::uniformity::cv_by_zone_size(img.view(), 1e-3, &zones);
    assert_eq!(direct.len(), nz);
    for (j, z) in direct.iter().enumerate() {
        assert!((raw[j] / z.cv - 1.0).abs() < 1e-9, "zone {j}: {} vs {}", raw[j], z.cv);
    }
    assert_eq!(raw[0], read(&archive, "scans", "cv_raw")[0]);
    // Bond-free: nothing notched, the filtered curve is the raw one.
    assert_eq!(&filtered[..nz], &raw[..nz]);
    // The 20 × 20 px image fits 4 zones up to 8 px (at 11 px only one zone fits):
    // its curve stops there, padded after its last size, never inside.
    let last = 6;
    assert_eq!(&cells[nz..nz + last], &want_cells[..last]);
    assert!(raw[nz..nz + last].iter().chain(&sizes[nz..nz + last]).all(|v| v.is_finite()));
    assert!(raw[nz + last..].iter().chain(&sizes[nz + last..]).chain(&filtered[nz + last..]).all(|v| v.is_nan()));
    assert!(cells[nz + last..].iter().all(|&c| c == 0.0));
}

/// The rule behind the reported `cv_corr` (CV_CORR_RULE): on bonded renderings of known
/// web CV, including strong, rotated, staggered and large elliptical bonds whose periods
/// do not divide the image, the compensated CV has the smaller worst-case and mean error.
/// (300 × 360 px here: compensated −0.13 to +1.28 %, plain −7.7 to −0.6 %; at 617 × 871 px,
/// 3 seeds, examples/image_estimators.rs: +0.03 to +0.68 % and −5.2 to −0.5 %; smaller
/// images are less accurate, examples/image_size_accuracy.rs.)
#[test]
fn reported_cv_corr_is_the_compensated_estimate_and_closer_to_the_truth() {
    let cases = [
        ("weak 4.2 mm at 45°", BondPattern { period1: 4.2e-3, period2: 4.2e-3, angle_deg: 45.0, contrast: 0.15, shape: BondShape::Circle { diameter: 1.5e-3 }, ..Default::default() }),
        ("strong 4.1 mm off-grid", BondPattern { period1: 4.1e-3, period2: 4.1e-3, contrast: 0.5, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() }),
        (
            "rotated 30°, elliptical",
            BondPattern { period1: 5e-3, period2: 3.5e-3, angle_deg: 30.0, contrast: 0.5, shape: BondShape::Ellipse { major: 1.8e-3, minor: 1.1e-3, angle_deg: 30.0 }, ..Default::default() },
        ),
        (
            "large ellipses",
            BondPattern { period1: 5.3e-3, period2: 5.3e-3, angle_deg: 10.0, contrast: 0.4, shape: BondShape::Ellipse { major: 3e-3, minor: 1.6e-3, angle_deg: 35.0 }, ..Default::default() },
        ),
        (
            "staggered rectangles, dark",
            BondPattern {
                period1: 4.5e-3,
                period2: 4.5e-3,
                angle_deg: 15.0,
                angle_between_deg: 60.0,
                contrast: -0.4,
                shape: BondShape::Rectangle { width: 1.6e-3, height: 1.1e-3, angle_deg: 15.0 },
                ..Default::default()
            },
        ),
    ];
    let mut errors: Vec<(f64, f64)> = vec![];
    for (k, (name, b)) in cases.into_iter().enumerate() {
        let density = web(300, 360, 60 + k as u64);
        let (truth, img) = bonded(&density, b);
        let a = analyze(&img, PX, &ImageParams::default()).unwrap();
        let t = cv(&truth);
        let (comp, plain) = ((a.cv_corr_compensated / t - 1.0).abs(), (a.cv_corr_plain / t - 1.0).abs());
        println!("{name}: compensated {:+.2} %, plain {:+.2} %", 100.0 * (a.cv_corr_compensated / t - 1.0), 100.0 * (a.cv_corr_plain / t - 1.0));
        assert_eq!(a.cv_corr, a.cv_corr_compensated, "{name}");
        assert!(comp < 0.025, "{name}: compensated off by {comp}");
        errors.push((comp, plain));
    }
    let worst = |f: fn(&(f64, f64)) -> f64| errors.iter().map(f).fold(0.0, f64::max);
    let mean = |f: fn(&(f64, f64)) -> f64| errors.iter().map(f).sum::<f64>() / errors.len() as f64;
    assert!(worst(|e| e.0) < worst(|e| e.1) && mean(|e| e.0) < mean(|e| e.1), "{errors:?}");
    // Nothing notched: every corrected CV is the raw one.
    let plain_web = render(&web(200, 200, 70), PX, &RenderParams::default()).unwrap().grey;
    let a = analyze(&plain_web, PX, &ImageParams::default()).unwrap();
    assert!(a.peaks.is_empty());
    assert!(a.cv_corr == a.cv_raw && a.cv_corr_plain == a.cv_raw && a.cv_corr_compensated == a.cv_raw);
}

/// Issue 17: on the paper's scan size (617 × 871 px) the reported `cv_corr` is within 1 %
/// of the web's known CV for strong round bonds at an off-grid period and for large
/// elliptical bonds; both patterns clip part of the bonds to white (saturated pixels). The
/// method as it was before (no notch growth, no censoring correction, one period of edge
/// band) misses by about 2 % on the same images, so the tests can fail.
/// (examples/image_estimators.rs: the same lattices, 3 other seeds.)
fn hard_lattice_within_one_percent(name: &str, b: BondPattern, seed: u64) {
    let px = 297e-3 / 871.0;
    let density = random_fibre_web(617, 871, px, 20.0, 10e-3, 1e-3, Some(35.0), seed);
    let truth = cv(&render(&density, px, &RenderParams::default()).unwrap().grey);
    let rendered = render(&density, px, &RenderParams { bonds: Some(b), ..Default::default() }).unwrap();
    assert!(rendered.saturated_fraction > 0.03, "{name}: the bonds should clip: {}", rendered.saturated_fraction);
    let a = analyze(&rendered.grey, px, &ImageParams::default()).unwrap();
    let before = ImageParams { notch_growth: false, censoring_correction: false, edge_margin_periods: 1.0, ..Default::default() };
    let b = analyze(&rendered.grey, px, &before).unwrap();
    let (err, err_before) = (a.cv_corr / truth - 1.0, b.cv_corr / truth - 1.0);
    println!(
        "{name}: truth {truth:.5} cv_corr {:.5} ({:+.2} %), before {:+.2} %, plain {:+.2} %, {} bins grown, {:.1} % of pixels restored",
        a.cv_corr,
        100.0 * err,
        100.0 * err_before,
        100.0 * (a.cv_corr_plain / truth - 1.0),
        a.grown_bins,
        100.0 * a.censored_fraction
    );
    assert!(err.abs() < 0.01, "{name}: cv_corr {} is {:+.2} % off the truth {truth}", a.cv_corr, 100.0 * err);
    assert!(err_before.abs() > 0.015, "{name}: the old method should miss here ({:+.2} %)", 100.0 * err_before);
    assert!(a.grown_bins > 0 && a.censored_fraction > 0.03);
    // The stored filtered image is still the paper's (notched raw image, mean kept).
    assert!((a.filtered.mean().unwrap() - a.mean).abs() < 1e-12 * a.mean);
}

#[test]
fn strong_off_grid_lattice_gives_cv_corr_within_one_percent() {
    // 4.1 mm = 12.02 px: 72.4 periods across 871 px, 51.3 down 617 px.
    let b = BondPattern { period1: 4.1e-3, period2: 4.1e-3, contrast: 0.5, shape: BondShape::Circle { diameter: 1.6e-3 }, ..Default::default() };
    hard_lattice_within_one_percent("strong off-grid 4.1 mm", b, 1);
}

#[test]
fn large_elliptical_bonds_give_cv_corr_within_one_percent() {
    let b = BondPattern {
        period1: 5.3e-3,
        period2: 5.3e-3,
        angle_deg: 10.0,
        contrast: 0.4,
        shape: BondShape::Ellipse { major: 3.0e-3, minor: 1.6e-3, angle_deg: 35.0 },
        ..Default::default()
    };
    hard_lattice_within_one_percent("large ellipses 3 × 1.6 mm at 5.3 mm, 10°", b, 1);
}
