//! Fibre-fibre contact: the centrelines of two fibres (or of a fibre and its own laid
//! stretch) stay at least one diameter d apart, with Coulomb friction μ_ff between them.
//! Opt-in: a [`Simulator`](super::Simulator) without a [`FibreContact`] pays nothing.
//!
//! A rod sees the other fibres as **obstacle segments**: end points and velocities at a
//! reference time t_ref, moved on linearly (x_q(t) = x_q + v_q (t − t_ref)). A laid,
//! frozen segment moves with the belt, which is exact; a segment of another simulated
//! fibre is refreshed before every step by [`ContactWorld`](super::contact_world), so
//! within a step each rod sees the others where they were at its start, moving at the
//! velocities they reach in the step without fibre contact. Each own segment
//! carries its list of candidate obstacles (those whose swept bounding boxes can meet
//! its own before the next broad-phase search).
//!
//! Within each step, for an own segment P(s) = (1 − s) x_i + s x_j and an obstacle
//! Q(u), with (s, u) the closest points, n = (P − Q)/|P − Q| and g = |P − Q| the
//! centreline distance:
//! - **velocity pass** (before the belt's impulses): if the relative normal velocity
//!   v_n = (v_P − v_Q)·n would bring g below d by the end of the step, the point velocity
//!   gets the impulse that makes v_n = (d − g)/Δt (g ≥ d), or keeps it within
//!   [0, `MAX_SEPARATION_SPEED`] (g < d): perfectly inelastic like the belt. Coulomb
//!   friction: a relative tangential velocity w_t with |w_t| ≤ μ_ff Δv_n is removed
//!   (stick), otherwise reduced by μ_ff Δv_n. A change Δ of the point is carried by the
//!   nodes through the step's inverse node matrices W_k (which hold a node stuck on the
//!   belt fixed): q_k += β_k λ W_k u, β = (1 − s, s), u = Δ/|Δ|, λ = |Δ|/Σ β_k² uᵀW_k u.
//!   The node nearer the contact then loses its freedom along n in the length
//!   projection, with or without an impulse (a resting contact needs none, and the
//!   projection would otherwise pull the node back into the other fibre), and the belt
//!   leaves it alone in that step (its lagged axial force would otherwise send it
//!   through the fibre onto the belt);
//! - **position pass** (after the length projection, alternating with it and with the
//!   belt's, like the belt): a pair closer than (1 − `SLOP`) d is pushed apart towards
//!   d, by at most [`MAX_SEPARATION_SPEED`]·Δt per step; a node held along n by the
//!   velocity pass moves here with that freedom restored (it is the node that must move).
//!   The correction is not velocity ([`FibreContact::shift`], post-stabilisation): the
//!   step's velocity update leaves it out, so an overlap is undone without throwing the
//!   fibres apart.
//!
//! **Pruning** (exact: the same corrections as testing every candidate in every pass).
//! Most candidates of an interval are far apart in any one step. Each rod keeps the
//! path length every own node and every obstacle end has travelled (t_k, t_q) and, per
//! candidate, the gap it last measured plus the travel at that moment; the gap now is
//! at least that gap minus the travel since (the closest-point distance of two segments
//! moves no more than their ends). A pair whose lower bound exceeds d by more than the
//! step can close at the current speeds is skipped in the velocity pass, and one whose
//! bound is at least d in the position pass; a pair first tested in the position pass
//! takes the share its start-of-step state gives, as it would have in the velocity pass.
//! Each own segment also keeps the least bound of its candidates, less the travel of the
//! obstacles since (`FibreContact::row_gap`), so a pass skips a segment far from every
//! candidate in one comparison instead of visiting its candidates one by one.
//! `pruning: false` tests every candidate (`pruning_skips_pair_tests_and_changes_nothing`).
//!
//! Who yields ([`yield_share`]): against a frozen or held segment the rod takes the whole
//! correction. Of two simulated fibres, the upper one takes it all if the lower one lies
//! on the belt (landed, and on the plane or not rising off it: [`on_belt`]) or rested in
//! the last step on fibre that takes none of the correction (the web holds it:
//! [`FibreContact::resting`]); with half each, a fibre pressed onto the belt or the
//! web cannot give way and the penetration left drives spurious velocities. A landed node
//! lifted off the belt, or a node lying on a fibre that gives way with it, is not held:
//! counted as held, the fibre above it took the whole correction and was carried up with
//! it, and the other fibre saw it at its current velocity instead of the one it uses
//! itself, so the pair's approach was judged two ways and never removed. Otherwise,
//! and side by side (heights within 0.1 d), each takes ½ (equal masses per length; where
//! one meets the other off its nodes and the other at a node the two impulses differ and
//! the pair's momentum changes, by 6 % at a quarter of an element). Where such a ½ pair
//! meets below z0, in the air or on laid fibre that gives way, a
//! [`ContactWorld`](super::contact_world) solves its velocity pass for both fibres at once
//! instead, with the belt under their nodes ([`air`]): equal and opposite impulses
//! (`a_collision_of_two_free_fibres_conserves_their_momentum`,
//! `a_fibre_meeting_laid_fibre_that_gives_way_conserves_momentum`); the position pass
//! still takes ½ each. Both decide the shares on the holds settled before the step
//! ([`FibreContact::settle_holds`]). A pair
//! closer than d/2 at the start of a step has crossed ([`CROSSED`]) and is left alone.
//! Tunnelling needs a relative normal motion of more than d in one step while the pair
//! is not yet a candidate; the candidate margins are twice the motion measured at the
//! search.

use super::state::Rod;

/// Relative penetration tolerated without a position correction (a resting contact
/// then does not jitter); the position pass restores d.
pub const SLOP: f64 = 0.01;

/// Fastest the position pass separates a pair (m/s): a correction δ in a step Δt becomes
/// a velocity δ/Δt, and in the µs steps of an impact a correction of a diameter would
/// throw the node at tens of m/s. A deeper penetration (fibres that overlap when contact
/// begins, or after an extrapolation error) is undone over several steps.
pub const MAX_SEPARATION_SPEED: f64 = 1.0;

/// Largest time step of fibres in contact, as a fraction of the stable step (the
/// `contact_step_factor` of a laid web). Where a fibre rests on a sloping one, their
/// contact normal (the cross product of the two tangents) is tilted across each fibre by
/// the other's slope, and the node held along it in the length projection makes the
/// in-plane grid-scale mode of the explicit step unstable above 0.5-0.6 of the stable step
/// (`a_tilted_contact_is_stable_at_the_contact_step_factor`; what it changes in webs, and
/// costs: `pipelines/studies/PHYSICAL_WEBS.md`, "The contact step").
pub const CONTACT_STEP_FACTOR: f64 = 0.5;

/// Centreline distance, in diameters, below which a pair counts as crossed and is left alone.
pub const CROSSED: f64 = 0.5;

/// Most rounds of belt push, fibre push and length projection in one step; each fibre
/// push moves a pair by at most [`MAX_SEPARATION_SPEED`]·Δt/`POSITION_ROUNDS`.
pub const POSITION_ROUNDS: usize = 8;

/// Fewest segments from one of a rod's own segments to another it can touch: the two
/// next to it on either side (they share a node with it, or bend away from it over a
/// node) are left out, simulated or frozen.
pub const SELF_GAP: usize = 3;

/// Centreline distances between the laid segments (both end nodes landed) of one fibre
/// that lie [`SELF_GAP`] or more apart along it: below d/2 the fibre was laid across its
/// own loop ([`CROSSED`]).
pub fn laid_self_gaps<'a>(positions: &'a [[f64; 3]], landing_time: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
    let laid: Vec<usize> = (0..positions.len().saturating_sub(1)).filter(|&i| landing_time[i].is_finite() && landing_time[i + 1].is_finite()).collect();
    (0..laid.len()).flat_map(move |a| {
        let i = laid[a];
        let later: Vec<usize> = laid[a + 1..].iter().copied().filter(|&k| k >= i + SELF_GAP).collect();
        later.into_iter().map(move |k| norm(closest_points(positions[i], positions[i + 1], positions[k], positions[k + 1]).2))
    })
}

/// A segment of another fibre: end points and velocities at time `t_ref`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObstacleSegment {
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub va: [f64; 3],
    pub vb: [f64; 3],
    pub t_ref: f64,
    /// Whether it belongs to another simulated fibre, which responds to contact too
    /// (see [`yield_share`]); false: frozen or held, this rod takes every correction.
    pub simulated: bool,
    /// Whether each end node is held: lies on the belt or rests on the web
    /// ([`FibreContact::rests`]).
    pub landed: [bool; 2],
    /// The simulated segment it copies, (rod, segment), refreshed before every step;
    /// None: frozen (moves with the belt, never refreshed).
    pub source: Option<(u32, u32)>,
    /// Cross-direction shift of the periodic image used (m).
    pub cd_shift: f64,
}

impl ObstacleSegment {
    /// End points at time `t`.
    fn at(&self, t: f64) -> ([f64; 3], [f64; 3]) {
        let tau = t - self.t_ref;
        (add_scaled(self.a, self.va, tau), add_scaled(self.b, self.vb, tau))
    }
}

/// The contact state of one rod: its obstacles and each own segment's candidates.
#[derive(Clone, Debug, Default)]
pub struct FibreContact {
    /// d, the fibre diameter (m): least distance between two centrelines.
    pub diameter: f64,
    /// μ_ff, Coulomb friction between fibres; None: frictionless.
    pub friction: Option<f64>,
    pub obstacles: Vec<ObstacleSegment>,
    /// Candidates of own segment row r: `candidates[rows[r] .. rows[r + 1]]`.
    pub rows: Vec<u32>,
    pub candidates: Vec<u32>,
    /// This rod's index among the rods of its [`ContactWorld`](super::contact_world) (the
    /// first element of the `source` of an obstacle copying one of its segments), set by
    /// `ContactWorld::prepare`; 0 on a contact made by [`FibreContact::new`].
    pub world: u32,
    /// Each row's candidates ordered by the segment their obstacle copies: (source packed
    /// as world rod · 2³² + segment, obstacles without a source last; candidate index),
    /// over the same ranges as `candidates`. Made by [`FibreContact::copying`] when its
    /// length differs from the candidates'; emptied by [`FibreContact::clear`], which code
    /// that replaces the candidates calls first.
    by_source: Vec<(u64, u32)>,
    /// Share of each candidate contact this rod takes in the current step.
    shares: Vec<f64>,
    /// Nodes held up by another fibre in the current step (the nearer node of each
    /// contact that got an impulse): the belt leaves them alone in this step.
    pub supported: Vec<bool>,
    /// The inverse node matrix W of each supported node before the velocity pass took its
    /// freedom along the contact normal: the position pass moves it with that freedom
    /// (the projection after it then keeps the node where the pass put it).
    unconstrained: Vec<[f64; 6]>,
    /// Nodes resting on another fibre (held up from below in the current step), and in
    /// the step before: such a node counts as landed in [`yield_share`], as one on the belt.
    pub resting: Vec<bool>,
    was_resting: Vec<bool>,
    /// Nodes of own segments resting in the current step on laid fibre (an obstacle end
    /// that lies on the belt or the web, or a frozen segment, touched no higher than
    /// `web_top`): such a node is laid, on the web instead of the belt.
    pub on_web: Vec<bool>,
    /// Time each node first rested on laid fibre (s; NaN: never), kept as nodes are fed
    /// and frozen ([`super::Simulator::laid_time`]).
    pub web_landing_time: Vec<f64>,
    /// Highest a contact point on laid fibre may be for a node resting there to land
    /// (m): the laid web's top, the scene's `bounce_tolerance` (above it a landed node
    /// counts as bounced). Without this bound a node lifted from the web would lay
    /// whatever rests on it, and so on up the hanging fibre.
    pub web_top: f64,
    /// Displacement the position pass gave each node in the current step: it corrects
    /// the position only and does not become velocity (post-stabilisation).
    pub shift: Vec<[f64; 3]>,
    /// Nodes dropped from the front of the rod since the rows were prepared: own
    /// segment k is row k + `dropped`. Segments added at the top have no row.
    pub dropped: usize,
    /// Deepest penetration d − g left after a step's position pass (m).
    pub max_penetration: f64,
    /// Contacts that received a velocity impulse, and position corrections.
    pub impulses: u64,
    pub corrections: u64,
    /// Pair-steps found crossed (closer than [`CROSSED`] d at the start of a step) and left alone.
    pub crossed: u64,
    /// Pruning ([module docs](self)): path length travelled by each own node and the
    /// position it was last seen at; the same for each obstacle (its farther-moving end)
    /// and the time it was last seen at; per candidate, the gap last measured plus the
    /// travel of its row and obstacle at that moment (−∞: never measured).
    travel: Vec<f64>,
    last_x: Vec<[f64; 3]>,
    obstacle_travel: Vec<f64>,
    obstacle_last: Vec<([f64; 3], [f64; 3])>,
    obstacle_seen_at: f64,
    /// Fastest end of each obstacle (m/s).
    obstacle_speed: Vec<f64>,
    /// Per obstacle, for the current pass: its travel plus how far it can move in the
    /// step (the part of a pair's skip test that depends on the obstacle alone).
    obstacle_reach: Vec<f64>,
    gap_bound: Vec<f64>,
    /// Per row (own segment): the least over its candidates of the gap bound less the
    /// obstacle's travel, plus `obstacle_drift`, when the row was last visited (−∞:
    /// never); see [`FibreContact::row_gap`].
    row_bound: Vec<f64>,
    /// Σ over [`FibreContact::update_travel`] calls of the farthest any obstacle moved:
    /// no obstacle's travel grew more than this since.
    obstacle_drift: f64,
    /// Per row, the candidates the position rounds still visit while the obstacles stand
    /// still and the row's nodes move less than [`ROUND_MARGIN`] d ([`RoundList`]); the
    /// list of row r lies in `round_pairs[rows[r] ..]`.
    round_rows: Vec<RoundList>,
    round_pairs: Vec<u32>,
    /// Candidates a row visits in the current position round (scratch).
    visit: Vec<u32>,
    /// Start of the current step: positions, time, and whether each node was held
    /// (on the belt or resting on fibre), for shares settled in the position pass.
    x_start: Vec<[f64; 3]>,
    t_start: f64,
    held_start: Vec<bool>,
    /// The time the flags `held_start` were settled for ([`FibreContact::settle_holds`]).
    held_at: Option<f64>,
    /// The time the joint solve brought the travels up to ([`FibreContact::bounds_at`]),
    /// until the velocity pass at that time uses it.
    bounds_for: Option<f64>,
    /// Skip the pairs the gap bound shows cannot be in contact (on by default); off,
    /// every candidate is tested in every pass: the reference the pruning is checked
    /// against (it must give the same corrections to the bit).
    pub pruning: bool,
    /// Pair tests made (closest points computed) and skipped by the bound.
    pub pair_tests: u64,
    pub pairs_skipped: u64,
    /// The rod's velocities v* before contact in the step about to be taken from time
    /// `predicted_at` ([`super::Simulator::predict_velocities`]): the other rods see this
    /// rod's segments move at v* in that step, as the rod itself does, so both sides of
    /// a pair judge its approach alike.
    pub predicted: Vec<[f64; 3]>,
    pub predicted_at: Option<f64>,
    /// The same step's velocities and inverse node matrices W before the belt (after the
    /// node-wise implicit update): the basis of the contacts solved for both fibres ([`air`]).
    pub free_velocities: Vec<[f64; 3]>,
    pub free_mobility: Vec<[f64; 6]>,
    /// The time t of the step the contacts shared ½ ([`air`]) were solved for, with this
    /// rod in at least one of them; the velocity change they give each node in that step
    /// (empty: none); and which candidates they solved (the velocity pass applies no
    /// impulse to those; empty when none). A step retaken smaller from t keeps them: their
    /// impulses then let a pair close less than the shorter step would allow, and their
    /// equal and opposite impulses keep momentum (with the rods' own ½ shares instead, the
    /// three fibres without friction moved at 2.8 cm/s at the contact step, against
    /// 0.08 cm/s).
    pub air_at: Option<f64>,
    pub air_change: Vec<[f64; 3]>,
    pub air_pairs: Vec<bool>,
}

/// The range of own nodes free to move (clamped leading nodes and a driven top excluded).
pub type FreeNodes = std::ops::Range<usize>;

impl FibreContact {
    /// No obstacles, for `diameter` and `friction`.
    pub fn new(diameter: f64, friction: Option<f64>) -> Self {
        FibreContact { diameter, friction, rows: vec![0], web_top: f64::INFINITY, pruning: true, ..FibreContact::default() }
    }

    /// Forget obstacles and candidates (before new ones are prepared for the rod's
    /// current segments).
    pub fn clear(&mut self) {
        self.obstacles.clear();
        self.rows.clear();
        self.rows.push(0);
        self.candidates.clear();
        self.by_source.clear();
        self.dropped = 0;
        self.gap_bound.clear();
        self.row_bound.clear();
        self.round_rows.clear();
        self.round_pairs.clear();
        self.obstacle_drift = 0.0;
        self.travel.clear();
        self.last_x.clear();
        self.obstacle_travel.clear();
        self.obstacle_last.clear();
        self.obstacle_seen_at = f64::NAN;
        self.bounds_for = None;
    }

    /// The first `count` nodes left the rod (frozen): the per-node flags follow.
    pub fn drop_front(&mut self, count: usize) {
        self.dropped += count;
        self.held_at = None;
        self.bounds_for = None;
        for flags in [&mut self.resting, &mut self.was_resting, &mut self.supported, &mut self.on_web] {
            flags.drain(..count.min(flags.len()));
        }
        self.web_landing_time.drain(..count.min(self.web_landing_time.len()));
        self.travel.drain(..count.min(self.travel.len()));
        self.last_x.drain(..count.min(self.last_x.len()));
    }

    /// Add the motion since the last call to the travel of every own node and (when `t`
    /// is a new time, or the obstacles may have been refreshed since) of every obstacle,
    /// the farthest of them to `obstacle_drift`; a node or obstacle seen for the first
    /// time starts at 0.
    fn update_travel(&mut self, x: &[[f64; 3]], t: f64, obstacles_refreshed: bool) {
        let n = x.len();
        let seen = self.last_x.len().min(n);
        for ((&now, last), travel) in x[..seen].iter().zip(&mut self.last_x).zip(&mut self.travel) {
            *travel += norm(sub(now, *last));
            *last = now;
        }
        // (a node new since the last call has no candidates: rows are made at preparation)
        self.travel.truncate(n);
        self.last_x.truncate(n);
        self.travel.resize(n, 0.0);
        self.last_x.extend_from_slice(&x[seen..]);
        if !obstacles_refreshed && self.obstacle_seen_at == t && self.obstacle_last.len() == self.obstacles.len() {
            return;
        }
        self.obstacle_seen_at = t;
        self.refresh_obstacle_speed();
        let mut farthest = 0.0f64;
        for (q, ob) in self.obstacles.iter().enumerate() {
            let (a, b) = ob.at(t);
            if let Some(&(la, lb)) = self.obstacle_last.get(q) {
                let step = norm(sub(a, la)).max(norm(sub(b, lb)));
                self.obstacle_travel[q] += step;
                self.obstacle_last[q] = (a, b);
                farthest = farthest.max(step);
            } else {
                // an obstacle new since the last call: its candidates were never measured
                self.obstacle_travel.push(0.0);
                self.obstacle_last.push((a, b));
            }
        }
        self.obstacle_drift += farthest;
    }

    /// Each obstacle's speed, the faster of its two ends (m/s).
    fn refresh_obstacle_speed(&mut self) {
        self.obstacle_speed.clear();
        self.obstacle_speed.extend(self.obstacles.iter().map(|ob| norm(ob.va).max(norm(ob.vb))));
    }

    /// Travel of own segment k's nodes plus that of obstacle q: how far the pair's gap
    /// can have shrunk since the travels were this much smaller.
    fn pair_travel(&self, k: usize, q: usize) -> f64 {
        self.travel[k] + self.travel[k + 1] + self.obstacle_travel[q]
    }

    /// A lower bound on the gap between own segment k and any of its candidates now
    /// (+∞ for a segment without candidates): the row's least recorded bound, less the
    /// segment's own travel and the most any obstacle can have travelled since.
    fn row_gap(&self, k: usize) -> f64 {
        let row = k + self.dropped;
        if row + 1 >= self.rows.len() {
            return f64::INFINITY;
        }
        self.row_bound.get(row).map_or(f64::NEG_INFINITY, |b| b - self.obstacle_drift - self.travel[k] - self.travel[k + 1])
    }

    /// Record row k's least bound after a visit (`least`: the least over its candidates
    /// of the gap bound less the obstacle's reach; see `row_bound`).
    fn close_row(&mut self, k: usize, least: f64) {
        if let Some(b) = self.row_bound.get_mut(k + self.dropped) {
            *b = least + self.obstacle_drift;
        }
    }

    /// Bring the gap bounds up to the start of the step from `t` (own nodes at `x`, the
    /// obstacles just refreshed) for the solve before the velocity pass ([`air`]), and
    /// return the fastest obstacle's speed (m/s). The pass's own update at `t` then adds
    /// nothing (the same positions), so it only renews the obstacles' speeds, which the
    /// solve changes.
    pub(super) fn bounds_at(&mut self, x: &[[f64; 3]], t: f64) -> f64 {
        self.update_travel(x, t, true);
        self.bounds_for = Some(t);
        self.obstacle_speed.iter().copied().fold(0.0, f64::max)
    }

    /// Whether own segment k may come within d + `reach` of a candidate, by the row bound
    /// as brought up to date by [`FibreContact::bounds_at`] (always, with pruning off).
    pub(super) fn row_may_reach(&self, k: usize, reach: f64) -> bool {
        !self.pruning || self.row_gap(k) - self.diameter <= reach
    }

    /// Whether own segment k and candidate c may be within d + `reach` of each other, by
    /// the pair's gap bound as brought up to date by [`FibreContact::bounds_at`] (always,
    /// with pruning off or a pair never measured).
    pub(super) fn pair_may_reach(&self, k: usize, c: usize, reach: f64) -> bool {
        let q = self.candidates[c] as usize;
        !self.pruning || self.gap_bound.get(c).is_none_or(|b| b - self.pair_travel(k, q) - self.diameter <= reach)
    }

    /// Whether a pass may skip own segment k whole: pruning is on and no candidate can
    /// come within d + `reach`. Counts the skipped candidates.
    fn skip_row(&mut self, k: usize, reach: f64) -> bool {
        if self.pruning && self.row_gap(k) - self.diameter > reach {
            self.pairs_skipped += self.row(k).len() as u64;
            true
        } else {
            false
        }
    }

    /// Whether node `k` rests on the belt's web: held by the belt ([`on_belt`], with `v`
    /// the velocities the rod reaches in the step before fibre contact), or held up from
    /// below by fibre the web holds in the last step.
    pub fn rests(&self, k: usize, landing_time: &[f64], x: &[[f64; 3]], v: &[[f64; 3]]) -> bool {
        on_belt(k, landing_time, x, v, self.diameter) || self.resting.get(k) == Some(&true)
    }

    /// Settle which nodes hold in the step from time `t` ([`FibreContact::rests`], at the
    /// velocities predicted for the step), before any of its contacts is solved. The
    /// contacts solved for both fibres at once ([`air`]) and the rod's own passes judge
    /// every pair's shares ([`yield_share`]) on these flags, although that solve changes
    /// the predicted velocities [`on_belt`] reads: one decision per pair and step.
    pub fn settle_holds(&mut self, landing_time: &[f64], rod: &Rod, t: f64) {
        let mut held = std::mem::take(&mut self.held_start);
        held.clear();
        let v = self.before_contact(rod, t);
        held.extend((0..rod.nodes()).map(|k| self.rests(k, landing_time, &rod.x, v)));
        self.held_start = held;
        self.held_at = Some(t);
    }

    /// Whether node `k` is held in the step from `t`, as [`FibreContact::settle_holds`]
    /// settled it (false when not settled for `t`).
    pub(super) fn held(&self, k: usize, t: f64) -> bool {
        self.held_at == Some(t) && self.held_start.get(k) == Some(&true)
    }

    /// The velocities the rod reaches in the step from time `t` before fibre contact
    /// (v*, the ones the other rods see), else its current ones.
    pub fn before_contact<'a>(&'a self, rod: &'a Rod, t: f64) -> &'a [[f64; 3]] {
        if self.predicted_at == Some(t) && self.predicted.len() == rod.nodes() {
            &self.predicted
        } else {
            &rod.v
        }
    }

    /// Candidate indices of own segment k (empty for a segment added since preparation).
    fn row(&self, k: usize) -> std::ops::Range<usize> {
        let row = k + self.dropped;
        if row + 1 < self.rows.len() {
            self.rows[row] as usize..self.rows[row + 1] as usize
        } else {
            0..0
        }
    }

    /// The positions in `by_source` of own segment k's candidates whose obstacle copies
    /// segment `segment` of world rod `world` (at most one from `ContactWorld::prepare`,
    /// which gives each row the image nearest it; every match if a row holds more); the
    /// candidate indices are `by_source[i].1`.
    pub(super) fn copying(&mut self, k: usize, world: u32, segment: u32) -> std::ops::Range<usize> {
        if self.by_source.len() != self.candidates.len() {
            let (obstacles, candidates) = (&self.obstacles, &self.candidates);
            self.by_source.clear();
            self.by_source.extend(candidates.iter().enumerate().map(|(cand, &o)| {
                let key = obstacles[o as usize].source.map_or(u64::MAX, |(w, k)| (u64::from(w) << 32) | u64::from(k));
                (key, cand as u32)
            }));
            for row in self.rows.windows(2) {
                self.by_source[row[0] as usize..row[1] as usize].sort_unstable();
            }
        }
        let row = self.row(k);
        let key = (u64::from(world) << 32) | u64::from(segment);
        let slice = &self.by_source[row.clone()];
        let first = slice.partition_point(|e| e.0 < key);
        let last = slice.partition_point(|e| e.0 <= key);
        row.start + first..row.start + last
    }

    /// Velocity pass at the start of a step at time `t` (see the module docs). It also
    /// settles, from the start-of-step positions (the obstacles were refreshed then, so
    /// both rods of a pair see the same two segments), which rod yields in each pair
    /// ([`yield_share`]); the position pass at the end of the step keeps that decision.
    /// With `winv` (the projection schemes' effective inverse masses), the node nearer
    /// each contact point loses its freedom along the contact normal in this step's
    /// length projection, as a node on the belt loses its vertical one: otherwise the
    /// projection pulls a node held up by a crossing fibre back into it.
    pub fn apply_impulses(&mut self, rod: &mut Rod, landing_time: &[f64], mut winv: Option<&mut [[f64; 6]]>, t: f64, dt: f64, free: FreeNodes) {
        let d = self.diameter;
        let (mut impulses, mut skipped) = (0, 0);
        // (a rod stepped outside a contact world settles its holds here, before `resting`
        // becomes `was_resting`)
        if self.held_at != Some(t) || self.held_start.len() != rod.nodes() {
            self.settle_holds(landing_time, rod, t);
        }
        // NaN: not settled in this pass (see `share_at_start`)
        self.shares.clear();
        self.shares.resize(self.candidates.len(), f64::NAN);
        self.supported.clear();
        self.supported.resize(rod.nodes(), false);
        std::mem::swap(&mut self.resting, &mut self.was_resting);
        self.resting.clear();
        self.resting.resize(rod.nodes(), false);
        self.on_web.clear();
        self.on_web.resize(rod.nodes(), false);
        // nodes fed since the last step are appended at the top
        self.web_landing_time.resize(rod.nodes(), f64::NAN);
        self.shift.clear();
        self.shift.resize(rod.nodes(), [0.0; 3]);
        self.unconstrained.resize(rod.nodes(), [0.0; 6]);
        // the obstacles were refreshed before this step; the joint solve ([`air`]) may have
        // brought the travels up to t already, the rod not having moved since, and changed
        // only the obstacles' velocities
        if self.bounds_for.take() == Some(t) && self.last_x.len() == rod.nodes() {
            self.refresh_obstacle_speed();
        } else {
            self.update_travel(&rod.x, t, true);
        }
        self.begin_pass(dt);
        self.x_start.clone_from(&rod.x);
        self.t_start = t;
        let speed = |v: [f64; 3]| norm(v);
        let fastest_obstacle = self.obstacle_speed.iter().copied().fold(0.0, f64::max);
        for k in 0..rod.rest.len() {
            let (i, j) = (k, k + 1);
            let mut row_speed = speed(rod.v[i]).max(speed(rod.v[j]));
            // nothing happens to a segment that cannot reach any candidate in this step
            if self.skip_row(k, dt * (row_speed + fastest_obstacle)) {
                continue;
            }
            let mut limit = self.pair_limit(k, dt, row_speed);
            let mut least = f64::INFINITY;
            for c in self.row(k) {
                // nor to a pair that cannot reach contact in this step
                let (test, lower) = self.visit_pair(&rod.x, k, c, t, limit);
                least = least.min(lower);
                let Some(PairTest { q, s, u, gap, g, q0, q1 }) = test else {
                    skipped += 1;
                    continue;
                };
                let ob = &self.obstacles[q];
                // a pair closer than d/2 has crossed (in a violent event, or before
                // contact began): pushing it apart along a normal that flipped as they
                // passed would drive them into each other; it is left until it parts
                let near = if s < 0.5 { i } else { j };
                let share = if g < CROSSED * d { 0.0 } else { yield_share(ob, u, gap[2], d, self.held_start[near]) };
                self.shares[c] = share;
                if share == 0.0 && g < CROSSED * d {
                    self.crossed += 1;
                }
                if share == 0.0 || !(g > 0.0) {
                    continue;
                }
                let n = scale(gap, 1.0 / g);
                let vrel = sub(lerp(rod.v[i], rod.v[j], s), lerp(ob.va, ob.vb, u));
                let vn = dot(vrel, n);
                // approach: only up to contact at the end of the step; in contact or
                // overlapping: no approach, and separation no faster than the position
                // pass's (which would otherwise add up, step after step, while an
                // overlap persists)
                let target = if g >= d { (d - g) / dt } else { vn.clamp(0.0, MAX_SEPARATION_SPEED) };
                // solved with the other fibre ([`air`]): no impulse here, but the
                // node is held along n as for any contact (one the solve brought to its
                // target is still in contact; what the solve's sweeps and the impulses
                // after it leave of an approach, the position pass corrects)
                let in_air = self.air_at == Some(t) && self.air_pairs.get(c) == Some(&true);
                if g >= d && vn >= target + if in_air { air::SOLVED_TOLERANCE } else { 0.0 } {
                    continue;
                }
                // in contact (or reaching it in this step): the node nearer the contact
                // point is held along n in the projection, with or without an impulse (a
                // resting contact needs none, and the projection would otherwise pull the
                // node back into the other fibre)
                // resting on the web: held up from below by fibre that takes none of
                // the correction (frozen, held, or itself on the belt or the web); a
                // node lying on a fibre that gives way with it is not resting
                if gap[2] > 0.0 && share == 1.0 {
                    self.resting[near] = true;
                    // the segment lies on laid fibre: both its nodes are part of the web
                    if ob.landed[usize::from(u >= 0.5)] && q0[2] + u * (q1[2] - q0[2]) <= self.web_top {
                        for k in [i, j] {
                            self.on_web[k] = true;
                            if self.web_landing_time[k].is_nan() {
                                self.web_landing_time[k] = t;
                            }
                        }
                    }
                }
                if let Some(winv) = winv.as_deref_mut() {
                    if !self.supported[near] {
                        self.unconstrained[near] = winv[near];
                    }
                    // a node already held along (nearly) this normal keeps its other
                    // freedoms: pinned to a line by two nearly parallel or opposite
                    // normals (a node squeezed between two fibres that overlap it from
                    // both sides), the projection restores the lengths by sliding it far
                    // along that line, and the slide becomes velocity (tens of m/s in one
                    // step in the Table 4 web)
                    if held_fraction(&winv[near], &self.unconstrained[near], n) < HELD_ALREADY {
                        winv[near] = without_direction(&winv[near], n);
                    }
                }
                self.supported[near] = true;
                if vn == target || in_air {
                    continue;
                }
                let delta = target - vn;
                let mobility = Mobility { winv: winv.as_deref(), supported: &self.supported, unconstrained: &self.unconstrained, mass: &rod.mass, free: &free };
                if !mobility.shift(&mut rod.v, i, j, s, scale(n, share * delta)) {
                    continue;
                }
                if let Some(mu) = self.friction {
                    let wt = sub(vrel, scale(n, vn));
                    let wtn = norm(wt);
                    if wtn > 0.0 {
                        let removed = if wtn <= mu * delta { 1.0 } else { mu * delta / wtn };
                        mobility.shift(&mut rod.v, i, j, s, scale(wt, -share * removed));
                    }
                }
                row_speed = speed(rod.v[i]).max(speed(rod.v[j]));
                limit = self.pair_limit(k, dt, row_speed);
                impulses += 1;
            }
            self.close_row(k, least);
        }
        self.impulses += impulses;
        self.pairs_skipped += skipped;
    }

    /// Candidate c of own segment k (nodes `x`) in a pass at time `t`, its segment's
    /// pairs having the skip limit `limit` ([`FibreContact::pair_limit`]): skipped (None)
    /// when pruning is on and the gap bound shows the pair cannot reach contact within
    /// the pass's step, else measured ([`FibreContact::test_pair`]). Also returns the
    /// pair's bound less the obstacle's reach (after the measurement, if any), for the
    /// row's least ([`FibreContact::close_row`]).
    #[inline(always)]
    fn visit_pair(&mut self, x: &[[f64; 3]], k: usize, c: usize, t: f64, limit: f64) -> (Option<PairTest>, f64) {
        let reach = self.obstacle_reach[self.candidates[c] as usize];
        let lower = self.gap_bound[c] - reach;
        if self.pruning && lower > limit {
            return (None, lower);
        }
        let test = self.test_pair(x, k, c, t);
        (Some(test), self.gap_bound[c] - reach)
    }

    /// Measure own segment k (of nodes `x`) against candidate c's obstacle at time `t`:
    /// their closest points, which renew the pair's gap bound.
    fn test_pair(&mut self, x: &[[f64; 3]], k: usize, c: usize, t: f64) -> PairTest {
        let q = self.candidates[c] as usize;
        self.pair_tests += 1;
        let (q0, q1) = self.obstacles[q].at(t);
        let (s, u, gap) = closest_points(x[k], x[k + 1], q0, q1);
        let g = norm(gap);
        self.gap_bound[c] = g + self.pair_travel(k, q);
        PairTest { q, s, u, gap, g, q0, q1 }
    }

    /// The skip limit of own segment k's pairs in a pass: d plus the travel of its nodes
    /// and what they can move in the step `dt` at `speed` (see [`FibreContact::test_pair`]).
    fn pair_limit(&self, k: usize, dt: f64, speed: f64) -> f64 {
        self.diameter + self.travel[k] + self.travel[k + 1] + dt * speed
    }

    /// Before a pass with step `dt`: the sizes of the per-candidate and per-row bounds,
    /// and each obstacle's reach (its travel plus what it can move in the step).
    fn begin_pass(&mut self, dt: f64) {
        self.gap_bound.resize(self.candidates.len(), f64::NEG_INFINITY);
        self.row_bound.resize(self.rows.len().saturating_sub(1), f64::NEG_INFINITY);
        let (travel, speed, reach) = (&self.obstacle_travel, &self.obstacle_speed, &mut self.obstacle_reach);
        reach.clear();
        reach.extend(travel.iter().enumerate().map(|(q, t)| if dt > 0.0 { t + dt * speed.get(q).copied().unwrap_or(f64::INFINITY) } else { *t }));
    }

    /// The share of candidate c (own segment k, obstacle q) the velocity pass skipped,
    /// from the start-of-step state, as that pass would have settled it.
    fn share_at_start(&self, k: usize, q: usize) -> f64 {
        let ob = &self.obstacles[q];
        let (q0, q1) = ob.at(self.t_start);
        let (s, u, gap) = closest_points(self.x_start[k], self.x_start[k + 1], q0, q1);
        let near = if s < 0.5 { k } else { k + 1 };
        // skipped only when farther apart than d, so never crossed
        yield_share(ob, u, gap[2], self.diameter, self.held_start[near])
    }

    /// Position pass at the end of a step (time `t`, step `dt`): pushes pairs closer
    /// than (1 − SLOP) d apart towards d, each by the share the velocity pass settled and
    /// by at most [`MAX_SEPARATION_SPEED`]·Δt. Returns the
    /// corrections made and the deepest penetration d − g found before correcting (m).
    pub fn push_apart(&mut self, rod: &mut Rod, winv: Option<&[[f64; 6]]>, t: f64, dt: f64, free: FreeNodes) -> (usize, f64) {
        let d = self.diameter;
        let max_push = MAX_SEPARATION_SPEED * dt / POSITION_ROUNDS as f64;
        let (mut count, mut skipped) = (0, 0);
        let mut deepest = 0.0f64;
        self.update_travel(&rod.x, t, false);
        self.begin_pass(0.0);
        let unset = RoundList { len: 0, own_travel: f64::NAN, drift: f64::NAN, least_left_out: f64::NEG_INFINITY };
        self.round_rows.resize(self.rows.len().saturating_sub(1), unset);
        self.round_pairs.resize(self.candidates.len(), 0);
        let mut visit = std::mem::take(&mut self.visit);
        let margin = ROUND_MARGIN * d;
        for k in 0..rod.rest.len() {
            let (i, j) = (k, k + 1);
            if self.skip_row(k, 0.0) {
                continue;
            }
            let row = k + self.dropped;
            let candidates = self.row(k);
            let own_travel = self.travel[i] + self.travel[j];
            let list = self.round_rows[row];
            let reuse = self.pruning && list.drift == self.obstacle_drift && own_travel - list.own_travel < margin;
            visit.clear();
            let mut least = f64::INFINITY;
            if reuse {
                visit.extend_from_slice(&self.round_pairs[candidates.start..candidates.start + list.len as usize]);
                skipped += (candidates.len() - visit.len()) as u64;
                least = list.least_left_out;
            } else {
                visit.extend(candidates.clone().map(|c| c as u32));
            }
            let (mut kept, mut least_left_out) = (0, f64::INFINITY);
            let mut limit = self.pair_limit(k, 0.0, 0.0);
            for &c in &visit {
                let c = c as usize;
                let (test, lower) = self.visit_pair(&rod.x, k, c, t, limit);
                least = least.min(lower);
                if !reuse {
                    if lower <= limit + margin {
                        self.round_pairs[candidates.start + kept] = c as u32;
                        kept += 1;
                    } else {
                        least_left_out = least_left_out.min(lower);
                    }
                }
                let Some(PairTest { q, s, gap, g, .. }) = test else {
                    skipped += 1;
                    continue;
                };
                if !(g < d) {
                    continue;
                }
                deepest = deepest.max(d - g);
                let mut share = self.shares.get(c).copied().unwrap_or(1.0);
                if share.is_nan() {
                    share = self.share_at_start(k, q);
                    self.shares[c] = share;
                }
                if g >= (1.0 - SLOP) * d || !(g > 0.0) || share == 0.0 {
                    continue;
                }
                let dx = scale(gap, share * (d - g).min(max_push) / g);
                let mobility = Mobility { winv, supported: &self.supported, unconstrained: &self.unconstrained, mass: &rod.mass, free: &free };
                let (xi, xj) = (rod.x[i], rod.x[j]);
                if mobility.shift(&mut rod.x, i, j, s, dx) {
                    count += 1;
                    if let (Some(si), Some(sj)) = (self.shift.get(i).copied(), self.shift.get(j).copied()) {
                        self.shift[i] = add_scaled(si, sub(rod.x[i], xi), 1.0);
                        self.shift[j] = add_scaled(sj, sub(rod.x[j], xj), 1.0);
                    }
                    // the later pairs of this pass, and of the later rounds, see the move
                    for m in [i, j] {
                        let step = norm(sub(rod.x[m], self.last_x[m]));
                        self.travel[m] += step;
                        self.last_x[m] = rod.x[m];
                    }
                    limit = self.pair_limit(k, 0.0, 0.0);
                }
            }
            if !reuse {
                self.round_rows[row] = RoundList { len: kept as u32, own_travel, drift: self.obstacle_drift, least_left_out };
            }
            self.close_row(k, least);
        }
        self.visit = visit;
        self.corrections += count as u64;
        self.pairs_skipped += skipped;
        (count, deepest)
    }
}

/// How far, in diameters, a candidate's gap bound may lie beyond contact and still be
/// visited by the later position rounds of a step ([`RoundList`]).
const ROUND_MARGIN: f64 = 0.5;

/// The candidates of one row that the position rounds of a step visit: those whose bound
/// was within [`ROUND_MARGIN`] d of the skip limit when the list was made. It serves
/// while no obstacle has moved (`drift` is still the obstacles' drift) and the row's
/// nodes have travelled less than the margin since (`own_travel`): every candidate left
/// out is then still skipped, so the rounds correct exactly what visiting every
/// candidate would. `least_left_out` is the least bound among those left out, for the
/// row's least ([`FibreContact::close_row`]).
#[derive(Clone, Copy, Debug)]
struct RoundList {
    len: u32,
    own_travel: f64,
    drift: f64,
    least_left_out: f64,
}

/// A pair tested by [`FibreContact::test_pair`]: obstacle q at the time of the test (end
/// points q0, q1), the closest points' parameters s (own) and u (obstacle), the gap
/// vector between them (obstacle to own) and its length g.
struct PairTest {
    q: usize,
    s: f64,
    u: f64,
    gap: [f64; 3],
    g: f64,
    q0: [f64; 3],
    q1: [f64; 3],
}

/// Whether the belt holds node `k`: it has landed and lies on the belt (within the
/// contact tolerance [`SLOP`] d of the plane) or is not rising off it (`v` its velocity
/// before fibre contact in the step). A landed node that fibre tension or a fibre below it
/// lifts off the belt is not held: a fibre lying on it must not take the whole
/// correction, or it is carried up with it.
pub fn on_belt(k: usize, landing_time: &[f64], x: &[[f64; 3]], v: &[[f64; 3]], d: f64) -> bool {
    landing_time[k].is_finite() && (x[k][2] <= SLOP * d || v[k][2] <= 0.0)
}

/// Height difference, in diameters, below which two simulated fibres in contact are
/// side by side and share the correction.
pub const SIDE_BY_SIDE: f64 = 0.1;

/// The share of a contact's correction this rod takes, `dz` = z_P − z_Q the height of
/// its contact point above the obstacle's: all of it against a frozen or held segment.
/// Against another simulated fibre: if the lower of the two is held at the contact
/// (the segment end nearer the contact point, at `u` along the obstacle, lies on the belt
/// or rests on the web: [`FibreContact::rests`]), the upper one takes it all; otherwise, and side by side (|dz| < 0.1 d),
/// each takes ½ (equal masses per length; momentum is exchanged, not made, only where the
/// two contact points are alike, both at nodes or both mid-segment; below z0 such
/// pairs are solved for both fibres at once, [`air`]). Both rods evaluate the same rule on
/// the same data, so a contact is shared once.
pub fn yield_share(ob: &ObstacleSegment, u: f64, dz: f64, d: f64, own_landed: bool) -> f64 {
    let ob_landed = ob.landed[usize::from(u >= 0.5)];
    if !ob.simulated {
        1.0
    } else if dz > SIDE_BY_SIDE * d && ob_landed {
        1.0
    } else if dz < -SIDE_BY_SIDE * d && own_landed {
        0.0
    } else {
        0.5
    }
}

/// Fraction of a node's freedom along n that the contacts before took away (1 − nᵀWn /
/// nᵀW₀n, W₀ its inverse node matrix before the velocity pass) above which it counts as
/// held along n already: n then lies within 45° of the directions held (W₀ isotropic).
const HELD_ALREADY: f64 = 0.5;

/// 1 − nᵀ W n / nᵀ W₀ n: how much of the freedom along n that W₀ gives W no longer has.
fn held_fraction(w: &[f64; 6], w0: &[f64; 6], n: [f64; 3]) -> f64 {
    let before = dot(n, super::forces::sym_mul(w0, &n));
    if !(before > 0.0) {
        return 1.0;
    }
    1.0 - dot(n, super::forces::sym_mul(w, &n)) / before
}

/// W − (W n)(W n)ᵀ/(nᵀ W n): the symmetric inverse mass W [xx, yy, zz, xy, xz, yz] with
/// no freedom along the unit vector n (unchanged if it has none already).
fn without_direction(w: &[f64; 6], n: [f64; 3]) -> [f64; 6] {
    let wn = super::forces::sym_mul(w, &n);
    let nwn = dot(n, wn);
    if !(nwn > 1e-12 * (w[0] + w[1] + w[2])) {
        return *w;
    }
    let r = 1.0 / nwn;
    [
        w[0] - wn[0] * wn[0] * r,
        w[1] - wn[1] * wn[1] * r,
        w[2] - wn[2] * wn[2] * r,
        w[3] - wn[0] * wn[1] * r,
        w[4] - wn[0] * wn[2] * r,
        w[5] - wn[1] * wn[2] * r,
    ]
}

/// How the nodes of the rod respond to a change asked of a point of a segment: the
/// inverse node matrices W_k of the step (the projection schemes' effective inverse
/// masses, which already hold a node stuck on the belt fixed and a sliding one in plane),
/// or 1/m for the free nodes.
struct Mobility<'a> {
    winv: Option<&'a [[f64; 6]]>,
    /// Supported nodes move with their W from before the velocity pass (`unconstrained`).
    supported: &'a [bool],
    unconstrained: &'a [[f64; 6]],
    mass: &'a [f64],
    free: &'a FreeNodes,
}

impl Mobility<'_> {
    fn along(&self, k: usize, u: [f64; 3]) -> [f64; 3] {
        match self.winv {
            Some(_) if self.supported.get(k) == Some(&true) => super::forces::sym_mul(&self.unconstrained[k], &u),
            Some(w) => super::forces::sym_mul(&w[k], &u),
            None if self.free.contains(&k) => scale(u, 1.0 / self.mass[k]),
            None => [0.0; 3],
        }
    }

    /// Change the point P(s) = (1 − s) q_i + s q_j of `q` (velocities or positions) by
    /// `change`: along u = change/|change|, q_k += β_k λ W_k u with λ = |change| /
    /// Σ β_k² uᵀW_k u (β = (1 − s, s)), so that the point moves by exactly `change` along
    /// u. Refused (false, nothing changed) where the point can hardly move: an effective
    /// mobility below a quarter of the larger end's (near a held end the free one would
    /// need 1/s times the change), such a contact is left to the held node.
    fn shift(&self, q: &mut [[f64; 3]], i: usize, j: usize, s: f64, change: [f64; 3]) -> bool {
        let size = norm(change);
        if !(size > 0.0) {
            return true;
        }
        let u = scale(change, 1.0 / size);
        let (wi, wj) = (self.along(i, u), self.along(j, u));
        let Some(effective) = point_mobility(u, wi, wj, s) else { return false };
        let lambda = size / effective;
        q[i] = add_scaled(q[i], wi, (1.0 - s) * lambda);
        q[j] = add_scaled(q[j], wj, s * lambda);
        true
    }
}

/// The mobility along the unit vector `u` of the point at `s` of a segment whose nodes
/// respond to a unit impulse along u with `wi` and `wj`: Σ β_k² uᵀW_k u (β = (1 − s, s)).
/// None where the point can hardly move: below a quarter of the more mobile node's
/// mobility (near a held node the free one would need 1/s times the change), such a
/// contact is left to the held node.
pub(super) fn point_mobility(u: [f64; 3], wi: [f64; 3], wj: [f64; 3], s: f64) -> Option<f64> {
    let (mi, mj) = (dot(u, wi), dot(u, wj));
    let effective = (1.0 - s) * (1.0 - s) * mi + s * s * mj;
    (mi.max(mj) > 0.0 && effective >= 0.25 * mi.max(mj)).then_some(effective)
}

/// Closest points of segments p0-p1 and q0-q1: (s, u, P(s) − Q(u)) with
/// P(s) = p0 + s (p1 − p0), Q(u) = q0 + u (q1 − q0), s, u ∈ [0, 1] (Ericson,
/// Real-Time Collision Detection §5.1.9; parallel segments give one of the closest pairs).
pub fn closest_points(p0: [f64; 3], p1: [f64; 3], q0: [f64; 3], q1: [f64; 3]) -> (f64, f64, [f64; 3]) {
    let d1 = sub(p1, p0);
    let d2 = sub(q1, q0);
    let r = sub(p0, q0);
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let tiny = 1e-300;
    let (s, u) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = dot(d1, r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-14 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut u = (b * s + f) / e;
            if u < 0.0 {
                u = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if u > 1.0 {
                u = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, u)
        }
    };
    let p = add_scaled(p0, d1, s);
    let q = add_scaled(q0, d2, u);
    (s, u, sub(p, q))
}

#[inline]
pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(super) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
#[inline]
pub(super) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
pub(super) fn add_scaled(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}
#[inline]
pub(super) fn lerp(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), a[2] + s * (b[2] - a[2])]
}

#[path = "fibre_contact_air.rs"]
pub mod air;

#[cfg(test)]
#[path = "fibre_contact_tests.rs"]
mod tests;
