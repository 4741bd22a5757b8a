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
//!   (among the first N − N/2) closest to the fibre's state: least |Δr|² + ℓ²Δθ² with Δr
//!   the position and Δθ the tangent mismatch (wrapped), ℓ = 5Δs;
//! - the position mismatch is blended out linearly over the next K = min(20, N/10) nodes,
//!   so the fibre is continuous in position, its tangent turns by at most the small mismatch
//!   spread over K steps, and every node stays within the blend of its template's place
//!   relative to the feed axis.
//!
//! The fibre's deposition point is its starting point's (0, y_j); the web adds the belt
//! drift of eq 14 like the other generators.
use super::sde::Draws;
use crate::stages::spectra::wrap_angle;

/// One laid fibre ready to be walked along.
#[derive(Debug, Clone)]
struct Template {
    /// Nodes about the centroid, N + 1 (m).
    positions: Vec<[f64; 2]>,
    /// Tangent angle at each node (rad, the chord leaving it), N + 1.
    angles: Vec<f64>,
    /// Curvature samples κ_m (1/m), N.
    curvature: Vec<f64>,
}

/// The laid fibres of a `laid_segments` web with the matched join.
#[derive(Debug, Clone)]
pub struct LaidTemplates {
    templates: Vec<Template>,
    spacing: f64,
}

impl LaidTemplates {
    /// Templates from the laid fibres' resampled nodes (N + 1 each, at arc-length spacing
    /// `spacing`) and their curvature samples (N each).
    pub fn new(positions: &[Vec<[f64; 2]>], curvature: &[Vec<f64>], spacing: f64) -> Self {
        let templates = positions
            .iter()
            .zip(curvature)
            .map(|(nodes, kappa)| {
                // Tangent at a node: the direction of the chord leaving it (the last node's: the last chord's).
                let chord = |m: usize| (nodes[m + 1][1] - nodes[m][1]).atan2(nodes[m + 1][0] - nodes[m][0]);
                let n = nodes.len() - 1;
                let angles = (0..=n).map(|m| chord(m.min(n - 1))).collect();
                Template { positions: crate::geometry::centred(nodes), angles, curvature: kappa.clone() }
            })
            .collect();
        Self { templates, spacing }
    }

    /// N, samples per template.
    fn points(&self) -> usize {
        self.templates[0].curvature.len()
    }

    /// Walks a fibre of `samples` steps: fills `nodes` (samples + 1, belt removed, about
    /// the deposition point) and `curvature` (samples: the visited templates' κ, signed by
    /// their mirror). Draws per template entered: its index, its mirror flag (with
    /// `mirror`), then for the first template its starting node.
    pub(crate) fn walk(&self, draws: &mut Draws, mirror: bool, samples: usize, nodes: &mut Vec<[f64; 2]>, curvature: &mut Vec<f64>) {
        let n = self.points();
        let blend = (n / 10).clamp(1, 20);
        let last_entry = n - n / 2; // enter at m < N − N/2: at least N/2 samples before the next join
        let weight = (5.0 * self.spacing).powi(2);
        nodes.clear();
        curvature.clear();
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
                        continue; // the angle term only adds: this node cannot win
                    }
                    let d = position + weight * wrap_angle(angle(t1, sign1, m1) - end_angle).powi(2);
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
            let fade = (1.0 - since_join as f64 / blend as f64).max(0.0);
            let q = place(t, sign, m);
            nodes.push([q[0] + fade * offset[0], q[1] + fade * offset[1]]);
            curvature.push(sign * self.templates[t].curvature[m.min(n - 1)]);
        }
    }
}
