//! What the fed start's freezing front costs in accuracy and saves in time (issue 15):
//! `start: fed` replicates with the front at each margin, against the same replicates
//! (same seeds) with the front off. Per margin: S and e (raw) averaged over the
//! replicates valid in both runs, their paired differences against the front off with
//! standard errors, the same differences over every replicate that ran to the end in
//! both (freezing changes which replicates pass the bounce test, so the valid pairs are a
//! selection), the validity and the CPU time per replicate (each replicate timed on its
//! own thread, so compare the ratios of one run). `reference_settle_time=1` makes the
//! reference freeze nothing in a replicate shorter than 1 s.
//!
//! `cargo run --release --example fed_freezing_accuracy -- [replicates] [margins,comma,separated] [name=value ...]`
//! e.g. `... -- 32 0.002,0.005` (Table 1), or the 50 m/s scene
//! `... -- 16 0.002 fibre_speed=50 air_speed=150 belt_speed=2 oscillation_frequency=100`.
//! The fed start itself puts the front two elements of the scene's mesh past the farthest
//! touchdown, at most 2 mm (`fed_settings`); each margin given here replaces that.
//! A margin of `inf` is the front off (the reference, always run first). `settle_time=`
//! (s) gives the candidates (not the reference) another settle time than the fed start's
//! (28 coil scales of fed fibre, `FED_SETTLE_COILS`: 20 ms at 5 m/s, 0.2 ms at 50 m/s),
//! and `reference_settle_time=` (s) the reference, e.g. the time 0.1 m takes to feed, the
//! rule before 2026-12-05 (`pipelines/studies/FIBRE_SPEED.md`, "The settle time in coil
//! scales").
use laydown::rod::feed::{fed_settings, simulate_fed_with, FeedSettings};
use laydown::rod::{replicate_rng, LaydownParams, LaydownResult};
use laydown::stages::mean_std;
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.first().map_or(16, |s| s.parse().expect("a replicate count"));
    let margins: Vec<f64> = args.get(1).map_or("0.002", |s| s.as_str()).split(',').map(|s| s.parse().expect("a margin in m, or inf")).collect();
    let mut p = LaydownParams::default();
    let (mut settle_time, mut reference_settle_time) = (None, None);
    for kv in args.iter().skip(2) {
        let (k, v) = kv.split_once('=').expect("name=value");
        match k {
            "settle_time" => settle_time = Some(v.parse().expect("a settle time in s")),
            "reference_settle_time" => reference_settle_time = Some(v.parse().expect("a settle time in s")),
            _ => p.set(k, v.parse().expect("a number")).unwrap_or_else(|e| panic!("{k}: {e}")),
        }
    }
    p.validate().expect("valid parameters");
    let seed = 2024;
    let run = |margin: f64| -> Vec<LaydownResult> {
        let mut settings = FeedSettings { front_margin: margin, ..fed_settings(&p) };
        let chosen = if margin.is_finite() { settle_time } else { reference_settle_time };
        settings.settle_time = chosen.unwrap_or(settings.settle_time);
        (0..n).into_par_iter().map(|r| simulate_fed_with(&p, &settings, &mut replicate_rng(seed, r))).collect()
    };
    println!(
        "scene: v_f {} m/s, V_air {} m/s, v_b {} m/s, f {} Hz, {} elements, end time {:.4} s, {n} replicates of seed {seed}, candidates' settle time {:.4} s, reference's {:.4} s",
        p.fibre_speed,
        p.air_speed,
        p.belt_speed,
        p.oscillation_frequency,
        p.resolved_elements(),
        p.end_time(),
        settle_time.unwrap_or(fed_settings(&p).settle_time),
        reference_settle_time.unwrap_or(fed_settings(&p).settle_time)
    );
    let reference = run(f64::INFINITY);
    let cpu = |rs: &[LaydownResult]| rs.iter().map(|r| r.wall_seconds).sum::<f64>() / rs.len() as f64;
    let valid = |rs: &[LaydownResult]| rs.iter().filter(|r| r.valid).count();
    println!("front margin | valid | valid in both | S (mm) | e | S against off (paired) | e against off (paired) | ran in both | S against off (all paired) | e against off (all paired) | CPU per replicate (s) | against off");
    println!(
        "off | {}/{n} | | {:.3} | {:.0} | | | | | | {:.3} | 1.000",
        valid(&reference),
        mean(reference.iter().filter(|r| r.valid).map(|r| r.radius_of_gyration * 1e3)).0,
        mean(reference.iter().filter(|r| r.valid).map(|r| r.bending_energy)).0,
        cpu(&reference)
    );
    for &m in margins.iter().filter(|m| m.is_finite()) {
        let rs = run(m);
        let both: Vec<(&LaydownResult, &LaydownResult)> = reference.iter().zip(&rs).filter(|(a, b)| a.valid && b.valid).collect();
        // every replicate that ran to the end in both, valid or not: freezing moves which
        // replicates pass the bounce test, so the valid pairs alone are a selection
        let ran: Vec<(&LaydownResult, &LaydownResult)> = reference.iter().zip(&rs).filter(|(a, b)| a.error.is_none() && b.error.is_none()).collect();
        let rel = |pairs: &[(&LaydownResult, &LaydownResult)], f: &dyn Fn(&LaydownResult) -> f64| {
            let base = mean(pairs.iter().map(|(a, _)| f(a))).0;
            mean(pairs.iter().map(|(a, b)| 100.0 * (f(b) - f(a)) / base))
        };
        let (ds, ds_se) = rel(&both, &|r| r.radius_of_gyration);
        let (de, de_se) = rel(&both, &|r| r.bending_energy);
        let (das, das_se) = rel(&ran, &|r| r.radius_of_gyration);
        let (dae, dae_se) = rel(&ran, &|r| r.bending_energy);
        println!(
            "{m} m | {}/{n} | {} | {:.3} | {:.0} | {ds:+.2} ± {ds_se:.2} % | {de:+.2} ± {de_se:.2} % | {} | {das:+.2} ± {das_se:.2} % | {dae:+.2} ± {dae_se:.2} % | {:.3} | {:.3}",
            valid(&rs),
            both.len(),
            mean(rs.iter().filter(|r| r.valid).map(|r| r.radius_of_gyration * 1e3)).0,
            mean(rs.iter().filter(|r| r.valid).map(|r| r.bending_energy)).0,
            ran.len(),
            cpu(&rs),
            cpu(&rs) / cpu(&reference)
        );
    }
}

/// Mean and its standard error.
fn mean(xs: impl Iterator<Item = f64>) -> (f64, f64) {
    let v: Vec<f64> = xs.collect();
    let (m, sd) = mean_std(&v);
    (m, sd / (v.len() as f64).sqrt())
}
