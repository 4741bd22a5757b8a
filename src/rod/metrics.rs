//! Result of one replicate and the shape measures of the laid fibre.

use super::integrator::{EnergySample, TimeStepLimits};
use super::lift_watch::LiftWatch;
use super::params::{BounceCheck, LaydownParams};
use crate::geometry::{bending_energy, radius_of_gyration};

/// A column of the stored energy diagnostics: its name and its value in a record.
pub type EnergyColumn = (&'static str, fn(&EnergySample) -> f64);

/// The columns of a replicate's stored energy diagnostics (the laydown stage's
/// `energy_diagnostics`, along its `diagnostic` dimension), in order: the time (s), the
/// kinetic and elastic energy and the cumulative work of every source that acts in a
/// laydown (J), so that kinetic + elastic − Σ work_* is constant up to the integrator's
/// error (`rod::energy_tests`). `Work::clamp` and `Work::transport` are the continuous
/// feed's only, zero here.
pub const ENERGY_COLUMNS: &[EnergyColumn] = &[
    ("time", |d| d.time),
    ("kinetic", |d| d.kinetic),
    ("elastic", |d| d.elastic),
    ("work_drag", |d| d.work.drag),
    ("work_friction", |d| d.work.friction),
    ("work_gravity", |d| d.work.gravity),
    ("work_oscillation", |d| d.work.oscillation),
    ("work_damping", |d| d.work.damping),
    ("work_contact", |d| d.work.contact),
    ("work_feed", |d| d.work.feed),
];

/// Why a run bounced by `p.bounce_check` (None: it did not): the highest landed node in
/// the final profile `final_highest` = (node, height above the belt) for `final`, the
/// highest rise after landing `lifted` = (node, height) for `transient` (None: the run
/// kept no lift history, as a fed fibre does not for its frozen nodes), the last-period
/// `watch` for `last_period`. A run that kept neither is not judged valid.
pub(crate) fn bounce_reason(p: &LaydownParams, final_highest: (usize, f64), lifted: Option<(usize, f64)>, watch: Option<&LiftWatch>) -> Option<String> {
    match p.bounce_check {
        BounceCheck::Final => (final_highest.1 > p.bounce_tolerance).then(|| {
            format!(
                "bounced: landed node {} is {:.3e} m above the belt in the final profile (bounce_tolerance {:.3e} m)",
                final_highest.0, final_highest.1, p.bounce_tolerance
            )
        }),
        BounceCheck::LastPeriod => match watch {
            Some(w) => w.bounced().then(|| w.bounce_reason()),
            None => Some("bounce_check last_period, but the run kept no lift watch".into()),
        },
        BounceCheck::Transient => match lifted {
            Some((node, height)) => (height > p.bounce_tolerance).then(|| {
                format!(
                    "bounced: node {node} rose {height:.3e} m above the belt after landing (bounce_tolerance {:.3e} m, bounce_check transient)",
                    p.bounce_tolerance
                )
            }),
            None => Some("bounce_check transient, but the run kept no lift history".into()),
        },
    }
}

/// Everything one replicate produces (a plain struct the pipeline stage stores).
#[derive(Clone, Debug, PartialEq)]
pub struct LaydownResult {
    /// Final node positions, (N+1) × 3 (m). Never NaN: after a failure, the last good state.
    pub positions: Vec<[f64; 3]>,
    /// Time each node first touched the belt (s); NaN = never landed.
    pub landing_time: Vec<f64>,
    /// False when a landed node is above `bounce_tolerance` (in the final profile, or at
    /// any time with `bounce_check` = transient; the paper rejects such bounced fibres)
    /// or when the run failed.
    pub valid: bool,
    pub invalid_reason: Option<String>,
    /// Highest rise of any node above the belt after its landing, at any time (m);
    /// compared with `bounce_tolerance` for `valid` when `bounce_check` = transient.
    pub max_lift_after_landing: f64,
    /// Highest landed node above the belt in the final profile (m); compared with
    /// `bounce_tolerance` for `valid` when `bounce_check` = final (the default).
    pub final_lift_of_landed: f64,
    /// Share of the last oscillation period in which a landed node stood above
    /// `bounce_tolerance` (`bounce_check` = last_period, which invalidates the replicate
    /// above one half; NaN with the other checks, or when nothing landed within the
    /// window).
    pub lifted_fraction: f64,
    /// Per node: highest rise above the belt after landing (m, 0 = never rose or never landed).
    pub lift: Vec<f64>,
    /// Per node: time of that highest rise (s, NaN = never rose).
    pub lift_time: Vec<f64>,
    /// Laid nodes (those that landed), in fibre order.
    pub landed_nodes: usize,
    /// Arc length of the laid polyline (m).
    pub laid_length: f64,
    /// S (eq 5) of the laid nodes projected on the belt plane (m).
    pub radius_of_gyration: f64,
    /// e = V_b L / EI (eq 6) of the laid nodes projected on the belt plane.
    pub bending_energy: f64,
    /// The laid nodes with the belt motion removed (by the scene's `belt_removal`).
    pub laid_belt_removed: Vec<[f64; 3]>,
    /// S of `laid_belt_removed` (m).
    pub radius_of_gyration_belt_removed: f64,
    /// e with the belt motion removed.
    pub bending_energy_belt_removed: f64,
    /// Opt-in twist ([`super::twist`]), at the end of the run: the hanging span's twist
    /// rate Ω (rad/m) and the twist laid down with the fibre, Σ τ over the laid nodes
    /// (rad); 0 without twist.
    pub twist_rate: f64,
    pub laid_twist: f64,
    /// Energy records every `diagnostic_stride` steps and at the end.
    pub diagnostics: Vec<EnergySample>,
    pub steps: u64,
    /// Time step used (s): the fixed step (explicit) or the largest allowed step (adaptive).
    pub time_step: f64,
    /// Smallest step taken (s).
    pub min_time_step: f64,
    /// Steps rejected and retaken with a smaller step (adaptive schemes).
    pub rejected_steps: u64,
    /// Times the run was rolled back to a checkpoint after a failed step and the stretch
    /// retaken ([`super::recovery`]).
    pub rollbacks: usize,
    /// Newton iterations of the length projection (tridiagonal solves, summed over runs).
    pub projection_iterations: u64,
    pub time_step_limits: Option<TimeStepLimits>,
    /// Simulated time reached (s).
    pub end_time: f64,
    /// Elements actually used (after `coil_resolution`).
    pub elements: usize,
    /// Deepest belt penetration before correction (m).
    pub max_penetration: f64,
    /// Largest relative segment-length error left by the projection (inextensible).
    pub max_constraint_error: f64,
    pub wall_seconds: f64,
    /// Set when the replicate could not be completed (bad parameters, unstable step…).
    pub error: Option<String>,
    /// Non-fatal remarks (e.g. resolution).
    pub warnings: Vec<String>,
}

impl LaydownResult {
    /// One line with the outcome, shape measures and cost of the replicate (for tools and
    /// test output).
    pub fn summary(&self) -> String {
        format!(
            "err={:?} valid={} lift={:.2e} reason={:?} landed={} laid={:.4} S={:.5} e={:.1} S_rm={:.5} e_rm={:.1} steps={} rej={} rb={} dt={:.3e} mindt={:.2e} wall={:.2}s pen={:.2e} cons={:.1e}",
            self.error, self.valid, self.max_lift_after_landing, self.invalid_reason, self.landed_nodes, self.laid_length, self.radius_of_gyration,
            self.bending_energy, self.radius_of_gyration_belt_removed, self.bending_energy_belt_removed, self.steps, self.rejected_steps, self.rollbacks, self.time_step,
            self.min_time_step, self.wall_seconds, self.max_penetration, self.max_constraint_error
        )
    }
    /// A result for a run that could not start.
    pub fn failed(error: String) -> Self {
        LaydownResult {
            positions: Vec::new(),
            landing_time: Vec::new(),
            valid: false,
            invalid_reason: Some(error.clone()),
            max_lift_after_landing: 0.0,
            lift: Vec::new(),
            final_lift_of_landed: 0.0,
            lifted_fraction: f64::NAN,
            lift_time: Vec::new(),
            landed_nodes: 0,
            laid_length: 0.0,
            radius_of_gyration: 0.0,
            bending_energy: 0.0,
            laid_belt_removed: Vec::new(),
            radius_of_gyration_belt_removed: 0.0,
            bending_energy_belt_removed: 0.0,
            twist_rate: 0.0,
            laid_twist: 0.0,
            diagnostics: Vec::new(),
            steps: 0,
            time_step: 0.0,
            min_time_step: 0.0,
            rejected_steps: 0,
            rollbacks: 0,
            projection_iterations: 0,
            time_step_limits: None,
            end_time: 0.0,
            elements: 0,
            max_penetration: 0.0,
            max_constraint_error: 0.0,
            wall_seconds: 0.0,
            error: Some(error),
            warnings: Vec::new(),
        }
    }

    /// Same result with the wall time zeroed (for bit-for-bit comparisons).
    pub fn without_wall_time(mut self) -> Self {
        self.wall_seconds = 0.0;
        self
    }
}

crate::params::choice_enum! {
    /// How the belt motion is taken off laid nodes (the paper's dashed lines, Figs 5-6).
    pub enum BeltRemoval {
        /// x − v_b (t_end − t_land): the belt travel since each node *landed*. Neighbours do
        /// not land in arc-length order to within Δs/v_b, so this adds a node-scale jitter
        /// v_b δt_land along x that the curvature sees: e grows with refinement.
        #[default]
        Landing = "landing",
        /// x + (v_b/v_f)·s, s the node's material coordinate: the belt travel since each node
        /// was *fed* (eq 14's drift taken off), smooth in s, so e converges with the mesh;
        /// shifted as a whole onto the landing definition's centroid (S and e do not see the
        /// shift), so the nodes stay about the feed axis.
        Feed = "feed",
    }
}


/// The belt motion under one laid fibre, for [`laid_polyline`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeltMotion {
    /// v_b (m/s).
    pub belt_speed: f64,
    /// v_f (m/s): the fibre's material passes the feed point at this speed.
    pub fibre_speed: f64,
    /// t_end (s): the time the positions are taken at.
    pub end_time: f64,
    /// Δs (m): node i has material coordinate s = iΔs (node 0 fed first).
    pub element_length: f64,
}

/// Laid nodes (finite landing time) projected on the belt plane, in fibre order; with
/// `belt_removed = Some((rule, motion))` the belt travel is taken off by `rule`.
pub fn laid_polyline(positions: &[[f64; 3]], landing_time: &[f64], belt_removed: Option<(BeltRemoval, BeltMotion)>) -> Vec<[f64; 3]> {
    let laid = positions.iter().zip(landing_time).enumerate().filter(|(_, (_, t))| t.is_finite());
    let Some((rule, m)) = belt_removed else {
        return laid.map(|(_, (p, _))| [p[0], p[1], 0.0]).collect();
    };
    let since_landing: Vec<[f64; 3]> = laid.clone().map(|(_, (p, &t))| [p[0] - m.belt_speed * (m.end_time - t), p[1], 0.0]).collect();
    match rule {
        BeltRemoval::Landing => since_landing,
        BeltRemoval::Feed => {
            let c = m.belt_speed / m.fibre_speed;
            let mut since_feed: Vec<[f64; 3]> = laid.map(|(i, (p, _))| [p[0] + c * i as f64 * m.element_length, p[1], 0.0]).collect();
            let n = since_feed.len().max(1) as f64;
            let shift = (since_landing.iter().map(|q| q[0]).sum::<f64>() - since_feed.iter().map(|q| q[0]).sum::<f64>()) / n;
            for q in &mut since_feed {
                q[0] += shift;
            }
            since_feed
        }
    }
}

/// (S, e) of a laid polyline (S eq 5, e eq 6 via [`crate::geometry`]).
pub fn shape_measures(laid: &[[f64; 3]]) -> (f64, f64) {
    if laid.len() < 2 {
        return (0.0, 0.0);
    }
    (radius_of_gyration(laid), bending_energy(laid))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A fibre laid as a circle of radius R about the feed axis (deposition point at the
    /// origin), fed at v_f, carried by the belt: node i was fed at t_i = iΔs/v_f, so at t_end
    /// it lies at its circle point + v_b (t_end − t_i). Its landing time is t_i plus a hanging
    /// time with node-scale jitter (a coil touching down as a whole).
    fn carried_circle(jitter: f64) -> (Vec<[f64; 3]>, Vec<f64>, BeltMotion, Vec<[f64; 3]>) {
        let (n, radius, ds) = (400, 5e-3, 1e-4);
        let motion = BeltMotion { belt_speed: 0.2, fibre_speed: 5.0, end_time: 0.05, element_length: ds };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let circle: Vec<[f64; 3]> = (0..n).map(|i| {
            let phi = i as f64 * ds / radius;
            [radius * phi.cos(), radius * phi.sin(), 0.0]
        }).collect();
        let fed = |i: usize| i as f64 * ds / motion.fibre_speed;
        let positions = circle.iter().enumerate().map(|(i, q)| [q[0] + motion.belt_speed * (motion.end_time - fed(i)), q[1], 0.0]).collect();
        let landing = (0..n).map(|i| fed(i) + 0.01 + jitter * rng.random_range(-1.0..1.0)).collect();
        (positions, landing, motion, circle)
    }

    #[test]
    fn feed_removal_recovers_the_laid_curve_whatever_the_landing_order() {
        let (positions, landing, motion, circle) = carried_circle(2e-4);
        let feed = laid_polyline(&positions, &landing, Some((BeltRemoval::Feed, motion)));
        let by_landing = laid_polyline(&positions, &landing, Some((BeltRemoval::Landing, motion)));
        // The circle's shape exactly, shifted as a whole.
        let (s0, e0) = shape_measures(&circle);
        let (s, e) = shape_measures(&feed);
        assert!((s / s0 - 1.0).abs() < 1e-9 && (e / e0 - 1.0).abs() < 1e-9, "S {s} / {s0}, e {e} / {e0}");
        let shift = feed[0][0] - circle[0][0];
        assert!(feed.iter().zip(&circle).all(|(a, b)| (a[0] - b[0] - shift).abs() < 1e-12 && a[1] == b[1]));
        // ... onto the landing definition's centroid.
        let mean = |q: &[[f64; 3]]| q.iter().map(|p| p[0]).sum::<f64>() / q.len() as f64;
        assert!((mean(&feed) - mean(&by_landing)).abs() < 1e-15);
        // The landing definition sees the jitter v_b δt (±40 µm here) as curvature.
        let (_, e_landing) = shape_measures(&by_landing);
        assert!(e_landing > 10.0 * e0, "e by landing {e_landing}, laid {e0}");
    }

    #[test]
    fn both_removals_agree_without_jitter_or_without_a_belt() {
        // Landing exactly a fixed time after feeding: the two differ by a constant shift.
        let (positions, landing, motion, _) = carried_circle(0.0);
        let feed = laid_polyline(&positions, &landing, Some((BeltRemoval::Feed, motion)));
        let by_landing = laid_polyline(&positions, &landing, Some((BeltRemoval::Landing, motion)));
        for (a, b) in feed.iter().zip(&by_landing) {
            assert!((a[0] - b[0]).abs() < 1e-15, "{a:?} {b:?}");
        }
        // No belt: both are the laid nodes themselves.
        let still = BeltMotion { belt_speed: 0.0, ..motion };
        let plain = laid_polyline(&positions, &landing, None);
        for rule in [BeltRemoval::Feed, BeltRemoval::Landing] {
            assert_eq!(laid_polyline(&positions, &landing, Some((rule, still))), plain);
        }
    }
}
