//! Symmetric positive definite band matrices: storage, Cholesky factorisation and
//! solves in O(n p²) and O(n p) for n unknowns and half-bandwidth p.
//!
//! Used by the `implicit_bending` integrator ([`super::integrator`]): the linearised
//! bending system of a rod of N + 1 nodes has 3(N + 1) unknowns (x, y, z per node) and
//! couples node i to nodes i ± 2 (the bending stencil), so p = 3·2 + 2 = 8. A small
//! hand-written LLᵀ (no pivoting: the matrix is SPD by construction, m I + implicit
//! node terms + Δt² times a Gauss-Newton Hessian) keeps the dependency list as it is;
//! the general band solvers of the Rust linear-algebra crates are LU with pivoting or
//! need LAPACK.

/// Lower band of a symmetric n × n matrix: `band[i·(p+1) + d]` = A[i][i − d], d = 0..=p.
#[derive(Clone, Debug, Default)]
pub struct BandSym {
    pub n: usize,
    pub p: usize,
    pub band: Vec<f64>,
}

/// The factorisation met a pivot that is not positive (or not finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositiveDefinite {
    /// Row of the failing pivot.
    pub row: usize,
    pub pivot: f64,
}

impl BandSym {
    pub fn new(n: usize, p: usize) -> Self {
        BandSym { n, p, band: vec![0.0; n * (p + 1)] }
    }

    /// Resize to n × n with half-bandwidth p and set every entry to zero.
    pub fn reset(&mut self, n: usize, p: usize) {
        self.n = n;
        self.p = p;
        self.band.clear();
        self.band.resize(n * (p + 1), 0.0);
    }

    /// `A[i][j]` (either triangle); zero outside the band.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i - j > self.p {
            0.0
        } else {
            self.band[i * (self.p + 1) + (i - j)]
        }
    }

    /// `A[i][j] += a` and, by symmetry, `A[j][i]`; (i, j) must lie in the band.
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, a: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= self.p, "entry ({i}, {j}) outside half-bandwidth {}", self.p);
        self.band[i * (self.p + 1) + (i - j)] += a;
    }

    /// y = A x.
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        let (n, p) = (self.n, self.p);
        for v in y.iter_mut() {
            *v = 0.0;
        }
        for i in 0..n {
            let row = &self.band[i * (p + 1)..(i + 1) * (p + 1)];
            y[i] += row[0] * x[i];
            for d in 1..=p.min(i) {
                let a = row[d];
                y[i] += a * x[i - d];
                y[i - d] += a * x[i];
            }
        }
    }

    /// Replace row and column `i` by those of the identity and move the column's
    /// contribution x_i = `value` to the right-hand side `b` (a Dirichlet condition that
    /// keeps the matrix symmetric); `b[i] = value`.
    pub fn fix(&mut self, i: usize, value: f64, b: &mut [f64]) {
        let (n, p) = (self.n, self.p);
        for j in i.saturating_sub(p)..(i + p + 1).min(n) {
            if j != i {
                let a = self.get(i, j);
                b[j] -= a * value;
                let (r, c) = if i >= j { (i, j) } else { (j, i) };
                self.band[r * (p + 1) + (r - c)] = 0.0;
            }
        }
        self.band[i * (p + 1)] = 1.0;
        b[i] = value;
    }

    /// In-place Cholesky A = L Lᵀ; the band then holds L.
    pub fn cholesky(&mut self) -> Result<(), NotPositiveDefinite> {
        let (n, p) = (self.n, self.p);
        let w = p + 1;
        for i in 0..n {
            let j0 = i.saturating_sub(p);
            for j in j0..=i {
                // s = A[i][j] − Σ_k L[i][k] L[j][k], k from max(i, j) − p.. j
                let mut s = self.band[i * w + (i - j)];
                let k0 = j0.max(j.saturating_sub(p));
                for k in k0..j {
                    s -= self.band[i * w + (i - k)] * self.band[j * w + (j - k)];
                }
                if j == i {
                    if !(s > 0.0) || !s.is_finite() {
                        return Err(NotPositiveDefinite { row: i, pivot: s });
                    }
                    self.band[i * w] = s.sqrt();
                } else {
                    self.band[i * w + (i - j)] = s / self.band[j * w];
                }
            }
        }
        Ok(())
    }

    /// Solve L Lᵀ x = b in place (after [`Self::cholesky`]).
    pub fn solve_factored(&self, b: &mut [f64]) {
        let (n, p) = (self.n, self.p);
        let w = p + 1;
        for i in 0..n {
            let mut s = b[i];
            for k in i.saturating_sub(p)..i {
                s -= self.band[i * w + (i - k)] * b[k];
            }
            b[i] = s / self.band[i * w];
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for k in i + 1..(i + p + 1).min(n) {
                s -= self.band[k * w + (k - i)] * b[k];
            }
            b[i] = s / self.band[i * w];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random SPD band matrix: random symmetric in-band entries and a diagonal that
    /// dominates them (Gershgorin).
    fn random_spd(rng: &mut ChaCha8Rng, n: usize, p: usize) -> BandSym {
        let mut a = BandSym::new(n, p);
        for i in 0..n {
            for j in i.saturating_sub(p)..i {
                a.add(i, j, rng.random_range(-1.0..1.0));
            }
        }
        for i in 0..n {
            let off: f64 = (0..n).filter(|&j| j != i).map(|j| a.get(i, j).abs()).sum();
            a.add(i, i, off + rng.random_range(0.1..2.0));
        }
        a
    }

    /// Cholesky solve against the product: A x = b is recovered to round-off for band
    /// matrices of several sizes and bandwidths (p = 0, 1, 8 and p ≥ n), and a Dirichlet
    /// row fixes its unknown while the others solve the reduced system.
    #[test]
    fn cholesky_solves_band_systems() {
        let mut rng = ChaCha8Rng::seed_from_u64(15);
        for (n, p) in [(1, 0), (5, 0), (7, 1), (30, 8), (303, 8), (4, 8)] {
            let a = random_spd(&mut rng, n, p);
            let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut b = vec![0.0; n];
            a.mul(&x, &mut b);
            let mut f = a.clone();
            f.cholesky().unwrap();
            f.solve_factored(&mut b);
            let err = x.iter().zip(&b).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
            assert!(err < 1e-12, "n {n}, p {p}: error {err:e}");
        }
        // Dirichlet: fix x_3 = 0.7 in a 30 × 30, p = 8 system
        let a = random_spd(&mut rng, 30, 8);
        let x: Vec<f64> = (0..30).map(|i| if i == 3 { 0.7 } else { rng.random_range(-1.0..1.0) }).collect();
        let mut b = vec![0.0; 30];
        a.mul(&x, &mut b);
        let mut f = a.clone();
        b[3] = 123.0; // whatever row 3 said is replaced by x_3 = 0.7
        f.fix(3, 0.7, &mut b);
        f.cholesky().unwrap();
        f.solve_factored(&mut b);
        let err = x.iter().zip(&b).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "Dirichlet row: error {err:e}");
    }

    /// An indefinite matrix is reported with the failing row, never a NaN solution.
    #[test]
    fn indefinite_matrix_is_reported() {
        let mut a = BandSym::new(3, 1);
        a.add(0, 0, 1.0);
        a.add(1, 0, 2.0);
        a.add(1, 1, 1.0);
        a.add(2, 2, 1.0);
        let err = a.cholesky().unwrap_err();
        assert_eq!(err.row, 1);
        assert!(err.pivot < 0.0);
    }
}
