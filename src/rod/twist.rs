//! Opt-in twist of the rod (effect `twist` with `feed_end: clamped`): the discrete
//! elastic rod's twist (Bergou et al. 2008; 2010) for an isotropic, naturally straight
//! fibre, as the paper's B31 beams carry it.
//!
//! # Model
//! Segment j carries a reference director a_j ⊥ t_j, moved from step to step by
//! parallel transport in time (it never spins about its tangent). The reference twist
//! m_i at interior node i is the signed angle about t_i from a_{i−1}, transported in
//! space onto t_i, to a_i. The material frame sits at angle θ_j from a_j; the twist at
//! node i is τ_i = θ_i − θ_{i−1} + m_i and its energy E_t = Σ_i GJ τ_i²/(2 V_i) (V_i the
//! Voronoi rest length), with GJ = EI/(1 + ν) for a round section (G = E/2(1 + ν), J = 2I).
//!
//! θ is quasistatic: twist waves run at √(G/ρ) (about 900 m/s for Table 1), far faster
//! than anything else in the scene, so the material frame is in equilibrium at every
//! step, ∂E_t/∂θ_j = 0 on every segment nothing holds. Then τ_i/V_i = Ω, the twist
//! rate, is uniform over the span between two held segments,
//! Ω = (θ_top − θ_b + Σ_{i=b+1}^{top} m_i) / Σ_{i=b+1}^{top} V_i,
//! and zero when the span ends in a free end. Held segments:
//! - the top (feed) segment of a driven top: the spinneret does not let the filament
//!   spin, θ_top = 0 in its time-parallel frame. A feed free to spin leaves the span a
//!   free end, Ω ≡ 0 and the model without twist: `feed_end: free` builds nothing;
//! - laid segments: both nodes clamped, or landed and within `hold_height` of the belt.
//!   Friction at its surface holds a laid fibre against spinning (a stuck node cannot
//!   roll). When a segment lands its θ is fixed at the value the span's uniform twist
//!   gives it, so a landing lays the span's twist down with the fibre.
//!
//! The topmost held segment below the top bounds the span; before any segment lands
//! the span ends free at the fibre's front and Ω = 0.
//!
//! With θ in equilibrium the centreline force is F = −GJ Ω Σ_i ∂m_i/∂x (the θ terms
//! vanish), with ∂m_i/∂x_{i−1} = −κb_i/(2 l_{i−1}), ∂m_i/∂x_{i+1} = κb_i/(2 l_i) and
//! ∂m_i/∂x_i minus their sum (the holonomy gradient of Bergou et al. 2008; checked
//! against finite differences of m in the tests), κb_i = 2 t_{i−1} × t_i/(1 + t_{i−1}·t_i) the
//! curvature binormal. For an isotropic rod twist enters bending only through this force.
//!
//! # Use
//! [`super::scene`] builds a [`Twist`] into the [`super::Simulator`] when the scene
//! asks for it; the simulator calls [`Twist::accumulate`] after the force terms at the
//! start of every step (the directors follow the positions the step starts from, so a
//! retaken step recomputes the same state).

use super::forces::MIN_ONE_PLUS_COS;
use super::state::{Rod, Workspace};

/// Twist state of one rod: directors, reference twists, the held segments' θ.
#[derive(Clone, Debug)]
pub struct Twist {
    /// Torsional stiffness GJ (N·m²).
    pub twist_stiffness: f64,
    /// A landed node at most this high above the belt holds its segments (m).
    pub hold_height: f64,
    /// Reference director a_j of each segment and the tangent it was transported to.
    director: Vec<[f64; 3]>,
    director_tangent: Vec<[f64; 3]>,
    /// Reference twist m_i of each node (rad; ends unused), kept to unwrap across ±π.
    reference_twist: Vec<f64>,
    /// Material angle θ_j of each segment (rad); set when it is held.
    theta: Vec<f64>,
    /// Twist τ_i each node carried when a landing took it out of the span (rad).
    laid_twist: Vec<f64>,
    /// Topmost held segment below the top (None: the span ends at a free front).
    held: Option<usize>,
    /// Twist rate Ω of the span at the last evaluation (rad/m).
    pub twist_rate: f64,
    /// Twist laid down with nodes that have since left the rod (frozen; rad).
    dropped_twist: f64,
    /// Σ V_i over the span at the last evaluation (m).
    span_length: f64,
}

#[inline]
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Parallel transport of u ⊥ t1 from unit tangent t1 to t2 (the rotation about t1 × t2
/// taking t1 to t2): u − (u·t2)/(1 + t1·t2) (t1 + t2), then made ⊥ t2 and unit again
/// against round-off (one Newton step on the length, which is 1 to round-off).
/// Across a fold-back (t2 ≈ −t1) u is only re-orthogonalised and normalised.
#[inline]
fn transport(u: [f64; 3], t1: &[f64; 3], t2: &[f64; 3]) -> [f64; 3] {
    let opc = 1.0 + dot(t1, t2);
    if !(opc > 1e-12) {
        let s = dot(&u, t2);
        let w = [u[0] - s * t2[0], u[1] - s * t2[1], u[2] - s * t2[2]];
        let n = dot(&w, &w).sqrt();
        return if n > 1e-150 { [w[0] / n, w[1] / n, w[2] / n] } else { unit_normal(t2) };
    }
    let s = dot(&u, t2) / opc;
    let w = [u[0] - s * (t1[0] + t2[0]), u[1] - s * (t1[1] + t2[1]), u[2] - s * (t1[2] + t2[2])];
    let s = dot(&w, t2);
    let w = [w[0] - s * t2[0], w[1] - s * t2[1], w[2] - s * t2[2]];
    let scale = 1.5 - 0.5 * dot(&w, &w);
    [w[0] * scale, w[1] * scale, w[2] * scale]
}

/// [`transport`] without the clean-up, for angles: u − (u·t2)/(1 + t1·t2) (t1 + t2).
#[inline]
fn transport_unnormalised(u: [f64; 3], t1: &[f64; 3], t2: &[f64; 3]) -> [f64; 3] {
    let opc = 1.0 + dot(t1, t2);
    if !(opc > 1e-12) {
        return u;
    }
    let s = dot(&u, t2) / opc;
    [u[0] - s * (t1[0] + t2[0]), u[1] - s * (t1[1] + t2[1]), u[2] - s * (t1[2] + t2[2])]
}

/// Some unit vector ⊥ t.
fn unit_normal(t: &[f64; 3]) -> [f64; 3] {
    let axis = if t[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let w = cross(t, &axis);
    let n = dot(&w, &w).sqrt();
    [w[0] / n, w[1] / n, w[2] / n]
}

/// Signed angle about t from u to a (both ⊥ t; any lengths).
#[inline]
fn angle_about(u: &[f64; 3], a: &[f64; 3], t: &[f64; 3]) -> f64 {
    atan2_small(dot(&cross(u, a), t), dot(u, a))
}

/// atan2(y, x), by its Taylor series when |y| ≤ x/8 (the reference twists between
/// neighbouring segments nearly always are: 10 terms, truncation below 3e-18
/// relative), else libm's.
#[inline]
fn atan2_small(y: f64, x: f64) -> f64 {
    if !(x > 0.0 && y.abs() <= 0.125 * x) {
        return y.atan2(x);
    }
    let r = y / x;
    let q = r * r;
    // atan r = r Σ_k (−1)^k q^k/(2k + 1), k = 0..9 (Horner, smallest term first)
    const C: [f64; 10] = [1.0, -1.0 / 3.0, 1.0 / 5.0, -1.0 / 7.0, 1.0 / 9.0, -1.0 / 11.0, 1.0 / 13.0, -1.0 / 15.0, 1.0 / 17.0, -1.0 / 19.0];
    let mut s = C[9];
    for c in C[..9].iter().rev() {
        s = c + q * s;
    }
    r * s
}

/// The representative of `angle` nearest to `near` (2π apart).
#[inline]
fn unwrap_near(angle: f64, near: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if (angle - near).abs() <= PI {
        angle
    } else {
        angle + TAU * ((near - angle) / TAU).round()
    }
}

impl Twist {
    /// An untwisted rod in its current shape: directors transported in space from the
    /// first segment, so that every reference twist and θ starts at zero.
    pub fn new(rod: &Rod, twist_stiffness: f64, hold_height: f64) -> Self {
        let mut ws = Workspace::new(rod.nodes());
        ws.update_geometry(rod);
        let ns = rod.rest.len();
        let mut director = Vec::with_capacity(ns);
        director.push(unit_normal(&ws.tangent[0]));
        for j in 1..ns {
            director.push(transport(director[j - 1], &ws.tangent[j - 1], &ws.tangent[j]));
        }
        Twist {
            twist_stiffness,
            hold_height,
            director,
            director_tangent: ws.tangent.clone(),
            reference_twist: vec![0.0; ns + 1],
            theta: vec![0.0; ns],
            laid_twist: vec![0.0; ns + 1],
            held: None,
            twist_rate: 0.0,
            dropped_twist: 0.0,
            span_length: 0.0,
        }
    }

    /// Topmost held segment below the top one (None: the span ends free).
    pub fn held_segment(&self) -> Option<usize> {
        self.held
    }

    /// The laid nodes below the span (0..=held).
    fn laid(&self) -> std::ops::Range<usize> {
        0..self.held.map_or(0, |b| b + 1)
    }

    /// Twist energy (J): the span's ½ GJ Ω² Σ V_i and Σ GJ τ_i²/(2V_i) of the twist
    /// landings laid down with the fibre.
    pub fn energy(&self, rod: &Rod) -> f64 {
        let span = 0.5 * self.twist_stiffness * self.twist_rate * self.twist_rate * self.span_length;
        let laid: f64 = self.laid().map(|i| 0.5 * self.twist_stiffness * self.laid_twist[i] * self.laid_twist[i] * rod.inv_voronoi[i]).sum();
        span + laid
    }

    /// Total twist laid down with the fibre, Σ τ_i over the laid nodes (rad), those
    /// that have left the rod included.
    pub fn laid_twist(&self) -> f64 {
        self.dropped_twist + self.laid().map(|i| self.laid_twist[i]).sum::<f64>()
    }

    /// Transport the directors to `tangent` (unit tangents of the current positions).
    fn transport_directors(&mut self, tangent: &[[f64; 3]]) {
        for ((a, ta), t) in self.director.iter_mut().zip(self.director_tangent.iter_mut()).zip(tangent) {
            *a = transport(*a, ta, t);
            *ta = *t;
        }
    }

    /// m_i at node i from the transported directors, unwrapped to its last value.
    fn update_reference_twist(&mut self, tangent: &[[f64; 3]], i: usize) -> f64 {
        let u = transport_unnormalised(self.director[i - 1], &tangent[i - 1], &tangent[i]);
        let m = unwrap_near(angle_about(&u, &self.director[i], &tangent[i]), self.reference_twist[i]);
        self.reference_twist[i] = m;
        m
    }

    /// Twist rate Ω of the span above held segment `b` (θ_top = 0): eq in the module docs.
    fn span_rate(&self, rod: &Rod, b: usize, top: usize) -> (f64, f64) {
        let (mut sum_m, mut sum_v) = (-self.theta[b], 0.0);
        for i in b + 1..=top {
            sum_m += self.reference_twist[i];
            sum_v += 1.0 / rod.inv_voronoi[i];
        }
        (sum_m / sum_v, sum_v)
    }

    /// Update the twist state to the rod's current positions (`ws.tangent`/`ws.seg_len`
    /// filled for them) and add the twist force to `ws.force`. `top_held`: the top
    /// segment is clamped against spinning (a driven top); `holds(i)`: node i lies on
    /// the belt or is clamped.
    pub fn accumulate(&mut self, rod: &Rod, ws: &mut Workspace, top_held: bool, holds: impl Fn(usize) -> bool) {
        let ns = rod.rest.len();
        assert_eq!(self.director.len(), ns, "twist state out of step with the rod (push_top/drop_front missed)");
        self.transport_directors(&ws.tangent);
        if !top_held || ns < 2 {
            self.held = None;
            self.twist_rate = 0.0;
            self.span_length = 0.0;
            return;
        }
        let top = ns - 1;
        let held = (0..top).rev().find(|&j| holds(j) && holds(j + 1));
        // reference twists over the old and the new span
        let lowest = match (self.held, held) {
            (Some(a), Some(b)) => a.min(b) + 1,
            _ => 1,
        };
        for i in lowest..=top {
            self.update_reference_twist(&ws.tangent, i);
        }
        let rank = |h: Option<usize>| h.map_or(-1, |b| b as i64);
        if rank(held) > rank(self.held) {
            // segments landed: their θ from the span's uniform twist, top down,
            // θ_{i−1} = θ_i + m_i − Ω V_i (τ_i = Ω V_i); the nodes leaving the span lay
            // their twist energy down with them
            let rate = self.held.map_or(0.0, |b| self.span_rate(rod, b, top).0);
            let new_low = held.expect("ranked above");
            let first_landed = self.held.map_or(0, |b| b + 1);
            let mut theta = 0.0;
            for i in (first_landed + 1..=top).rev() {
                theta += self.reference_twist[i] - rate / rod.inv_voronoi[i];
                if i - 1 <= new_low {
                    self.theta[i - 1] = theta;
                }
            }
            for i in first_landed.max(1)..=new_low {
                self.laid_twist[i] = rate / rod.inv_voronoi[i];
            }
        }
        self.held = held;
        let Some(b) = held else {
            self.twist_rate = 0.0;
            self.span_length = 0.0;
            return;
        };
        let (rate, span) = self.span_rate(rod, b, top);
        self.twist_rate = rate;
        self.span_length = span;
        if rate == 0.0 {
            return;
        }
        // F = −GJ Ω Σ ∂m_i/∂x (module docs)
        let moment = self.twist_stiffness * rate;
        for i in b + 1..=top {
            let (ta, tb) = (&ws.tangent[i - 1], &ws.tangent[i]);
            let opc = (1.0 + dot(ta, tb)).max(MIN_ONE_PLUS_COS);
            let k = cross(ta, tb);
            let ga = moment / (opc * ws.seg_len[i - 1]);
            let gb = moment / (opc * ws.seg_len[i]);
            let f = &mut ws.force;
            for c in 0..3 {
                // −GJΩ ∂m/∂x with ∂m/∂x_{i−1} = −κb/(2 l_a), ∂m/∂x_{i+1} = κb/(2 l_b), κb = 2k/opc
                let (fa, fb) = (ga * k[c], gb * k[c]);
                f[i - 1][c] += fa;
                f[i][c] += fb - fa;
                f[i + 1][c] -= fb;
            }
        }
    }

    /// Continuous feed: a segment added at the top, its director transported from the
    /// old top segment's, entering untwisted (θ = 0).
    pub fn push_top(&mut self, new_tangent: [f64; 3]) {
        let top = self.director.len() - 1;
        let a = transport(self.director[top], &self.director_tangent[top], &new_tangent);
        self.director.push(a);
        self.director_tangent.push(new_tangent);
        self.theta.push(0.0);
        self.reference_twist.push(0.0);
        self.laid_twist.push(0.0);
    }

    /// Continuous feed: the first `count` nodes (laid, below the span) leave the rod.
    /// Returns the twist energy they carry out (J).
    pub fn drop_front(&mut self, rod: &Rod, count: usize) -> f64 {
        let gone = 0..count.min(self.laid().end);
        self.dropped_twist += self.laid_twist[gone.clone()].iter().sum::<f64>();
        let energy = gone.map(|i| 0.5 * self.twist_stiffness * self.laid_twist[i] * self.laid_twist[i] * rod.inv_voronoi[i]).sum();
        self.director.drain(..count);
        self.director_tangent.drain(..count);
        self.theta.drain(..count);
        self.reference_twist.drain(..count);
        self.laid_twist.drain(..count);
        self.reference_twist[0] = 0.0;
        self.held = self.held.and_then(|b| b.checked_sub(count));
        energy
    }

    /// The reference twist the transported directors give node i now (no unwrapping),
    /// for tests.
    #[cfg(test)]
    pub(crate) fn reference_twist_now(&self, tangent: &[[f64; 3]], i: usize) -> f64 {
        let u = transport(self.director[i - 1], &tangent[i - 1], &tangent[i]);
        angle_about(&u, &self.director[i], &tangent[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    fn rod_through(x: Vec<[f64; 3]>) -> Rod {
        let rest = x.windows(2).map(|w| crate::geometry::distance(&w[0], &w[1])).collect();
        let v = vec![[0.0; 3]; x.len()];
        Rod::new(x, v, rest, 1e-6, 1.0, 1e-9)
    }

    /// A quarter circle of radius r in the x-z plane rotated by `phi` about the z axis:
    /// vertical at its top node (0, 0, r), horizontal at its bottom node, n segments.
    fn quarter_circle(n: usize, r: f64, phi: f64) -> Vec<[f64; 3]> {
        (0..=n)
            .map(|k| {
                let a = FRAC_PI_2 * k as f64 / n as f64; // 0 at the bottom
                let (h, z) = (r - r * a.sin(), r - r * a.cos());
                [h * phi.cos(), h * phi.sin(), z]
            })
            .collect()
    }

    /// A rod whose positions follow `shape(s)` for s = 0..=1 in `steps` steps, the twist
    /// state carried along (bottom segment held, top held).
    fn carried(shape: impl Fn(f64) -> Vec<[f64; 3]>, steps: usize) -> (Rod, Workspace, Twist) {
        let mut rod = rod_through(shape(0.0));
        let mut twist = Twist::new(&rod, 1.0, 0.0);
        let mut ws = Workspace::new(rod.nodes());
        for k in 0..=steps {
            rod.x = shape(k as f64 / steps as f64);
            ws.update_geometry(&rod);
            ws.force.fill([0.0; 3]);
            twist.accumulate(&rod, &mut ws, true, |i| i < 2);
        }
        (rod, ws, twist)
    }

    /// Central difference (f(x + h e) − f(x − h e))/2h of `f` over the rod with node
    /// `node`'s component `c` moved, each side from a copy of `twist` and fresh geometry.
    fn central_difference(rod: &Rod, twist: &Twist, node: usize, c: usize, h: f64, f: impl Fn(&Rod, &mut Workspace, &mut Twist) -> f64) -> f64 {
        let side = |sign: f64| {
            let mut r = rod.clone();
            r.x[node][c] += sign * h;
            let mut w = Workspace::new(r.nodes());
            w.update_geometry(&r);
            f(&r, &mut w, &mut twist.clone())
        };
        (side(1.0) - side(-1.0)) / (2.0 * h)
    }

    #[test]
    fn small_angle_atan2_is_libms_within_two_ulp() {
        let mut worst = 0.0f64;
        for k in 0..=20000 {
            let y = -0.125 + 0.25 * k as f64 / 20000.0;
            for x in [1.0, 0.37, 3.0e5] {
                let (a, b) = (atan2_small(y * x, x), (y * x).atan2(x));
                worst = worst.max((a - b).abs() / (b.abs() * f64::EPSILON).max(f64::MIN_POSITIVE));
            }
        }
        assert!(worst <= 2.0, "{worst} ulp");
        assert_eq!(atan2_small(1.0, -1.0), 1.0f64.atan2(-1.0));
        assert_eq!(atan2_small(0.5, 1.0), 0.5f64.atan2(1.0));
    }

    #[test]
    fn a_turn_of_the_laid_end_twists_the_span_by_the_solid_angle_its_tangents_sweep() {
        // Rotating a quarter circle (top vertical, bottom horizontal) once about the
        // vertical: each segment's tangent runs round a circle of latitude α_j and its
        // director picks up the holonomy 2π(1 − cos α_j); the span's total reference twist
        // is the difference between its ends, 2π(cos α_top − cos α_bottom) = 2π, and with
        // both ends held Ω = 2π/ΣV. Half a turn: π.
        let n = 40;
        for (turns, expected) in [(1.0, TAU), (0.5, PI), (-1.0, -TAU)] {
            let (rod, _, twist) = carried(|s| quarter_circle(n, 0.01, turns * TAU * s), 2000);
            let span: f64 = (1..n).map(|i| 1.0 / rod.inv_voronoi[i]).sum();
            // the end segments are a chord apart from the exact vertical / horizontal
            let (ta, tb) = (FRAC_PI_2 * 0.5 / n as f64, FRAC_PI_2 * (1.0 - 0.5 / n as f64));
            let exact = expected.signum() * expected.abs() * (tb.cos() - ta.cos()).abs();
            let total = twist.twist_rate * span;
            assert!((total.abs() - exact.abs()).abs() < 1e-3 * exact.abs(), "turns {turns}: Σm = {total}, expected ±{exact}");
            assert_eq!(twist.held_segment(), Some(0));
            for (a, t) in twist.director.iter().zip(&twist.director_tangent) {
                assert!((dot(a, a) - 1.0).abs() < 1e-14 && dot(a, t).abs() < 1e-14, "director not unit and normal after 2000 transports");
            }
            assert_eq!(total.signum(), -turns.signum(), "a right-handed turn gives negative reference twist here");
        }
    }

    #[test]
    fn reference_twist_gradient_matches_finite_differences() {
        // ∂m_i/∂x on a bent, non-planar rod: carry the directors to x ± h and difference
        let base: Vec<[f64; 3]> = (0..7).map(|k| {
            let s = k as f64 * 0.3;
            [0.4 * s.sin() + 0.05 * s * s, 0.3 * (1.3 * s).cos(), s]
        }).collect();
        let rod = rod_through(base.clone());
        let twist = Twist::new(&rod, 1.0, 0.0);
        let mut ws = Workspace::new(rod.nodes());
        ws.update_geometry(&rod);
        let h = 1e-6;
        for i in 1..6 {
            let (ta, tb) = (ws.tangent[i - 1], ws.tangent[i]);
            let opc = 1.0 + dot(&ta, &tb);
            let k = cross(&ta, &tb);
            let kb = [2.0 * k[0] / opc, 2.0 * k[1] / opc, 2.0 * k[2] / opc];
            let (la, lb) = (ws.seg_len[i - 1], ws.seg_len[i]);
            for node in [i - 1, i, i + 1] {
                for c in 0..3 {
                    let fd = central_difference(&rod, &twist, node, c, h, |_, w, t| {
                        t.transport_directors(&w.tangent);
                        t.reference_twist_now(&w.tangent, i)
                    });
                    let analytic = if node == i - 1 {
                        -kb[c] / (2.0 * la)
                    } else if node == i + 1 {
                        kb[c] / (2.0 * lb)
                    } else {
                        kb[c] / (2.0 * la) - kb[c] / (2.0 * lb)
                    };
                    assert!((fd - analytic).abs() < 1e-6 * (1.0 + analytic.abs()), "node {i}, ∂/∂x_{node}[{c}]: fd {fd}, formula {analytic}");
                }
            }
        }
    }

    #[test]
    fn twist_force_is_minus_the_gradient_of_the_twist_energy() {
        // twisted by half a turn of the laid end, then E_t(x ± h) with θ in equilibrium
        let n = 12;
        let shape = |s: f64| {
            let mut x = quarter_circle(n, 0.01, 0.5 * TAU * s);
            // not planar: lift the middle a little
            x[6][1] += 1e-3 * s;
            x
        };
        let (rod, ws, twist) = carried(shape, 400);
        assert!(twist.twist_rate.abs() > 10.0, "Ω = {} rad/m: not twisted", twist.twist_rate);
        let h = 1e-8;
        for node in 1..n {
            for c in 0..3 {
                let fd = -central_difference(&rod, &twist, node, c, h, |r, w, t| {
                    t.accumulate(r, w, true, |i| i < 2);
                    t.energy(r)
                });
                let f = ws.force[node][c];
                let scale = ws.force.iter().flatten().fold(0.0f64, |a, b| a.max(b.abs()));
                assert!((fd - f).abs() < 1e-5 * scale, "node {node}[{c}]: −∂E/∂x {fd:.6e}, force {f:.6e}");
            }
        }
    }

    #[test]
    fn a_free_end_or_free_top_carries_no_twist() {
        let n = 20;
        let mut rod = rod_through(quarter_circle(n, 0.01, 0.0));
        let mut twist = Twist::new(&rod, 1.0, 0.0);
        let mut ws = Workspace::new(rod.nodes());
        for k in 0..=200 {
            rod.x = quarter_circle(n, 0.01, TAU * k as f64 / 200.0);
            ws.update_geometry(&rod);
            ws.force.fill([0.0; 3]);
            twist.accumulate(&rod, &mut ws, true, |_| false); // nothing laid: free front
            assert_eq!(twist.twist_rate, 0.0);
            assert!(ws.force.iter().flatten().all(|f| *f == 0.0));
            twist.accumulate(&rod, &mut ws, false, |i| i < 2); // feed free to spin
            assert_eq!(twist.twist_rate, 0.0);
        }
    }

    #[test]
    fn a_landing_lays_the_span_twist_down_and_keeps_the_rate() {
        // held boundary moving up by one segment: θ of the landed segment from the
        // uniform twist, so Ω and the total energy are unchanged by the landing
        let n = 16;
        let (rod, mut ws, mut twist) = carried(|s| quarter_circle(n, 0.01, TAU * s), 800);
        let (rate, energy) = (twist.twist_rate, twist.energy(&rod));
        ws.force.fill([0.0; 3]);
        twist.accumulate(&rod, &mut ws, true, |i| i < 4);
        assert_eq!(twist.held_segment(), Some(2));
        assert!((twist.twist_rate - rate).abs() < 1e-12 * rate.abs(), "{} vs {rate}", twist.twist_rate);
        assert!((twist.energy(&rod) - energy).abs() < 1e-12 * energy, "{} vs {energy}", twist.energy(&rod));
        let laid = rate * (1.0 / rod.inv_voronoi[1] + 1.0 / rod.inv_voronoi[2]);
        assert!((twist.laid_twist() - laid).abs() < 1e-12 * laid.abs(), "laid twist {} vs {laid}", twist.laid_twist());
        // lifting off again restores the longer span
        twist.accumulate(&rod, &mut ws, true, |i| i < 2);
        assert!((twist.twist_rate - rate).abs() < 1e-12 * rate.abs());
    }
}
