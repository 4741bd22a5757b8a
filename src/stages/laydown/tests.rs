//! Physics verification tests (run with `cargo test --release --lib stages::laydown`).
use super::*;

fn summary(r: &LaydownResult) -> String {
    format!(
        "err={:?} valid={} reason={:?} landed={} laid={:.4} S={:.5} e={:.1} S_rm={:.5} e_rm={:.1} steps={} rej={} dt={:.3e} mindt={:.2e} wall={:.2}s pen={:.2e} cons={:.1e}",
        r.error, r.valid, r.invalid_reason, r.landed_nodes, r.laid_length, r.radius_of_gyration, r.bending_energy,
        r.radius_of_gyration_belt_removed, r.bending_energy_belt_removed, r.steps, r.rejected_steps, r.time_step, r.min_time_step, r.wall_seconds,
        r.max_penetration, r.max_constraint_error
    )
}

/// Manual: `cargo test --release --lib stages::laydown::tests::smoke -- --ignored --nocapture`
#[test]
#[ignore]
fn smoke() {
    let integ = std::env::var("INTEG").unwrap_or("inextensible".into());
    let n: usize = std::env::var("N").ok().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let seed: u64 = std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut p = LaydownParams::default();
    p.integrator = Integrator::from_name(&integ).unwrap();
    p.elements = n;
    p.coil_resolution = 0.0;
    let r = simulate(&p, &mut replicate_rng(seed, 0));
    println!("{}", summary(&r));
    for d in r.diagnostics.iter().step_by((r.diagnostics.len() / 10).max(1)) {
        println!("{:?}", d);
    }
}

#[test]
#[ignore]
fn debug_start() {
    let integ = std::env::var("INTEG").unwrap_or("implicit_axial".into());
    let mut p = LaydownParams::default();
    p.integrator = Integrator::from_name(&integ).unwrap();
    p.coil_resolution = 0.0;
    let mut rng = replicate_rng(1, 0);
    let start = scene::paper_start(&p, 1000, &mut rng);
    let mut sim = scene::build(&p, start);
    let steps: usize = std::env::var("STEPS").ok().and_then(|s| s.parse().ok()).unwrap_or(150);
    let every: usize = std::env::var("EVERY").ok().and_then(|s| s.parse().ok()).unwrap_or(30);
    for s in 0..steps {
        if let Err(e) = sim.step() {
            println!("fail {:?}", e);
            break;
        }
        if s % every == 0 {
            println!("t={:.3e} contact={:?}", sim.t, &sim.ws.contact[..12].iter().map(|c| *c as u8).collect::<Vec<_>>());
            for i in (0..60).step_by(4) {
                let x = sim.rod.x[i];
                let v = sim.rod.v[i];
                println!("  {i:3} x=({:+.3e},{:+.3e},{:.5e}) v=({:+.2e},{:+.2e},{:+.2e})", x[0], x[1], x[2], v[0], v[1], v[2]);
            }
        }
    }
}
