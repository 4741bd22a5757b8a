//! Contacts between two simulated fibres that share the correction, solved for both
//! fibres at once, with the belt under them.
//!
//! Where two simulated fibres meet and neither is held at the contact (a collision of two
//! hanging fibres, or a fibre meeting a laid span that gives way: [`yield_share`] gives
//! each ½), each rod's own velocity pass would take half the correction against where it
//! sees the other moving. The two impulses then differ wherever one contact point lies at
//! a node and the other between nodes, and the pair's momentum changes (by 6 % at a
//! quarter of an element, `a_collision_of_two_free_fibres_conserves_their_momentum`).
//! Each rod also sees the other at its prediction v*, which lacks the other's half, so its
//! position pass pushed, every step, a penetration the other's half already closed: the
//! laid web's grid-scale motion (`pipelines/studies/PHYSICAL_WEBS.md`, "The belt in the
//! joint solve: measured, not kept" and "The belt in the joint solve, landed").
//!
//! So before each lock step of a cluster ([`super::super::contact_world`]), after every rod
//! has predicted its velocities and settled its holds ([`FibreContact::settle_holds`]),
//! the contacts of such pairs are solved together: a projected Gauss-Seidel over their
//! impulses, [`SWEEPS`] sweeps in a fixed order (the rod that found the pair, its
//! segments and candidates, then belt nodes), so threads do not change the result. Each
//! pair is looked for by one of its two rods only ([`searches`]; a fibre meeting its own
//! simulated stretch under `self_contact`, from the lower-numbered of its two segments),
//! the rods' searches run in parallel, and a sweep passes over a contact that has no
//! impulse and does not approach its target (most of a laid web's). A pair is solved so
//! when all four ends lie below z0, the yield rule shares it ½ each on the holds both
//! rods' passes use, and both rods have predicted the step. Each contact has a normal
//! impulse λ ≥ 0 towards the velocity pass's target (reach d at the end of the step, or
//! no approach while closer) and a friction impulse within μ_ff λ. Each is applied to the
//! nodes of both rods through their inverse node matrices W before the belt (the velocity
//! pass's own), equal and opposite, so the pair's momentum is kept; a side whose contact
//! point can hardly move takes nothing, as `Mobility::shift` refuses, and the impulse then
//! acts on the other side alone.
//!
//! The belt is part of the same solve: every node of a solved pair that lies within d of
//! the belt has a belt contact, unilateral (v_z ≥ −z/Δt, the belt pass's own target) with
//! Coulomb friction μ against the belt's velocity ([`super::super::contact::BeltContact`]'s
//! law, through W). A node pressed onto the belt then cannot give way to the fibre above
//! it, and the fibre above takes the whole correction within the solve instead of the belt
//! undoing half of it afterwards.
//!
//! The change goes into each rod's predicted velocities (the other rods' copies then carry
//! it, except for nodes resting on a fibre, which they see at their current velocity) and
//! into its step ([`FibreContact::air_change`]); a node with a belt contact in the solve is
//! seen at the velocity the solve gave (its predicted v* already held the belt's action).
//! The rod's own velocity pass applies no impulse to those pairs but still holds the node
//! along n, so that node skips the step's belt pass (the solve's belt, without the belt
//! pass's lagged axial force, is then its only one); the position pass treats the pairs as
//! before.

use super::super::contact_world::seen_velocity;
use super::super::integrator::Simulator;
use super::super::Integrator;
use super::{add_scaled, closest_points, dot, lerp, norm, point_mobility, scale, sub, yield_share, FibreContact, CROSSED, MAX_SEPARATION_SPEED};
use rayon::prelude::*;

/// Gauss-Seidel sweeps over the contacts of a cluster.
pub const SWEEPS: usize = 4;

/// Relative normal speed (m/s) by which a pair solved here may exceed its target and
/// still count as in contact in the rod's velocity pass, which then holds its node along
/// n: a pair the solve pushed ends at its target (up to round-off).
pub const SOLVED_TOLERANCE: f64 = 1e-6;

/// One contact that two simulated fibres (or two segments of one, `g == r`) share ½: own
/// segment `k` of rod `r` (closest point at `s`) against segment `kg` of rod `g` (at `u`),
/// normal `n` from the other towards the own segment, and the impulses found so far.
struct AirContact {
    r: usize,
    k: usize,
    /// The candidate of own segment `k` it was found as.
    cand: usize,
    s: f64,
    g: usize,
    kg: usize,
    u: f64,
    n: [f64; 3],
    gap: f64,
    lambda: f64,
    friction: [f64; 3],
    /// The pair's mobility along n and its four nodes' responses (see `side`), once needed.
    normal_response: Option<(f64, [[f64; 3]; 4])>,
}

/// Whether rod `r` of a cluster searches its pairs with rod `g` (the other one does not):
/// each pair is found once, and the rods share the search about equally (alternately
/// the lower and the higher of the two).
fn searches(r: usize, g: usize) -> bool {
    (r < g) == ((r + g) % 2 == 0)
}

/// What the search for the pairs a cluster's rods share ½ reads: the rods (`local[w]` the
/// place of world rod w among them), which of them take part, how fast their nodes move,
/// and the step from `t` of length `dt`, below the height `top`.
struct Search<'a> {
    sims: &'a [&'a Simulator],
    local: &'a [usize],
    ready: &'a [bool],
    /// Each rod's node speeds, the faster of its velocity before the belt and the one the
    /// other rods see ([`super::super::contact_world::seen_velocity`]); and per rod, a
    /// bound on how fast any of its candidates moves: its fastest obstacle (frozen ones
    /// included) or the fastest node of the cluster, whichever is faster.
    node_speed: &'a [Vec<f64>],
    fastest_met: &'a [f64],
    t: f64,
    dt: f64,
    top: f64,
}

impl Search<'_> {
    /// The pairs rod `r` finds from its own segments ([`searches`]), in the order of its
    /// segments and candidates; a pair seen in two periodic images once, in the first.
    fn rod(&self, r: usize) -> Vec<AirContact> {
        let mut contacts: Vec<AirContact> = Vec::new();
        let (sims, t, dt) = (self.sims, self.t, self.dt);
        let sim = sims[r];
        let Some(c) = sim.fibre_contact.as_ref() else { return contacts };
        if !self.ready[r] {
            return contacts;
        }
        let d = c.diameter;
        let (x, speed) = (&sim.rod.x, &self.node_speed[r]);
        // no pair closes more than this in the step, at the fastest its four nodes move as
        // either rod sees them (the same reach whichever rod searches the pair)
        let closing = |speed: f64| 2.0 * dt * (speed + 1.0);
        for k in 0..sim.rod.rest.len() {
            let own_speed = speed[k].max(speed[k + 1]);
            if !c.row_may_reach(k, closing(own_speed.max(self.fastest_met[r]))) {
                continue;
            }
            let row_start = contacts.len();
            for cand in c.row(k) {
                let ob = &c.obstacles[c.candidates[cand] as usize];
                let Some((world, kg)) = ob.source else { continue };
                let (g, kg) = (self.local[world as usize], kg as usize);
                // a pair within one rod (self-contact) is found from its lower-numbered segment
                // (the two are at least `SELF_GAP` apart, so they share no node)
                let found_here = if g == r { kg > k } else { searches(r, g) };
                if !found_here || !self.ready[g] || kg + 1 >= sims[g].rod.nodes() {
                    continue;
                }
                let pair_speed = own_speed.max(self.node_speed[g][kg]).max(self.node_speed[g][kg + 1]);
                let reach = d + closing(pair_speed);
                if !c.pair_may_reach(k, cand, reach - d) {
                    continue;
                }
                let (q0, q1) = ob.at(t);
                if x[k][2].max(x[k + 1][2]).max(q0[2]).max(q1[2]) > self.top {
                    continue;
                }
                let apart = |a: usize| x[k][a].min(x[k + 1][a]) > q0[a].max(q1[a]) + reach || q0[a].min(q1[a]) > x[k][a].max(x[k + 1][a]) + reach;
                if apart(0) || apart(1) || apart(2) {
                    continue;
                }
                let (s, u, gap) = closest_points(x[k], x[k + 1], q0, q1);
                let gl = norm(gap);
                if !(gl >= CROSSED * d) || gl > reach {
                    continue;
                }
                let near = if s < 0.5 { k } else { k + 1 };
                if yield_share(ob, u, gap[2], d, c.held(near, t)) != 0.5 || contacts[row_start..].iter().any(|a| a.g == g && a.kg == kg) {
                    continue;
                }
                contacts.push(AirContact { r, k, cand, s, g, kg, u, n: scale(gap, 1.0 / gl), gap: gl, lambda: 0.0, friction: [0.0; 3], normal_response: None });
            }
        }
        contacts
    }
}

/// Solve the contacts that share ½ between the fibres of one cluster (`sims`, with `local[w]`
/// the place of world rod w in it) for the step from `t` of length `dt`, each rod having
/// predicted its velocities for that step. A pair with an end above `top` (the laydown
/// height z0, where eq 7's oscillator holds the fibre: its W is about 150 times smaller
/// across the fibre than along it) is left to the rods' own passes. Writes each rod's
/// velocity change into its [`FibreContact::air_change`], adds it to its predicted
/// velocities and marks the pairs solved ([`FibreContact::air_pairs`],
/// [`FibreContact::air_at`]); with `parallel`, the rods search and mark in parallel (the
/// same result). Returns whether any velocity changed (the other rods' copies are then out
/// of date).
pub(in crate::rod) fn solve_in_air(sims: &mut [&mut Simulator], local: &[usize], t: f64, dt: f64, top: f64, parallel: bool) -> bool {
    // each rod's gap bounds at t, and its fastest obstacle: a segment whose bound shows
    // no candidate within a pair's reach (below) is skipped whole
    let fastest_obstacle: Vec<f64> = sims
        .iter_mut()
        .map(|sim| {
            let x = &sim.rod.x;
            sim.fibre_contact.as_mut().map_or(0.0, |c| c.bounds_at(x, t))
        })
        .collect();
    // the rods that predicted this step and settled its holds (a rod that failed takes no part)
    let ready: Vec<bool> = sims
        .iter()
        .map(|sim| {
            let n = sim.rod.nodes();
            sim.fibre_contact.as_ref().is_some_and(|c| c.predicted_at == Some(t) && c.free_velocities.len() == n && c.free_mobility.len() == n && c.held_at == Some(t))
        })
        .collect();
    // (a rod alone can meet itself: self-contact pairs are solved here too)
    let mut contacts: Vec<AirContact> = Vec::new();
    if ready.iter().any(|&r| r) {
        let node_speed: Vec<Vec<f64>> = sims
            .iter()
            .zip(&ready)
            .map(|(sim, &ready)| match &sim.fibre_contact {
                Some(c) if ready => c.free_velocities.iter().enumerate().map(|(i, &v)| norm(v).max(norm(seen_velocity(sim, i)))).collect(),
                _ => Vec::new(),
            })
            .collect();
        let fastest_free = node_speed.iter().flatten().copied().fold(0.0, f64::max);
        let fastest_met: Vec<f64> = fastest_obstacle.iter().map(|&v| v.max(fastest_free)).collect();
        let view: Vec<&Simulator> = sims.iter().map(|sim| &**sim).collect();
        let search = Search { sims: &view, local, ready: &ready, node_speed: &node_speed, fastest_met: &fastest_met, t, dt, top };
        contacts = if parallel {
            (0..view.len()).into_par_iter().flat_map_iter(|r| search.rod(r)).collect()
        } else {
            (0..view.len()).flat_map(|r| search.rod(r)).collect()
        };
    }
    // each rod's solved pairs, seen from either side (the other rod's candidates of the
    // pair are those of its segment whose obstacle copies the own segment); a rod in no
    // pair keeps an empty list (emptying it costs nothing, sizing it is left to a pair)
    let mut of_rod: Vec<Vec<usize>> = vec![Vec::new(); sims.len()];
    let world: Vec<u32> = sims.iter().map(|sim| sim.fibre_contact.as_ref().map_or(u32::MAX, |c| c.world)).collect();
    for (i, a) in contacts.iter().enumerate() {
        of_rod[a.r].push(i);
        if a.g != a.r {
            of_rod[a.g].push(i);
        }
    }
    let mark_rod = |w: usize, sim: &mut Simulator| {
        let Some(c) = sim.fibre_contact.as_mut() else { return };
        c.air_pairs.clear();
        c.air_change.clear();
        c.air_at = None;
        let mark = |c: &mut FibreContact, cand: usize| {
            if c.air_pairs.len() != c.candidates.len() {
                c.air_pairs.resize(c.candidates.len(), false);
            }
            c.air_pairs[cand] = true;
        };
        for a in of_rod[w].iter().map(|&i| &contacts[i]) {
            c.air_at = Some(t);
            if a.r == w {
                mark(c, a.cand);
                if a.g != w {
                    continue;
                }
            }
            for i in c.copying(a.kg, world[a.r], a.k as u32) {
                let cand = c.by_source[i].1 as usize;
                mark(c, cand);
            }
        }
    };
    if parallel {
        sims.par_iter_mut().enumerate().for_each(|(w, sim)| mark_rod(w, sim));
    } else {
        sims.iter_mut().enumerate().for_each(|(w, sim)| mark_rod(w, sim));
    }
    if contacts.is_empty() {
        return false;
    }
    let mut velocity: Vec<Vec<[f64; 3]>> = sims.iter().map(|sim| sim.fibre_contact.as_ref().map_or(Vec::new(), |c| c.free_velocities.clone())).collect();
    let dt_inv = 1.0 / dt;
    // one world: every rod has its diameter and friction
    let (d, friction) = sims[contacts[0].r].fibre_contact.as_ref().map_or((0.0, None), |c| (c.diameter, c.friction));
    let mut belt = belt_rows(sims, &contacts, d);
    for _ in 0..SWEEPS {
        for a in contacts.iter_mut() {
            let (r, k, s, g, kg, u) = (a.r, a.k, a.s, a.g, a.kg, a.u);
            let (own, other) = (&*sims[r], &*sims[g]);
            let relative = |velocity: &[Vec<[f64; 3]>]| sub(lerp(velocity[r][k], velocity[r][k + 1], s), lerp(velocity[g][kg], velocity[g][kg + 1], u));
            // the point mobility of the pair along `dir`, and each node's response
            let respond = |dir: [f64; 3]| -> (f64, [[f64; 3]; 4]) {
                let (e_own, ri, rj) = side(own, k, s, dir);
                let (e_other, gi, gj) = side(other, kg, u, dir);
                (e_own + e_other, [ri, rj, gi, gj])
            };
            // equal and opposite: +β J on the own nodes, −β J on the other's
            let apply = |velocity: &mut [Vec<[f64; 3]>], w: [[f64; 3]; 4], amount: f64| {
                velocity[r][k] = add_scaled(velocity[r][k], w[0], (1.0 - s) * amount);
                velocity[r][k + 1] = add_scaled(velocity[r][k + 1], w[1], s * amount);
                velocity[g][kg] = add_scaled(velocity[g][kg], w[2], -(1.0 - u) * amount);
                velocity[g][kg + 1] = add_scaled(velocity[g][kg + 1], w[3], -u * amount);
            };
            let vn = dot(relative(&velocity), a.n);
            // the velocity pass's target: reach d at the end of the step, or (closer)
            // no approach and a separation no faster than the position pass's
            let target = if a.gap >= d { (d - a.gap) * dt_inv } else { vn.clamp(0.0, MAX_SEPARATION_SPEED) };
            // a contact that has no impulse and does not approach its target gains none
            // in this update, normal or friction (most contacts of a laid web)
            if a.lambda == 0.0 && a.friction == [0.0; 3] && vn >= target {
                continue;
            }
            // the response along n is the same in every sweep (W does not change)
            let (e, w) = *a.normal_response.get_or_insert_with(|| respond(a.n));
            if !(e > 0.0) {
                continue;
            }
            let lambda = (a.lambda + (target - vn) / e).max(0.0);
            let change = lambda - a.lambda;
            a.lambda = lambda;
            if change != 0.0 {
                apply(&mut velocity, w, change);
            }
            // Coulomb friction within μ_ff λ against the relative tangential velocity
            let Some(mu) = friction else { continue };
            let vrel = relative(&velocity);
            let slip = sub(vrel, scale(a.n, dot(vrel, a.n)));
            if let Some(friction) = coulomb(a.friction, slip, mu * a.lambda, |dir| respond(dir).0) {
                let step = sub(friction, a.friction);
                let step_size = norm(step);
                let (e_step, w) = respond(scale(step, 1.0 / step_size));
                if e_step > 0.0 {
                    a.friction = friction;
                    apply(&mut velocity, w, step_size);
                }
            }
        }
        for b in belt.iter_mut() {
            b.sweep(&*sims[b.r], &mut velocity[b.r][b.i], dt_inv);
        }
    }
    for a in &contacts {
        if a.lambda > 0.0 {
            for r in [a.r, a.g] {
                if let Some(c) = sims[r].fibre_contact.as_mut() {
                    c.impulses += 1;
                }
            }
        }
    }
    let mut changed = false;
    for (r, (sim, solved)) in sims.iter_mut().zip(velocity).enumerate() {
        let Some(c) = sim.fibre_contact.as_mut() else { continue };
        if solved.len() != c.free_velocities.len() || solved == c.free_velocities {
            continue;
        }
        c.air_change = solved.iter().zip(&c.free_velocities).map(|(a, b)| sub(*a, *b)).collect();
        // v* already holds the belt's action (the prediction's own belt pass); a node with a
        // belt row has the belt in its change as well, so it moves at what the solve gave
        for (p, change) in c.predicted.iter_mut().zip(&c.air_change) {
            *p = add_scaled(*p, *change, 1.0);
        }
        for b in belt.iter().filter(|b| b.r == r) {
            if let Some(p) = c.predicted.get_mut(b.i) {
                *p = solved[b.i];
            }
        }
        changed = true;
    }
    changed
}

/// The belt under node `i` of rod `r` in the solve, and its impulses so far: normal
/// (λ ≥ 0, upwards) and friction (horizontal, within μ λ).
struct BeltRow {
    r: usize,
    i: usize,
    lambda: f64,
    friction: [f64; 3],
}

/// The belt contacts of the solve: each free node of a solved pair within `d` of the belt,
/// of a rod that has a belt, once, in the order of rods and nodes.
fn belt_rows(sims: &[&mut Simulator], contacts: &[AirContact], d: f64) -> Vec<BeltRow> {
    let mut rows: Vec<BeltRow> = Vec::new();
    for a in contacts {
        for (r, i) in [(a.r, a.k), (a.r, a.k + 1), (a.g, a.kg), (a.g, a.kg + 1)] {
            let sim = &*sims[r];
            if sim.contact.is_some() && sim.free_nodes().contains(&i) && sim.rod.x[i][2] <= d {
                rows.push(BeltRow { r, i, lambda: 0.0, friction: [0.0; 3] });
            }
        }
    }
    rows.sort_unstable_by_key(|b| (b.r, b.i));
    rows.dedup_by_key(|b| (b.r, b.i));
    rows
}

impl BeltRow {
    /// One Gauss-Seidel update of this row on its node's velocity `v` (`dt_inv` = 1/Δt):
    /// the belt's target v_z ≥ −z/Δt (the node reaches the plane at most, as in
    /// [`super::super::contact::BeltContact::apply`]), then Coulomb friction against the
    /// slip over the belt, through the node's W.
    fn sweep(&mut self, sim: &Simulator, v: &mut [f64; 3], dt_inv: f64) {
        let Some(belt) = sim.contact.as_ref() else { return };
        let response = |dir: [f64; 3]| node_response(sim, self.i, dir);
        let up = response([0.0, 0.0, 1.0]);
        if !(up[2] > 0.0) {
            return;
        }
        let target = -sim.rod.x[self.i][2] * dt_inv;
        let lambda = (self.lambda + (target - v[2]) / up[2]).max(0.0);
        *v = add_scaled(*v, up, lambda - self.lambda);
        self.lambda = lambda;
        let Some(mu) = belt.friction else { return };
        let slip = [v[0] - belt.belt_speed, v[1], 0.0];
        if let Some(friction) = coulomb(self.friction, slip, mu * self.lambda, |dir| dot(response(dir), dir)) {
            *v = add_scaled(*v, response(sub(friction, self.friction)), 1.0);
            self.friction = friction;
        }
    }
}

/// One projected Gauss-Seidel update of an accumulated Coulomb friction impulse
/// `previous`: add what stops the `slip` velocity (`mobility(e)` the contact's mobility
/// along a unit vector e), then hold the total within `most` (μ λ). The new impulse, or
/// None where it does not change.
fn coulomb(previous: [f64; 3], slip: [f64; 3], most: f64, mobility: impl Fn([f64; 3]) -> f64) -> Option<[f64; 3]> {
    let slip_speed = norm(slip);
    if !(slip_speed > 0.0) {
        return None;
    }
    let along = scale(slip, 1.0 / slip_speed);
    let e_t = mobility(along);
    if !(e_t > 0.0) {
        return None;
    }
    let mut friction = add_scaled(previous, along, -slip_speed / e_t);
    let size = norm(friction);
    if size > most {
        friction = scale(friction, most / size);
    }
    (norm(sub(friction, previous)) > 0.0).then_some(friction)
}

/// W dir of node `i` of `sim` (dir/m for the explicit scheme, which has no W; nothing for
/// a clamped or driven node).
fn node_response(sim: &Simulator, i: usize, dir: [f64; 3]) -> [f64; 3] {
    let w = sim.fibre_contact.as_ref().map_or(&[][..], |c| &c.free_mobility[..]);
    if !sim.free_nodes().contains(&i) {
        [0.0; 3]
    } else if sim.integrator != Integrator::Explicit && i < w.len() {
        super::super::forces::sym_mul(&w[i], &dir)
    } else {
        scale(dir, 1.0 / sim.rod.mass[i])
    }
}

/// How the point at `s` of segment `k` of `sim` responds to an impulse along the unit
/// vector `dir`: its mobility Σ β² dirᵀ W dir (β = (1 − s, s)) and the responses W dir
/// of the two nodes (1/m for the explicit scheme, which has no W; nothing for a clamped
/// or driven node); nothing where [`point_mobility`] refuses the point.
fn side(sim: &Simulator, k: usize, s: f64, dir: [f64; 3]) -> (f64, [f64; 3], [f64; 3]) {
    let (wi, wj) = (node_response(sim, k, dir), node_response(sim, k + 1, dir));
    match point_mobility(dir, wi, wj, s) {
        Some(e) => (e, wi, wj),
        None => (0.0, [0.0; 3], [0.0; 3]),
    }
}
