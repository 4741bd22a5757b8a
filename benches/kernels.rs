//! Criterion benches of the hot kernels beyond the rod (release profile):
//! - `web/generate_fibre_100_segments`: one paper fibre (n_l = 100 segments of N = 1000
//!   points: random phases, inverse DFT, trapezoidal integration, belt drift), spectrum1;
//! - `web/laid_segments_fibre_100_segments`, `web/lay_down_sde_fibre_100_segments`: the same
//!   fibre from 64 laid templates joined, and from the lay-down SDE (b = 5 mm, A = 2);
//! - `web/*_16_fibres_streamed`: 16 such fibres as the grid streams them (one thread; the
//!   SDE integrates 16 fibres in lockstep there, in pieces): divide by 16 × 100 001 nodes;
//! - `grid/deposit_point_mass` and `grid/deposit_segment_clipping`: scattering that fibre
//!   (1e5 nodes) into a 500 × 500 mm grid of 1 mm cells;
//! - `image/analyze_871x617`: the whole bond-removal method on a paper-size scan (2-D
//!   FFTs, background fit, peak detection, notches, inverse FFT, CVs).
//!
//! `cargo bench --bench kernels`. Per-node rates: divide by 100 001 nodes.
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use laydown::stages::grid::{DensityGrid, Deposit};
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
use laydown::stages::spectra::{integrate_curvature, SquareWaveParams};
use laydown::stages::web::sde::LayDownSde;
use laydown::stages::web::{Web, WebParams};
use std::time::Duration;

fn paper_web() -> Web {
    let spectrum = SquareWaveParams::preset("spectrum1").unwrap().spectrum().unwrap();
    Web::new(WebParams { fibres_across: 1500, segments_per_fibre: 100, ..WebParams::default() }, vec![spectrum]).unwrap()
}

fn web_and_grid(c: &mut Criterion) {
    let web = paper_web();
    let mut g = c.benchmark_group("web");
    g.measurement_time(Duration::from_secs(5));
    let mut k = 0usize;
    g.bench_function("generate_fibre_100_segments", |b| {
        b.iter(|| {
            k = (k + 1) % 1500;
            black_box(web.generate_fibre(0, k))
        })
    });
    // The other generators at the same size: 64 segment-long templates, and the SDE.
    let params = *web.params();
    let templates: Vec<Vec<f64>> = (0..64).map(|j| web.fibre_curvature(1, j).1[..1000].to_vec()).collect();
    let nodes = templates.iter().map(|k| integrate_curvature(k, web.spacing(), 0.0, [0.0, 0.0], 0.0)).collect();
    let laid = Web::laid_segments(params, templates, nodes, web.spacing()).unwrap();
    g.bench_function("laid_segments_fibre_100_segments", |b| {
        b.iter(|| {
            k = (k + 1) % 1500;
            black_box(laid.generate_fibre(0, k))
        })
    });
    let sde = Web::lay_down_sde(params, LayDownSde { potential_length: 5e-3, noise: 2.0 }, web.spacing(), 1000).unwrap();
    g.bench_function("lay_down_sde_fibre_100_segments", |b| {
        b.iter(|| {
            k = (k + 1) % 1500;
            black_box(sde.generate_fibre(0, k))
        })
    });
    // Whole webs' worth of fibres as the grid streams them (`par_for_each_fibre_piece` on a
    // one-thread pool): the SDE integrates 16 fibres in lockstep there and hands them over in
    // pieces of 1024 steps. 16 fibres per iteration.
    for (name, w) in [("generate_16_fibres_streamed", &web), ("laid_segments_16_fibres_streamed", &laid), ("lay_down_sde_16_fibres_streamed", &sde)] {
        let small = match w.sde_model() {
            Some(m) => Web::lay_down_sde(WebParams { fibres_across: 16, ..params }, m, w.spacing(), 1000).unwrap(),
            None if w.templates().is_some() => {
                let nodes = w.template_positions().map(|p| p.to_vec()).unwrap_or_default();
                Web::laid_segments(WebParams { fibres_across: 16, ..params }, w.templates().unwrap().to_vec(), nodes, w.spacing()).unwrap()
            }
            None => Web::new(WebParams { fibres_across: 16, ..params }, vec![SquareWaveParams::preset("spectrum1").unwrap().spectrum().unwrap()]).unwrap(),
        };
        let mut r = 0u32;
        let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        g.bench_function(name, |b| {
            b.iter(|| {
                r += 1;
                one_thread.install(|| {
                    small.par_for_each_fibre_piece(r, |_, _, nodes| {
                        black_box(nodes);
                    })
                })
            })
        });
    }
    g.finish();
    // A fibre centred in a 500 mm window.
    let nodes = web.generate_fibre(0, 750);
    let (mx, my) = nodes.iter().fold((0.0, 0.0), |a, p| (a.0 + p[0], a.1 + p[1]));
    let (mx, my) = (mx / nodes.len() as f64, my / nodes.len() as f64);
    let mut g = c.benchmark_group("grid");
    g.measurement_time(Duration::from_secs(5));
    for (name, method) in [("deposit_point_mass", Deposit::PointMass), ("deposit_segment_clipping", Deposit::SegmentClipping)] {
        let grid = DensityGrid::new(mx - 0.25, my - 0.25, 1e-3, 500);
        g.bench_function(name, |b| b.iter(|| grid.deposit_fibre(black_box(&nodes), method)));
    }
    g.finish();
}

fn image(c: &mut Criterion) {
    let px = 297e-3 / 871.0;
    let web = random_fibre_web(617, 871, px, 20.0, 10e-3, 1e-3, Some(35.0), 71);
    let rp = RenderParams { bonds: Some(BondPattern { contrast: 0.3, ..Default::default() }), bits: 8, ..Default::default() };
    let img = render(&web, px, &rp).unwrap().grey;
    let p = ImageParams::default();
    let mut g = c.benchmark_group("image");
    g.sample_size(20).measurement_time(Duration::from_secs(5));
    g.bench_function("analyze_871x617", |b| b.iter(|| black_box(analyze(black_box(&img), px, &p).unwrap())));
    g.finish();
}

criterion_group!(benches, web_and_grid, image);
criterion_main!(benches);
