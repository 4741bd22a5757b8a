//! Energy checks of the rod that `tests.rs` does not make (issue 18): the oscillator's
//! implicit spring against its energy, and the work budget that a replicate stores
//! (`energy_diagnostics`, [`ENERGY_COLUMNS`]) against its change of energy: a free fibre
//! falling onto the belt, laydown replicates as the laydown stage runs them (feed drive,
//! belt, friction, drag, gravity and the oscillation all acting), and the energy the
//! continuous feed adds and removes (new nodes, frozen nodes, clamps).
//! Run with `cargo test --release --lib rod::energy_tests -- --nocapture` (prints the
//! measured errors).
use super::forces::{Oscillation, Term};
use super::metrics::ENERGY_COLUMNS;
use super::params::LaydownParams;
use super::params::Integrator;
use super::replicate::simulate;
use super::scene::{build, prepared_simulator, replicate_rng, run, CustomStart};
use super::state::{Rod, Workspace};
use super::integrator::{EnergySample, Work};

/// A rod of `nodes` nodes on a helix around the z axis, from z = 10 mm up to 30 mm, so
/// that the nodes lie on both sides of an oscillator zone top at 20 mm, none within
/// 0.1 mm of it.
fn helix(nodes: usize) -> Rod {
    let mut x: Vec<[f64; 3]> = (0..nodes)
        .map(|i| {
            let s = i as f64 / (nodes - 1) as f64;
            let a = 7.0 * s;
            [3e-3 * a.cos(), 2e-3 * a.sin() + 1e-3, 0.01 + 0.02 * s]
        })
        .collect();
    for p in &mut x {
        if (p[2] - 0.02).abs() < 1e-4 {
            p[2] += 2e-4;
        }
    }
    let rest = x.windows(2).map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2) + (w[1][2] - w[0][2]).powi(2)).sqrt()).collect();
    let p = LaydownParams::default();
    Rod::new(x, vec![[0.0; 3]; nodes], rest, p.mass_per_length(), p.axial_stiffness(), p.bending_stiffness())
}

/// The oscillator of eq 7 is a spring k (and a damper c) from every node above z0 to the
/// dummy point (0, u(t)), applied implicitly: F = −K (x + Δt v' − x_target), which adds
/// Δt² K to the node matrix and −Δt K (x − x_target) to the right-hand side. With c = 0
/// the right-hand side over Δt must be −∂E/∂x of E = ½ k Σ_{z > z0} (x² + (y − u)²)
/// (central differences), and the matrix entries over Δt² its second derivatives,
/// for rods of 3, 10 and 100 nodes. A wrong sign, a missing Δt, the spring on the wrong
/// side of z0 or a target at −u would each be an O(1) error; the tolerance 1e-6 is far
/// above round-off (E is quadratic: central differences are exact but for it).
#[test]
fn oscillator_spring_is_minus_the_gradient_of_its_energy() {
    let o = Oscillation { amplitude: 2e-3, angular_frequency: 300.0, phase: 0.4, stiffness: 0.7, damping: 0.0, zone_top: 0.02, ramp_time: 0.0 };
    let (t, dt) = (0.013, 1e-5);
    let u = o.amplitude * (o.angular_frequency * (t + dt) + o.phase).sin();
    let energy = |r: &Rod| -> f64 { r.x.iter().filter(|x| x[2] > o.zone_top).map(|x| 0.5 * o.stiffness * (x[0] * x[0] + (x[1] - u) * (x[1] - u))).sum() };
    let h = 1e-7;
    let mut worst = (0.0f64, 0.0f64);
    for nodes in [3, 10, 100] {
        let rod = helix(nodes);
        let mut ws = Workspace::new(nodes);
        ws.update_geometry(&rod);
        Term::Oscillation(o.clone()).accumulate(&rod, &mut ws, t, dt);
        let scale = ws.rhs.iter().flat_map(|f| f.iter()).fold(0.0f64, |a, f| a.max(f.abs())) / dt;
        assert!(scale > 0.0 && ws.rhs.iter().any(|f| f == &[0.0; 3]), "{nodes} nodes: the rod should have nodes on both sides of z0");
        let mut r = rod.clone();
        for i in 0..nodes {
            for k in 0..3 {
                let x0 = rod.x[i][k];
                r.x[i][k] = x0 + h;
                let (ep, fp) = (energy(&r), spring_rhs(&o, &r, t, dt)[i][k]);
                r.x[i][k] = x0 - h;
                let (em, fm) = (energy(&r), spring_rhs(&o, &r, t, dt)[i][k]);
                r.x[i][k] = x0;
                let grad = (ep - em) / (2.0 * h);
                let force = ws.rhs[i][k] / dt;
                worst.0 = worst.0.max((force + grad).abs() / scale);
                // ∂²E/∂x_k² = −∂F_k/∂x_k, against the matrix entry over Δt²
                let stiffness = -(fp - fm) / (2.0 * h);
                worst.1 = worst.1.max((ws.amat[i][k] / (dt * dt) - stiffness).abs() / o.stiffness);
            }
        }
        assert!(worst.0 < 1e-6, "{nodes} nodes: oscillator force vs -dE/dx: relative error {:.3e}", worst.0);
        assert!(worst.1 < 1e-6, "{nodes} nodes: oscillator matrix vs d2E/dx2: relative error {:.3e}", worst.1);
    }
    println!("oscillator spring vs energy: force {:.2e}, stiffness {:.2e} (relative)", worst.0, worst.1);
}

/// The oscillator's right-hand side over Δt (the spring force at v' = 0) at the rod's
/// positions.
fn spring_rhs(o: &Oscillation, rod: &Rod, t: f64, dt: f64) -> Vec<[f64; 3]> {
    let mut ws = Workspace::new(rod.nodes());
    ws.update_geometry(rod);
    Term::Oscillation(o.clone()).accumulate(rod, &mut ws, t, dt);
    ws.rhs.iter().map(|f| [f[0] / dt, f[1] / dt, f[2] / dt]).collect()
}

/// K + U − (the sum of the stored work columns but `skip`) of a record.
fn stored_balance(d: &EnergySample, skip: &str) -> f64 {
    let get = |name: &str| ENERGY_COLUMNS.iter().find(|c| c.0 == name).map(|c| (c.1)(d)).unwrap_or_else(|| panic!("no column {name}"));
    let work: f64 = ENERGY_COLUMNS.iter().filter(|c| c.0.starts_with("work_") && c.0 != skip).map(|c| (c.1)(d)).sum();
    get("kinetic") + get("elastic") - work
}

/// The energy moved by a run: K0 + U0 + Σ |stored work| at the end (J).
fn energy_moved(d: &[EnergySample]) -> f64 {
    let last = d.last().unwrap();
    ENERGY_COLUMNS.iter().filter(|c| c.0.starts_with("work_")).map(|c| (c.1)(last).abs()).sum::<f64>() + d[0].kinetic + d[0].elastic
}

/// max |Δ(K + U − ΣW)| over the records relative to the energy moved, the stored work
/// column `skip` left out ("" = none).
fn stored_drift(d: &[EnergySample], skip: &str) -> f64 {
    let b0 = stored_balance(&d[0], skip);
    d.iter().map(|s| (stored_balance(s, skip) - b0).abs()).fold(0.0, f64::max) / energy_moved(d)
}

/// A free fibre (no kinematic drive, no clamp) falling onto the moving belt with every
/// effect on: drag below z0, the oscillator above it, gravity, belt contact with
/// friction, Rayleigh damping. Its stored energy diagnostics must balance: K + U − ΣW
/// over the stored work columns stays at its initial value up to the integrator's own
/// error, relative to the energy moved (K0 + U0 + Σ|W| at the end). The fibre hangs as
/// in the paper's start, vertical at x = y = 0 (where the oscillator holds it) from 1 mm
/// to 51 mm above the belt (z0 = 10 mm), falling at 2 m/s; 15 ms of the explicit scheme
/// at 25, 50 and 100 elements.
///
/// Measured max drift / energy moved: 1.9e-2, 2.0e-2, 7.5e-3 at 25, 50, 100 elements
/// (O(Δt)); the larger stored works (oscillation, damping, drag) are 2-11e-8 J of the
/// 3.6e-7 J moved, so leaving one out breaks the balance by 6-30 %. Each effect alone
/// (a fibre falling from an incline, 25 and 100 elements): gravity 4e-7, 1e-7; drag
/// 9e-5, 2e-5; damping 1e-5, 3e-6; belt contact 1.8e-2, 7e-3, with friction 2.3e-2.
/// Only one node lands here (contact work 1-4e-9 J, below the drift): the laydown test
/// below is the one that checks `work_contact`. (Booked as before, ½ m (v'² − v*²) per
/// contact, it put this budget off by 1.0, 0.92, 0.80.) A start far from the
/// oscillator's target cannot balance: the implicit spring-damper (c/m ≈ 5·10⁵ 1/s)
/// then loses m |Δv|²/2 a step to backward Euler's numerical dissipation.
#[test]
fn stored_work_budget_balances_the_change_of_energy() {
    let mut worst = 0.0f64;
    for elements in [25, 50, 100] {
        let p = LaydownParams {
            laydown_height: 0.01,
            rayleigh_damping: 50.0,
            diagnostic_stride: 20,
            integrator: Integrator::Explicit,
            ..LaydownParams::default()
        };
        let positions: Vec<[f64; 3]> = (0..=elements).map(|i| [0.0, 0.0, 1e-3 + 0.05 * i as f64 / elements as f64]).collect();
        let start = CustomStart { velocities: vec![[0.0, 0.0, -2.0]; elements + 1], positions, driven_top: false, clamped: 0, rest_length: None };
        let mut sim = build(&p, start);
        let r = run(&mut sim, &p, 0.015);
        assert!(r.error.is_none(), "{elements} elements: {:?}", r.error);
        let d = &r.diagnostics;
        let last = d.last().unwrap();
        let (moved, drift) = (energy_moved(d), stored_drift(d, ""));
        let w = last.work;
        println!(
            "{elements} elements: {} records, landed {}, K_end {:.3e} J, U_end {:.3e} J, W drag {:.3e} gravity {:.3e} oscillation {:.3e} friction {:.3e} contact {:.3e} damping {:.3e} J; energy moved {moved:.3e} J, max |d(K+U-W)| / energy moved {drift:.3e}",
            d.len(), r.landed_nodes, last.kinetic, last.elastic, w.drag, w.gravity, w.oscillation, w.friction, w.contact, w.damping
        );
        worst = worst.max(drift);
        assert!(r.landed_nodes > 0 && w.oscillation != 0.0 && w.drag != 0.0 && w.damping != 0.0, "{elements} elements: every effect should be at play: {w:?}");
        assert!(w.feed == 0.0 && w.clamp == 0.0 && w.transport == 0.0, "{elements} elements: nothing drives this fibre: {w:?}");
        assert!(drift < 0.05, "{elements} elements: the stored budget K + U - W drifts by {drift:.3e} of the energy moved");
    }
    println!("stored work budget: worst drift {worst:.3e} of the energy moved");
}

/// Laydown replicates run as the laydown stage runs them (`simulate`, replicate 0 of
/// seed 2024, the Table-1 scene, `diagnostic_stride` 100), shortened: the whole laydown
/// of a 0.1 m fibre (10 ms) at 100, 150 and 200 elements, and the first 10 ms of the
/// 1 m, 1000-element fibre. The top node is driven at v_f (`work_feed`), 35-72 nodes land
/// and stick or slide (`work_contact`, `work_friction`). Scheme `explicit`.
///
/// Measured max |Δ(K + U − ΣW)| / energy moved: 1.8e-3, 1.5e-3, 6.4e-4 (0.1 m) and 1.5e-3
/// (1 m); at most 2.7e-3 over replicates 0-3; O(Δt) (0.1 m, 100 elements: 1.8e-3,
/// 1.3e-3, 7.0e-4 at time_step_factor 0.8, 0.4, 0.2). Tolerance 5e-3. Left out,
/// `work_feed` puts it off by 0.24-0.48 and `work_contact` by 2.0e-2 (1 m, the energy
/// moved being mostly the falling fibre's K0) to 8.6e-2 (replicates 0-3): the test
/// asserts both stay above twice the tolerance.
#[test]
fn laydown_replicate_stored_budget_balances() {
    let tol = 5e-3;
    for (length, elements, duration) in [(0.1, 100, 0.0), (0.1, 150, 0.0), (0.1, 200, 0.0), (1.0, 1000, 0.01)] {
        let p = LaydownParams { length, elements, duration, integrator: Integrator::Explicit, diagnostic_stride: 100, ..LaydownParams::default() };
        let r = simulate(&p, &mut replicate_rng(2024, 0));
        let d = &r.diagnostics;
        let w = d.last().unwrap().work;
        let (drift, no_feed, no_contact) = (stored_drift(d, ""), stored_drift(d, "work_feed"), stored_drift(d, "work_contact"));
        println!(
            "explicit L = {length} m, {elements} elements: {} steps, {} landed; W feed {:.3e} contact {:.3e} friction {:.3e} J, energy moved {:.3e} J; max |d(K+U-W)| / moved {drift:.3e}; without work_feed {no_feed:.3e}, without work_contact {no_contact:.3e}",
            r.steps, r.landed_nodes, w.feed, w.contact, w.friction, energy_moved(d)
        );
        assert!(r.error.is_none() && r.elements == elements, "{elements} elements: {:?}, {} elements", r.error, r.elements);
        assert!(r.landed_nodes > 10 && w.contact < 0.0 && w.friction < 0.0 && w.feed > 0.0, "{elements} elements: contact, friction and the drive should be at play: {w:?}");
        assert!(drift < tol, "{elements} elements: K + U - W drifts by {drift:.3e} of the energy moved");
        assert!(no_feed > 2.0 * tol && no_contact > 2.0 * tol, "{elements} elements: the test should see a missing column ({no_feed:.3e}, {no_contact:.3e})");
    }
}

/// The same with the default scheme (`trapezoidal_axial`) at the Table-1 element size
/// (1 mm): the 0.1 m fibre's whole laydown, the first 10 ms of the 0.5 m and 1 m fibres.
/// Its stored budget closes only to the scheme's own energy error, not the bookkeeping's:
/// the reactions (belt, drive) are the residuals of the nodes' own equations, the formula
/// that closes the explicit budget to 1e-3, and per step ΔK + ΔU − ΣW splits, to
/// round-off, into ΔU + (elastic and projection impulses)·v' and −½ (those impulses)·(v' − v),
/// both largest in free segments of the hanging fibre whose axial force flips sign from
/// step to step (ω_a Δt ≈ 50) while they turn by ~0.2 rad a step; the explicit scheme's
/// two parts cancel to 1e-3, this one's do not.
///
/// Measured: 0.32, 9.7e-2, 6.2e-2 of the energy moved (replicates 0-3: up to 0.45, 0.18,
/// 0.13; 0.1 m: 0.23, 0.21, 0.12 at time_step_factor 0.2, 0.05, 0.01; at 0.5 mm elements
/// 1.5, falling to 5e-2 at 0.01). Tolerances 1.5 times the worst replicate. Left out,
/// `work_feed` puts it off by 0.70, 0.39, 0.25, 2.2-4.1 times the drift (asserted above
/// 1.5 times); a lost `work_contact` (1.2-2.2e-7 J) is below this scheme's error and only
/// the explicit test above sees it.
#[test]
fn default_scheme_stored_budget_closes_to_its_own_error() {
    assert_eq!(Integrator::default(), Integrator::TrapezoidalAxial);
    for (length, elements, duration, tol) in [(0.1, 100, 0.0, 0.7), (0.5, 500, 0.01, 0.27), (1.0, 1000, 0.01, 0.2)] {
        let p = LaydownParams { length, elements, duration, diagnostic_stride: 5, ..LaydownParams::default() };
        let r = simulate(&p, &mut replicate_rng(2024, 0));
        let d = &r.diagnostics;
        let w = d.last().unwrap().work;
        let (drift, no_feed, no_contact) = (stored_drift(d, ""), stored_drift(d, "work_feed"), stored_drift(d, "work_contact"));
        println!(
            "default scheme L = {length} m, {elements} elements: {} steps, {} landed; W feed {:.3e} contact {:.3e} friction {:.3e} J, energy moved {:.3e} J; max |d(K+U-W)| / moved {drift:.3e} (tolerance {tol}); without work_feed {no_feed:.3e}, without work_contact {no_contact:.3e}",
            r.steps, r.landed_nodes, w.feed, w.contact, w.friction, energy_moved(d)
        );
        assert!(r.error.is_none() && r.landed_nodes > 10 && w.contact < 0.0 && w.friction < 0.0 && w.feed > 0.0, "{elements} elements: {:?} {w:?}", r.error);
        assert!(drift < tol, "{elements} elements: K + U - W drifts by {drift:.3e} of the energy moved");
        assert!(no_feed > 1.5 * drift, "{elements} elements: the test should see a missing work_feed ({no_feed:.3e} vs {drift:.3e})");
    }
}

/// K + U − Σ (every work of the record, continuous-feed ones included).
fn full_balance(s: &EnergySample) -> f64 {
    let w: Work = s.work;
    s.kinetic + s.elastic - (w.gravity + w.drag + w.damping + w.oscillation + w.contact + w.friction + w.feed + w.clamp + w.transport)
}

/// The continuous feed (`feed.rs`, laid_web) adds a node above the driven top
/// (`push_top`) and drops frozen nodes off the front, clamping the next two to the belt
/// (`drop_front`). The energy they add and remove (K of the new mass at the feed speed,
/// the new bending at the old top; K, strain and bending of the dropped nodes) is booked
/// in `Work::transport`: on a laydown replicate 9 ms in (explicit, 60 and 100 elements),
/// Δ(K + U) = Δtransport across each call to round-off (measured ≤ 2e-16 of K + U;
/// tolerance 1e-12). The clamps' reaction is booked in `Work::clamp` like the belt's and
/// the drive's (R at ½(v + v')): a fibre hanging from its first two nodes, clamped and
/// carried at (1, 0, 0.5) m/s, falling at 2 m/s (explicit, 10 ms, every effect on):
/// K + U − ΣW drifts by 1.2e-3, 6.9e-4 of the energy moved, by 0.53, 0.52 without
/// `clamp`. Tolerance 5e-3. (The feed path as a whole runs the default scheme, whose own
/// error is above; with `explicit` it runs away in its first milliseconds.)
#[test]
fn continuous_feed_books_the_energy_it_adds_and_removes() {
    let p = LaydownParams { integrator: Integrator::Explicit, rayleigh_damping: 50.0, laydown_height: 0.01, ..LaydownParams::default() };
    for elements in [60usize, 100] {
        // a laydown replicate 9 ms in: coiling, its first nodes on the belt
        let scene = LaydownParams { length: 0.1, elements, integrator: Integrator::Explicit, ..LaydownParams::default() };
        let mut sim = prepared_simulator(&scene, &mut replicate_rng(2024, 0), 0.009);
        assert!(sim.landing_time[..5].iter().all(|t| t.is_finite()), "{elements} elements: the first nodes should have landed");
        let ds = sim.rod.rest[0];
        let check = |sim: &mut super::integrator::Simulator, before: f64, what: &str| {
            let e = sim.energy_sample();
            let err = (full_balance(&e) - before).abs() / (e.kinetic + e.elastic);
            println!("{elements} elements, {what}: transport {:.3e} J, relative error {err:.1e}", e.work.transport);
            assert!(err < 1e-12, "{elements} elements, {what}: Δ(K + U) - Δtransport = {err:.3e} of K + U");
        };
        let b = full_balance(&sim.energy_sample());
        let top = sim.rod.x[sim.rod.nodes() - 1];
        let v = sim.rod.v[sim.rod.nodes() - 1];
        sim.push_top([top[0], top[1], top[2] + ds], v, ds, p.mass_per_length());
        check(&mut sim, b, "push_top");
        let b = full_balance(&sim.energy_sample());
        sim.drop_front(5, 2, [p.belt_speed, 0.0, 0.0]);
        check(&mut sim, b, "drop_front");

        // the clamps' work
        let positions: Vec<[f64; 3]> = (0..=elements).map(|i| [0.0, 0.0, 1e-3 + 0.05 * i as f64 / elements as f64]).collect();
        let start = CustomStart { velocities: vec![[0.0, 0.0, -2.0]; elements + 1], positions, driven_top: false, clamped: 2, rest_length: None };
        let mut sim = build(&p, start);
        sim.clamp_velocity = [1.0, 0.0, 0.5];
        let r = run(&mut sim, &p, 0.01);
        assert!(r.error.is_none(), "{elements} elements: {:?}", r.error);
        let d = &r.diagnostics;
        let w = d.last().unwrap().work;
        let moved = d[0].kinetic + d[0].elastic + [w.gravity, w.drag, w.damping, w.oscillation, w.contact, w.friction, w.feed, w.clamp, w.transport].iter().map(|x| x.abs()).sum::<f64>();
        let drift = |dropped: f64| d.iter().map(|s| (full_balance(s) + dropped * s.work.clamp - full_balance(&d[0])).abs()).fold(0.0, f64::max) / moved;
        let (with, without) = (drift(0.0), drift(1.0));
        println!("{elements} elements, clamped end carried at 1 m/s: W clamp {:.3e} J, energy moved {moved:.3e} J; drift {with:.3e}, without W clamp {without:.3e}", w.clamp);
        assert!(w.clamp.abs() > 0.1 * moved, "{elements} elements: the clamps should work: {w:?}");
        assert!(with < 5e-3 && without > 0.1, "{elements} elements: drift {with:.3e}, without the clamp's work {without:.3e}");
    }
}

/// The stored budget of laydown replicates run with `implicit_bending` (as the test above:
/// replicate 0 of seed 2024, the 0.1 m fibre's whole laydown and the first 10 ms of the
/// 1 m fibre, `diagnostic_stride` 5). The belt's and the drive's reactions include the
/// implicit bending force (R = (A + Δt² H) v' − b − G/Δt). Backward Euler on bending and
/// on the axial springs dissipates: the budget's error is the scheme's numerical loss,
/// one-signed (K + U − ΣW ends below its start) and large, 0.57 of the energy moved on
/// the 0.1 m fibre and 0.14 on the 1 m fibre, more than a missing `work_feed` (0.26,
/// 0.11), so unlike the explicit
/// scheme's budget this one cannot catch a lost work column. Tolerances 1.5 times the
/// measured drift.
#[test]
fn implicit_bending_stored_budget_closes_to_its_own_error() {
    for (length, elements, duration, tol) in [(0.1, 100, 0.0, IB_BUDGET_TOL[0]), (1.0, 1000, 0.01, IB_BUDGET_TOL[1])] {
        let p = LaydownParams { length, elements, duration, diagnostic_stride: 5, integrator: Integrator::ImplicitBending, ..LaydownParams::default() };
        let r = simulate(&p, &mut replicate_rng(2024, 0));
        let d = &r.diagnostics;
        let w = d.last().unwrap().work;
        let (drift, no_feed) = (stored_drift(d, ""), stored_drift(d, "work_feed"));
        let b = |s: &EnergySample| stored_balance(s, "");
        let end_change = (b(d.last().unwrap()) - b(&d[0])) / energy_moved(d);
        println!(
            "implicit_bending L = {length} m, {elements} elements: {} steps, {} landed; W feed {:.3e} contact {:.3e} friction {:.3e} J, energy moved {:.3e} J; max |d(K+U-W)| / moved {drift:.3e}, at the end {end_change:+.3e} (tolerance {tol}); without work_feed {no_feed:.3e}",
            r.steps, r.landed_nodes, w.feed, w.contact, w.friction, energy_moved(d)
        );
        assert!(r.error.is_none() && r.landed_nodes > 10 && w.contact < 0.0 && w.feed > 0.0, "{elements} elements: {:?} {w:?}", r.error);
        assert!(drift < tol, "{elements} elements: K + U - W drifts by {drift:.3e} of the energy moved");
        assert!(end_change < 0.0, "{elements} elements: the scheme should lose energy, not gain it ({end_change:+.3e})");
    }
}
const IB_BUDGET_TOL: [f64; 2] = [0.85, 0.2];
