//! How far laid nodes slide on the belt under each air field (issue 15,
//! `pipelines/studies/AIR_FIELD.md`): for every node, its position when it first touches
//! the belt against its final position with the belt motion removed. Prints, per case,
//! S, the median and 90th-percentile slip of the laid nodes, the share sliding more than
//! 1 mm, the mean outward part of the slip (radial from the feed axis, at the landing
//! point) and its mean machine-direction part (+x, downstream; the slot jet blows along ±x).
//!
//! `cargo run --release --example air_field_slip -- [replicates seed]` (Table 1 baseline).
use laydown::rod::{laid_polyline, prepared_simulator, replicate_rng, shape_measures, AirField, LaydownParams, StepControl};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let reps: u64 = args.first().map_or(3, |s| s.parse().unwrap());
    let seed: u64 = args.get(1).map_or(2015, |s| s.parse().unwrap());
    let cases = [
        ("uniform", AirField::Uniform, 1.0),
        ("impinging 0.5", AirField::Impinging, 0.5),
        ("impinging 0.4", AirField::Impinging, 0.4),
        ("impinging 0.25", AirField::Impinging, 0.25),
        ("slot 0.5", AirField::ImpingingSlot, 0.5),
        ("slot 0.25", AirField::ImpingingSlot, 0.25),
    ];
    println!("| field | V_air (m/s) | S (mm) | median slip (mm) | 90 % slip (mm) | share > 1 mm | mean outward slip (mm) | mean MD slip (mm) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, field, phi) in cases {
        for v_air in [10.0, 30.0] {
            let p = LaydownParams { air_field: field, belt_permeability: phi, air_speed: v_air, ..LaydownParams::default() };
            let (mut slips, mut outward, mut md, mut s_sum) = (Vec::new(), 0.0, 0.0, 0.0);
            for r in 0..reps {
                let mut sim = prepared_simulator(&p, &mut replicate_rng(seed, r), 0.0);
                let mut control = StepControl::new(sim.limits.chosen, p.mass_per_length());
                let end = p.end_time();
                let mut landed_at: Vec<Option<([f64; 3], f64)>> = vec![None; sim.rod.nodes()];
                while sim.t < end * (1.0 - 1e-12) {
                    if control.advance(&mut sim, end).is_err() {
                        break;
                    }
                    for (i, t) in sim.landing_time.iter().enumerate() {
                        if t.is_finite() && landed_at[i].is_none() {
                            landed_at[i] = Some((sim.rod.x[i], *t));
                        }
                    }
                }
                s_sum += shape_measures(&laid_polyline(&sim.rod.x, &sim.landing_time, None)).0;
                for (i, at) in landed_at.iter().enumerate() {
                    let Some((x0, t0)) = at else { continue };
                    let x = sim.rod.x[i];
                    // belt motion since landing removed
                    let d = [x[0] - p.belt_speed * (sim.t - t0) - x0[0], x[1] - x0[1]];
                    slips.push((d[0] * d[0] + d[1] * d[1]).sqrt());
                    let r0 = (x0[0] * x0[0] + x0[1] * x0[1]).sqrt().max(1e-9);
                    outward += (d[0] * x0[0] + d[1] * x0[1]) / r0;
                    md += d[0];
                }
            }
            let n = slips.len().max(1);
            slips.sort_by(|a, b| a.total_cmp(b));
            let q = |f: f64| slips.get(((n - 1) as f64 * f) as usize).copied().unwrap_or(f64::NAN) * 1e3;
            let share = slips.iter().filter(|s| **s > 1e-3).count() as f64 / n as f64;
            println!(
                "| {name} | {v_air} | {:.2} | {:.3} | {:.2} | {:.2} | {:.2} | {:.2} |",
                s_sum / reps as f64 * 1e3,
                q(0.5),
                q(0.9),
                share,
                outward / n as f64 * 1e3,
                md / n as f64 * 1e3
            );
        }
    }
}
