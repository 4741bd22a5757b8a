//! Laydown replicates and ensembles by hand (was the ignored `smoke` and `ensemble` tests).
//!
//! `cargo run --release --example laydown_ensemble` runs SEEDS (default 4) replicates of
//! the Table 1 baseline with seed SEED (default 2024), on THREADS threads (default 1), and
//! prints one line per replicate and the ensemble means ± standard errors of S and e (as
//! laid and belt-removed), and of S and e of the nodes that landed after T_LATE (default
//! 0.03 s). Environment:
//! - `INTEG`: integrator name (default the stage's default);
//! - `SET="name=value,..."`: scene parameters (`LaydownParams::set`), e.g. `SET=elements=1000`;
//! - `DIAGNOSTICS=1`: also print ten of each replicate's energy records;
//! - `PARAMETERS=1`: print the parameter table (Markdown) and stop.
use laydown::rod::{laid_polyline, replicate_rng, shape_measures, simulate, Integrator, LaydownParams, LaydownResult, parameter_table_markdown};
use rayon::prelude::*;

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// Mean and standard error.
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    (m, sd / n.sqrt())
}

fn main() {
    if env("PARAMETERS", 0) == 1 {
        println!("{}", parameter_table_markdown());
        return;
    }
    let mut p = LaydownParams::default();
    if let Ok(i) = std::env::var("INTEG") {
        p.integrator = Integrator::from_name(&i).expect("INTEG: an integrator name");
    }
    for kv in std::env::var("SET").unwrap_or_default().split(',').filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').expect("SET: name=value,...");
        p.set(k, v.parse().expect("SET: a number")).expect("SET: a scene parameter");
    }
    let (seeds, seed, threads, t_late) = (env("SEEDS", 4u64), env("SEED", 2024u64), env("THREADS", 1usize), env("T_LATE", 0.03f64));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let t0 = std::time::Instant::now();
    let res: Vec<LaydownResult> = pool.install(|| (0..seeds).into_par_iter().map(|r| simulate(&p, &mut replicate_rng(seed, r))).collect());
    let wall = t0.elapsed().as_secs_f64();
    let (mut s, mut e, mut s_rm, mut e_rm, mut late_s, mut late_e) = (vec![], vec![], vec![], vec![], vec![], vec![]);
    for r in &res {
        println!("{}", r.summary());
        if env("DIAGNOSTICS", 0) == 1 {
            for d in r.diagnostics.iter().step_by((r.diagnostics.len() / 10).max(1)) {
                println!("  {d:?}");
            }
        }
        if r.error.is_none() {
            let lt: Vec<f64> = r.landing_time.iter().map(|&t| if t > t_late { t } else { f64::NAN }).collect();
            let (ls, le) = shape_measures(&laid_polyline(&r.positions, &lt, None));
            late_s.push(ls);
            late_e.push(le);
            s.push(r.radius_of_gyration);
            e.push(r.bending_energy);
            s_rm.push(r.radius_of_gyration_belt_removed);
            e_rm.push(r.bending_energy_belt_removed);
        }
    }
    let ((ls, lse), (le, lee)) = (mean_se(&late_s), mean_se(&late_e));
    println!("LATE (landed after {t_late} s) S={ls:.5}±{lse:.5} e={le:.0}±{lee:.0}");
    let ((ms, mse), (me, mee), (mr, mre), (er, ere)) = (mean_se(&s), mean_se(&e), mean_se(&s_rm), mean_se(&e_rm));
    let valid = res.iter().filter(|r| r.valid).count();
    println!(
        "ENSEMBLE {} n={} valid={valid} S={ms:.5}±{mse:.5} e={me:.0}±{mee:.0} S_rm={mr:.5}±{mre:.5} e_rm={er:.0}±{ere:.0} wall={wall:.1}s",
        p.integrator.name(),
        s.len()
    );
}
