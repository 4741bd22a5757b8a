//! Criterion benches of the laydown stage (release profile):
//! - `forces_1000`: force and implicit-matrix evaluation of every term, Table 1 rod
//!   (1000 elements) in mid-run (0.05 s: about 250 nodes laid, the rest falling);
//! - `step_1000`: one full time step (forces, node solves, contact/friction, length
//!   projection) from the same state (restoring a snapshot first, included in the time);
//! - `replicate_baseline_fast`: one whole Table 1 replicate with the default
//!   `trapezoidal_axial` scheme (0.19 s simulated), sample size 10.
//!
//! The explicit reference (about 40 s per replicate) is timed by
//! `examples/laydown_timing.rs` instead.
//!
//! `cargo bench --bench laydown` (RAYON_NUM_THREADS is irrelevant: one replicate is serial).
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use laydown::stages::laydown::{prepared_simulator, replicate_rng, simulate, LaydownParams, Snapshot};
use std::time::Duration;

fn kernels(c: &mut Criterion) {
    let p = LaydownParams::default();
    let mut sim = prepared_simulator(&p, &mut replicate_rng(2024, 0), 0.05);
    c.bench_function("forces_1000", |b| b.iter(|| black_box(&mut sim).evaluate_forces()));
    let mut sim = prepared_simulator(&p, &mut replicate_rng(2024, 0), 0.05);
    let mut snap = Snapshot::default();
    sim.save(&mut snap);
    c.bench_function("step_1000", |b| {
        b.iter(|| {
            sim.restore(&snap);
            black_box(sim.step()).ok();
        })
    });
}

fn replicate(c: &mut Criterion) {
    let p = LaydownParams::default();
    let mut g = c.benchmark_group("replicate");
    g.sample_size(10).measurement_time(Duration::from_secs(20)).warm_up_time(Duration::from_secs(1));
    g.bench_function("replicate_baseline_fast", |b| b.iter(|| black_box(simulate(&p, &mut replicate_rng(2024, 0)))));
    g.finish();
}

criterion_group!(benches, kernels, replicate);
criterion_main!(benches);
