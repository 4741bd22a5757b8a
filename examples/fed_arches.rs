//! When landed fibre stands up behind the touchdown of a fed fibre (issue 15): the highest
//! landed, unfrozen node over time, per replicate and over the ensemble, for one scheme.
//! The bounce test looks at this height at the end instant only; this shows what it is at
//! every other instant, so that a validity count can be read against the phase of the
//! oscillation the run ends in (`pipelines/studies/FIBRE_SPEED.md`, "Arches come with the
//! sweep").
//!
//! `cargo run --release --example fed_arches -- [replicates] [scheme] [name=value ...]`,
//! e.g. the 50 m/s scene with the explicit reference:
//! `... -- 24 explicit fibre_speed=50 air_speed=150 belt_speed=2 oscillation_frequency=100`.
//! `scheme` is an integrator name (`trapezoidal_axial`, the default, or `explicit`, ...);
//! `sample=S` (s, default 2e-5, at most 1e-4) is the sampling interval, and samples are
//! taken at `from` + S, `from` + 2S, ... up to the end (`from=T`, s, default half the end
//! time). A sample is taken at the first step that reaches its time, by an observer
//! ([`Feeder::advance_observed`]), so the run is the laydown stage's replicate to the bit;
//! advancing in pieces instead would cut a step short at the end of each piece and make a
//! different run. Replicates run in parallel (seed 2024, the stream of replicate r as in the
//! laydown stage).
//!
//! Prints per replicate the height at the end and the fraction of the samples of the last
//! quarter of the run above `bounce_tolerance` (NaN if the run failed before it), then per
//! window of 0.1 ms the ensemble's mean height and the fraction of samples above the
//! tolerance.
use laydown::rod::feed::{fed_scene, fed_settings, Feeder};
use laydown::rod::{replicate_rng, Simulator, Start};
use laydown::stages::laydown::{Integrator, LaydownParams};
use rayon::prelude::*;

/// One replicate: the highest landed node at each sample time reached, the final lift the
/// bounce test reads, and the run's error.
struct Replicate {
    heights: Vec<f64>,
    final_lift: f64,
    error: Option<String>,
}

/// The highest landed, unfrozen node above the belt (m).
fn highest_landed_node(sim: &Simulator) -> f64 {
    sim.highest_laid_node().map_or(0.0, |n| n.1.max(0.0))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let replicates: u64 = args.first().map_or(8, |s| s.parse().expect("a replicate count"));
    let mut p = LaydownParams { start: Start::Fed, ..LaydownParams::default() };
    if let Some(scheme) = args.get(1) {
        p.integrator = Integrator::from_name(scheme).expect("an integrator name");
    }
    let (mut sample, mut from) = (2e-5, f64::NAN);
    for kv in args.iter().skip(2) {
        let (k, v) = kv.split_once('=').expect("name=value");
        let x: f64 = v.parse().expect("a number");
        match k {
            "sample" => sample = x,
            "from" => from = x,
            _ => p.set(k, x).unwrap_or_else(|e| panic!("{k}: {e}")),
        }
    }
    p.validate().unwrap();
    let end = p.end_time();
    if from.is_nan() {
        from = 0.5 * end;
    }
    assert!(sample > 0.0 && sample <= 1e-4, "sample must lie in (0, 1e-4] s");
    assert!((0.0..end).contains(&from), "from must lie in [0, {end}) s");
    // sample times from + k S, and the end itself unless the last one is (within round-off)
    let count = ((end - from) / sample).floor() as usize;
    let mut times: Vec<f64> = (1..=count).map(|k| from + k as f64 * sample).filter(|&t| t < end * (1.0 - 1e-9)).collect();
    times.push(end);
    let (scene, settings) = (fed_scene(&p), fed_settings(&p));
    println!(
        "scheme {:?}, v_f {} m/s, f {} Hz, end {:.4} s, samples {} after {:.4} s every {:.1e} s, bounce_tolerance {:.1e} m",
        p.integrator,
        p.fibre_speed,
        p.oscillation_frequency,
        end,
        times.len(),
        from,
        sample,
        p.bounce_tolerance
    );
    let runs: Vec<Replicate> = (0..replicates)
        .into_par_iter()
        .map(|r| {
            let mut feeder = Feeder::new(&scene, scene.element_length(), 0.0, &settings, &mut replicate_rng(2024, r));
            let mut heights: Vec<f64> = Vec::with_capacity(times.len());
            feeder.advance_observed(end, |sim| {
                // a rollback steps back in time: drop the samples it undid
                while heights.last().is_some() && times[heights.len() - 1] > sim.t {
                    heights.pop();
                }
                while heights.len() < times.len() && sim.t >= times[heights.len()] * (1.0 - 1e-12) {
                    heights.push(highest_landed_node(sim));
                }
            });
            let fibre = feeder.finish();
            Replicate { heights, final_lift: fibre.final_lift_of_landed, error: fibre.error }
        })
        .collect();
    let bounce_tolerance = p.bounce_tolerance;
    let last_quarter_start = times.iter().position(|&t| t >= 0.75 * end).unwrap_or(times.len());
    println!("replicate | height at the end (mm) | last quarter: fraction above tolerance | error");
    for (r, run) in runs.iter().enumerate() {
        let tail = run.heights.get(last_quarter_start..).unwrap_or(&[]);
        let above = if tail.is_empty() { f64::NAN } else { tail.iter().filter(|&&z| z > bounce_tolerance).count() as f64 / tail.len() as f64 };
        println!("{r} | {:.3} | {:.3} | {}", run.final_lift * 1e3, above, run.error.as_deref().unwrap_or("-"));
    }
    println!("window centre (ms) | mean height (mm) | fraction of samples above tolerance");
    let per_window = (1e-4 / sample).round() as usize;
    for start in (0..times.len()).step_by(per_window) {
        let stop = (start + per_window).min(times.len());
        let (mut sum, mut above, mut samples) = (0.0, 0usize, 0usize);
        for run in &runs {
            for &z in run.heights.get(start..stop.min(run.heights.len())).unwrap_or(&[]) {
                sum += z;
                above += (z > bounce_tolerance) as usize;
                samples += 1;
            }
        }
        // NaN for a window no run reached
        let (mean, share) = (sum / samples as f64, above as f64 / samples as f64);
        println!("{:.2} | {:.3} | {:.2}", 0.5 * (times[start] + times[stop - 1]) * 1e3, mean * 1e3, share);
    }
}
