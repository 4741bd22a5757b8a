//! Result of one replicate and the shape measures of the laid fibre.

use super::integrator::{EnergySample, TimeStepLimits};
use crate::geometry::{bending_energy, radius_of_gyration};

/// A column of the stored energy diagnostics: its name and its value in a record.
pub type EnergyColumn = (&'static str, fn(&EnergySample) -> f64);

/// The columns of a replicate's stored energy diagnostics (the laydown stage's
/// `energy_diagnostics`, along its `diagnostic` dimension), in order: the time (s), the
/// kinetic and elastic energy and the cumulative work of every source (J).
pub const ENERGY_COLUMNS: &[EnergyColumn] = &[
    ("time", |d| d.time),
    ("kinetic", |d| d.kinetic),
    ("elastic", |d| d.elastic),
    ("work_drag", |d| d.work.drag),
    ("work_friction", |d| d.work.friction),
    ("work_gravity", |d| d.work.gravity),
    ("work_oscillation", |d| d.work.oscillation),
    ("work_damping", |d| d.work.damping),
];

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
    /// S with the belt motion removed: x − v_belt (t_end − landing_time) per laid node.
    pub radius_of_gyration_belt_removed: f64,
    /// e with the belt motion removed.
    pub bending_energy_belt_removed: f64,
    /// Energy records every `diagnostic_stride` steps and at the end.
    pub diagnostics: Vec<EnergySample>,
    pub steps: u64,
    /// Time step used (s): the fixed step (explicit) or the largest allowed step (adaptive).
    pub time_step: f64,
    /// Smallest step taken (s).
    pub min_time_step: f64,
    /// Steps rejected and retaken with a smaller step (adaptive schemes).
    pub rejected_steps: u64,
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
            "err={:?} valid={} lift={:.2e} reason={:?} landed={} laid={:.4} S={:.5} e={:.1} S_rm={:.5} e_rm={:.1} steps={} rej={} dt={:.3e} mindt={:.2e} wall={:.2}s pen={:.2e} cons={:.1e}",
            self.error, self.valid, self.max_lift_after_landing, self.invalid_reason, self.landed_nodes, self.laid_length, self.radius_of_gyration,
            self.bending_energy, self.radius_of_gyration_belt_removed, self.bending_energy_belt_removed, self.steps, self.rejected_steps, self.time_step,
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
            lift_time: Vec::new(),
            landed_nodes: 0,
            laid_length: 0.0,
            radius_of_gyration: 0.0,
            bending_energy: 0.0,
            radius_of_gyration_belt_removed: 0.0,
            bending_energy_belt_removed: 0.0,
            diagnostics: Vec::new(),
            steps: 0,
            time_step: 0.0,
            min_time_step: 0.0,
            rejected_steps: 0,
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

/// Laid nodes (finite landing time) projected on the belt plane, in fibre order;
/// with `belt_speed_removed = Some((v_belt, t_end))` each node is shifted back by
/// v_belt (t_end − landing_time) along x (the paper's dashed lines, Figs 5-6).
pub fn laid_polyline(positions: &[[f64; 3]], landing_time: &[f64], belt_removed: Option<(f64, f64)>) -> Vec<[f64; 3]> {
    positions
        .iter()
        .zip(landing_time)
        .filter(|(_, t)| t.is_finite())
        .map(|(p, &t)| {
            let shift = belt_removed.map_or(0.0, |(vb, te)| vb * (te - t));
            [p[0] - shift, p[1], 0.0]
        })
        .collect()
}

/// (S, e) of a laid polyline (S eq 5, e eq 6 via [`crate::geometry`]).
pub fn shape_measures(laid: &[[f64; 3]]) -> (f64, f64) {
    if laid.len() < 2 {
        return (0.0, 0.0);
    }
    (radius_of_gyration(laid), bending_energy(laid))
}
