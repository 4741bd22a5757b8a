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

/// Manual ensemble runner: INTEG, SEEDS (count), SET="name=value,..." overrides, THREADS.
/// `cargo test --release --lib stages::laydown::tests::ensemble -- --ignored --nocapture`
#[test]
#[ignore]
fn ensemble() {
    let mut p = LaydownParams::default();
    if let Ok(i) = std::env::var("INTEG") {
        p.integrator = Integrator::from_name(&i).unwrap();
    }
    if let Ok(set) = std::env::var("SET") {
        for kv in set.split(',').filter(|s| !s.is_empty()) {
            let (k, v) = kv.split_once('=').unwrap();
            p.set(k, v.parse().unwrap()).unwrap();
        }
    }
    let seeds: u64 = std::env::var("SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(4);
    let threads: usize = std::env::var("THREADS").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let jobs: Vec<LaydownJob> = (0..seeds).map(|r| LaydownJob { params: p.clone(), seed: 2024, replicate: r }).collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let t0 = std::time::Instant::now();
    let res = pool.install(|| run_jobs(&jobs));
    let wall = t0.elapsed().as_secs_f64();
    let mut acc = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
    for r in &res {
        println!("{}", summary(r));
        if r.error.is_none() {
            acc[0].push(r.radius_of_gyration);
            acc[1].push(r.bending_energy);
            acc[2].push(r.radius_of_gyration_belt_removed);
            acc[3].push(r.bending_energy_belt_removed);
        }
    }
    let ms = |v: &Vec<f64>| {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
        (m, sd / n.sqrt())
    };
    let (s, se) = ms(&acc[0]);
    let (e, ee) = ms(&acc[1]);
    let (sr, sre) = ms(&acc[2]);
    let (er, ere) = ms(&acc[3]);
    let valid = res.iter().filter(|r| r.valid).count();
    println!(
        "ENSEMBLE {} n={} valid={} S={:.5}±{:.5} e={:.0}±{:.0} S_rm={:.5}±{:.5} e_rm={:.0}±{:.0} wall={:.1}s",
        p.integrator.name(), acc[0].len(), valid, s, se, e, ee, sr, sre, er, ere, wall
    );
}

// ---------------------------------------------------------------- helpers

use super::integrator::Simulator;
use super::scene::{build, CustomStart};
use crate::geometry::{bending_energy, radius_of_gyration};
use std::f64::consts::PI;

/// Parameters with every effect off except those listed.
fn only(effects: &[&str]) -> LaydownParams {
    let mut p = LaydownParams::default();
    p.effects = Effects {
        elasticity: false,
        gravity: false,
        drag: false,
        oscillation: false,
        contact: false,
        friction: false,
        damping: false,
        imperfections: false,
    };
    for e in effects {
        match *e {
            "elasticity" => p.effects.elasticity = true,
            "gravity" => p.effects.gravity = true,
            "drag" => p.effects.drag = true,
            "oscillation" => p.effects.oscillation = true,
            "contact" => p.effects.contact = true,
            "friction" => p.effects.friction = true,
            "damping" => p.effects.damping = true,
            "imperfections" => p.effects.imperfections = true,
            _ => panic!("unknown effect {e}"),
        }
    }
    p
}

/// A straight fibre of `n` segments of length `ds` from `origin` along `dir`, at rest.
fn straight(origin: [f64; 3], dir: [f64; 3], n: usize, ds: f64) -> CustomStart {
    let positions = (0..=n).map(|i| {
        let s = i as f64 * ds;
        [origin[0] + s * dir[0], origin[1] + s * dir[1], origin[2] + s * dir[2]]
    });
    CustomStart { positions: positions.collect(), velocities: vec![[0.0; 3]; n + 1], driven_top: false, clamped: 0 }
}

/// Step `sim` with its stable step for `duration`, calling `f` after each step.
fn advance(sim: &mut Simulator, duration: f64, mut f: impl FnMut(&Simulator)) {
    let steps = (duration / sim.limits.chosen).ceil() as usize;
    sim.dt = duration / steps as f64;
    for _ in 0..steps {
        sim.step().expect("stable step");
        f(sim);
    }
}

// ---------------------------------------------------------------- metrics

#[test]
fn metrics_straight_circle_arc() {
    let n = 1000;
    let line: Vec<[f64; 3]> = (0..=n).map(|i| [i as f64 / n as f64, 0.0, 0.0]).collect();
    assert!((radius_of_gyration(&line) - 1.0 / 12f64.sqrt()).abs() < 1e-3);
    assert_eq!(bending_energy(&line), 0.0);
    let circle = |turn: f64| -> Vec<[f64; 3]> {
        let r = 1.0 / turn;
        (0..=n).map(|i| {
            let a = turn * i as f64 / n as f64;
            [r * a.sin(), r * (1.0 - a.cos()), 0.0]
        })
        .collect()
    };
    let c = circle(2.0 * PI);
    assert!((bending_energy(&c) - 2.0 * PI * PI).abs() / (2.0 * PI * PI) < 2e-3);
    assert!((radius_of_gyration(&c[..n]) - 1.0 / (2.0 * PI)).abs() < 1e-9);
    for theta in [0.5, 2.0] {
        assert!((bending_energy(&circle(theta)) - theta * theta / 2.0).abs() < 2e-3 * theta * theta);
    }
    // laid_polyline keeps only landed nodes and removes the belt motion
    let pos = vec![[1.0, 2.0, 0.0], [3.0, 4.0, 0.5], [5.0, 6.0, 0.0]];
    let lt = vec![0.1, f64::NAN, 0.3];
    let laid = laid_polyline(&pos, &lt, Some((2.0, 0.5)));
    assert_eq!(laid, vec![[1.0 - 0.8, 2.0, 0.0], [5.0 - 0.4, 6.0, 0.0]]);
}

// ---------------------------------------------------------------- cantilever

/// Clamped horizontal cantilever of length L: nodes 0 (ghost, x = −Δs) and 1 (x = 0)
/// held; the clamp node's Voronoi cell is halved so the flexible beam starts at x = 0.
fn cantilever(d: f64, n: usize, integrator: Integrator) -> (LaydownParams, Simulator) {
    let l = 0.010;
    let ds = l / n as f64;
    let mut p = only(&["elasticity", "gravity"]);
    p.diameter = d;
    p.integrator = integrator;
    let mut start = straight([-ds, 0.0, 1.0], [1.0, 0.0, 0.0], n + 1, ds);
    start.clamped = 2;
    let mut sim = build(&p, start);
    sim.rod.inv_voronoi[1] *= 2.0;
    (p, sim)
}

fn cantilever_check(d: f64, sag_ref: f64, f1_ref: f64, integrator: Integrator) {
    let (p, mut sim) = cantilever(d, 40, integrator);
    let l: f64 = 0.010;
    let q = p.mass_per_length() * p.gravity;
    let sag = q * l.powi(4) / (8.0 * p.bending_stiffness());
    let f1 = 1.8751f64.powi(2) / (2.0 * PI) * (p.bending_stiffness() / p.mass_per_length()).sqrt() / (l * l);
    assert!((sag - sag_ref).abs() / sag_ref < 0.01, "analytic sag {sag}");
    assert!((f1 - f1_ref).abs() / f1_ref < 0.01, "analytic f1 {f1}");
    // Released straight at rest: the tip oscillates about the static sag at f1.
    let tip = sim.rod.nodes() - 1;
    let z0 = sim.rod.x[tip][2];
    let mut hist: Vec<(f64, f64)> = Vec::new();
    advance(&mut sim, 4.2 / f1, |s| hist.push((s.t, z0 - s.rod.x[tip][2])));
    let mean_of = |h: &[(f64, f64)]| h.iter().map(|x| x.1).sum::<f64>() / h.len() as f64;
    let crossings = |h: &[(f64, f64)], m: f64| -> Vec<f64> {
        h.windows(2)
            .filter(|w| w[0].1 < m && w[1].1 >= m)
            .map(|w| w[0].0 + (m - w[0].1) / (w[1].1 - w[0].1) * (w[1].0 - w[0].0))
            .collect()
    };
    let mut mean = mean_of(&hist);
    let mut c = crossings(&hist, mean);
    for _ in 0..3 {
        let (a, b) = (c[0], *c.last().unwrap());
        let window: Vec<_> = hist.iter().cloned().filter(|x| x.0 >= a && x.0 < b).collect();
        mean = mean_of(&window);
        c = crossings(&hist, mean);
    }
    let period = (c.last().unwrap() - c[0]) / (c.len() - 1) as f64;
    let f_sim = 1.0 / period;
    println!("d={d:e} {integrator:?}: sag {mean:.5e} (beam {sag:.5e}), f1 {f_sim:.3} Hz (beam {f1:.3})");
    assert!((mean - sag).abs() / sag < 0.01, "sag {mean} vs {sag}");
    assert!((f_sim - f1).abs() / f1 < 0.01, "f1 {f_sim} vs {f1}");
}

#[test]
fn cantilever_20um() {
    cantilever_check(20e-6, 0.233e-3, 40.6, Integrator::ImplicitAxial);
    cantilever_check(20e-6, 0.233e-3, 40.6, Integrator::Explicit);
}

#[test]
fn cantilever_50um() {
    cantilever_check(50e-6, 0.037e-3, 101.5, Integrator::ImplicitAxial);
    cantilever_check(50e-6, 0.037e-3, 101.5, Integrator::Explicit);
}

// ---------------------------------------------------------------- drag

fn falling(d: f64, dir: [f64; 3], integrator: Integrator, duration: f64) -> (LaydownParams, f64) {
    let mut p = only(&["elasticity", "gravity", "drag"]);
    p.diameter = d;
    p.air_speed = 0.0;
    p.laydown_height = 50.0;
    p.length = 100.0;
    p.integrator = integrator;
    let start = straight([0.0, 0.0, 20.0], dir, 20, 1e-3);
    let mut sim = build(&p, start);
    advance(&mut sim, duration, |_| {});
    let vz = sim.rod.v.iter().map(|v| v[2]).sum::<f64>() / sim.rod.nodes() as f64;
    for v in &sim.rod.v {
        assert!((v[2] - vz).abs() < 1e-6 * vz.abs(), "the fibre should fall rigidly");
    }
    (p, -vz)
}

#[test]
fn drag_terminal_velocity_normal() {
    for (d, reference) in [(20e-6, 0.180), (50e-6, 0.330)] {
        let (p, v) = falling(d, [1.0, 0.0, 0.0], Integrator::ImplicitAxial, 0.4);
        let law = effects::DragLaw::new(d, p.air_density, p.air_kinematic_viscosity, p.tangential_drag_beta);
        let analytic = law.normal_terminal_speed(p.mass_per_length() * p.gravity);
        println!("horizontal d={d:e}: {v:.5} m/s, analytic {analytic:.5}, reference {reference}");
        assert!((v - analytic).abs() / analytic < 1e-3, "{v} vs {analytic}");
        assert!((v - reference).abs() / reference < 0.02, "{v} vs {reference}");
    }
}

#[test]
fn drag_terminal_velocity_tangential() {
    for d in [20e-6, 50e-6] {
        let (p, v) = falling(d, [0.0, 0.0, 1.0], Integrator::ImplicitAxial, 2.0);
        // eqs 1-2: ½ π d ρ_a β (V d/ν)^-0.61 V² = ρ A g  ⇒  V = (ρAg / (½ π d ρ_a β (d/ν)^-0.61))^(1/1.39)
        let k = 0.5 * PI * d * p.air_density * p.tangential_drag_beta * (d / p.air_kinematic_viscosity).powf(-0.61);
        let analytic = (p.mass_per_length() * p.gravity / k).powf(1.0 / 1.39);
        println!("vertical d={d:e}: {v:.5} m/s, analytic {analytic:.5}");
        assert!((v - analytic).abs() / analytic < 2e-3, "{v} vs {analytic}");
    }
}

// ---------------------------------------------------------------- friction

/// A short fibre (along y) lying on the belt, pressed down by gravity (and by the
/// air when `air`), thrown along +x at 1 m/s; returns the velocities after 20 ms.
fn sliding(mu: f64, air: bool, integrator: Integrator) -> (LaydownParams, Vec<[f64; 3]>) {
    let mut p = only(&["elasticity", "gravity", "contact", "friction"]);
    p.effects.drag = air;
    p.friction_coefficient = mu;
    p.belt_speed = 0.2;
    p.integrator = integrator;
    let mut start = straight([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 20, 1e-3);
    start.velocities = vec![[1.0, 0.0, 0.0]; 21];
    let mut sim = build(&p, start);
    advance(&mut sim, 0.02, |s| {
        for x in &s.rod.x {
            assert!(x[2] >= 0.0 && x[2] < 1e-9, "node left the belt: z = {}", x[2]);
        }
    });
    (p, sim.rod.v.clone())
}

#[test]
fn friction_stick_and_slip() {
    for integ in [Integrator::Explicit, Integrator::ImplicitAxial] {
        // high mu, pressed by the air: every node moves exactly with the belt
        let (p, v) = sliding(5.0, true, integ);
        for v in &v {
            assert_eq!(v[0], p.belt_speed, "high mu: a landed node moves exactly with the belt");
            assert_eq!(v[1], 0.0);
        }
        // mu = 0: the fibre keeps sliding at 1 m/s
        let (_, v) = sliding(0.0, false, integ);
        for v in &v {
            assert!((v[0] - 1.0).abs() < 1e-9, "mu = 0: the node keeps sliding, v_x = {}", v[0]);
        }
        // moderate mu under its weight: Coulomb slip decelerates at mu g
        let (p, v) = sliding(0.05, false, integ);
        let expected = 1.0 - 0.05 * p.gravity * 0.02;
        for v in &v {
            assert!((v[0] - expected).abs() < 1e-3 * (1.0 - expected), "v_x = {} vs {expected}", v[0]);
        }
    }
}
#[test]
#[ignore]
fn debug_friction() {
    let mut p = only(&["elasticity", "gravity", "contact", "friction", "drag"]);
    p.friction_coefficient = 5.0;
    p.integrator = Integrator::Explicit;
    let mut start = straight([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 20, 1e-3);
    start.velocities = vec![[1.0, 0.0, 0.0]; 21];
    let mut sim = build(&p, start);
    advance(&mut sim, 0.02, |_| {});
    for i in 0..21 {
        println!("{i} {:?} {:?} {:?}", sim.ws.contact[i], sim.rod.x[i], sim.rod.v[i]);
    }
}
