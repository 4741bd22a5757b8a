//! Diagnose bounced replicates: for each replicate, where (node, landing time, time of
//! the rise) the landed nodes lift off the belt and by how much.
//!
//! `cargo run --release --example laydown_bounce -- [length elements replicates seed] [name=value ...]`
use laydown::stages::laydown::{replicate_rng, run_jobs, LaydownJob, LaydownParams};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num: Vec<&String> = args.iter().filter(|a| !a.contains('=')).collect();
    let mut p = LaydownParams {
        length: num.first().map_or(0.3, |s| s.parse().unwrap()),
        elements: num.get(1).map_or(300, |s| s.parse().unwrap()),
        ..Default::default()
    };
    let reps: u64 = num.get(2).map_or(8, |s| s.parse().unwrap());
    let seed: u64 = num.get(3).map_or(2024, |s| s.parse().unwrap());
    for kv in args.iter().filter(|a| a.contains('=')) {
        let (k, v) = kv.split_once('=').unwrap();
        if k == "bounce_check" {
            p.bounce_check = if v == "transient" { laydown::stages::laydown::BounceCheck::Transient } else { laydown::stages::laydown::BounceCheck::Final };
        } else if k == "integrator" {
            p.integrator = laydown::stages::laydown::Integrator::from_name(v).unwrap();
        } else {
            p.set(k, v.parse().unwrap()).unwrap();
        }
    }
    let _ = replicate_rng(seed, 0);
    let jobs: Vec<LaydownJob> = (0..reps).map(|r| LaydownJob { params: p.clone(), seed, replicate: r }).collect();
    let res = run_jobs(&jobs);
    let n = p.resolved_elements();
    let mut invalid = 0;
    let (mut inv_final, mut inv_transient) = (0, 0);
    for (k, r) in res.iter().enumerate() {
        if !r.valid {
            invalid += 1;
        }
        if r.error.is_some() || r.final_lift_of_landed > p.bounce_tolerance {
            inv_final += 1;
        }
        if r.error.is_some() || r.max_lift_after_landing > p.bounce_tolerance {
            inv_transient += 1;
        }
        // nodes lifting more than 0.1 mm, sorted by lift
        let mut lifted: Vec<(usize, f64)> = r.lift.iter().cloned().enumerate().filter(|(_, h)| *h > 1e-4).collect();
        lifted.sort_by(|a, b| b.1.partial_cmp(&a.1).unwrap());
        let over = r.lift.iter().filter(|h| **h > p.bounce_tolerance).count();
        // final height of landed nodes (out of plane at the end, the paper's observation)
        let final_lift = r.positions.iter().zip(&r.landing_time).filter(|(_, t)| t.is_finite()).map(|(x, _)| x[2]).fold(0.0, f64::max);
        // nodes still out of plane at the end by more than the tolerance
        let final_over = r.positions.iter().zip(&r.landing_time).filter(|(x, t)| t.is_finite() && x[2] > p.bounce_tolerance).count();
        // transient lift of nodes landed after the start-up impact (first 5 % of the run)
        let late_lift = r.lift.iter().zip(&r.landing_time).filter(|(_, t)| **t > 0.05 * r.end_time).map(|(h, _)| *h).fold(0.0, f64::max);
        let first_over = r.lift.iter().position(|h| *h > p.bounce_tolerance);
        println!(
            "SUMMARY rep {k}: max_lift {:.3} mm  late_lift {:.3} mm  final_lift {:.3} mm  final_over {final_over}  first_over_node {first_over:?}",
            r.max_lift_after_landing * 1e3,
            late_lift * 1e3,
            final_lift * 1e3
        );
        println!(
            "rep {k}: valid={} err={:?} max_lift={:.3} mm  nodes>tol={over}  nodes>0.1mm={}  S={:.2} mm e={:.0} wall={:.2}s",
            r.valid,
            r.error,
            r.max_lift_after_landing * 1e3,
            lifted.len(),
            r.radius_of_gyration * 1e3,
            r.bending_energy,
            r.wall_seconds
        );
        for (i, h) in lifted.iter().take(6) {
            println!(
                "    node {i:5} (from free end {:5}) lift {:.3} mm landed {:.4} s rose at {:.4} s",
                i,
                h * 1e3,
                r.landing_time[*i],
                r.lift_time[*i]
            );
        }
        // histogram of lift by landing time
        let mut bins = [0usize; 10];
        let t_end = r.end_time;
        for (i, h) in r.lift.iter().enumerate() {
            if *h > p.bounce_tolerance {
                let b = ((r.landing_time[i] / t_end) * 10.0).floor().clamp(0.0, 9.0) as usize;
                bins[b] += 1;
            }
        }
        if over > 0 {
            println!("    over-tolerance nodes by landing-time decile: {bins:?}  (n = {n})");
        }
    }
    println!(
        "INVALID {invalid}/{reps} (bounce_check {}); by final profile {inv_final}/{reps}, by transient lift {inv_transient}/{reps} (tolerance {} m, {} elements)",
        p.bounce_check.name(),
        p.bounce_tolerance,
        n
    );
}
