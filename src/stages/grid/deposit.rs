//! Depositing fibre mass on the window's cells, deterministically in parallel.
//!
//! Every contribution is an integer number of quanta (Δm/2³²) added atomically, so
//! the totals are exact integers whatever the order of the additions: the grid is
//! bit-identical for any number of threads.
use std::sync::atomic::{AtomicU64, Ordering};

use ndarray::Array2;

/// Quanta per point mass Δm.
pub const QUANTA_PER_POINT: u64 = 1 << 32;

crate::params::choice_enum! {
    /// How fibre mass reaches the cells.
    pub enum Deposit {
        /// The paper's method (§3.3): each node but the last carries Δm = ρAΔs, added to
        /// the cell containing it. Adds sampling noise when Δs ~ Δh (REFERENCE.md §2).
        #[default]
        PointMass = "point_mass",
        /// Each interval between consecutive nodes carries Δm spread uniformly along its
        /// chord, split between cells by exact clipping of the chord to the cell edges.
        SegmentClipping = "segment_clipping",
    }
}


crate::params::choice_enum! {
    /// Whether the web is evaluated as laid or folded onto a torus.
    pub enum Boundary {
        /// The web as laid (the paper): open CD edges and drift ends; the window must
        /// keep away from them.
        #[default]
        Open = "open",
        /// Positions are folded onto the torus MD [0, c·n_l·L) × CD [−n_wΔw/2, n_wΔw/2):
        /// every fibre's whole mass lands in the domain, so the density is statistically
        /// uniform (interior mean ρA/(Δw·c) exactly on average) with no edges or run-in.
        /// Not the paper's set-up; a way to get interior statistics from a smaller web.
        Periodic = "periodic",
    }
}


/// Folding of positions onto a periodic domain [origin, origin + period) per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Period {
    pub origin: [f64; 2],
    pub period: [f64; 2],
}

impl Period {
    /// Shift that brings `p` into the domain (exactly: rounding never leaves the
    /// shifted point on the far seam).
    #[inline]
    fn shift(&self, p: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for a in 0..2 {
            let rel = p[a] - self.origin[a];
            if rel < 0.0 || rel >= self.period[a] {
                let mut d = -self.period[a] * (rel / self.period[a]).floor();
                let folded = p[a] + d - self.origin[a];
                if folded >= self.period[a] {
                    d -= self.period[a];
                } else if folded < 0.0 {
                    d += self.period[a];
                }
                out[a] = d;
            }
        }
        out
    }
}

/// A square window of `cells × cells` cells of side `cell_size`, lower corner
/// (`x_min`, `y_min`); cell (i, j) covers x ∈ [x_min + iΔh, x_min + (i+1)Δh) (MD,
/// rows) and y ∈ [y_min + jΔh, …) (CD, columns). Accumulates mass in quanta.
pub struct DensityGrid {
    pub x_min: f64,
    pub y_min: f64,
    pub cell_size: f64,
    pub cells: usize,
    inverse_cell: f64,
    period: Option<Period>,
    quanta: Vec<AtomicU64>,
}

impl DensityGrid {
    pub fn new(x_min: f64, y_min: f64, cell_size: f64, cells: usize) -> Self {
        Self::try_new(x_min, y_min, cell_size, cells).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Self::new`] with the cells (8 B each) allocated fallibly.
    pub fn try_new(x_min: f64, y_min: f64, cell_size: f64, cells: usize) -> Result<Self, crate::memory::AllocError> {
        let n = cells.saturating_mul(cells);
        let mut quanta = Vec::new();
        quanta.try_reserve_exact(n).map_err(|_| crate::memory::AllocError { bytes: n.saturating_mul(8), what: "the density grid's cells".into() })?;
        quanta.extend((0..n).map(|_| AtomicU64::new(0)));
        Ok(Self { x_min, y_min, cell_size, cells, inverse_cell: 1.0 / cell_size, period: None, quanta })
    }

    /// Folds every deposit onto a periodic domain (see [`Boundary::Periodic`]); the
    /// window must lie inside the domain.
    pub fn with_period(mut self, period: Period) -> Self {
        self.period = Some(period);
        self
    }

    #[inline]
    fn add(&self, i: usize, j: usize, q: u64) {
        self.quanta[i * self.cells + j].fetch_add(q, Ordering::Relaxed);
    }

    /// Cell of a point, if inside the window.
    #[inline]
    fn cell_of(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let [u, v] = self.cell_coordinates(p);
        if self.inside([u, v]) {
            Some((u as usize, v as usize))
        } else {
            None
        }
    }

    /// Whether cell coordinates lie in the window (branch-free).
    #[inline]
    fn inside(&self, [u, v]: [f64; 2]) -> bool {
        let n = self.cells as f64;
        (u >= 0.0) & (v >= 0.0) & (u < n) & (v < n)
    }

    /// One point mass at each of `points` inside the window.
    #[inline]
    fn deposit_points(&self, points: &[[f64; 2]]) {
        for &p in points {
            if let Some((i, j)) = self.cell_of(p) {
                self.add(i, j, QUANTA_PER_POINT);
            }
        }
    }

    /// Deposits one fibre (all its nodes, see the web conventions) by `method`.
    pub fn deposit_fibre(&self, nodes: &[[f64; 2]], method: Deposit) {
        if nodes.len() < 2 {
            return;
        }
        match (method, self.period) {
            (Deposit::PointMass, None) => {
                // Most nodes of a web lie outside the window: a branch-free test of eight
                // at a time (it vectorises) passes over runs of them.
                let mut runs = nodes[..nodes.len() - 1].chunks_exact(8);
                for run in &mut runs {
                    if run.iter().fold(false, |any, &p| any | self.inside(self.cell_coordinates(p))) {
                        self.deposit_points(run);
                    }
                }
                self.deposit_points(runs.remainder());
            }
            (Deposit::PointMass, Some(period)) => {
                for &p in &nodes[..nodes.len() - 1] {
                    let d = period.shift(p);
                    if let Some((i, j)) = self.cell_of([p[0] + d[0], p[1] + d[1]]) {
                        self.add(i, j, QUANTA_PER_POINT);
                    }
                }
            }
            (Deposit::SegmentClipping, None) => {
                // Cell coordinates once per node; cheap rejection of chords whose both
                // ends lie beyond the same side of the window (almost all of them).
                let n = self.cells as f64;
                let mut a = self.cell_coordinates(nodes[0]);
                for &p in &nodes[1..] {
                    let b = self.cell_coordinates(p);
                    let outside = (a[0] < 0.0 && b[0] < 0.0)
                        || (a[0] >= n && b[0] >= n)
                        || (a[1] < 0.0 && b[1] < 0.0)
                        || (a[1] >= n && b[1] >= n);
                    if !outside {
                        self.deposit_chord_cells(a, b);
                    }
                    a = b;
                }
            }
            (Deposit::SegmentClipping, Some(period)) => {
                // Fold the chord by the shift of its start, and also by those of its end
                // (per axis) when it crosses a seam; chords are far shorter than the window.
                for w in nodes.windows(2) {
                    let (da, db) = (period.shift(w[0]), period.shift(w[1]));
                    let moved = |d: [f64; 2], p: [f64; 2]| [p[0] + d[0], p[1] + d[1]];
                    self.deposit_chord(moved(da, w[0]), moved(da, w[1]));
                    if db != da {
                        let mut shifts = [db, [da[0], db[1]], [db[0], da[1]]];
                        let mut count = 1;
                        if shifts[1] != da && shifts[1] != db {
                            count = 2;
                        }
                        if shifts[2] != da && shifts[2] != db {
                            shifts[count] = shifts[2];
                            count += 1;
                        }
                        for d in &shifts[..count] {
                            self.deposit_chord(moved(*d, w[0]), moved(*d, w[1]));
                        }
                    }
                }
            }
        }
    }

    /// Position in cell units relative to the window corner.
    #[inline]
    fn cell_coordinates(&self, p: [f64; 2]) -> [f64; 2] {
        [(p[0] - self.x_min) * self.inverse_cell, (p[1] - self.y_min) * self.inverse_cell]
    }

    /// Spreads one point mass uniformly along the chord a→b, clipped to cells.
    fn deposit_chord(&self, a: [f64; 2], b: [f64; 2]) {
        self.deposit_chord_cells(self.cell_coordinates(a), self.cell_coordinates(b));
    }

    /// As [`Self::deposit_chord`] with the ends in cell coordinates.
    fn deposit_chord_cells(&self, a: [f64; 2], b: [f64; 2]) {
        let ([ua, va], [ub, vb]) = (a, b);
        let n = self.cells as f64;
        if ua.max(ub) < 0.0 || va.max(vb) < 0.0 || ua.min(ub) >= n || va.min(vb) >= n {
            return; // bounding box outside the window
        }
        let (ia, ja, ib, jb) = (ua.floor(), va.floor(), ub.floor(), vb.floor());
        if ia == ib && ja == jb {
            self.add(ia as usize, ja as usize, QUANTA_PER_POINT); // inside one cell (and the window)
            return;
        }
        // Parameters t ∈ (0, 1) where the chord crosses cell lines (sorted), then one
        // piece per interval, assigned to the cell holding its midpoint.
        let crossings = (ib - ia).abs() as usize + (jb - ja).abs() as usize;
        let mut stack = [0.0f64; 18];
        let mut heap = Vec::new();
        let ts: &mut [f64] = if crossings + 2 <= stack.len() {
            &mut stack[..crossings + 2]
        } else {
            heap.resize(crossings + 2, 0.0);
            &mut heap
        };
        let mut count = 1; // ts[0] = 0
        for (c0, c1, p0, d) in [(ia, ib, ua, ub - ua), (ja, jb, va, vb - va)] {
            if c0 == c1 {
                continue;
            }
            let (mut line, hi) = if c0 < c1 { (c0 + 1.0, c1) } else { (c1 + 1.0, c0) };
            while line <= hi {
                ts[count] = ((line - p0) / d).clamp(0.0, 1.0);
                count += 1;
                line += 1.0;
            }
        }
        ts[count] = 1.0;
        count += 1;
        let ts = &mut ts[..count];
        ts.sort_unstable_by(|x, y| x.total_cmp(y));
        // Pieces in order; the last takes the remainder so the chord totals exactly Δm.
        let mut assigned = 0u64;
        for k in 0..count - 1 {
            let (t0, t1) = (ts[k], ts[k + 1]);
            let q = if k + 2 == count {
                QUANTA_PER_POINT - assigned
            } else {
                (((t1 - t0) * QUANTA_PER_POINT as f64).round() as u64).min(QUANTA_PER_POINT - assigned)
            };
            assigned += q;
            if q == 0 {
                continue;
            }
            let tm = 0.5 * (t0 + t1);
            let (u, v) = (ua + tm * (ub - ua), va + tm * (vb - va));
            if u >= 0.0 && v >= 0.0 && u < n && v < n {
                self.add(u as usize, v as usize, q);
            }
        }
    }

    /// Mass per cell (kg) given the point mass Δm, as an MD × CD array.
    pub fn masses(&self, point_mass: f64) -> Array2<f64> {
        let scale = point_mass / QUANTA_PER_POINT as f64;
        Array2::from_shape_fn((self.cells, self.cells), |(i, j)| {
            self.quanta[i * self.cells + j].load(Ordering::Relaxed) as f64 * scale
        })
    }

    /// Total quanta deposited (exact).
    pub fn total_quanta(&self) -> u128 {
        self.quanta.iter().map(|q| q.load(Ordering::Relaxed) as u128).sum()
    }
}
