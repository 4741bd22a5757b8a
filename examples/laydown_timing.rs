//! Explicit reference vs the fast default scheme on the Table 1 baseline, side by side
//! on one core: S, e, their relative differences, wall time and the speed-up.
//!
//! `RAYON_NUM_THREADS=1 cargo run --release --example laydown_timing -- [replicates] [seed]`
//! (default 1 replicate, seed 2024). Replicates run one after the other on the calling
//! thread. One replicate of the explicit scheme takes about 40 s on an idle core.
//! Single replicates of this chaotic laydown differ by several per cent between schemes
//! (as between two seeds); only ensemble means are comparable (module docs of
//! `laydown::stages::laydown`).
use laydown::stages::laydown::{replicate_rng, simulate, Integrator, LaydownParams, LaydownResult};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u64 = args.first().map_or(1, |s| s.parse().unwrap());
    let seed: u64 = args.get(1).map_or(2024, |s| s.parse().unwrap());
    let run = |integ: Integrator| -> (Vec<LaydownResult>, f64) {
        let p = LaydownParams { integrator: integ, ..Default::default() };
        let t0 = Instant::now();
        let res: Vec<LaydownResult> = (0..n).map(|r| simulate(&p, &mut replicate_rng(seed, r))).collect();
        (res, t0.elapsed().as_secs_f64())
    };
    let (fast, wall_fast) = run(Integrator::TrapezoidalAxial);
    let (reference, wall_ref) = run(Integrator::Explicit);
    let mean = |v: &[LaydownResult], f: &dyn Fn(&LaydownResult) -> f64| v.iter().map(f).sum::<f64>() / v.len() as f64;
    println!("replicate | scheme | S (mm) | e | S belt removed (mm) | steps | wall (s) | valid");
    for r in 0..n as usize {
        for (name, res) in [("explicit", &reference), ("trapezoidal_axial", &fast)] {
            let x = &res[r];
            println!(
                "{r} | {name} | {:.3} | {:.0} | {:.3} | {} | {:.2} | {}{}",
                x.radius_of_gyration * 1e3,
                x.bending_energy,
                x.radius_of_gyration_belt_removed * 1e3,
                x.steps,
                x.wall_seconds,
                x.valid,
                x.error.as_ref().map(|e| format!(" error: {e}")).unwrap_or_default()
            );
        }
    }
    let s = |v: &[LaydownResult]| mean(v, &|x| x.radius_of_gyration);
    let e = |v: &[LaydownResult]| mean(v, &|x| x.bending_energy);
    let (sr, sf, er, ef) = (s(&reference), s(&fast), e(&reference), e(&fast));
    println!(
        "MEAN over {n}: S explicit {:.3} mm, fast {:.3} mm ({:+.2} %); e explicit {:.0}, fast {:.0} ({:+.2} %)",
        sr * 1e3,
        sf * 1e3,
        100.0 * (sf - sr) / sr,
        er,
        ef,
        100.0 * (ef - er) / er
    );
    println!(
        "WALL explicit {:.2} s, fast {:.2} s per replicate; speed-up {:.1}x",
        wall_ref / n as f64,
        wall_fast / n as f64,
        wall_ref / wall_fast
    );
}
