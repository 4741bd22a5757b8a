//! Rigid belt plane z = 0 moving at belt_speed along +x: unilateral contact and
//! Coulomb friction as velocity-level impulses, node by node (the plane couples
//! no nodes to each other).
//!
//! For a node that would end the step below the plane (z + Δt v_z ≤ 0):
//! - normal: v_z ← −z/Δt, so the node lands exactly on z = 0 (perfectly inelastic);
//!   the normal impulse per unit mass is p_n = v_z,new − v_z ≥ 0;
//! - friction (Coulomb μ): with w the tangential velocity relative to the belt, if
//!   |w| ≤ μ p_n the node sticks (tangential velocity set to the belt's, exactly);
//!   otherwise it slips and the impulse is μ p_n opposite w. With μ = 0 the node slides freely.
//!
//! In the projection schemes the axial force comes from the projection, after this
//! step: the contact and stick tests then add the previous projection's force on the
//! node (one step lag), so that fibre tension can lift or pull a laid node loose. The
//! velocities predicted for fibre contact ([`super::Simulator::predict_velocities`])
//! leave it out.
//!
//! In the projection schemes the contact state also restricts the node's
//! effective inverse mass in the length projection: a sticking node is fixed, a
//! sliding one keeps only its in-plane freedom.

use super::state::{sym_inverse_xy, NodeContact, Rod, Workspace};

#[derive(Clone, Debug)]
pub struct BeltContact {
    pub belt_speed: f64,
    /// Coulomb μ; None = frictionless contact (friction effect off).
    pub friction: Option<f64>,
}

impl BeltContact {
    /// Apply contact and friction to the velocities of the nodes in `nodes` (clamped
    /// and driven nodes are excluded). Their work is booked by the integrator, from the
    /// belt's whole reaction over the step ([`super::integrator`], "Work").
    /// Nodes with `supported[i]` set (held up by another fibre in this step, see
    /// [`super::fibre_contact`]) are left alone. `segment_force` (projection schemes):
    /// the last projection's axial force P_k of each segment, compression positive; the
    /// tests add the lagged force it puts on each node, P_{i−1} t_{i−1} − P_i t_i.
    #[allow(clippy::too_many_arguments)]
    pub fn apply(&self, rod: &mut Rod, ws: &mut Workspace, dt: f64, nodes: std::ops::Range<usize>, restrict_w: bool, segment_force: Option<&[f64]>, supported: &[bool]) {
        let vb = self.belt_speed;
        let idt = 1.0 / dt;
        let segments = rod.rest.len();
        for i in nodes {
            if supported.get(i).copied().unwrap_or(false) {
                continue;
            }
            let z = rod.x[i][2];
            let v = rod.v[i];
            let m = rod.mass[i];
            // In the projection schemes the axial force is not in v yet: the contact and
            // stick tests use the last projection's force on the node (lagged), so that
            // fibre tension can lift or pull a laid node loose.
            let lag_along = |j: usize| match segment_force {
                Some(p) => {
                    let mut f = 0.0;
                    if i > 0 {
                        f += p[i - 1] * ws.tangent[i - 1][j];
                    }
                    if i < segments {
                        f -= p[i] * ws.tangent[i][j];
                    }
                    f
                }
                None => 0.0,
            };
            let h = dt / m;
            let vz_test = v[2] + h * lag_along(2);
            if z + dt * vz_test > 0.0 {
                continue;
            }
            let lag = [lag_along(0), lag_along(1)];
            let vz = -z * idt;
            let pn = (vz - vz_test).max(0.0);
            let mut state = NodeContact::Slide;
            let mut vt = [v[0], v[1]];
            if let Some(mu) = self.friction {
                let w = [v[0] - vb + h * lag[0], v[1] + h * lag[1]];
                let wn = (w[0] * w[0] + w[1] * w[1]).sqrt();
                let limit = mu * pn;
                if wn <= limit {
                    vt = [vb, 0.0];
                    state = NodeContact::Stick;
                } else {
                    let s = limit / wn;
                    vt = [v[0] - s * w[0], v[1] - s * w[1]];
                }
            }
            rod.v[i] = [vt[0], vt[1], vz];
            ws.contact[i] = state;
            if restrict_w {
                ws.winv[i] = match state {
                    NodeContact::Stick => [0.0; 6],
                    _ => sym_inverse_xy(&ws.amat[i]).unwrap_or([0.0; 6]),
                };
            }
        }
    }
}
