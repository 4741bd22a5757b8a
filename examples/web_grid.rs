//! Benchmark: timing (wall, nodes/s), peak RSS and results of web generation + density
//! grid (no file I/O). Paper size: `cargo run --release --example web_grid -- spectrum1 0.04 1500 100 1000 point_mass 3 2 0`
//!
//! cargo run --release --example web_grid -- [preset] [c] [n_w] [n_l] [N] [deposit] [realisations] [threads] [margin] [boundary] [window] [generator]
//! defaults:                                  spectrum1 0.05 1500 100 1000 point_mass 1 2 3 open 0.5 random_phase
//!
//! `generator` laid_segments joins 64 segment-long templates cut from random-phase fibres of
//! the preset (the cost does not depend on where the templates come from); lay_down_sde
//! runs the ITWM model with b = 5 mm, A = 2 m^-1/2 at Δs = L/N.
use std::time::Instant;

use laydown::stages::grid::{grid_realisation, Boundary, Deposit, GridParams};
use laydown::stages::spectra::{integrate_curvature, SquareWaveParams};
use laydown::stages::web::sde::LayDownSde;
use laydown::stages::web::{Web, WebParams};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: &str| a.get(i).cloned().unwrap_or_else(|| d.to_string());
    let preset = arg(0, "spectrum1");
    let c: f64 = arg(1, "0.05").parse().unwrap();
    let n_w: usize = arg(2, "1500").parse().unwrap();
    let n_l: usize = arg(3, "100").parse().unwrap();
    let n: usize = arg(4, "1000").parse().unwrap();
    let deposit = Deposit::from_name(&arg(5, "point_mass")).expect("deposit");
    let realisations: u32 = arg(6, "1").parse().unwrap();
    let threads: usize = arg(7, "2").parse().unwrap();
    let margin: f64 = arg(8, "3").parse().unwrap();
    let boundary = Boundary::from_name(&arg(9, "open")).expect("boundary");
    let window_side: f64 = arg(10, "0.5").parse().unwrap();
    rayon::ThreadPoolBuilder::new().num_threads(threads).build_global().unwrap();

    let spectrum = SquareWaveParams { points_per_segment: n, ..SquareWaveParams::preset(&preset).expect("preset") }
        .spectrum()
        .unwrap();
    let generator = arg(11, "random_phase");
    let params = WebParams { fibres_across: n_w, segments_per_fibre: n_l, belt_speed_ratio: c, ..WebParams::default() };
    let random_phase = Web::new(params, vec![spectrum]).unwrap();
    let web = match generator.as_str() {
        "random_phase" => random_phase,
        "laid_segments" => {
            let templates: Vec<Vec<f64>> = (0..64).map(|j| random_phase.fibre_curvature(1, j % n_w).1[..n].to_vec()).collect();
            let nodes = templates.iter().map(|k| integrate_curvature(k, random_phase.spacing(), 0.0, [0.0, 0.0], 0.0)).collect();
            Web::laid_segments(params, templates, nodes, random_phase.spacing()).unwrap()
        }
        "lay_down_sde" => Web::lay_down_sde(params, LayDownSde { potential_length: 5e-3, noise: 2.0 }, random_phase.spacing(), n).unwrap(),
        other => panic!("generator {other}: random_phase | laid_segments | lay_down_sde"),
    };
    let grid = GridParams { deposit, boundary, window_side, edge_margin_spreads: margin, ..GridParams::default() };
    println!("{generator} {preset} c={c} n_w={n_w} n_l={n_l} N={n} deposit={} boundary={} threads={threads}", deposit.name(), boundary.name());
    let (mut cvs, mut rhos) = (Vec::new(), Vec::new());
    for k in 0..realisations {
        let t = Instant::now();
        match grid_realisation(&web, &grid, k) {
            Ok(r) => {
                let dt = t.elapsed().as_secs_f64();
                println!(
                    "  realisation {k}: {:.3} s, {:.3e} nodes/s, rho_av {:.4} g/m2 (interior {:.4}), CV {:.4}, spreads CD {:.3} m MD {:.3} m",
                    dt,
                    r.nodes_generated as f64 / dt,
                    r.mean_areal_density_gsm,
                    r.expected_interior_density * 1e3,
                    r.cv,
                    r.spreads.cross_direction,
                    r.spreads.machine_direction
                );
                if k == 0 {
                    for z in &r.zone_curve {
                        println!(
                            "    zone {:.1} mm: CV {:.4}, random-line CV {:.4}, n_f {:.3}",
                            z.zone_size * 1e3,
                            z.cv,
                            z.random_line_cv,
                            z.formation_number
                        );
                    }
                }
                cvs.push(r.cv);
                rhos.push(r.mean_areal_density_gsm);
            }
            Err(e) => println!("  realisation {k}: error: {e}"),
        }
    }
    let stats = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len().max(2) - 1) as f64).sqrt();
        (m, s)
    };
    if !cvs.is_empty() {
        let (rm, rs) = stats(&rhos);
        let (cm, cs) = stats(&cvs);
        println!("  mean over {}: rho_av {rm:.3}({rs:.3}) g/m2, CV {cm:.4}({cs:.4})", cvs.len());
    }
    // Peak resident memory of the whole run (Linux).
    if let Some(line) = std::fs::read_to_string("/proc/self/status").ok().and_then(|s| s.lines().find(|l| l.starts_with("VmHWM")).map(str::to_string)) {
        println!("  peak RSS: {}", line.trim_start_matches("VmHWM:").trim());
    }
}
