//! `implicit_bending` against today's schemes (issue 15), side by side on one core in one
//! run: per scheme the mean and std over replicates of S and e, steps, rejected steps and
//! the wall time per replicate, and each scheme's wall time as a ratio of the first's.
//! Replicates are interleaved (replicate r of every scheme, then r + 1), so that a load
//! change on a shared machine hits every scheme alike.
//!
//! `RAYON_NUM_THREADS=1 cargo run --release --example implicit_bending_timing -- \
//!     [replicates] [schemes,comma,separated] [name=value ...]`
//! e.g. `... -- 4 trapezoidal_axial,implicit_bending,explicit`, or the 50 m/s scene
//! `... -- 2 trapezoidal_axial,implicit_bending fibre_speed=50 air_speed=150 belt_speed=2 oscillation_frequency=100`.
//! A scheme may carry its own setting after a colon: `implicit_bending:implicit_step_travel=0.5`,
//! switch on the opt-in twist (feed clamped), `trapezoidal_axial:twist=1`, or start
//! the fibre as a continuous feed, `trapezoidal_axial:start=fed`, or judge validity over
//! the last oscillation period, `trapezoidal_axial:bounce_check=last_period`.
use laydown::stages::laydown::{replicate_rng, simulate, Integrator, LaydownParams, LaydownResult};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.first().map_or(1, |s| s.parse().unwrap());
    let schemes: Vec<String> = args
        .get(1)
        .map_or("trapezoidal_axial,implicit_bending", |s| s.as_str())
        .split(',')
        .map(String::from)
        .collect();
    let mut base = LaydownParams::default();
    for kv in args.iter().skip(2) {
        let (k, v) = kv.split_once('=').expect("name=value");
        base.set(k, v.parse().expect("a number")).unwrap_or_else(|e| panic!("{k}: {e}"));
    }
    let seed = 2024;
    let params: Vec<LaydownParams> = schemes
        .iter()
        .map(|s| {
            let mut p = base.clone();
            let mut parts = s.split(':');
            p.integrator = Integrator::from_name(parts.next().unwrap()).expect("an integrator name");
            for kv in parts {
                let (k, v) = kv.split_once('=').expect("name=value");
                match k {
                    "twist" => p.effects.twist = v != "0",
                    "start" => p.start = laydown::rod::Start::from_name(v).expect("vertical or fed"),
                    "bounce_check" => p.bounce_check = laydown::rod::BounceCheck::from_name(v).expect("final, transient or last_period"),
                    _ => p.set(k, v.parse().unwrap()).unwrap(),
                }
            }
            p.validate().unwrap();
            p
        })
        .collect();
    println!(
        "scene: v_f {} m/s, V_air {} m/s, v_b {} m/s, f {} Hz, elements {} (resolved {}), end time {:.4} s",
        base.fibre_speed,
        base.air_speed,
        base.belt_speed,
        base.oscillation_frequency,
        base.elements,
        base.resolved_elements(),
        base.end_time()
    );
    let mut results: Vec<Vec<LaydownResult>> = vec![Vec::new(); schemes.len()];
    println!("replicate | scheme | S (mm) | e | S belt removed (mm) | steps | rejected | projection iterations per step | min dt (s) | wall (s) | valid");
    for r in 0..n {
        for (k, p) in params.iter().enumerate() {
            let x = simulate(p, &mut replicate_rng(seed, r));
            println!(
                "{r} | {} | {:.3} | {:.0} | {:.3} | {} | {} | {:.2} | {:.2e} | {:.2} | {}{}",
                schemes[k],
                x.radius_of_gyration * 1e3,
                x.bending_energy,
                x.radius_of_gyration_belt_removed * 1e3,
                x.steps,
                x.rejected_steps,
                x.projection_iterations as f64 / x.steps.max(1) as f64,
                x.min_time_step,
                x.wall_seconds,
                x.valid,
                x.error.as_ref().map(|e| format!(" error: {e}")).unwrap_or_default()
            );
            results[k].push(x);
        }
    }
    let stats = |v: &[LaydownResult], f: &dyn Fn(&LaydownResult) -> f64| {
        let m = v.len() as f64;
        let mean = v.iter().map(f).sum::<f64>() / m;
        let var = if v.len() > 1 { v.iter().map(|x| (f(x) - mean).powi(2)).sum::<f64>() / (m - 1.0) } else { 0.0 };
        (mean, var.sqrt())
    };
    let wall0 = stats(&results[0], &|x| x.wall_seconds).0;
    let (s0, e0) = (stats(&results[0], &|x| x.radius_of_gyration).0, stats(&results[0], &|x| x.bending_energy).0);
    println!("scheme | S mean ± std (mm) | e mean ± std | S vs first | e vs first | steps | wall per replicate (s) | wall / first's | valid");
    for (k, v) in results.iter().enumerate() {
        let (s, ss) = stats(v, &|x| x.radius_of_gyration);
        let (e, es) = stats(v, &|x| x.bending_energy);
        let (w, _) = stats(v, &|x| x.wall_seconds);
        let (st, _) = stats(v, &|x| x.steps as f64);
        println!(
            "{} | {:.3} ± {:.3} | {:.0} ± {:.0} | {:+.2} % | {:+.2} % | {:.0} | {:.3} | {:.3} | {}/{}",
            schemes[k],
            s * 1e3,
            ss * 1e3,
            e,
            es,
            100.0 * (s - s0) / s0,
            100.0 * (e - e0) / e0,
            st,
            w,
            w / wall0,
            v.iter().filter(|x| x.valid).count(),
            v.len()
        );
    }
}
