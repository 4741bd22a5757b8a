//! Contact between many rods advanced together ([`ContactWorld`]): the broad phase,
//! and the lock-step driver.
//!
//! Every `interval` Δt_c, [`ContactWorld::run_interval`] lets each body freeze what has
//! settled, then gives each rod its [`FibreContact`] obstacles (the segments of the other
//! rods, and every frozen laid segment, its own included) with each own segment's
//! candidates. Rods that can touch in the interval (a segment of one is a candidate of
//! the other, or through a chain of such rods) form a cluster; each cluster advances in
//! lock step to the end of the interval, every step the smallest any of its rods asks
//! for, and the clusters advance side by side, each rod of a lone cluster at its own
//! step. Before each step every rod predicts the
//! velocities v* it will reach without fibre contact (forces, the implicit update and
//! the belt: [`Simulator::predict_velocities`]), and every rod's copies of the other
//! rods' segments are refreshed with their positions and v* (a node resting on another
//! fibre is seen at its current velocity instead: its v* would carry it into the fibre
//! that holds it, and a fibre lying on it would sink by that much; Jacobi: within a step a
//! rod sees the others move as they would without it, and judges a pair's approach as
//! the other rod does; which of the two yields is in
//! [`super::fibre_contact::yield_share`]). Seen at their start-of-step velocities, two
//! fibres accelerated by the drag passed through each other
//! (`fibres_colliding_in_the_air_stay_one_diameter_apart`). The clusters, and the rods of
//! a large cluster, step in parallel and only read what was refreshed, so the result
//! does not depend on the thread count; the step reuses the forces of its prediction.
//!
//! Spatial hashing keeps the cost proportional to the local neighbour count: the
//! simulated segments go into a 3-D grid rebuilt at each preparation, each spread over
//! the cells of its bounding box grown by its reach, 2 |v| Δt_c + d/2 (twice the
//! motion its velocity predicts over the interval); the frozen segments go once into a
//! 2-D grid in belt coordinates (x − v_b t, y), where they never move. Two segments are
//! candidates when their grown boxes overlap. The cross direction may be periodic
//! (period P): cells wrap and an obstacle is the image of the segment nearest to the
//! own segment, per candidate pair (a rod spanning more than a period can meet one
//! segment in two images: each image used is an obstacle of its own).
//!
//! A rod whose step fails even at the smallest size takes its cluster with it: each rod
//! of a cluster keeps a checkpoint at the start of the interval ([`ContactBody::checkpoint`]),
//! and when one fails they all go back to it and retake the interval with the recovery
//! scheme ([`super::recovery`]; the fibres could have touched, so none may keep a state
//! the others no longer see). When a rod has no rollback left it stops, and the others
//! go on.
//!
//! Segments above [`ContactWorld::contact_top`] take no part (set it to the laydown
//! height z0: above it eq 7's oscillator prescribes where each fibre is, and two
//! prescribed positions cannot give way to each other).
//!
//! A rod collides with its own frozen stretch, except the two frozen segments next to
//! the simulated part ([`SELF_GAP`]). With [`ContactWorld::self_contact`] (opt-in) it also
//! collides with its own simulated segments [`SELF_GAP`] or more apart along it, as with
//! another fibre: a coil landing on the fibre's own laid loops that are not yet frozen
//! rests on them. Without it the fibre goes through those loops (the crossed pairs within
//! fibres that `examples/laid_web_contact.rs` counts; `pipelines/studies/PHYSICAL_WEBS.md`,
//! "A fibre against its own laid loops", measures both).

use super::fibre_contact::{FibreContact, ObstacleSegment, SELF_GAP};
use super::integrator::Simulator;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

/// A frozen segment in belt coordinates.
#[derive(Clone, Copy, Debug)]
struct Frozen {
    a: [f64; 3],
    b: [f64; 3],
    fibre: u32,
    /// Index of the segment along its fibre's frozen chain.
    index: u32,
}

/// A simulated segment at the preparation time.
#[derive(Clone, Copy, Debug)]
struct Active {
    a: [f64; 3],
    b: [f64; 3],
    va: [f64; 3],
    vb: [f64; 3],
    fibre: u32,
    /// Index of the segment in its rod (u32::MAX: the link to the frozen stretch).
    segment: u32,
    held: bool,
    /// Whether each end has landed.
    landed: [bool; 2],
    /// Reach per axis, 2 |v − w| Δt_c (w the reference velocity).
    reach: [f64; 3],
}

/// Frozen segments and the settings shared by all rods of a web.
pub struct ContactWorld {
    /// d (m).
    pub diameter: f64,
    /// μ_ff; None: frictionless.
    pub friction: Option<f64>,
    /// v_b along +x (m/s).
    pub belt_speed: f64,
    /// Cross-direction period P (m); None: not periodic.
    pub cd_period: Option<f64>,
    /// CD offset of each rod's own frame in the world (m): rod f's y is y_world − offset
    /// (each fibre of a web is simulated under its own feed point). Zero by default.
    pub cd_offsets: Vec<f64>,
    /// Height above which segments take no part in contact (m): where eq 7's oscillator
    /// prescribes each fibre's position (z > z0), two prescribed positions cannot give
    /// way to each other. Infinite by default.
    pub contact_top: f64,
    /// Whether a rod collides with its own simulated segments (module docs); off by
    /// default.
    pub self_contact: bool,
    /// Grid cell side h (m).
    cell: f64,
    /// CD cells per period (when periodic) and their side.
    cd_cells: i64,
    cd_cell: f64,
    frozen: Vec<Frozen>,
    frozen_grid: FxHashMap<(i64, i64), Vec<u32>>,
    /// Grid of the simulated segments, rebuilt at each preparation.
    active_grid: FxHashMap<(i64, i64, i64), Vec<u32>>,
    /// Highest frozen node above the belt (m).
    frozen_top: f64,
    /// Per fibre: frozen nodes so far and the last one (belt coordinates).
    frozen_count: Vec<usize>,
    last_frozen: Vec<Option<[f64; 3]>>,
}

/// A rod that takes part in contact, advanced by its own step control.
pub trait ContactBody: Send + Sync {
    fn simulator(&self) -> &Simulator;
    fn simulator_mut(&mut self) -> &mut Simulator;
    /// The step it would take next (s).
    fn next_step(&self) -> f64;
    /// Advance to `until` (one or more steps); does nothing once it has failed.
    fn advance_to(&mut self, until: f64);
    /// Whether it still runs (not failed).
    fn running(&self) -> bool;
    /// Prepare the next step, to `until` at most: what must happen before it (a fed rod
    /// adds its new top node), then the velocities before contact it will reach, kept
    /// in its [`FibreContact`] for the other rods to see.
    fn predict(&mut self, until: f64) {
        self.before_step();
        let dt = self.next_step().min(until - self.simulator().t);
        let sim = self.simulator_mut();
        let Some(mut contact) = sim.fibre_contact.take() else { return };
        let mut predicted = std::mem::take(&mut contact.predicted);
        let (mut free_v, mut free_w) = (std::mem::take(&mut contact.free_velocities), std::mem::take(&mut contact.free_mobility));
        let ok = sim.predict_velocities(dt, &mut predicted, Some((&mut free_v, &mut free_w))).is_ok();
        contact.predicted = predicted;
        (contact.free_velocities, contact.free_mobility) = (free_v, free_w);
        contact.predicted_at = ok.then_some(sim.t);
        // the holds every solve of this step's contacts judges shares on
        contact.settle_holds(&sim.landing_time, &sim.rod, sim.t);
        sim.fibre_contact = Some(contact);
    }
    /// What must happen before each step (a fed rod adds its new top node).
    fn before_step(&mut self) {}
    /// Keep the state now, the start of an interval, to go back to if a rod it can touch
    /// fails in it (a rod that cannot go back keeps nothing).
    fn checkpoint(&mut self) {}
    /// Whether it can go back to its checkpoint ([`super::recovery`]: rollbacks left).
    fn can_roll_back(&self) -> bool {
        false
    }
    /// Go back to the checkpoint, running again if it had failed, and retake the stretch
    /// past `failed_at` (s), where a rod it can touch failed, with the recovery scheme.
    /// Called only when [`Self::can_roll_back`].
    fn roll_back(&mut self, _failed_at: f64) {}
    /// The farthest downstream (m, lab frame) this body's touchdown point (its last laid
    /// node along the fibre) has been at any preparation so far; −∞ if it lays none.
    /// Called at each preparation, before [`Self::freeze`]; it notes the touchdown point then.
    fn landing_reach(&mut self) -> f64 {
        f64::NEG_INFINITY
    }
    /// Freeze what has settled; append the nodes newly frozen, in fibre order, in belt
    /// coordinates (x − v_b t_freeze, y, z). `landing_front` is the farthest downstream
    /// touchdown point of any body of the world so far ([`Self::landing_reach`]): nothing
    /// lands beyond it.
    fn freeze(&mut self, _frozen: &mut Vec<[f64; 3]>, _landing_front: f64) {}
}

/// A rod with its step control and nothing else (falling fibres in tests and examples).
pub struct FreeRod {
    pub sim: Simulator,
    pub control: super::integrator::StepControl,
    pub error: Option<String>,
}

impl FreeRod {
    pub fn new(sim: Simulator, mass_per_length: f64) -> Self {
        let control = super::integrator::StepControl::new(sim.limits.chosen, mass_per_length);
        FreeRod { sim, control, error: None }
    }
}

impl ContactBody for FreeRod {
    fn simulator(&self) -> &Simulator {
        &self.sim
    }
    fn simulator_mut(&mut self) -> &mut Simulator {
        &mut self.sim
    }
    fn next_step(&self) -> f64 {
        self.control.dt
    }
    fn advance_to(&mut self, until: f64) {
        while self.error.is_none() && self.sim.t < until - until.abs() * 1e-12 {
            if let Err(e) = self.control.advance(&mut self.sim, until) {
                self.error = Some(e.to_string());
            }
        }
    }
    fn running(&self) -> bool {
        self.error.is_none()
    }
}

/// Cost counters of the contact work.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// Preparations (intervals); Σ over them of the clusters of rods that can touch
    /// (rods of different clusters step on their own); Σ over the clusters of the steps
    /// they took in lock step.
    pub preparations: u64,
    pub clusters: u64,
    pub lock_steps: u64,
    /// Σ over preparations of the simulated segments and of the candidate pairs.
    pub active_segments: u64,
    pub candidate_pairs: u64,
    /// Wall time in freezing, the broad phase and the clustering (s), not in the rods'
    /// steps and refreshes.
    pub wall_seconds: f64,
}

impl ContactWorld {
    /// A world of `fibres` rods with no frozen segment yet. `cell` is the grid side
    /// (about an element length).
    pub fn new(fibres: usize, diameter: f64, friction: Option<f64>, belt_speed: f64, cd_period: Option<f64>, cell: f64) -> Self {
        let (cd_cells, cd_cell) = match cd_period {
            Some(p) => {
                let n = (p / cell).floor().max(1.0);
                (n as i64, p / n)
            }
            None => (0, cell),
        };
        ContactWorld {
            diameter,
            friction,
            belt_speed,
            cd_period,
            cell,
            cd_cells,
            cd_cell,
            frozen: Vec::new(),
            frozen_grid: FxHashMap::default(),
            active_grid: FxHashMap::default(),
            frozen_top: f64::NEG_INFINITY,
            frozen_count: vec![0; fibres],
            last_frozen: vec![None; fibres],
            cd_offsets: vec![0.0; fibres],
            contact_top: f64::INFINITY,
            self_contact: false,
        }
    }

    /// Append frozen nodes of `fibre`, in fibre order, in belt coordinates of the rod's
    /// frame (x − v_b t_freeze, y, z); they join the fibre's frozen chain.
    pub fn add_frozen(&mut self, fibre: usize, nodes: &[[f64; 3]]) {
        let r = 0.5 * self.diameter;
        let offset = self.cd_offsets[fibre];
        for &x in nodes {
            let x = [x[0], x[1] + offset, x[2]];
            self.frozen_top = self.frozen_top.max(x[2]);
            if let Some(a) = self.last_frozen[fibre] {
                let id = self.frozen.len() as u32;
                let index = self.frozen_count[fibre] as u32 - 1;
                self.frozen.push(Frozen { a, b: x, fibre: fibre as u32, index });
                let (lo, hi) = bbox(a, x, [r; 3]);
                let keys: Vec<(i64, i64)> = self.cells_2d(lo, hi).collect();
                for key in keys {
                    self.frozen_grid.entry(key).or_default().push(id);
                }
            }
            self.last_frozen[fibre] = Some(x);
            self.frozen_count[fibre] += 1;
        }
    }

    /// One interval [t, t_next] of stepping with contact (see the module docs): freeze,
    /// search, then each cluster of rods in lock step, the clusters side by side.
    pub fn run_interval<B: ContactBody>(&mut self, bodies: &mut [B], t: f64, t_next: f64, stats: &mut ContactStats) {
        let clock = std::time::Instant::now();
        let mut frozen = Vec::new();
        let landing_front = bodies.iter_mut().map(|b| b.landing_reach()).fold(f64::NEG_INFINITY, f64::max);
        for (f, body) in bodies.iter_mut().enumerate() {
            frozen.clear();
            body.freeze(&mut frozen, landing_front);
            self.add_frozen(f, &frozen);
        }
        let (segments, pairs) = self.prepare(t, t_next - t, bodies);
        stats.preparations += 1;
        stats.active_segments += segments as u64;
        stats.candidate_pairs += pairs as u64;
        let cluster_of = clusters(bodies);
        let count = cluster_of.iter().max().map_or(0, |&c| c + 1);
        stats.clusters += count as u64;
        stats.wall_seconds += clock.elapsed().as_secs_f64();
        // each rod's place in its cluster; a cluster's rods in fibre order
        let mut local = vec![0usize; bodies.len()];
        let mut groups: Vec<Vec<&mut B>> = (0..count).map(|_| Vec::new()).collect();
        for (f, body) in bodies.iter_mut().enumerate() {
            local[f] = groups[cluster_of[f]].len();
            groups[cluster_of[f]].push(body);
        }
        let steps: u64 = groups.par_iter_mut().map(|group| lock_step(group, &local, t, t_next, self.contact_top)).sum();
        stats.lock_steps += steps;
    }

    /// Give every running rod its obstacles and candidates for the interval
    /// [t, t + interval]. Returns (simulated segments, candidate pairs).
    pub fn prepare<B: ContactBody>(&mut self, t: f64, interval: f64, bodies: &mut [B]) -> (usize, usize) {
        let vb = self.belt_speed;
        let belt = [vb, 0.0, 0.0];
        let half_d = 0.5 * self.diameter;
        // simulated segments, and each rod's first segment index among them
        let mut active: Vec<Active> = Vec::new();
        let mut first: Vec<usize> = Vec::with_capacity(bodies.len() + 1);
        for (f, body) in bodies.iter().enumerate() {
            first.push(active.len());
            if !body.running() {
                continue;
            }
            let sim = body.simulator();
            let free = sim.free_nodes();
            let (x, v) = (&sim.rod.x, &sim.rod.v);
            let offset = self.cd_offsets[f];
            let world = |p: [f64; 3]| [p[0], p[1] + offset, p[2]];
            let w = [0.0; 3]; // reach measured in the lab frame
            if let Some(l) = self.last_frozen[f] {
                // the link from the last frozen node to the first (held) simulated one
                let a = [l[0] + vb * t, l[1], l[2]];
                let reach = reach(belt, belt, w, interval);
                active.push(Active { a, b: world(x[0]), va: belt, vb: v[0], fibre: f as u32, segment: u32::MAX, held: true, landed: [true; 2], reach });
            }
            for k in 0..x.len() - 1 {
                let held = !free.contains(&k) && !free.contains(&(k + 1));
                let reach = reach(v[k], v[k + 1], w, interval);
                let landed = [rests_on_web(sim, k), rests_on_web(sim, k + 1)];
                active.push(Active { a: world(x[k]), b: world(x[k + 1]), va: v[k], vb: v[k + 1], fibre: f as u32, segment: k as u32, held, landed, reach });
            }
        }
        first.push(active.len());
        // the cells keep their lists from the last preparation (cleared, not freed): the
        // hanging fibres fill the same cells interval after interval
        let mut grid = std::mem::take(&mut self.active_grid);
        for (id, s) in active.iter().enumerate() {
            let (lo, hi) = bbox(s.a, s.b, add(s.reach, half_d));
            if lo[2] > self.contact_top {
                continue;
            }
            for key in self.cells_3d(lo, hi) {
                grid.entry(key).or_default().push(id as u32);
            }
        }
        let in_cell = |key: (i64, i64, i64)| grid.get(&key).into_iter().flatten().copied();
        let frozen_top = self.frozen_top + self.diameter;
        let pairs: usize = bodies
            .par_iter_mut()
            .enumerate()
            .map(|(f, body)| {
                if !body.running() {
                    return 0;
                }
                let sim = body.simulator_mut();
                let mut contact = sim.fibre_contact.take().unwrap_or_else(|| FibreContact::new(self.diameter, self.friction));
                contact.diameter = self.diameter;
                contact.friction = self.friction;
                contact.clear();
                contact.world = f as u32;
                let own_link = usize::from(self.last_frozen[f].is_some());
                let own_frozen = self.frozen_count[f];
                // (row, obstacle key): key < active.len() a simulated segment, else frozen
                let mut found: Vec<(u32, u32)> = Vec::new();
                let mut seen: Vec<u32> = Vec::new();
                for k in first[f] + own_link..first[f + 1] {
                    let row = (k - first[f] - own_link) as u32;
                    let s = &active[k];
                    let (lo, hi) = bbox(s.a, s.b, add(s.reach, half_d));
                    seen.clear();
                    if lo[2] > self.contact_top {
                        continue;
                    }
                    for key in self.cells_3d(lo, hi) {
                        for o in in_cell(key) {
                            let other = &active[o as usize];
                            let apart = other.fibre as usize != f || (self.self_contact && apart_along_rod(row as usize, other.segment));
                            if apart && self.overlap(lo, hi, other.a, other.b, add(other.reach, half_d)) {
                                seen.push(o);
                            }
                        }
                    }
                    if lo[2] <= frozen_top {
                        // in belt coordinates the frozen segments stand still
                        let (mut flo, mut fhi) = bbox(s.a, s.b, add(reach(s.va, s.vb, belt, interval), half_d));
                        flo[0] -= vb * t;
                        fhi[0] -= vb * t;
                        for key in self.cells_2d(flo, fhi) {
                            if let Some(ids) = self.frozen_grid.get(&key) {
                                for &o in ids {
                                    let z = &self.frozen[o as usize];
                                    let adjacent = z.fibre as usize == f && z.index as usize + SELF_GAP >= own_frozen;
                                    if !adjacent && self.overlap(flo, fhi, z.a, z.b, [half_d; 3]) {
                                        seen.push(active.len() as u32 + o);
                                    }
                                }
                            }
                        }
                    }
                    seen.sort_unstable();
                    seen.dedup();
                    found.extend(seen.iter().map(|&o| (row, o)));
                }
                // obstacles in the rod's own frame; cd_shift carries a simulated
                // source's frame into it (its offset, then the periodic image)
                let own = self.cd_offsets[f];
                let obstacle = |key: u32| {
                    if (key as usize) < active.len() {
                        let o = &active[key as usize];
                        let source = (o.segment != u32::MAX).then_some((o.fibre, o.segment));
                        let local = |p: [f64; 3]| [p[0], p[1] - own, p[2]];
                        let cd_shift = self.cd_offsets[o.fibre as usize] - own;
                        ObstacleSegment { a: local(o.a), b: local(o.b), va: o.va, vb: o.vb, t_ref: t, simulated: !o.held, landed: o.landed, source, cd_shift }
                    } else {
                        let z = &self.frozen[key as usize - active.len()];
                        let lab = |p: [f64; 3]| [p[0] + vb * t, p[1] - own, p[2]];
                        ObstacleSegment { a: lab(z.a), b: lab(z.b), va: belt, vb: belt, t_ref: t, simulated: false, landed: [true; 2], source: None, cd_shift: 0.0 }
                    }
                };
                // periodic CD: each candidate pair uses the image of the obstacle nearest
                // its own segment, and each image used is an obstacle of its own (a rod
                // that spans more than a period meets one segment in two images; with one
                // image per segment, the rows nearest the other saw it a period away and
                // let it through)
                let image = |row: u32, key: u32| -> i64 {
                    let Some(p) = self.cd_period else { return 0 };
                    let r = row as usize;
                    let y = 0.5 * (sim.rod.x[r][1] + sim.rod.x[r + 1][1]);
                    // the obstacle's end points' y in the rod's own frame
                    let (ya, yb) = match active.get(key as usize) {
                        Some(o) => (o.a[1], o.b[1]),
                        None => {
                            let z = &self.frozen[key as usize - active.len()];
                            (z.a[1], z.b[1])
                        }
                    };
                    ((y - 0.5 * ((ya - own) + (yb - own))) / p).round() as i64
                };
                let found: Vec<(u32, (u32, i64))> = found.iter().map(|&(row, key)| (row, (key, image(row, key)))).collect();
                // local obstacles: the distinct (key, image) pairs, in order
                let mut keys: Vec<(u32, i64)> = found.iter().map(|p| p.1).collect();
                keys.sort_unstable();
                keys.dedup();
                for &(key, m) in &keys {
                    let mut o = obstacle(key);
                    if let Some(p) = self.cd_period {
                        let shift = p * m as f64;
                        o.a[1] += shift;
                        o.b[1] += shift;
                        o.cd_shift += shift;
                    }
                    contact.obstacles.push(o);
                }
                let rows = first[f + 1] - first[f] - own_link;
                let mut row_of = found.iter().peekable();
                for r in 0..rows as u32 {
                    while let Some(&&(row, key)) = row_of.peek() {
                        if row != r {
                            break;
                        }
                        let local = keys.binary_search(&key).expect("key collected") as u32;
                        contact.candidates.push(local);
                        row_of.next();
                    }
                    contact.rows.push(contact.candidates.len() as u32);
                }
                let n = contact.candidates.len();
                sim.fibre_contact = Some(contact);
                n
            })
            .sum();
        // cells left empty this time are dropped, the others emptied for the next
        grid.retain(|_, ids| !ids.is_empty());
        grid.values_mut().for_each(Vec::clear);
        self.active_grid = grid;
        (active.len(), pairs)
    }

    fn cd_index(&self, y: f64) -> i64 {
        (y / self.cd_cell).floor() as i64
    }

    fn wrap(&self, iy: i64) -> i64 {
        if self.cd_cells > 0 {
            iy.rem_euclid(self.cd_cells)
        } else {
            iy
        }
    }

    /// CD cell indices covering [lo, hi] (each once, wrapped when periodic).
    fn cd_range(&self, lo: f64, hi: f64) -> impl Iterator<Item = i64> + Clone + '_ {
        let (a, b) = (self.cd_index(lo), self.cd_index(hi));
        let (start, count) = if self.cd_cells > 0 && b - a + 1 >= self.cd_cells { (0, self.cd_cells) } else { (a, b - a + 1) };
        (start..start + count).map(move |i| self.wrap(i))
    }

    fn cells_3d(&self, lo: [f64; 3], hi: [f64; 3]) -> impl Iterator<Item = (i64, i64, i64)> + '_ {
        let h = self.cell;
        let (x0, x1) = ((lo[0] / h).floor() as i64, (hi[0] / h).floor() as i64);
        let (z0, z1) = ((lo[2] / h).floor() as i64, (hi[2] / h).floor() as i64);
        let ys = self.cd_range(lo[1], hi[1]);
        (x0..=x1).flat_map(move |ix| ys.clone().flat_map(move |iy| (z0..=z1).map(move |iz| (ix, iy, iz))))
    }

    fn cells_2d(&self, lo: [f64; 3], hi: [f64; 3]) -> impl Iterator<Item = (i64, i64)> + '_ {
        let h = self.cell;
        let (x0, x1) = ((lo[0] / h).floor() as i64, (hi[0] / h).floor() as i64);
        let ys = self.cd_range(lo[1], hi[1]);
        (x0..=x1).flat_map(move |ix| ys.clone().map(move |iy| (ix, iy)))
    }

    /// Whether the box [lo, hi] overlaps the box of segment a-b grown by `grow` (CD
    /// periodic: its nearest image).
    fn overlap(&self, lo: [f64; 3], hi: [f64; 3], a: [f64; 3], b: [f64; 3], grow: [f64; 3]) -> bool {
        let (slo, shi) = bbox(a, b, grow);
        for k in 0..3 {
            let (mut a, mut b) = (slo[k], shi[k]);
            if k == 1 {
                if let Some(p) = self.cd_period {
                    // the image of the other box nearest to this one
                    let shift = p * ((0.5 * (lo[1] + hi[1]) - 0.5 * (a + b)) / p).round();
                    a += shift;
                    b += shift;
                }
            }
            if b < lo[k] || a > hi[k] {
                return false;
            }
        }
        true
    }
}

/// Rods that can touch within the interval, as cluster indices per rod (in order of each
/// cluster's first rod): two rods are in one cluster when a segment of one is a
/// candidate obstacle of the other, or through a chain of such rods.
fn clusters<B: ContactBody>(bodies: &[B]) -> Vec<usize> {
    fn root(parent: &mut [usize], mut f: usize) -> usize {
        while parent[f] != f {
            parent[f] = parent[parent[f]];
            f = parent[f];
        }
        f
    }
    let mut parent: Vec<usize> = (0..bodies.len()).collect();
    for (f, body) in bodies.iter().enumerate() {
        let Some(contact) = body.simulator().fibre_contact.as_ref() else { continue };
        for o in &contact.obstacles {
            if let Some((g, _)) = o.source {
                let (a, b) = (root(&mut parent, f), root(&mut parent, g as usize));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut index = vec![usize::MAX; bodies.len()];
    let mut next = 0;
    (0..bodies.len())
        .map(|f| {
            let r = root(&mut parent, f);
            if index[r] == usize::MAX {
                index[r] = next;
                next += 1;
            }
            index[r]
        })
        .collect()
}

/// Rods in a cluster from which its rods' steps are taken in parallel (smaller
/// clusters step one rod after the other, side by side with the other clusters).
const PARALLEL_CLUSTER: usize = 3;

/// Advance one cluster from t to t_next in lock step: every step is the smallest any of
/// its rods asks for, each rod predicts its velocities before contact, and every rod's
/// copies of the others' segments are refreshed ([`refresh`]). `local[g]` is rod g's
/// place in its cluster. When a rod's step fails and every rod of the cluster can go
/// back, they all go back to t (the checkpoint each took there) and retake the interval,
/// with the recovery scheme ([`super::recovery`]) up to as far again past the failure;
/// otherwise the failed rod stops and the others go on. Returns the steps taken.
fn lock_step<B: ContactBody>(group: &mut [&mut B], local: &[usize], t: f64, t_next: f64, contact_top: f64) -> u64 {
    let parallel = group.len() >= PARALLEL_CLUSTER;
    let each = |group: &mut [&mut B], work: &(dyn Fn(&mut B) + Sync)| {
        if parallel {
            group.par_iter_mut().for_each(|b| work(b));
        } else {
            group.iter_mut().for_each(|b| work(b));
        }
    };
    let mut steps = 0;
    let mut now = t;
    // the obstacle lists the refreshes fill, swapped with the rods' own: no allocation
    // per step once they have grown
    let mut spare: Vec<Vec<ObstacleSegment>> = vec![Vec::new(); group.len()];
    // simulated obstacles (of other rods, or a rod's own far along it) follow their rods
    let refreshed = group.iter().any(|b| b.simulator().fibre_contact.as_ref().is_some_and(|c| c.obstacles.iter().any(|o| o.source.is_some())));
    // the rods running at t (a rod that has failed for good is left out) and their checkpoints
    let mut running: Vec<bool> = group.iter().map(|b| b.running()).collect();
    each(group, &|b: &mut B| {
        if b.running() {
            b.checkpoint()
        }
    });
    while now < t_next - t_next.abs() * 1e-12 {
        let dt = group.iter().filter(|b| b.running()).map(|b| b.next_step()).fold(f64::INFINITY, f64::min);
        if !dt.is_finite() {
            break;
        }
        let until = if now + dt >= t_next - t_next.abs() * 1e-12 { t_next } else { now + dt };
        each(group, &|b: &mut B| {
            if b.running() {
                b.predict(until)
            }
        });
        if refreshed {
            refresh(group, local, now, parallel, &mut spare);
            // the contacts two fibres share ½, for both fibres at once; the copies then
            // carry the velocities they give
            let mut sims: Vec<&mut Simulator> = group.iter_mut().map(|b| b.simulator_mut()).collect();
            if super::fibre_contact::air::solve_in_air(&mut sims, local, now, until - now, contact_top, parallel) {
                refresh_velocities(group, local, now);
            }
        }
        each(group, &|b: &mut B| b.advance_to(until));
        now = until;
        steps += 1;
        // a rod failed (its time is the last it reached): back together, or it stops
        let failed_at = group.iter().zip(&running).filter(|(b, &r)| r && !b.running()).map(|(b, _)| b.simulator().t).fold(f64::INFINITY, f64::min);
        if failed_at.is_finite() {
            if group.iter().zip(&running).all(|(b, &r)| !r || b.can_roll_back()) {
                for (b, _) in group.iter_mut().zip(&running).filter(|(_, &r)| r) {
                    b.roll_back(failed_at);
                }
                now = t;
            } else {
                for (b, r) in group.iter().zip(running.iter_mut()) {
                    *r = *r && b.running();
                }
            }
        }
    }
    steps
}

/// Copy each rod's simulated obstacles afresh from the other rods' state at `t` (rods of
/// one cluster; `local[g]` is rod g's place in it), through `spare` (one list per rod,
/// which ends up holding the rods' previous lists).
fn refresh<B: ContactBody>(group: &mut [&mut B], local: &[usize], t: f64, parallel: bool, spare: &mut [Vec<ObstacleSegment>]) {
    let copy = |(body, fresh): (&&mut B, &mut Vec<ObstacleSegment>)| {
        fresh.clear();
        let Some(contact) = body.simulator().fibre_contact.as_ref() else { return };
        fresh.extend(
            contact
                .obstacles
                .iter()
                .map(|o| match o.source {
                    // a rod that failed mid-interval keeps its last copy
                    Some((g, k)) if k as usize + 1 < group[local[g as usize]].simulator().rod.nodes() => {
                        let sim = group[local[g as usize]].simulator();
                        let k = k as usize;
                        let x = &sim.rod.x;
                        let shift = |p: [f64; 3]| [p[0], p[1] + o.cd_shift, p[2]];
                        let rests = |i: usize| rests_on_web(sim, i);
                        ObstacleSegment { a: shift(x[k]), b: shift(x[k + 1]), va: seen_velocity(sim, k), vb: seen_velocity(sim, k + 1), t_ref: t, landed: [rests(k), rests(k + 1)], ..*o }
                    }
                    _ => *o,
                }),
        );
    };
    if parallel {
        group.par_iter().zip(spare.par_iter_mut()).for_each(copy);
    } else {
        group.iter().zip(spare.iter_mut()).for_each(copy);
    }
    for (body, fresh) in group.iter_mut().zip(spare.iter_mut()) {
        if let Some(c) = body.simulator_mut().fibre_contact.as_mut() {
            std::mem::swap(&mut c.obstacles, fresh);
        }
    }
}

/// The velocity the other rods see node `i` of `sim` move at in the step from its time:
/// the one it reaches before contact, if predicted; a node held up by another fibre moves
/// as it did in the last step (its velocity before contact would carry it into that fibre).
pub(super) fn seen_velocity(sim: &Simulator, i: usize) -> [f64; 3] {
    match &sim.fibre_contact {
        Some(c) if c.resting.get(i) == Some(&true) => sim.rod.v[i],
        Some(c) if c.predicted_at == Some(sim.t) && c.predicted.len() == sim.rod.nodes() => c.predicted[i],
        _ => sim.rod.v[i],
    }
}

/// After the contacts solved for both fibres changed some rods' predicted velocities at `t`
/// ([`air::solve_in_air`](super::fibre_contact::air::solve_in_air)): the velocities of
/// every copy of those rods' segments, as [`refresh`] sets them; positions, and whether
/// each end rests (settled before the solve), stay as they are.
fn refresh_velocities<B: ContactBody>(group: &mut [&mut B], local: &[usize], t: f64) {
    // the velocities each changed rod is seen moving at
    let seen: Vec<Option<Vec<[f64; 3]>>> = group
        .iter()
        .map(|b| {
            let sim = b.simulator();
            let c = sim.fibre_contact.as_ref()?;
            (c.air_at == Some(t) && !c.air_change.is_empty()).then(|| (0..sim.rod.nodes()).map(|i| seen_velocity(sim, i)).collect())
        })
        .collect();
    for b in group.iter_mut() {
        let Some(c) = b.simulator_mut().fibre_contact.as_mut() else { continue };
        for o in c.obstacles.iter_mut() {
            if let Some((world, k)) = o.source {
                if let Some(Some(v)) = seen.get(local[world as usize]) {
                    let k = k as usize;
                    if k + 1 < v.len() {
                        (o.va, o.vb) = (v[k], v[k + 1]);
                    }
                }
            }
        }
    }
}

/// Whether own segment `k` and own simulated segment `segment` (`u32::MAX`: the link
/// from the last frozen node, just before segment 0) are [`SELF_GAP`] or more apart.
fn apart_along_rod(k: usize, segment: u32) -> bool {
    let q = if segment == u32::MAX { -1 } else { segment as i64 };
    (k as i64 - q).unsigned_abs() >= SELF_GAP as u64
}

/// Bounding box of segment a-b grown by `grow` per axis.
fn bbox(a: [f64; 3], b: [f64; 3], grow: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    (
        [a[0].min(b[0]) - grow[0], a[1].min(b[1]) - grow[1], a[2].min(b[2]) - grow[2]],
        [a[0].max(b[0]) + grow[0], a[1].max(b[1]) + grow[1], a[2].max(b[2]) + grow[2]],
    )
}

/// Per-axis reach of a segment whose ends move at va, vb, relative to w, over Δt_c:
/// twice the predicted motion.
fn reach(va: [f64; 3], vb: [f64; 3], w: [f64; 3], interval: f64) -> [f64; 3] {
    let r = |k: usize| 2.0 * interval * (va[k] - w[k]).abs().max((vb[k] - w[k]).abs());
    [r(0), r(1), r(2)]
}

fn add(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s, a[1] + s, a[2] + s]
}

/// Whether node `i` of `sim` lies on the belt or on the web (see [`FibreContact::rests`]).
fn rests_on_web(sim: &Simulator, i: usize) -> bool {
    sim.fibre_contact.as_ref().map_or(sim.landing_time[i].is_finite(), |c| c.rests(i, &sim.landing_time, &sim.rod.x, c.before_contact(&sim.rod, sim.t)))
}
