//! The `laid_segments` generator's matched join: laid fibres (belt removed, about their
//! feed axis, in their laid orientation) followed one after another, each entered at the
//! point where it best continues the previous one.
//!
//! A laid fibre coils and meanders around its feed axis; where it goes relative to that
//! axis, and the CD elongation the oscillation gives its path, are what a web's uniformity
//! depends on. Joining templates by integrating their curvature across the joins (the
//! `curvature` join) keeps each segment's shape but rotates every template to continue the
//! previous tangent and starts it where the previous one ended, so the fibre drifts away
//! from its hole and the meanders point every way. The matched join keeps both:
//!
//! - a template is the laid fibre's belt-removed nodes as the spectra stage resampled
//!   them (N + 1 at Δs), moved so that their centroid, taken as the feed axis, is the
//!   origin, and kept in their laid orientation (mirrored in CD, y → −y, with `mirror`).
//!   Not the curve its curvature samples rebuild: at u0 = 1 mm (coils of ~4 mm radius at
//!   Δs = 1 mm) that rebuild's coil centre drifts 7.9 mm over a laid fibre whose own
//!   belt-removed nodes stay within 0.3 mm of their axis;
//! - a fibre starts in a template drawn uniformly, at a uniform node; when the template
//!   runs out, the next template is drawn (and its mirror flag), and entered at the node m
//!   (among the first N − N/2) whose join bends least: least |Δr|² + ℓ²Δθ² with Δr the
//!   position and Δθ the tangent mismatch (wrapped);
//! - the position mismatch is blended out over the next K = min(40, N/5) nodes with the
//!   weight 1 − (3u² − 2u³), u = i/K, so the fibre is continuous in position and the blend
//!   starts and ends without a kink (for N < 10, K = 1 and the offset is taken in the first
//!   node after the join); every node stays within the blend of its template's place
//!   relative to the feed axis.
//!
//! ℓ weighs the two mismatches by the bending energy ∫κ² ds of the join itself, as on a
//! straight fibre: the tangent mismatch is a kink, Δθ²/Δs; the offset δ blended over
//! B = KΔs adds at most δ²/B³ ∫₀¹ w″(u)² du = 12 δ²/B³; hence ℓ² = B³/(12 Δs). (On a
//! curved template the kink also adds the cross term 2κΔθ, of either sign, which the
//! search leaves out; the blend's cross term averages out, ∫w″ du = 0.) K was chosen by
//! measuring the generated fibres' bending energy against the laid fibres'
//! (`pipelines/studies/PHYSICAL_WEBS.md`, "The matched join weighs what a join bends").
//! `LaidTemplates::walk` reads the curvature off the nodes it generates with the spectra
//! stage's function ([`crate::stages::spectra::turning_curvature`]; within a blend the
//! chords differ from Δs by up to 1.5δ/K, which it does not resample).
//!
//! Each template is walked to its end but entered in its first half, so a feature at the
//! end of a laid fibre (a fold near its last landed node) weighs up to 4/3 of its share
//! (e up to 17 % above the input in webs from 0.3 m laydowns; same section).
//!
//! The fibre's deposition point is its starting point's (0, y_j); the web adds the belt
//! drift of eq 14 like the other generators.
use super::sde::Draws;
use super::trig::widest_isa;

/// One laid fibre ready to be walked along.
#[derive(Debug, Clone)]
struct Template {
    /// Nodes about the centroid, N + 1 (m).
    positions: Vec<[f64; 2]>,
    /// Tangent angle at each node (rad, the chord leaving it), N + 1.
    angles: Vec<f64>,
}

/// The laid fibres of a `laid_segments` web with the matched join.
#[derive(Debug, Clone)]
pub struct LaidTemplates {
    templates: Vec<Template>,
    spacing: f64,
    /// K, nodes over which a join's offset is blended out.
    blend: usize,
    /// ℓ² (m²), the weight of the tangent mismatch in the entry search.
    angle_weight: f64,
}

/// Δθ² of a difference of tangent angles `a` (|a| < 4π), Δθ = a wrapped to [−π, π): by
/// `floor`, which vectorises, where `wrap_angle`'s `round` does not (`crate::stages::spectra::wrap_angle`).
#[inline(always)]
fn turn_squared(a: f64) -> f64 {
    let w = a - std::f64::consts::TAU * (a / std::f64::consts::TAU + 0.5).floor();
    w * w
}

/// The part of a join's offset left at the i-th node after it (i ≥ 1) with a blend over
/// `blend` = K nodes: 1 − (3u² − 2u³), u = i/K (0 from i = K on).
#[inline(always)]
fn fade(i: usize, blend: usize) -> f64 {
    let u = (i as f64 / blend as f64).min(1.0);
    1.0 - u * u * (3.0 - 2.0 * u)
}

impl LaidTemplates {
    /// Templates from the laid fibres' resampled nodes (N + 1 each, N ≥ 2, at arc-length
    /// spacing `spacing`).
    pub fn new(positions: &[Vec<[f64; 2]>], spacing: f64) -> Self {
        assert!(positions.iter().all(|p| p.len() >= 3 && p.len() <= i32::MAX as usize), "templates of 2 to 2³¹ − 1 samples");
        let templates: Vec<Template> = positions
            .iter()
            .map(|nodes| {
                // Tangent at a node: the direction of the chord leaving it (the last node's: the last chord's).
                let chord = |m: usize| crate::geometry::chord_angle(nodes[m], nodes[m + 1]);
                let n = nodes.len() - 1;
                let angles = (0..=n).map(|m| chord(m.min(n - 1))).collect();
                Template { positions: crate::geometry::centred(nodes), angles }
            })
            .collect();
        let n = templates.first().map_or(2, |t| t.positions.len() - 1);
        let blend = (n / 5).clamp(1, 40);
        // ℓ² = B³/(12 Δs), B = KΔs (module docs)
        let angle_weight = (blend as f64).powi(3) * spacing * spacing / 12.0;
        Self { templates, spacing, blend, angle_weight }
    }

    /// N, samples per template.
    fn points(&self) -> usize {
        self.templates[0].positions.len() - 1
    }

    /// Walks a fibre of `samples` steps: fills `nodes` (samples + 1, belt removed, about
    /// the deposition point) and `curvature` (samples: the curvature of those nodes as
    /// the spectra stage reads it off a laid fibre, joins and blends included). Draws per
    /// template entered: its index, its mirror flag (with `mirror`), then for the first
    /// template its starting node.
    pub(crate) fn walk(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, curvature: &mut Vec<f64>) {
        self.walk_with(draws, mirror, samples, nodes, |_, p| p);
        *curvature = crate::stages::spectra::turning_curvature(nodes, self.spacing);
    }

    /// The walk's nodes with `finish(k, node)` applied to node k (k as f64, exact) as it
    /// is written (the web adds the belt drift of eq 14 there), without the curvature
    /// samples. Compiled for the widest vector extension the CPU has (the same IEEE
    /// operations, so the same bits).
    pub(crate) fn walk_nodes(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, finish: impl Fn(f64, [f64; 2]) -> [f64; 2]) {
        widest_isa!(
            generic: self.walk_with(draws, mirror, samples, nodes, finish),
            avx2: self.walk_nodes_avx2(draws, mirror, samples, nodes, finish),
            avx512: self.walk_nodes_avx512(draws, mirror, samples, nodes, finish),
        )
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn walk_nodes_avx2(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, finish: impl Fn(f64, [f64; 2]) -> [f64; 2]) {
        self.walk_with(draws, mirror, samples, nodes, finish)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn walk_nodes_avx512(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, finish: impl Fn(f64, [f64; 2]) -> [f64; 2]) {
        self.walk_with(draws, mirror, samples, nodes, finish)
    }

    /// The walk. Between joins a template's nodes are copied run by run (the blend, then
    /// the rest, in loops that vectorise), and each join's entry node is found by
    /// [`Self::entry`].
    #[inline(always)]
    fn walk_with(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, finish: impl Fn(f64, [f64; 2]) -> [f64; 2]) {
        let n = self.points();
        let blend = self.blend;
        let last_entry = n - n / 2; // enter at m < N − N/2: at least N/2 samples before the next join
        nodes.clear();
        nodes.reserve(samples + 1);
        let pick = |draws: &mut Draws| {
            let t = ((draws.uniform() * self.templates.len() as f64) as usize).min(self.templates.len() - 1);
            let sign = if mirror && draws.uniform() < 0.5 { -1.0 } else { 1.0 };
            (t, sign)
        };
        let (mut t, mut sign) = pick(draws);
        let mut m = ((draws.uniform() * n as f64) as usize).min(n - 1);
        let mut offset = [0.0, 0.0];
        let mut since_join = blend;
        let p = self.templates[t].positions[m];
        // The last node written, before `finish` (the state the next join continues).
        let mut end = [p[0], sign * p[1]];
        nodes.push(finish(0.0, end));
        let mut position = Vec::new();
        while nodes.len() < samples + 1 {
            if m == n {
                let end_angle = sign * self.templates[t].angles[m];
                let (t1, sign1) = pick(draws);
                (t, sign, m) = (t1, sign1, self.entry(t1, sign1, end, end_angle, last_entry.max(1), &mut position));
                let p = self.templates[t].positions[m];
                offset = [end[0] - p[0], end[1] - sign * p[1]];
                since_join = 0;
            }
            // Nodes m + 1 ..= m + run of template t: node i after the join keeps
            // fade(i) of the offset (exactly 0 from i = K on, where it is not computed).
            let run = (n - m).min(samples + 1 - nodes.len());
            let template = &self.templates[t];
            let k0 = nodes.len();
            let blended = blend.saturating_sub(since_join).min(run);
            let fade = |i: usize| fade(since_join + 1 + i, blend);
            let place = |i: usize, f: f64| {
                let p = template.positions[m + 1 + i];
                [p[0] + f * offset[0], sign * p[1] + f * offset[1]]
            };
            // k as f64: the run's first k (exact) plus i < N < 2³¹ (exact, and a
            // conversion every vector extension has).
            let (base, rest_base) = (k0 as f64, (k0 + blended) as f64);
            let out = &mut nodes.spare_capacity_mut()[..run];
            for (i, o) in out[..blended].iter_mut().enumerate() {
                o.write(finish(base + (i as i32) as f64, place(i, fade(i))));
            }
            let zero = [0.0 * offset[0], 0.0 * offset[1]]; // the fade-0 term, signed zeros kept
            let rest = &template.positions[m + 1 + blended..m + 1 + run];
            for (i, (o, p)) in out[blended..].iter_mut().zip(rest).enumerate() {
                o.write(finish(rest_base + (i as i32) as f64, [p[0] + zero[0], sign * p[1] + zero[1]]));
            }
            // SAFETY: the `run` nodes after the first k0 were all written just above.
            unsafe { nodes.set_len(k0 + run) };
            end = place(run - 1, fade(run - 1));
            m += run;
            since_join += run;
        }
    }

    /// The node of template `t1` (mirrored with `sign1` = −1) among its first `candidates`
    /// at which the fibre, at `end` with tangent angle `end_angle`, enters it: the least
    /// |Δr|² + ℓ²Δθ² (ℓ² = `angle_weight`, Δθ wrapped), the first such node on ties. The
    /// mismatch of every candidate is computed in one pass that vectorises (with ℓ of tens
    /// of Δs, skipping the candidates whose position term alone exceeds the nearest one's
    /// mismatch skips few), then the first least is found.
    #[inline(always)]
    fn entry(&self, t1: usize, sign1: f64, end: [f64; 2], end_angle: f64, candidates: usize, cost: &mut Vec<f64>) -> usize {
        const LANES: usize = 8;
        let template = &self.templates[t1];
        let weight = self.angle_weight;
        let mismatch = |p: &[f64; 2], angle: f64| (p[0] - end[0]).powi(2) + (sign1 * p[1] - end[1]).powi(2) + weight * turn_squared(sign1 * angle - end_angle);
        cost.clear();
        cost.resize(candidates, 0.0);
        let mut least = [f64::INFINITY; LANES];
        let (nodes, angles) = (&template.positions[..candidates], &template.angles[..candidates]);
        let whole = candidates - candidates % LANES;
        for ((out, p), a) in cost[..whole].chunks_exact_mut(LANES).zip(nodes[..whole].chunks_exact(LANES)).zip(angles[..whole].chunks_exact(LANES)) {
            for l in 0..LANES {
                out[l] = mismatch(&p[l], a[l]);
                least[l] = if out[l] < least[l] { out[l] } else { least[l] };
            }
        }
        for ((out, p), a) in cost[whole..].iter_mut().zip(&nodes[whole..]).zip(&angles[whole..]) {
            *out = mismatch(p, *a);
            least[0] = if *out < least[0] { *out } else { least[0] };
        }
        let least = least.iter().fold(f64::INFINITY, |a, &b| if b < a { b } else { a });
        cost.iter().position(|&d| d == least).expect("finite template nodes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::rand_core::SeedableRng;

    impl LaidTemplates {
        /// The walk as first written (one node at a time, every candidate scanned), which
        /// the run-by-run walk and the vectorised entry search must reproduce bit for bit.
        fn walk_reference(&self, draws: &mut Draws, mirror: bool, samples: usize) -> Vec<[f64; 2]> {
            let n = self.points();
            let blend = self.blend;
            let last_entry = n - n / 2;
            let weight = self.angle_weight;
            let mut nodes = Vec::new();
            let pick = |draws: &mut Draws| {
                let t = ((draws.uniform() * self.templates.len() as f64) as usize).min(self.templates.len() - 1);
                let sign = if mirror && draws.uniform() < 0.5 { -1.0 } else { 1.0 };
                (t, sign)
            };
            let place = |t: usize, sign: f64, m: usize| {
                let p = self.templates[t].positions[m];
                [p[0], sign * p[1]]
            };
            let angle = |t: usize, sign: f64, m: usize| sign * self.templates[t].angles[m];
            let (mut t, mut sign) = pick(draws);
            let mut m = ((draws.uniform() * n as f64) as usize).min(n - 1);
            let mut offset = [0.0, 0.0];
            let mut since_join = blend;
            nodes.push(place(t, sign, m));
            while nodes.len() < samples + 1 {
                if m == n {
                    let end = *nodes.last().expect("a node");
                    let end_angle = angle(t, sign, m);
                    let (t1, sign1) = pick(draws);
                    let mut best = (f64::INFINITY, 0);
                    for m1 in 0..last_entry.max(1) {
                        let q = place(t1, sign1, m1);
                        let position = (q[0] - end[0]).powi(2) + (q[1] - end[1]).powi(2);
                        if position >= best.0 {
                            continue;
                        }
                        let d = position + weight * turn_squared(angle(t1, sign1, m1) - end_angle);
                        if d < best.0 {
                            best = (d, m1);
                        }
                    }
                    (t, sign, m) = (t1, sign1, best.1);
                    let q = place(t, sign, m);
                    offset = [end[0] - q[0], end[1] - q[1]];
                    since_join = 0;
                }
                m += 1;
                since_join += 1;
                let fade = if since_join >= blend { 0.0 } else { fade(since_join, blend) };
                let q = place(t, sign, m);
                nodes.push([q[0] + fade * offset[0], q[1] + fade * offset[1]]);
            }
            nodes
        }
    }

    /// Templates like laid fibres: random-walk curvature integrated, some of them short
    /// coils so that joins often have several near candidates (and exact ties: template 0
    /// is repeated).
    fn templates(count: usize, n: usize, spacing: f64, seed: u64) -> LaidTemplates {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut draws = Draws::new(&mut rng);
        let mut positions = Vec::new();
        for i in 0..count {
            let kappa: Vec<f64> = (0..n).map(|_| if i % 2 == 0 { 200.0 + 100.0 * (draws.uniform() - 0.5) } else { 600.0 * (draws.uniform() - 0.5) }).collect();
            positions.push(crate::stages::spectra::integrate_curvature(&kappa, spacing, 0.0, [0.0, 0.0], 0.0).iter().map(|p| [p[0], p[1]]).collect::<Vec<_>>());
        }
        positions.push(positions[0].clone());
        LaidTemplates::new(&positions, spacing)
    }

    #[test]
    fn walk_matches_the_plain_walk_bit_for_bit() {
        for (count, n, samples, mirror, seed) in [(7, 1000, 20_000, false, 1), (7, 1000, 20_000, true, 2), (3, 40, 1234, true, 3), (2, 7, 100, false, 4), (5, 2, 9, true, 5)] {
            let walk = templates(count, n, 1e-3, seed);
            for fibre in 0..4u64 {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(100 * seed + fibre);
                let want = walk.walk_reference(&mut Draws::new(&mut rng), mirror, samples);
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(100 * seed + fibre);
                let (mut nodes, mut kappa) = (Vec::new(), Vec::new());
                walk.walk(&mut Draws::new(&mut rng), mirror, samples, &mut nodes, &mut kappa);
                let bits = |v: &[[f64; 2]]| v.iter().flat_map(|p| [p[0].to_bits(), p[1].to_bits()]).collect::<Vec<_>>();
                assert_eq!(bits(&nodes), bits(&want), "nodes, templates {count} × {n}, mirror {mirror}, fibre {fibre}");
                let want_kappa = crate::stages::spectra::turning_curvature(&want, 1e-3);
                assert_eq!(kappa.iter().map(|k| k.to_bits()).collect::<Vec<_>>(), want_kappa.iter().map(|k| k.to_bits()).collect::<Vec<_>>());
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(100 * seed + fibre);
                let mut drifted = Vec::new();
                walk.walk_nodes(&mut Draws::new(&mut rng), mirror, samples, &mut drifted, |k, p| [p[0] + k * 2e-5, p[1] + 0.1]);
                let want_drifted: Vec<[f64; 2]> = want.iter().enumerate().map(|(k, p)| [p[0] + k as f64 * 2e-5, p[1] + 0.1]).collect();
                assert_eq!(bits(&drifted), bits(&want_drifted));
            }
        }
    }
}
