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
//! `sample=S` (s, default 2e-5) is the sampling interval and `from=T` (s, default half the
//! end time) the first sample. A sample is taken at the first step that reaches its time,
//! by an observer ([`Feeder::advance_observed`]), so the run is the laydown stage's
//! replicate to the bit (advancing in pieces instead would cut a step short at the end of
//! each, a different run; the explicit scheme at 50 m/s then stands up about twice as
//! often). Replicates run in parallel (seed 2024, the stream of replicate r as in the
//! laydown stage).
//!
//! Prints per replicate the height at the end and the fraction of the samples of the last
//! quarter of the run above `bounce_tolerance`, then per window of 0.1 ms the ensemble's
//! mean height and the fraction of samples above the tolerance.
use laydown::rod::feed::{fed_scene, fed_settings, Feeder};
use laydown::rod::{replicate_rng, Start};
use laydown::stages::laydown::{Integrator, LaydownParams};
use rayon::prelude::*;

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
    let samples = ((end - from) / sample).floor() as usize;
    let times: Vec<f64> = (1..=samples).map(|k| from + k as f64 * sample).chain((end > from + samples as f64 * sample).then_some(end)).collect();
    let (scene, settings) = (fed_scene(&p), fed_settings(&p));
    println!(
        "scheme {:?}, v_f {} m/s, f {} Hz, end {:.4} s, samples {} from {:.4} s every {:.1e} s, bounce_tolerance {:.1e} m",
        p.integrator,
        p.fibre_speed,
        p.oscillation_frequency,
        end,
        times.len(),
        from,
        sample,
        p.bounce_tolerance
    );
    let heights: Vec<(Vec<f64>, f64, Option<String>)> = (0..replicates)
        .into_par_iter()
        .map(|r| {
            let mut feeder = Feeder::new(&scene, 0.0, &settings, &mut replicate_rng(2024, r));
            let mut h = Vec::with_capacity(times.len());
            feeder.advance_observed(end, |sim| {
                while h.len() < times.len() && sim.t >= times[h.len()] * (1.0 - 1e-12) {
                    h.push((0..sim.rod.nodes()).filter(|&i| sim.laid_time(i).is_finite()).map(|i| sim.rod.x[i][2]).fold(0.0, f64::max));
                }
            });
            let fibre = feeder.finish();
            (h, fibre.final_lift_of_landed, fibre.error)
        })
        .collect();
    let tol = p.bounce_tolerance;
    let quarter = times.iter().position(|&t| t >= 0.75 * end).unwrap_or(0);
    println!("replicate | height at the end (mm) | last quarter: fraction above tolerance | error");
    for (r, (h, final_lift, error)) in heights.iter().enumerate() {
        let tail = h.get(quarter..).unwrap_or(&[]);
        let above = tail.iter().filter(|&&z| z > tol).count() as f64 / tail.len().max(1) as f64;
        println!("{r} | {:.3} | {:.3} | {}", final_lift * 1e3, above, error.as_deref().unwrap_or("-"));
    }
    println!("window centre (ms) | mean height (mm) | replicates above tolerance");
    let per_window = ((1e-4 / sample).round() as usize).max(1);
    for start in (0..times.len()).step_by(per_window) {
        let stop = (start + per_window).min(times.len());
        let (mut sum, mut above, mut count) = (0.0, 0usize, 0usize);
        for (h, _, _) in &heights {
            for &z in h.get(start..stop.min(h.len())).unwrap_or(&[]) {
                sum += z;
                above += (z > tol) as usize;
                count += 1;
            }
        }
        let centre = 0.5 * (times[start] + times[stop - 1]);
        println!("{:.2} | {:.3} | {:.2}", centre * 1e3, sum / count.max(1) as f64 * 1e3, above as f64 / count.max(1) as f64);
    }
}
