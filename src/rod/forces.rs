//! Force terms. Each enabled effect is one [`Term`], built once per replicate; the
//! integrator loops over the list, so a disabled effect costs nothing.
//!
//! Terms contribute either an explicit nodal force (elasticity, gravity) or a
//! linear, node-diagonal implicit part (drag, oscillator, Rayleigh damping). A
//! linear implicit force F = −G (v' − v_target) − K (x + Δt v' − x_target) adds
//! Δt G + Δt² K to the nodal 3×3 matrix and Δt G v_target − Δt K (x − x_target)
//! to the right-hand side of (m I + …) v' = m v + Δt F_explicit + …. Treating these
//! implicitly means the oscillator damper (c/m ≈ 5·10⁵ 1/s) and the drag of thin
//! fibres never limit the step.

use super::air::ImpingingAir;
use super::state::{Rod, Workspace};

/// Exponent of Re in the tangential skin-friction law, C_t = β Re^-0.61 (eq 2).
pub const TANGENTIAL_RE_EXPONENT: f64 = 0.61;
/// Fitted normal drag law C_n = A Re^-b (d/d0)^c of eq 4 (d = 13-390 µm).
pub const NORMAL_DRAG_A: f64 = 6.96;
pub const NORMAL_DRAG_B: f64 = 0.440;
pub const NORMAL_DRAG_C: f64 = 0.404;
pub const NORMAL_DRAG_D0: f64 = 78e-6;

/// Tangential skin-friction coefficient C_t = β Re_t^-0.61 (eq 2).
pub fn tangential_drag_coefficient(reynolds: f64, beta: f64) -> f64 {
    beta * reynolds.powf(-TANGENTIAL_RE_EXPONENT)
}

/// Normal drag coefficient C_n = 6.96 Re_n^-0.44 (d/78 µm)^0.404 (eq 4).
pub fn normal_drag_coefficient(reynolds: f64, diameter: f64) -> f64 {
    NORMAL_DRAG_A * reynolds.powf(-NORMAL_DRAG_B) * (diameter / NORMAL_DRAG_D0).powf(NORMAL_DRAG_C)
}

/// Air-drag law of the fibre (eqs 1-4) written as f = K |V|^p, which tends to 0
/// smoothly as Re → 0 (no division by Re, no NaN).
#[derive(Clone, Copy, Debug)]
pub struct DragLaw {
    /// f_t = k_t |V_t|^(2−0.61): k_t = ½ π d ρ_a β (d/ν)^-0.61 (eqs 1-2).
    pub k_tangential: f64,
    /// f_n = k_n |V_n|^(2−0.44): k_n = ½ d ρ_a 6.96 (d/ν)^-0.44 (d/d0)^0.404 (eqs 3-4).
    pub k_normal: f64,
}

impl DragLaw {
    pub fn new(diameter: f64, air_density: f64, viscosity: f64, beta: f64) -> Self {
        let dn = diameter / viscosity;
        DragLaw {
            k_tangential: 0.5 * std::f64::consts::PI * diameter * air_density * beta * dn.powf(-TANGENTIAL_RE_EXPONENT),
            k_normal: 0.5
                * diameter
                * air_density
                * NORMAL_DRAG_A
                * dn.powf(-NORMAL_DRAG_B)
                * (diameter / NORMAL_DRAG_D0).powf(NORMAL_DRAG_C),
        }
    }
    /// Tangential drag per unit length (N/m) for a relative tangential speed |V_t| (eq 1).
    pub fn tangential(&self, speed: f64) -> f64 {
        self.k_tangential * speed.abs().powf(2.0 - TANGENTIAL_RE_EXPONENT)
    }
    /// Normal drag per unit length (N/m) for a relative normal speed |V_n| (eq 3).
    pub fn normal(&self, speed: f64) -> f64 {
        self.k_normal * speed.abs().powf(2.0 - NORMAL_DRAG_B)
    }
    /// Speed at which the tangential drag carries a load q per unit length: f_t(V) = q.
    pub fn tangential_terminal_speed(&self, load_per_length: f64) -> f64 {
        (load_per_length / self.k_tangential).powf(1.0 / (2.0 - TANGENTIAL_RE_EXPONENT))
    }
    /// Speed at which the normal drag carries a load q per unit length: f_n(V) = q.
    pub fn normal_terminal_speed(&self, load_per_length: f64) -> f64 {
        (load_per_length / self.k_normal).powf(1.0 / (2.0 - NORMAL_DRAG_B))
    }
}

/// Drag in the laydown zone, per element, split into the tangential part (eqs 1-2)
/// and the normal part (eqs 3-4).
///
/// The normal force is applied along the normal relative velocity V_n with
/// magnitude f_n(|V_n|), not per normal direction n1, n2 as in the paper's VDLOAD:
/// for a round fibre the force must not depend on the (arbitrary) choice of n1, n2
/// (frame invariance about the axis). Both agree whenever V_n lies along n1 or n2; for
/// an oblique V_n at 45° to n1 the per-direction sum is smaller by 1 − 2^(−0.28) ≈ 18 %.
#[derive(Clone, Debug)]
pub struct Drag {
    pub law: DragLaw,
    /// Air velocity (0, 0, −V_air) of the uniform field.
    pub air_velocity: [f64; 3],
    /// Opt-in air field near the belt ([`super::air`]): when set, the air velocity is
    /// evaluated at each element's midpoint instead of `air_velocity`.
    pub field: Option<ImpingingAir>,
    /// Top of the zone z0; the zone is 0 ≤ z ≤ z0 for an element's midpoint.
    pub zone_top: f64,
}

/// Oscillator of eq 7: nodes above z0 are tied in x and y to the dummy point
/// (0, u0 sin(ωt + φ)) by a spring k and a damper c per node. The paper's single fibre
/// has φ = 0; in a laid web each fibre has its own turbulence phase.
#[derive(Clone, Debug)]
pub struct Oscillation {
    pub amplitude: f64,
    pub angular_frequency: f64,
    /// Phase φ (rad).
    pub phase: f64,
    pub stiffness: f64,
    pub damping: f64,
    pub zone_top: f64,
    /// Soft start T_r (s): the amplitude grows as u0 (1 − cos(π t/T_r))/2 until T_r
    /// (0: full amplitude from t = 0, the paper's scene).
    pub ramp_time: f64,
}

impl Oscillation {
    /// Position u and velocity du/dt of the dummy point's y at time t.
    fn dummy_point(&self, t: f64) -> (f64, f64) {
        let (s, c) = (self.angular_frequency * t + self.phase).sin_cos();
        let (u, du) = (self.amplitude * s, self.amplitude * self.angular_frequency * c);
        if t >= self.ramp_time {
            return (u, du);
        }
        let k = std::f64::consts::PI / self.ramp_time;
        let (rs, rc) = (k * t).sin_cos();
        let (r, dr) = (0.5 * (1.0 - rc), 0.5 * k * rs);
        (r * u, r * du + dr * u)
    }
}

#[derive(Clone, Debug)]
pub enum Term {
    /// Axial springs EA (l − l0)/l0 (explicit integrator only).
    Axial,
    /// Discrete elastic rod bending (no twist).
    Bending,
    Gravity { g: f64 },
    Drag(Drag),
    Oscillation(Oscillation),
    /// Rayleigh mass damping F = −α m v.
    Damping { alpha: f64 },
}

impl Term {
    pub fn name(&self) -> &'static str {
        match self {
            Term::Axial => "axial",
            Term::Bending => "bending",
            Term::Gravity { .. } => "gravity",
            Term::Drag(_) => "drag",
            Term::Oscillation(_) => "oscillation",
            Term::Damping { .. } => "damping",
        }
    }

    /// Add this term's contribution for the step t → t + dt.
    /// Needs `ws.tangent`/`ws.seg_len` filled for the current positions.
    pub fn accumulate(&self, rod: &Rod, ws: &mut Workspace, t: f64, dt: f64) {
        match self {
            Term::Axial => axial_forces(rod, ws),
            Term::Bending => bending_forces(rod, ws),
            Term::Gravity { g } => {
                for (f, m) in ws.force.iter_mut().zip(&rod.mass) {
                    f[2] -= m * g;
                }
            }
            Term::Damping { alpha } => {
                for (a, m) in ws.amat.iter_mut().zip(&rod.mass) {
                    let h = dt * alpha * m;
                    a[0] += h;
                    a[1] += h;
                    a[2] += h;
                }
            }
            Term::Drag(d) => drag_implicit(d, rod, ws, dt),
            Term::Oscillation(o) => {
                let (u, du) = o.dummy_point(t + dt);
                let h = dt * o.damping + dt * dt * o.stiffness;
                for i in 0..rod.x.len() {
                    if rod.x[i][2] > o.zone_top {
                        let a = &mut ws.amat[i];
                        a[0] += h;
                        a[1] += h;
                        let r = &mut ws.rhs[i];
                        r[0] += -dt * o.stiffness * rod.x[i][0];
                        r[1] += dt * o.damping * du - dt * o.stiffness * (rod.x[i][1] - u);
                    }
                }
            }
        }
    }

    /// Power delivered by this term's force at the end-of-step velocities (W), for the
    /// energy diagnostics. Explicit elastic terms return 0 (they are in the elastic energy).
    pub fn power(&self, rod: &Rod, ws: &Workspace, t: f64) -> f64 {
        match self {
            Term::Axial | Term::Bending => 0.0,
            Term::Gravity { g } => rod.v.iter().zip(&rod.mass).map(|(v, m)| -m * g * v[2]).sum(),
            Term::Damping { alpha } => {
                rod.v.iter().zip(&rod.mass).map(|(v, m)| -alpha * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])).sum()
            }
            Term::Drag(d) if d.field.is_some() => {
                // F_i = −G_i v_i + Σ_e G_e v_air(midpoint e), the force drag_implicit applied
                let mut p = 0.0;
                for ((g, gva), v) in ws.drag_g.iter().zip(&ws.drag_gva).zip(&rod.v) {
                    let gv = sym_mul(g, v);
                    let f = [gv[0] - gva[0], gv[1] - gva[1], gv[2] - gva[2]];
                    p -= f[0] * v[0] + f[1] * v[1] + f[2] * v[2];
                }
                p
            }
            Term::Drag(d) => {
                let mut p = 0.0;
                for (g, v) in ws.drag_g.iter().zip(&rod.v) {
                    let w = [v[0] - d.air_velocity[0], v[1] - d.air_velocity[1], v[2] - d.air_velocity[2]];
                    let f = sym_mul(g, &w);
                    p -= f[0] * v[0] + f[1] * v[1] + f[2] * v[2];
                }
                p
            }
            Term::Oscillation(o) => {
                let (u, du) = o.dummy_point(t);
                let mut p = 0.0;
                for (x, v) in rod.x.iter().zip(&rod.v) {
                    if x[2] > o.zone_top {
                        let fx = -o.stiffness * x[0] - o.damping * v[0];
                        let fy = -o.stiffness * (x[1] - u) - o.damping * (v[1] - du);
                        p += fx * v[0] + fy * v[1];
                    }
                }
                p
            }
        }
    }
}

/// x^p for x ≥ 0 and 0 < p < 1, exactly 0 at x = 0 so the drag vanishes smoothly as
/// Re → 0. Computed as exp(p ln x) with short series (relative error < 1e-9, about
/// three times cheaper than `powf`); arguments outside [1e-200, 1e200] use `powf`.
#[inline]
pub fn pow_pos(x: f64, p: f64) -> f64 {
    if !(x > 1e-200 && x < 1e200) {
        return if x > 0.0 { x.powf(p) } else { 0.0 };
    }
    use std::f64::consts::{LN_2, SQRT_2};
    // x = m 2^k with m in [√½, √2)
    let bits = x.to_bits();
    let mut k = ((bits >> 52) & 0x7ff) as i64 - 1023;
    let mut m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    if m > SQRT_2 {
        m *= 0.5;
        k += 1;
    }
    let y = p * (ln_mantissa(m) + k as f64 * LN_2);
    // exp(y) = 2^n exp(r), |r| ≤ ln2/2
    // round to nearest without a libm call (|y/ln2| < 2^51)
    let n = (y * (1.0 / LN_2) + MAGIC) - MAGIC;
    let r = y - n * LN_2;
    exp_reduced(r) * f64::from_bits(((n as i64 + 1023) as u64) << 52)
}

/// 1.5·2⁵²: adding it rounds to an integer held in the low mantissa bits.
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// ln m for m in [√½, √2): 2 atanh(s), s = (m − 1)/(m + 1), |s| < 0.172.
#[inline(always)]
fn ln_mantissa(m: f64) -> f64 {
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    2.0 * s * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0 + s2 * (1.0 / 11.0))))))
}

/// exp(r) for |r| ≤ ln2/2: Taylor polynomial of degree 9 (truncation < 3e-11), Estrin's
/// scheme for short dependency chains.
#[inline(always)]
fn exp_reduced(r: f64) -> f64 {
    let r2 = r * r;
    let r4 = r2 * r2;
    let a0 = 1.0 + r;
    let a1 = 0.5 + r * (1.0 / 6.0);
    let a2 = 1.0 / 24.0 + r * (1.0 / 120.0);
    let a3 = 1.0 / 720.0 + r * (1.0 / 5040.0);
    let a4 = 1.0 / 40_320.0 + r * (1.0 / 362_880.0);
    (a0 + r2 * a1) + r4 * ((a2 + r2 * a3) + r4 * a4)
}

/// [`pow_pos`] of `L` values at once, the same operations in the same order (so the same
/// bits), without branches so that the loop vectorises: the mantissa fold and the exponent
/// and 2ⁿ conversions are selects and exact bit tricks (2⁵² + i holds i in its low
/// mantissa bits). Values outside [1e-200, 1e200] are redone by [`pow_pos`].
#[inline(always)]
pub fn pow_pos_lanes<const L: usize>(x: &[f64; L], p: f64) -> [f64; L] {
    use std::f64::consts::{LN_2, SQRT_2};
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    let mut out = [0.0; L];
    let mut outside = false;
    for l in 0..L {
        let xv = x[l];
        outside |= !(xv > 1e-200 && xv < 1e200);
        let bits = xv.to_bits();
        let m0 = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
        let fold = m0 > SQRT_2;
        let m = if fold { m0 * 0.5 } else { m0 };
        // k + 1023 = the biased exponent (+ 1 after the fold), exactly as a double
        let biased = ((bits >> 52) & 0x7ff) + fold as u64;
        let k = f64::from_bits(0x4330_0000_0000_0000 | biased) - (TWO_52 + 1023.0);
        let y = p * (ln_mantissa(m) + k * LN_2);
        let t = y * (1.0 / LN_2) + MAGIC;
        let n = t - MAGIC;
        // 2ⁿ: t's low mantissa bits hold n (two's complement), so n + 1023 shifted into
        // the exponent field
        out[l] = exp_reduced(y - n * LN_2) * f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
    }
    if outside {
        for l in 0..L {
            if !(x[l] > 1e-200 && x[l] < 1e200) {
                out[l] = pow_pos(x[l], p);
            }
        }
    }
    out
}

/// y = S x for a symmetric 3×3 stored as [xx, yy, zz, xy, xz, yz].
#[inline]
pub fn sym_mul(s: &[f64; 6], x: &[f64; 3]) -> [f64; 3] {
    [
        s[0] * x[0] + s[3] * x[1] + s[4] * x[2],
        s[3] * x[0] + s[1] * x[1] + s[5] * x[2],
        s[4] * x[0] + s[5] * x[1] + s[2] * x[2],
    ]
}

/// Axial springs: T = EA (l − l0)/l0 along each segment.
fn axial_forces(rod: &Rod, ws: &mut Workspace) {
    let ea = rod.axial_stiffness;
    for k in 0..rod.rest.len() {
        let t = ws.tangent[k];
        let tension = ea * (ws.seg_len[k] - rod.rest[k]) / rod.rest[k];
        let f = [tension * t[0], tension * t[1], tension * t[2]];
        let a = &mut ws.force[k];
        a[0] += f[0];
        a[1] += f[1];
        a[2] += f[2];
        let b = &mut ws.force[k + 1];
        b[0] -= f[0];
        b[1] -= f[1];
        b[2] -= f[2];
    }
}

/// Lower bound on 1 + cos φ in the bending energy (φ → π is a fold-back).
pub(super) const MIN_ONE_PLUS_COS: f64 = 1e-2;

/// Discrete-elastic-rod bending (Bergou et al. 2008) of an isotropic rod without twist.
///
/// At interior node i with unit tangents t_a, t_b of the adjacent segments and
/// c = cos φ = t_a·t_b, the curvature binormal has |κb| = 2 tan(φ/2) and the energy is
/// V_i = EI |κb|²/(2 V_i) = (2 EI/V_i)(1 − c)/(1 + c), V_i the Voronoi (rest) length,
/// which tends to EI φ²/(2 V_i) = ½ EI κ² V_i, the discrete form of eq 6. For an
/// isotropic rod twist does not enter this energy; its force on the centreline is the
/// opt-in [`super::twist`].
fn bending_forces(rod: &Rod, ws: &mut Workspace) {
    let ei = rod.bending_stiffness;
    let n = rod.x.len();
    if n < 3 {
        return;
    }
    // F_{i-1} += g dc/da, F_i += g (dc/db − dc/da), F_{i+1} −= g dc/db, in this order;
    // node i's sum is finished at node i + 1 (`pending`: F_i before its last term, the
    // next node's g dc/da), so each force is read and written once
    let f = &mut ws.force;
    let mut pending = f[0];
    let mut db_prev = [0.0; 3];
    for i in 1..n - 1 {
        let ta = ws.tangent[i - 1];
        let tb = ws.tangent[i];
        let la = ws.seg_len[i - 1];
        let lb = ws.seg_len[i];
        let c = ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2];
        let opc = (1.0 + c).max(MIN_ONE_PLUS_COS);
        // dV/dc
        let g = -4.0 * ei * rod.inv_voronoi[i] / (opc * opc);
        // dc/da = (t_b − c t_a)/|a|, dc/db = (t_a − c t_b)/|b|
        let ga = g / la;
        let gb = g / lb;
        let da = [ga * (tb[0] - c * ta[0]), ga * (tb[1] - c * ta[1]), ga * (tb[2] - c * ta[2])];
        let db = [gb * (ta[0] - c * tb[0]), gb * (ta[1] - c * tb[1]), gb * (ta[2] - c * tb[2])];
        let mut here = f[i];
        for k in 0..3 {
            pending[k] += da[k];
            if i >= 2 {
                here[k] -= db_prev[k];
            }
            here[k] += db[k] - da[k];
        }
        f[i - 1] = pending;
        pending = here;
        db_prev = db;
    }
    f[n - 2] = pending;
    for k in 0..3 {
        f[n - 1][k] -= db_prev[k];
    }
}

/// Curvature binormal κb = 2 t_a × t_b/(1 + t_a·t_b) at an interior node (Bergou et al.
/// 2008; |κb| = 2 tan(φ/2)) and its Jacobians J_a = ∂κb/∂e_a, J_b = ∂κb/∂e_b with respect
/// to the two edge vectors (row-major 3 × 3, `J[r][c]` = ∂κb_r/∂e_c), from the unit tangents
/// and lengths: with D = 1 + c, P_a = I − t_a t_aᵀ,
/// `J_a = (1/l_a) [−(2/D) [t_b]× P_a − κb (t_b − c t_a)ᵀ/D]`,
/// `J_b = (1/l_b) [ (2/D) [t_a]× P_b − κb (t_a − c t_b)ᵀ/D]`
/// (`[t]× y = t × y`). D is kept above the fold-back clamp of the energy.
pub fn curvature_binormal_jacobian(ta: [f64; 3], tb: [f64; 3], la: f64, lb: f64) -> ([f64; 3], [[f64; 3]; 3], [[f64; 3]; 3]) {
    let c = ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2];
    let d = (1.0 + c).max(MIN_ONE_PLUS_COS);
    let cross = [ta[1] * tb[2] - ta[2] * tb[1], ta[2] * tb[0] - ta[0] * tb[2], ta[0] * tb[1] - ta[1] * tb[0]];
    let kb = [2.0 * cross[0] / d, 2.0 * cross[1] / d, 2.0 * cross[2] / d];
    let skew = |t: [f64; 3]| [[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]];
    let jac = |s: f64, tt: [f64; 3], tn: [f64; 3], l: f64| {
        // (1/l) [s (2/D) [tt]× (I − tn tnᵀ) − κb (tt − c tn)ᵀ/D]
        let k = skew(tt);
        let g = [tt[0] - c * tn[0], tt[1] - c * tn[1], tt[2] - c * tn[2]];
        let mut j = [[0.0; 3]; 3];
        for r in 0..3 {
            // row r of [tt]× P = k[r] − (k[r]·tn) tnᵀ
            let kt = k[r][0] * tn[0] + k[r][1] * tn[1] + k[r][2] * tn[2];
            for q in 0..3 {
                j[r][q] = (s * 2.0 / d * (k[r][q] - kt * tn[q]) - kb[r] * g[q] / d) / l;
            }
        }
        j
    };
    (kb, jac(-1.0, tb, ta, la), jac(1.0, ta, tb, lb))
}

/// Half-bandwidth of the 3(N + 1)-unknown bending system (node i couples to i ± 2).
pub const BENDING_BAND: usize = 8;

/// Adds `scale` times the Gauss-Newton Hessian of the bending energy, Σ_i (EI/V_i) G_iᵀ G_i
/// with G_i = ∂κb_i/∂(x_{i−1}, x_i, x_{i+1}) = [−J_a, J_a − J_b, J_b], to `h` (unknown
/// 3j + k is component k of node j). The energy is (EI/2V_i)|κb_i|², so this is its exact
/// Hessian less the term in κb·∂²κb, which vanishes on a straight rod (where it is the
/// fourth difference EI/Δs³ D4 on the normal displacements) and is O(κΔs) relative on a
/// resolved one; it is positive semi-definite at any configuration, so m I + Δt² H stays
/// positive definite whatever the step. `tangent`, `seg_len`: the segments' unit
/// tangents and lengths at the rod's positions ([`Workspace::update_geometry`]).
/// Only nodes `first`.. are unknowns (unknown 3(j − first) + k), and only the bending
/// terms whose three nodes are among them are added.
pub fn add_bending_gauss_newton(rod: &Rod, tangent: &[[f64; 3]], seg_len: &[f64], first: usize, scale: f64, h: &mut super::banded::BandSym) {
    let ei = rod.bending_stiffness;
    for i in (first + 1).max(1)..rod.x.len() - 1 {
        let (_, ja, jb) = curvature_binormal_jacobian(tangent[i - 1], tangent[i], seg_len[i - 1], seg_len[i]);
        // G (3 × 9)
        let mut g = [[0.0; 9]; 3];
        for r in 0..3 {
            for q in 0..3 {
                g[r][q] = -ja[r][q];
                g[r][3 + q] = ja[r][q] - jb[r][q];
                g[r][6 + q] = jb[r][q];
            }
        }
        let w = scale * ei * rod.inv_voronoi[i];
        let base = 3 * (i - 1 - first);
        for a in 0..9 {
            for b in 0..=a {
                let v = g[0][a] * g[0][b] + g[1][a] * g[1][b] + g[2][a] * g[2][b];
                if v != 0.0 {
                    h.add(base + a, base + b, w * v);
                }
            }
        }
    }
}

/// Bending energy Σ (2 EI/V_i)(1 − c)/(1 + c) (J).
pub fn bending_energy_of(rod: &Rod, ws: &Workspace) -> f64 {
    let ei = rod.bending_stiffness;
    let mut e = 0.0;
    for i in 1..rod.x.len() - 1 {
        let ta = ws.tangent[i - 1];
        let tb = ws.tangent[i];
        let c = ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2];
        e += 2.0 * ei * rod.inv_voronoi[i] * (1.0 - c) / (1.0 + c).max(MIN_ONE_PLUS_COS);
    }
    e
}

/// Axial energy Σ ½ EA (l − l0)²/l0 (J).
pub fn axial_energy_of(rod: &Rod, ws: &Workspace) -> f64 {
    rod.rest.iter().zip(&ws.seg_len).map(|(l0, l)| 0.5 * rod.axial_stiffness * (l - l0) * (l - l0) / l0).sum()
}

/// Length and unit tangent of segment k (as [`Workspace::update_geometry`]).
fn segment(rod: &Rod, k: usize) -> (f64, [f64; 3]) {
    let (p, q) = (rod.x[k], rod.x[k + 1]);
    let e = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    let il = if l > 0.0 { 1.0 / l } else { 0.0 };
    (l, [e[0] * il, e[1] * il, e[2] * il])
}

/// Elastic energy held by one segment's axial spring and one node's bending term (J):
/// the terms of [`axial_energy_of`] and [`bending_energy_of`], from the positions, for
/// the energy that nodes entering or leaving the rod carry ([`super::integrator::Work::transport`]).
pub fn axial_energy_at(rod: &Rod, k: usize) -> f64 {
    let (l, l0) = (segment(rod, k).0, rod.rest[k]);
    0.5 * rod.axial_stiffness * (l - l0) * (l - l0) / l0
}

/// See [`axial_energy_at`]; 0 at an end node.
pub fn bending_energy_at(rod: &Rod, i: usize) -> f64 {
    if i == 0 || i + 1 >= rod.x.len() {
        return 0.0;
    }
    let (ta, tb) = (segment(rod, i - 1).1, segment(rod, i).1);
    let c = ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2];
    2.0 * rod.bending_stiffness * rod.inv_voronoi[i] * (1.0 - c) / (1.0 + c).max(MIN_ONE_PLUS_COS)
}

/// Drag, linearised implicitly: on each element in the zone, with V the relative
/// velocity of its midpoint, F = −l [γ_t t tᵀ + γ_n (I − t tᵀ)] (v − v_air) with
/// γ_t = f_t/|V_t| = k_t |V_t|^0.39 and γ_n = k_n |V_n|^0.56 (eqs 1-4), split half to each node.
/// With an air field ([`Drag::field`]) v_air is the field at the element's midpoint and
/// each node's right-hand side gets Σ_e G_e v_air,e (kept in `ws.drag_gva` for the power);
/// the uniform field runs the code it always ran (G summed, then times v_air).
fn drag_implicit(d: &Drag, rod: &Rod, ws: &mut Workspace, dt: f64) {
    crate::simd::widest_isa!(
        generic: drag_lanes(d, rod, ws, dt),
        avx2: drag_avx2(d, rod, ws, dt),
        avx512: drag_avx512(d, rod, ws, dt),
    )
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn drag_avx512(d: &Drag, rod: &Rod, ws: &mut Workspace, dt: f64) {
    drag_lanes(d, rod, ws, dt)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn drag_avx2(d: &Drag, rod: &Rod, ws: &mut Workspace, dt: f64) {
    drag_lanes(d, rod, ws, dt)
}

/// Elements whose drag coefficients are computed together (the power laws of eqs 1-4
/// are most of the drag's cost, and vectorise across elements).
const DRAG_LANES: usize = 8;

/// The drag (eqs 1-4) as [`drag_implicit`] applies it, element speeds first, then the
/// normal speeds' square roots and the power laws [`DRAG_LANES`] at a time
/// ([`pow_pos_lanes`], the same bits as one at a time).
#[inline(always)]
fn drag_lanes(d: &Drag, rod: &Rod, ws: &mut Workspace, dt: f64) {
    let uniform = d.air_velocity;
    let field = d.field.as_ref();
    for g in ws.drag_g.iter_mut() {
        *g = [0.0; 6];
    }
    if field.is_some() {
        // allocated on first use: a uniform-field scene does not carry it
        ws.drag_gva.clear();
        ws.drag_gva.resize(rod.x.len(), [0.0; 3]);
    }
    let elements = rod.rest.len();
    for first in (0..elements).step_by(DRAG_LANES) {
        // Relative air speeds along (|v_t|) and across (v_n) each element; 1 where an
        // element is outside the drag zone (not used).
        let (mut inside, mut air, mut along, mut across2) = ([false; DRAG_LANES], [[0.0; 3]; DRAG_LANES], [1.0; DRAG_LANES], [1.0; DRAG_LANES]);
        for l in 0..DRAG_LANES.min(elements - first) {
            let k = first + l;
            let (p, q) = (rod.x[k], rod.x[k + 1]);
            let zm = 0.5 * (p[2] + q[2]);
            if !(0.0..=d.zone_top).contains(&zm) {
                continue;
            }
            inside[l] = true;
            air[l] = match field {
                Some(f) => f.velocity(&[0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), zm]),
                None => uniform,
            };
            let va = air[l];
            let t = ws.tangent[k];
            let (a, b) = (rod.v[k], rod.v[k + 1]);
            let w = [0.5 * (a[0] + b[0]) - va[0], 0.5 * (a[1] + b[1]) - va[1], 0.5 * (a[2] + b[2]) - va[2]];
            let vt = w[0] * t[0] + w[1] * t[1] + w[2] * t[2];
            let wn = [w[0] - vt * t[0], w[1] - vt * t[1], w[2] - vt * t[2]];
            along[l] = vt.abs();
            across2[l] = wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2];
        }
        if !inside.contains(&true) {
            // all above the zone (the hanging part of the fibre): no power laws to compute
            continue;
        }
        let across = across2.map(f64::sqrt);
        let tangential = pow_pos_lanes(&along, 1.0 - TANGENTIAL_RE_EXPONENT);
        let normal = pow_pos_lanes(&across, 1.0 - NORMAL_DRAG_B);
        for l in 0..DRAG_LANES.min(elements - first) {
            if !inside[l] {
                continue;
            }
            let k = first + l;
            let t = ws.tangent[k];
            let gt = d.law.k_tangential * tangential[l];
            let gn = d.law.k_normal * normal[l];
            let h = 0.5 * ws.seg_len[k];
            let dg = (gt - gn) * h;
            let gnh = gn * h;
            let s = [
                gnh + dg * t[0] * t[0],
                gnh + dg * t[1] * t[1],
                gnh + dg * t[2] * t[2],
                dg * t[0] * t[1],
                dg * t[0] * t[2],
                dg * t[1] * t[2],
            ];
            for node in [k, k + 1] {
                let g = &mut ws.drag_g[node];
                for j in 0..6 {
                    g[j] += s[j];
                }
            }
            if field.is_some() {
                let sv = sym_mul(&s, &air[l]);
                for node in [k, k + 1] {
                    let r = &mut ws.drag_gva[node];
                    r[0] += sv[0];
                    r[1] += sv[1];
                    r[2] += sv[2];
                }
            }
        }
    }
    for i in 0..rod.x.len() {
        let g = ws.drag_g[i];
        if g[0] == 0.0 && g[1] == 0.0 && g[2] == 0.0 {
            continue;
        }
        let a = &mut ws.amat[i];
        for j in 0..6 {
            a[j] += dt * g[j];
        }
        let gv = if field.is_some() { ws.drag_gva[i] } else { sym_mul(&g, &uniform) };
        let r = &mut ws.rhs[i];
        r[0] += dt * gv[0];
        r[1] += dt * gv[1];
        r[2] += dt * gv[2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_laws_in_lanes_are_the_scalar_ones_bit_for_bit() {
        // Speeds over 40 decades, the fold at √2 and its neighbours, and the values the
        // lanes hand back to pow_pos (0, tiny, huge, NaN).
        let mut x: Vec<f64> = (0..20_000).map(|i| 10f64.powf(-20.0 + 40.0 * i as f64 / 20_000.0)).collect();
        let root2 = std::f64::consts::SQRT_2;
        x.extend([root2, f64::from_bits(root2.to_bits() + 1), f64::from_bits(root2.to_bits() - 1), 1.0, 0.5, 2.0]);
        x.extend([0.0, 1e-250, 1e250, f64::NAN, f64::INFINITY, 3e-200, 1e-200, 1e200]);
        while !x.len().is_multiple_of(8) {
            x.push(1.0);
        }
        for p in [1.0 - TANGENTIAL_RE_EXPONENT, 1.0 - NORMAL_DRAG_B, 0.5] {
            for chunk in x.chunks_exact(8) {
                let lanes = pow_pos_lanes(&<[f64; 8]>::try_from(chunk).unwrap(), p);
                for (l, &v) in chunk.iter().enumerate() {
                    assert_eq!(lanes[l].to_bits(), pow_pos(v, p).to_bits(), "x = {v:e}, p = {p}");
                }
            }
        }
    }

    #[test]
    fn drag_law_matches_equations() {
        let (d, rho, nu, beta) = (50e-6, 1.2, 1.51e-5, 0.37);
        let law = DragLaw::new(d, rho, nu, beta);
        for v in [0.1, 1.0, 7.0] {
            let re = v * d / nu;
            let ft = 0.5 * std::f64::consts::PI * d * rho * tangential_drag_coefficient(re, beta) * v * v;
            let fnn = 0.5 * d * rho * normal_drag_coefficient(re, d) * v * v;
            assert!((law.tangential(v) - ft).abs() < 1e-12 * ft.max(1e-30));
            assert!((law.normal(v) - fnn).abs() < 1e-12 * fnn.max(1e-30));
        }
        assert_eq!(law.tangential(0.0), 0.0);
        for x in [1e-250, 1e-12, 0.003, 0.7, 1.0, 1.4143, 9.99, 123.4, 5e7] {
            for p in [0.39, 0.56] {
                let (a, b) = (pow_pos(x, p), x.powf(p));
                assert!((a - b).abs() <= 1e-9 * b, "{x}^{p}: {a} vs {b}");
            }
        }
        assert_eq!(pow_pos(0.0, 0.39), 0.0);
        assert_eq!(law.normal(0.0), 0.0);
    }

    /// The soft start: the dummy point starts at rest at y = 0, its velocity is the
    /// derivative of its position (central difference), and it joins u0 sin(ωt + φ)
    /// without a jump at T_r.
    #[test]
    fn oscillation_ramp_starts_at_rest_and_joins_smoothly() {
        let o = Oscillation { amplitude: 0.01, angular_frequency: 62.8, phase: 1.0, stiffness: 1.0, damping: 1e-3, zone_top: 0.05, ramp_time: 0.1 };
        assert_eq!(o.dummy_point(0.0), (0.0, 0.0));
        for t in [0.01, 0.05, 0.0999, 0.1001, 0.3] {
            let h = 1e-7;
            let fd = (o.dummy_point(t + h).0 - o.dummy_point(t - h).0) / (2.0 * h);
            assert!((fd - o.dummy_point(t).1).abs() < 1e-6, "t = {t}: du {} vs {fd}", o.dummy_point(t).1);
        }
        let full = Oscillation { ramp_time: 0.0, ..o.clone() };
        assert_eq!(o.dummy_point(0.1), full.dummy_point(0.1));
        assert!((o.dummy_point(0.1 - 1e-9).0 - full.dummy_point(0.1).0).abs() < 1e-9);
    }
}
