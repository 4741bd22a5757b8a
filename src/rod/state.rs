//! Discrete rod: node positions and velocities, lumped masses, rest lengths, and the
//! per-step workspace (segment geometry, nodal forces, implicit matrices).

/// State and constant properties of the discretised fibre.
#[derive(Clone, Debug)]
pub struct Rod {
    /// Node positions (m), N + 1 nodes.
    pub x: Vec<[f64; 3]>,
    /// Node velocities (m/s).
    pub v: Vec<[f64; 3]>,
    /// Lumped node masses ρA·(Voronoi length) (kg): ends carry half an element.
    pub mass: Vec<f64>,
    /// Rest lengths of the N segments (m).
    pub rest: Vec<f64>,
    /// 1 / Voronoi rest length of each node (interior nodes; ends unused).
    pub inv_voronoi: Vec<f64>,
    /// EA (N).
    pub axial_stiffness: f64,
    /// EI (N·m²).
    pub bending_stiffness: f64,
    /// Shortest rest length (m) and largest inverse node mass (1/kg).
    pub min_rest: f64,
    pub max_inv_mass: f64,
}

impl Rod {
    /// Rod through `x` with rest lengths equal to `rest`.
    pub fn new(x: Vec<[f64; 3]>, v: Vec<[f64; 3]>, rest: Vec<f64>, mass_per_length: f64, ea: f64, ei: f64) -> Self {
        let n = x.len();
        assert!(n >= 2 && v.len() == n && rest.len() == n - 1);
        let mut mass = vec![0.0; n];
        let mut inv_voronoi = vec![0.0; n];
        for (k, l0) in rest.iter().enumerate() {
            mass[k] += 0.5 * mass_per_length * l0;
            mass[k + 1] += 0.5 * mass_per_length * l0;
        }
        for i in 1..n - 1 {
            inv_voronoi[i] = 2.0 / (rest[i - 1] + rest[i]);
        }
        let mut rod = Rod { x, v, mass, rest, inv_voronoi, axial_stiffness: ea, bending_stiffness: ei, min_rest: 0.0, max_inv_mass: 0.0 };
        rod.refresh_bounds();
        rod
    }

    /// Recompute `min_rest` and `max_inv_mass` after nodes were added or removed.
    pub fn refresh_bounds(&mut self) {
        self.min_rest = self.rest.iter().cloned().fold(f64::INFINITY, f64::min);
        self.max_inv_mass = self.mass.iter().map(|m| 1.0 / m).fold(0.0, f64::max);
    }

    pub fn nodes(&self) -> usize {
        self.x.len()
    }

    pub fn kinetic_energy(&self) -> f64 {
        self.v.iter().zip(&self.mass).map(|(v, m)| 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])).sum()
    }
}

/// Contact state of a node during one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeContact {
    Free,
    /// On the belt, sliding (friction at its Coulomb limit) or frictionless.
    Slide,
    /// On the belt, moving with it.
    Stick,
}

/// Scratch arrays reused every step (no allocation in the time loop).
#[derive(Clone, Debug)]
pub struct Workspace {
    pub force: Vec<[f64; 3]>,
    /// Symmetric nodal matrix m I + implicit terms, [xx, yy, zz, xy, xz, yz].
    pub amat: Vec<[f64; 6]>,
    pub rhs: Vec<[f64; 3]>,
    /// Drag matrix G per node (for the drag work), zero when drag is off.
    pub drag_g: Vec<[f64; 6]>,
    /// Σ_e G_e v_air,e per node with an air field (empty otherwise): the drag's
    /// right-hand side, kept for its power.
    pub drag_gva: Vec<[f64; 3]>,
    /// Unit tangents and lengths of the segments at the current positions.
    pub tangent: Vec<[f64; 3]>,
    pub seg_len: Vec<f64>,
    /// Effective inverse mass of each node for the constraint projection.
    pub winv: Vec<[f64; 6]>,
    pub x_old: Vec<[f64; 3]>,
    pub contact: Vec<NodeContact>,
    /// Velocities at the start of the step (for the work of the constraint reactions, and
    /// `implicit_bending`); filled only while the work ledger is on or with that scheme.
    pub v_start: Vec<[f64; 3]>,
    /// Σ λ e per segment over the step's projections: the segment pushes its end nodes
    /// by ±(this)/Δt (N·s) (for the reactions on the held nodes); booked only while the
    /// work ledger is on.
    pub lambda_e: Vec<[f64; 3]>,
    // tridiagonal solver buffers (one entry per segment)
    pub seg_e: Vec<[f64; 3]>,
    pub cons: Vec<f64>,
    pub cprime: Vec<f64>,
    pub lambda: Vec<f64>,
    pub lambda_acc: Vec<f64>,
    pub we_prev: Vec<[f64; 3]>,
    pub we_next: Vec<[f64; 3]>,
    // `implicit_bending` only (sized on first use): Δt² H (the Gauss-Newton bending
    // Hessian), the system matrix, its right-hand side / solution, the node-wise
    // predictor's velocities and Δt² H v' per node (for the reactions)
    pub bend_h: super::banded::BandSym,
    pub bend_k: super::banded::BandSym,
    pub bend_b: Vec<f64>,
    pub v_pred: Vec<[f64; 3]>,
    pub bend_impl: Vec<[f64; 3]>,
    /// First node of the implicit bending system (the nodes before it are held on the
    /// belt or clamped); the next step starts from it.
    pub bend_first: usize,
}

impl Workspace {
    pub fn new(nodes: usize) -> Self {
        let s = nodes - 1;
        Workspace {
            force: vec![[0.0; 3]; nodes],
            amat: vec![[0.0; 6]; nodes],
            rhs: vec![[0.0; 3]; nodes],
            drag_g: vec![[0.0; 6]; nodes],
            drag_gva: Vec::new(),
            tangent: vec![[0.0; 3]; s],
            seg_len: vec![0.0; s],
            winv: vec![[0.0; 6]; nodes],
            x_old: vec![[0.0; 3]; nodes],
            contact: vec![NodeContact::Free; nodes],
            v_start: vec![[0.0; 3]; nodes],
            lambda_e: vec![[0.0; 3]; s],
            seg_e: vec![[0.0; 3]; s],
            cons: vec![0.0; s],
            cprime: vec![0.0; s],
            lambda: vec![0.0; s],
            lambda_acc: vec![0.0; s],
            we_prev: vec![[0.0; 3]; nodes],
            we_next: vec![[0.0; 3]; nodes],
            bend_h: Default::default(),
            bend_k: Default::default(),
            bend_b: Vec::new(),
            v_pred: Vec::new(),
            bend_impl: Vec::new(),
            bend_first: 0,
        }
    }

    /// Size for `nodes` nodes, as [`Workspace::new`] but keeping the allocations (the
    /// continuous feed changes the node count every few steps; every step writes these
    /// arrays before it reads them). `bend_first`, the one entry carried from step to
    /// step, starts again from 0, as in a new workspace.
    pub fn resize(&mut self, nodes: usize) {
        let s = nodes - 1;
        for v in [&mut self.force, &mut self.rhs, &mut self.x_old, &mut self.v_start, &mut self.we_prev, &mut self.we_next] {
            v.resize(nodes, [0.0; 3]);
        }
        for v in [&mut self.amat, &mut self.drag_g, &mut self.winv] {
            v.resize(nodes, [0.0; 6]);
        }
        self.contact.resize(nodes, NodeContact::Free);
        for v in [&mut self.tangent, &mut self.lambda_e, &mut self.seg_e] {
            v.resize(s, [0.0; 3]);
        }
        for v in [&mut self.seg_len, &mut self.cons, &mut self.cprime, &mut self.lambda, &mut self.lambda_acc] {
            v.resize(s, 0.0);
        }
        self.bend_first = 0;
    }

    /// Segment lengths and unit tangents of the rod's current positions.
    pub fn update_geometry(&mut self, rod: &Rod) {
        for k in 0..rod.rest.len() {
            let (p, q) = (rod.x[k], rod.x[k + 1]);
            let e = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            let il = if l > 0.0 { 1.0 / l } else { 0.0 };
            self.seg_len[k] = l;
            self.tangent[k] = [e[0] * il, e[1] * il, e[2] * il];
        }
    }
}

/// Inverse of a symmetric 3×3 [xx, yy, zz, xy, xz, yz]; None if singular.
#[inline]
pub fn sym_inverse(a: &[f64; 6]) -> Option<[f64; 6]> {
    let [xx, yy, zz, xy, xz, yz] = *a;
    let c00 = yy * zz - yz * yz;
    let c11 = xx * zz - xz * xz;
    let c22 = xx * yy - xy * xy;
    let c01 = xz * yz - xy * zz;
    let c02 = xy * yz - xz * yy;
    let c12 = xy * xz - xx * yz;
    let det = xx * c00 + xy * c01 + xz * c02;
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    let id = 1.0 / det;
    Some([c00 * id, c11 * id, c22 * id, c01 * id, c02 * id, c12 * id])
}

/// Inverse of the x-y block of a symmetric 3×3, embedded with zero z row/column.
#[inline]
pub fn sym_inverse_xy(a: &[f64; 6]) -> Option<[f64; 6]> {
    let det = a[0] * a[1] - a[3] * a[3];
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    let id = 1.0 / det;
    Some([a[1] * id, a[0] * id, 0.0, -a[3] * id, 0.0, 0.0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rod::forces::sym_mul;

    #[test]
    fn inverse_of_symmetric() {
        let a = [3.0, 2.0, 4.0, 0.5, -0.3, 0.7];
        let ai = sym_inverse(&a).unwrap();
        for e in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            let r = sym_mul(&a, &sym_mul(&ai, &e));
            for k in 0..3 {
                assert!((r[k] - e[k]).abs() < 1e-14);
            }
        }
    }
}
