//! Scene parameters of one laydown replicate (SI units throughout) and their table.
//!
//! `LaydownParams::default()` is the paper's Table 1 baseline with the paper's model
//! (every effect on but the opt-in twist). Every numeric field is described once in [`PARAMETERS`]
//! (name, unit, default, allowed range, one-line doc); [`LaydownParams::validate`]
//! checks against that table so the pipeline can reuse it for YAML validation,
//! `--help` and a JSON schema.

use super::lift_watch::LiftWatch;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

pub use super::air::AirField;

crate::params::choice_enum! {
    /// Time integration scheme of the rod.
    pub enum Integrator {
        /// Reference: extensible rod (axial springs EA plus bending EI), symplectic
        /// (semi-implicit) Euler. Step limited by the axial wave, Δs/√(E/ρ) (0.69 µs at 1 mm).
        Explicit = "explicit",
        /// Fast: the axial springs EA are integrated implicitly (backward Euler) by a
        /// compliant projection of the segment lengths (XPBD form, one tridiagonal solve
        /// per Newton iteration, O(N)); bending and the rest as in `Explicit`. Step limited
        /// by bending, Δs²/2·√(ρA/EI) (28 µs at 1 mm, d = 50 µm).
        ImplicitAxial = "implicit_axial",
        /// As `ImplicitAxial` with the trapezoidal rule (θ = ½) on the axial springs: the
        /// axial waves are not damped numerically (their frequencies are distorted). Closest
        /// to the explicit reference at the same cost: the default.
        #[default]
        TrapezoidalAxial = "trapezoidal_axial",
        /// As `ImplicitAxial` with zero compliance: exactly inextensible rod. Fails (clearly)
        /// when a straight column is pushed against the belt, which cannot shorten without
        /// axial compliance; kept for scenes without impact.
        Inextensible = "inextensible",
        /// Opt-in, experimental: bending linearly implicit (one backward-Euler Newton
        /// step with the Gauss-Newton bending Hessian, a banded 3(N+1) solve per step,
        /// O(N)) with backward Euler on the axial springs in the length projection; belt
        /// contact, the driven top and clamps held as Dirichlet rows. No elastic step
        /// limit: Δt ≤ factor·`implicit_step_travel`·Δs/v_max, and the buckling limit.
        /// On the coil-resolving mesh it is slower than `TrapezoidalAxial` at the steps
        /// that keep e near the explicit reference, and damps e at longer ones
        /// (pipelines/paper/LAYDOWN_MEASUREMENTS.md).
        ImplicitBending = "implicit_bending",
    }
}


crate::params::choice_enum! {
    /// Which rise of a landed node above the belt decides that a replicate bounced.
    pub enum BounceCheck {
        /// The paper's test: a landed node still out of plane (above `bounce_tolerance`) in
        /// the final profile, the one S and e are measured on.
        #[default]
        Final = "final",
        /// Stricter: the highest rise of any landed node at any time after its landing,
        /// including rises that settle back before the end.
        Transient = "transient",
        /// The paper's test at every step of the run's last oscillation period: invalid when
        /// landed fibre stood above `bounce_tolerance` for more than half of it. At process
        /// speeds arches rise and settle in step with the sweep, and the final profile reads
        /// where in the sweep the run ends ([`super::lift_watch`]).
        LastPeriod = "last_period",
    }
}


crate::params::choice_enum! {
    /// How the spinneret holds the fibre against spinning about its axis (effect `twist`).
    pub enum FeedEnd {
        /// The fibre cannot spin at the feed: the twist that coiling puts into the hanging
        /// fibre stays in it (and is laid down with it).
        #[default]
        Clamped = "clamped",
        /// Free to spin: the twist relaxes through the feed end, Ω ≡ 0, the model without
        /// twist (nothing is built).
        Free = "free",
    }
}

crate::params::choice_enum! {
    /// How the fibre enters the scene.
    pub enum Start {
        /// The paper's: a vertical fibre of length L, bottom node on the belt, every node
        /// simulated until the top reaches z0.
        #[default]
        Vertical = "vertical",
        /// Continuous feed ([`super::feed`], as `laid_web` lays each fibre): a short
        /// buffer above z0 into which fibre is fed at v_f, settled laid nodes frozen; the
        /// same element length, end time and laid length. Statistically the paper's
        /// replicate (tested), at a fraction of its cost.
        Fed = "fed",
    }
}

/// Opt-in physical effects. A disabled effect is not built at all (no cost).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Effects {
    /// Axial stretching (explicit integrator only) and bending of the rod.
    pub elasticity: bool,
    /// Weight, −g ẑ.
    pub gravity: bool,
    /// Air drag (eqs 1-4) in the laydown zone 0 ≤ z ≤ z0.
    pub drag: bool,
    /// Spring-damper to the oscillating dummy point for nodes above z0 (eq 7).
    pub oscillation: bool,
    /// Unilateral contact with the belt plane z = 0.
    pub contact: bool,
    /// Coulomb friction against the moving belt (needs `contact`).
    pub friction: bool,
    /// Rayleigh mass damping α_R.
    pub damping: bool,
    /// Random initial x/y node offsets N(0, imperfection_std).
    pub imperfections: bool,
    /// Rod twist (opt-in, off by default; [`super::twist`]): with `feed_end` clamped the
    /// twist the coiling puts into the hanging fibre acts back on its centreline.
    pub twist: bool,
}

impl Default for Effects {
    fn default() -> Self {
        Effects {
            elasticity: true,
            gravity: true,
            drag: true,
            oscillation: true,
            contact: true,
            friction: true,
            damping: true,
            imperfections: true,
            twist: false,
        }
    }
}

impl Effects {
    /// (name, doc) of every flag, for --help and schemas.
    pub const FLAGS: [(&'static str, &'static str); 9] = [
        ("elasticity", "axial stretching (explicit integrator) and bending EI of the rod"),
        ("gravity", "weight of the fibre, -g along z"),
        ("drag", "air drag of eqs 1-4 in the laydown zone 0 <= z <= laydown_height"),
        ("oscillation", "spring-damper (eq 7) pulling nodes above laydown_height to (0, u0 sin wt)"),
        ("contact", "no penetration of the belt plane z = 0"),
        ("friction", "Coulomb stick/slip friction against the belt moving at belt_speed along +x"),
        ("damping", "Rayleigh mass damping rayleigh_damping"),
        ("imperfections", "initial x/y node offsets N(0, imperfection_std)"),
        ("twist", "opt-in (off by default): rod twist, quasistatic, GJ = EI/(1 + poisson_ratio); with feed_end clamped the twist that coiling puts into the hanging fibre acts on it (src/rod/twist.rs)"),
    ];
}

/// Parameters of one laydown replicate. Coordinates: x = machine direction (belt moves
/// along +x), y = cross direction (oscillation along y), z up, belt plane z = 0.
/// (The paper's belt moves along its y axis.)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LaydownParams {
    /// Fibre length L (m).
    pub length: f64,
    /// Number of rod segments N (N + 1 nodes); may be raised by `coil_resolution`.
    pub elements: usize,
    /// Feed speed v_f of the fibre (m/s), downward.
    pub fibre_speed: f64,
    /// Belt speed v_belt along +x (m/s).
    pub belt_speed: f64,
    /// Coulomb friction coefficient μ fibre/belt.
    pub friction_coefficient: f64,
    /// Fibre diameter d (m).
    pub diameter: f64,
    /// Downward air speed V_air in the laydown zone (m/s).
    pub air_speed: f64,
    /// Air field near the belt ([`super::air`]): uniform (default) or impinging.
    pub air_field: AirField,
    /// Fraction φ of the air that passes through the belt (impinging fields; 1 = uniform).
    pub belt_permeability: f64,
    /// Height h over which the impinging air turns sideways (m).
    pub stagnation_height: f64,
    /// Oscillation amplitude u0 (m).
    pub oscillation_amplitude: f64,
    /// Oscillation frequency f (Hz), ω = 2πf (Table 1: ω = 62.8 rad/s → 10 Hz).
    pub oscillation_frequency: f64,
    /// Height z0 of the laydown zone (m).
    pub laydown_height: f64,
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Fibre density ρ (kg/m³).
    pub density: f64,
    /// Poisson's ratio ν: GJ = EI/(1 + ν) of the opt-in twist.
    pub poisson_ratio: f64,
    /// Air density ρ_a (kg/m³).
    pub air_density: f64,
    /// Air kinematic viscosity ν_a (m²/s).
    pub air_kinematic_viscosity: f64,
    /// β of the tangential skin-friction law C_t = β Re^-0.61 (eq 2).
    pub tangential_drag_beta: f64,
    /// Spring k of the oscillator (N/m per node, eq 7).
    pub oscillation_stiffness: f64,
    /// Damper c of the oscillator (N·s/m per node, eq 7).
    pub oscillation_damping: f64,
    /// Rayleigh mass damping α_R (1/s).
    pub rayleigh_damping: f64,
    /// Standard deviation of the initial x/y node imperfections (m).
    pub imperfection_std: f64,
    /// Gravitational acceleration g (m/s²).
    pub gravity: f64,
    /// Safety factor on the automatically chosen stable time step (≤ 1).
    pub time_step_factor: f64,
    /// Rollbacks a run may take after a failed step ([`super::recovery`]); 0: none.
    pub rollbacks: usize,
    /// Record energy diagnostics every this many steps.
    pub diagnostic_stride: usize,
    /// A landed node rising above this height later makes the replicate invalid (m).
    pub bounce_tolerance: f64,
    /// Penetration of the belt beyond this depth is a numerical failure (m).
    pub penetration_tolerance: f64,
    /// Minimum number of elements per inertial coil scale √(EI/ρAv_f²); 0 = use `elements` as given.
    pub coil_resolution: f64,
    /// Largest time step as a fraction of the inertial coil time ℓ_c/v_f (before
    /// `time_step_factor`); 0 = off.
    pub coil_step: f64,
    /// Simulated time (s); 0 = until the top node reaches z0, (L − z0)/v_f.
    pub duration: f64,
    /// `implicit_bending` only: elements a node moving at the largest imposed speed
    /// (feed, belt, ωu0) may travel in one step, Δt ≤ factor·travel·Δs/v_max.
    pub implicit_step_travel: f64,
    /// Time integration scheme.
    pub integrator: Integrator,
    /// Which lift of landed nodes `bounce_tolerance` applies to.
    pub bounce_check: BounceCheck,
    /// How the belt motion is taken off the laid nodes for the belt-removed S and e.
    pub belt_removal: super::metrics::BeltRemoval,
    /// With `effects.twist`: whether the feed end is clamped against spinning.
    pub feed_end: FeedEnd,
    /// How the fibre enters the scene: the paper's vertical fibre or a continuous feed.
    pub start: Start,
    /// Physical effects switched on.
    pub effects: Effects,
}

impl Default for LaydownParams {
    fn default() -> Self {
        LaydownParams {
            length: 1.0,
            elements: 1000,
            fibre_speed: 5.0,
            belt_speed: 0.2,
            friction_coefficient: 1.0,
            diameter: 50e-6,
            air_speed: 10.0,
            air_field: AirField::default(),
            belt_permeability: 0.0,
            stagnation_height: 0.01,
            oscillation_amplitude: 0.010,
            oscillation_frequency: 10.0,
            laydown_height: 0.05,
            youngs_modulus: 2e9,
            density: 950.0,
            poisson_ratio: 0.3,
            air_density: 1.2,
            air_kinematic_viscosity: 1.51e-5,
            tangential_drag_beta: 0.37,
            oscillation_stiffness: 1.0,
            oscillation_damping: 0.001,
            rayleigh_damping: 0.01,
            imperfection_std: 1e-6,
            gravity: 9.81,
            time_step_factor: 0.8,
            rollbacks: super::recovery::ROLLBACKS,
            diagnostic_stride: 1000,
            bounce_tolerance: 1e-3,
            penetration_tolerance: 1e-5,
            coil_resolution: 2.0,
            coil_step: 0.0,
            duration: 0.0,
            implicit_step_travel: 0.25,
            integrator: Integrator::default(),
            bounce_check: BounceCheck::default(),
            belt_removal: super::metrics::BeltRemoval::default(),
            feed_end: FeedEnd::default(),
            start: Start::default(),
            effects: Effects::default(),
        }
    }
}

pub use crate::params::ParamSpec;
use crate::params::ParamCaution;

/// Belt friction above which the default integrator (`trapezoidal_axial`) is cautioned
/// against ([`LaydownParams::cautions`]).
pub const HIGH_FRICTION: f64 = 2.0;

/// `time_step_factor` at or below which the default integrator held at high belt friction
/// (single fibres at μ = 10: none of 20 lost), so no caution is given.
pub const SAFE_HIGH_FRICTION_STEP: f64 = 0.2;

/// `coil_step` recommended where the step is coarse against the inertial coil time: S
/// within 0.6 % of its step-converged value at 10-50 m/s, e within about 2 % at 10-30 m/s
/// and for thin fibres at 5 m/s (pipelines/studies/FIBRE_SPEED.md, "Where the step error
/// comes from"); at Table 1 it does not bind.
pub const CONVERGED_COIL_STEP: f64 = 0.04;

const fn real(name: &'static str, unit: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> ParamSpec {
    ParamSpec::float(name, unit, default, min, max, doc)
}
const fn int(name: &'static str, default: i64, min: i64, max: i64, doc: &'static str) -> ParamSpec {
    ParamSpec::int(name, "1", default, min, max, doc)
}

/// Every numeric parameter with unit, default (Table 1 baseline), inclusive range and doc.
/// The effect flags are in [`Effects::FLAGS`], the integrator names in [`Integrator::NAMES`].
pub const PARAMETERS: &[ParamSpec] = &[
    real("length", "m", 1.0, 1e-3, 100.0, "fibre length L"),
    int("elements", 1000, 2, 1_000_000, "rod segments N (N+1 nodes), raised if coil_resolution asks for more"),
    real("fibre_speed", "m/s", 5.0, 1e-3, 200.0, "feed speed v_f of the fibre, downward (Table 1: 5)"),
    real("belt_speed", "m/s", 0.2, 0.0, 200.0, "belt speed along +x, machine direction (Table 1: 0.2)"),
    real("friction_coefficient", "1", 1.0, 0.0, 100.0, "Coulomb friction coefficient mu fibre/belt (Table 1: 1); above 2 prefer integrator implicit_axial: the default scheme's steps fail often there and are rolled back and retaken (laid webs at mu = 3: 37 of 200 fibres), and fibres bounce (single fibres at mu = 10: 2 of 20, the explicit reference none; FIBRE_SPEED.md), and validate warns (unless time_step_factor <= 0.2)"),
    real("diameter", "m", 50e-6, 1e-7, 1e-2, "fibre diameter d (Table 1: 50 um)"),
    real("air_speed", "m/s", 10.0, 0.0, 500.0, "downward air speed in the laydown zone (Table 1: 10)"),
    real("belt_permeability", "1", 0.0, 0.0, 1.0, "air_field impinging*: fraction phi of the air passing through the belt (0 = impermeable, 1 = the uniform field)"),
    real("stagnation_height", "m", 0.01, 1e-4, 10.0, "air_field impinging*: height h over which the air not passing the belt turns sideways; jet half-width 2h (round) or h (slot); 10 mm = laydown_height/5, jet radius 2 u0"),
    real("oscillation_amplitude", "m", 0.010, 0.0, 1.0, "amplitude u0 of the imposed cross-direction oscillation (Table 1: 10 mm)"),
    real("oscillation_frequency", "Hz", 10.0, 0.0, 1e4, "frequency f of the oscillation, omega = 2 pi f (Table 1: 62.8 rad/s)"),
    real("laydown_height", "m", 0.05, 1e-4, 100.0, "height z0 of the laydown zone, below length"),
    real("youngs_modulus", "Pa", 2e9, 1e3, 1e13, "Young's modulus E"),
    real("density", "kg/m^3", 950.0, 1.0, 1e5, "fibre density rho"),
    real("poisson_ratio", "1", 0.3, 0.0, 0.5, "Poisson's ratio nu: torsional stiffness GJ = EI/(1 + nu) of the opt-in twist"),
    real("air_density", "kg/m^3", 1.2, 0.0, 100.0, "air density rho_a"),
    real("air_kinematic_viscosity", "m^2/s", 1.51e-5, 1e-8, 1.0, "air kinematic viscosity nu_a in Re = V d / nu_a"),
    real("tangential_drag_beta", "1", 0.37, 0.0, 10.0, "beta in C_t = beta Re^-0.61 (eq 2); 0.37 after Matsui (1976)"),
    real("oscillation_stiffness", "N/m", 1.0, 0.0, 1e6, "spring k per node to the dummy point (eq 7)"),
    real("oscillation_damping", "N s/m", 0.001, 0.0, 1e3, "damper c per node to the dummy point (eq 7)"),
    real("rayleigh_damping", "1/s", 0.01, 0.0, 1e6, "Rayleigh mass damping alpha_R"),
    real("imperfection_std", "m", 1e-6, 0.0, 1e-2, "std of the initial x/y node imperfections"),
    real("gravity", "m/s^2", 9.81, 0.0, 1e3, "gravitational acceleration g"),
    real("time_step_factor", "1", 0.8, 1e-3, 1.0, "safety factor on the automatic stable time step; at 0.8 S and e are within about 2 % of their step-converged values at Table 1 and 20 m/s, but e reads 7-11 % low at 10 m/s, S about 2-2.7 % high at 30-50 m/s and e 2-7 % low at 50 m/s (0.2 there, at four times the time, or coil_step: 0.04, at three; pipelines/studies/FIBRE_SPEED.md, \"The time step at 50 m/s, and at 5-30 m/s\")"),
    int("rollbacks", super::recovery::ROLLBACKS as i64, 0, 1000, "adaptive-step schemes: times a run whose step failed even at the smallest step goes back to a checkpoint 64-128 steps earlier (or from before the step collapsed below 1/16 of the largest) and retakes the stretch with the axial springs by backward Euler (as implicit_axial has anyway) and a quarter of the step (src/rod/recovery.rs); with fibre_contact the fibres that can touch go back together to the start of the broad-phase interval; 0 = the first failure ends the replicate or fibre"),
    int("diagnostic_stride", 1000, 1, 1_000_000_000, "record energy diagnostics every this many steps"),
    real("bounce_tolerance", "m", 1e-3, 0.0, 1.0, "a landed node higher than this (at the end; at any time with bounce_check = transient; for more than half the last oscillation period with last_period) invalidates the replicate; 1 mm = 20 d = one element at the baseline"),
    real("penetration_tolerance", "m", 1e-5, 0.0, 1.0, "belt penetration deeper than this is a numerical failure"),
    real("coil_resolution", "1", 2.0, 0.0, 100.0, "minimum elements per inertial coil scale sqrt(EI/(rho A v_f^2)); 0 = off"),
    real("coil_step", "1", 0.0, 0.0, 1.0, "largest time step as a fraction of the inertial coil time l_c/v_f = sqrt(EI/(rho A))/v_f^2, times time_step_factor; 0 = off. 0.04 leaves Table 1 as it is, holds S within 0.6 % of its step-converged value at 10-50 m/s and e within about 2 % at 10-30 m/s and for thin fibres at 5 m/s (at 50 m/s e moves by a few % with any step), at about 3 times the steps there (pipelines/studies/FIBRE_SPEED.md, \"Where the step error comes from\")"),
    real("duration", "s", 0.0, 0.0, 1e3, "simulated time; 0 = until the top node reaches laydown_height"),
    real("implicit_step_travel", "1", 0.25, 0.01, 100.0, "integrator implicit_bending only: elements a node at the largest imposed speed (feed, belt, omega u0) may travel per step, dt <= time_step_factor * this * element length / v_max"),
];

/// A parameter outside its allowed range, or an inconsistent combination.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error(transparent)]
    Range(#[from] crate::params::ParamError),
    #[error("unknown parameter `{0}`")]
    Unknown(String),
    #[error("{0}")]
    Inconsistent(String),
}

impl LaydownParams {
    /// Value of a numeric parameter by its table name.
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "length" => self.length,
            "elements" => self.elements as f64,
            "fibre_speed" => self.fibre_speed,
            "belt_speed" => self.belt_speed,
            "friction_coefficient" => self.friction_coefficient,
            "diameter" => self.diameter,
            "air_speed" => self.air_speed,
            "belt_permeability" => self.belt_permeability,
            "stagnation_height" => self.stagnation_height,
            "oscillation_amplitude" => self.oscillation_amplitude,
            "oscillation_frequency" => self.oscillation_frequency,
            "laydown_height" => self.laydown_height,
            "youngs_modulus" => self.youngs_modulus,
            "density" => self.density,
            "poisson_ratio" => self.poisson_ratio,
            "air_density" => self.air_density,
            "air_kinematic_viscosity" => self.air_kinematic_viscosity,
            "tangential_drag_beta" => self.tangential_drag_beta,
            "oscillation_stiffness" => self.oscillation_stiffness,
            "oscillation_damping" => self.oscillation_damping,
            "rayleigh_damping" => self.rayleigh_damping,
            "imperfection_std" => self.imperfection_std,
            "gravity" => self.gravity,
            "time_step_factor" => self.time_step_factor,
            "diagnostic_stride" => self.diagnostic_stride as f64,
            "rollbacks" => self.rollbacks as f64,
            "bounce_tolerance" => self.bounce_tolerance,
            "penetration_tolerance" => self.penetration_tolerance,
            "coil_resolution" => self.coil_resolution,
            "coil_step" => self.coil_step,
            "duration" => self.duration,
            "implicit_step_travel" => self.implicit_step_travel,
            _ => return None,
        })
    }

    /// Set a numeric parameter by its table name (range-checked).
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let spec = PARAMETERS
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| ParamError::Unknown(name.to_string()))?;
        check(spec, value)?;
        let slot: &mut f64 = match name {
            "elements" => {
                self.elements = value as usize;
                return Ok(());
            }
            "diagnostic_stride" => {
                self.diagnostic_stride = value as usize;
                return Ok(());
            }
            "rollbacks" => {
                self.rollbacks = value as usize;
                return Ok(());
            }
            "length" => &mut self.length,
            "fibre_speed" => &mut self.fibre_speed,
            "belt_speed" => &mut self.belt_speed,
            "friction_coefficient" => &mut self.friction_coefficient,
            "diameter" => &mut self.diameter,
            "air_speed" => &mut self.air_speed,
            "belt_permeability" => &mut self.belt_permeability,
            "stagnation_height" => &mut self.stagnation_height,
            "oscillation_amplitude" => &mut self.oscillation_amplitude,
            "oscillation_frequency" => &mut self.oscillation_frequency,
            "laydown_height" => &mut self.laydown_height,
            "youngs_modulus" => &mut self.youngs_modulus,
            "density" => &mut self.density,
            "poisson_ratio" => &mut self.poisson_ratio,
            "air_density" => &mut self.air_density,
            "air_kinematic_viscosity" => &mut self.air_kinematic_viscosity,
            "tangential_drag_beta" => &mut self.tangential_drag_beta,
            "oscillation_stiffness" => &mut self.oscillation_stiffness,
            "oscillation_damping" => &mut self.oscillation_damping,
            "rayleigh_damping" => &mut self.rayleigh_damping,
            "imperfection_std" => &mut self.imperfection_std,
            "gravity" => &mut self.gravity,
            "time_step_factor" => &mut self.time_step_factor,
            "bounce_tolerance" => &mut self.bounce_tolerance,
            "penetration_tolerance" => &mut self.penetration_tolerance,
            "coil_resolution" => &mut self.coil_resolution,
            "coil_step" => &mut self.coil_step,
            "duration" => &mut self.duration,
            "implicit_step_travel" => &mut self.implicit_step_travel,
            _ => return Err(ParamError::Unknown(name.to_string())),
        };
        *slot = value;
        Ok(())
    }

    /// Table 1 parameters with every effect off except those named (the `effects.X`
    /// flag names); an unknown name panics. For tests that isolate one piece of physics.
    #[cfg(test)]
    pub(crate) fn with_only_effects(effects: &[&str]) -> Self {
        let mut p = LaydownParams::default();
        let mut flags = serde_json::Map::new();
        for (name, _) in Effects::FLAGS {
            flags.insert(name.to_string(), serde_json::Value::Bool(effects.contains(&name)));
        }
        for e in effects {
            assert!(Effects::FLAGS.iter().any(|(name, _)| name == e), "unknown effect {e}");
        }
        p.effects = serde_json::from_value(serde_json::Value::Object(flags)).expect("every flag named");
        p
    }

    /// Check every parameter against [`PARAMETERS`] and the cross-constraints.
    pub fn validate(&self) -> Result<(), ParamError> {
        for spec in PARAMETERS {
            let value = self.get(spec.name).expect("table and get() agree");
            check(spec, value)?;
        }
        if self.laydown_height >= self.length {
            return Err(ParamError::Inconsistent(format!(
                "laydown_height ({} m) must be below the fibre length ({} m)",
                self.laydown_height, self.length
            )));
        }
        if self.start == Start::Fed && self.bounce_check == BounceCheck::Transient {
            return Err(ParamError::Inconsistent(
                "bounce_check transient needs start: vertical (a fed fibre keeps no lift history of its frozen nodes); use bounce_check: final".into(),
            ));
        }
        self.check_lift_watch(self.end_time(), "duration, length")?;
        if self.duration > self.length / self.fibre_speed {
            return Err(ParamError::Inconsistent(format!(
                "duration ({} s) must not exceed length/fibre_speed = {} s: the driven top node would pass through the belt",
                self.duration,
                self.length / self.fibre_speed
            )));
        }
        Ok(())
    }

    /// Valid settings that are known to give poor results, each with what to do instead
    /// (printed as warnings by `validate` and `run`; the scene still runs).
    pub fn cautions(&self) -> Vec<ParamCaution> {
        let mut out = Vec::new();
        if self.effects.contact && self.friction_coefficient > HIGH_FRICTION && self.integrator == Integrator::TrapezoidalAxial && self.time_step_factor > SAFE_HIGH_FRICTION_STEP {
            out.push(ParamCaution {
                key: "friction_coefficient".into(),
                message: format!(
                    "{} is above {HIGH_FRICTION} with integrator trapezoidal_axial (the default), which does not damp the axial waves: at high belt friction its steps fail \
                     often and are rolled back and retaken, and fibres bounce (measured: laid webs at 3: 37 of 200 fibres rolled back, 2 bounced; single fibres at 10: \
                     2 of 20 bounced, the explicit reference none); set integrator: implicit_axial, which held in every case without rollbacks, or \
                     time_step_factor: {SAFE_HIGH_FRICTION_STEP} (single fibres at 10: none of 20 lost) (pipelines/studies/FIBRE_SPEED.md, \"High friction at the default step\")",
                    self.friction_coefficient
                ),
            });
        }
        out
    }

    /// Cross-section area A = πd²/4 (m²).
    pub fn area(&self) -> f64 {
        PI * self.diameter * self.diameter / 4.0
    }
    /// Axial stiffness EA (N).
    pub fn axial_stiffness(&self) -> f64 {
        self.youngs_modulus * self.area()
    }
    /// Bending stiffness EI, I = πd⁴/64 (N·m²).
    pub fn bending_stiffness(&self) -> f64 {
        self.youngs_modulus * PI * self.diameter.powi(4) / 64.0
    }
    /// The warning a replicate carries when `coil_resolution` raised `elements` to
    /// `resolved` ([`Self::resolved_elements`]); None when it did not.
    pub fn resolution_warning(&self, resolved: usize) -> Option<String> {
        (resolved != self.elements).then(|| {
            format!(
                "elements raised from {} to {} so that the element length is at most coil_scale/coil_resolution = {:.3e} m",
                self.elements,
                resolved,
                self.coil_scale() / self.coil_resolution
            )
        })
    }
    /// Torsional stiffness GJ = EI/(1 + ν) of a round section (N·m²): G = E/2(1 + ν), J = 2I.
    pub fn twist_stiffness(&self) -> f64 {
        self.bending_stiffness() / (1.0 + self.poisson_ratio)
    }
    /// Mass per unit length ρA (kg/m).
    pub fn mass_per_length(&self) -> f64 {
        self.density * self.area()
    }
    /// Angular frequency ω = 2πf of the oscillation (rad/s).
    pub fn angular_frequency(&self) -> f64 {
        2.0 * PI * self.oscillation_frequency
    }
    /// Largest speed the imposed oscillation gives a node, ω u0 (m/s; eq 7).
    pub fn oscillation_speed(&self) -> f64 {
        self.angular_frequency() * self.oscillation_amplitude
    }
    /// Inertial coil scale √(EI/(ρA v_f²)) (m): 3.6 mm at the baseline.
    pub fn coil_scale(&self) -> f64 {
        (self.bending_stiffness() / self.mass_per_length()).sqrt() / self.fibre_speed
    }
    /// Inertial coil time ℓ_c/v_f = √(EI/ρA)/v_f² (s): the time the feed takes to lay one
    /// coil scale, 0.73 ms at the baseline.
    pub fn coil_time(&self) -> f64 {
        self.coil_scale() / self.fibre_speed
    }
    /// Element length Δs actually used, `length` over [`Self::resolved_elements`] (m).
    pub fn element_length(&self) -> f64 {
        self.length / self.resolved_elements() as f64
    }
    /// Elements actually used: `elements`, raised so that the element length is at most
    /// coil_scale / coil_resolution (when coil_resolution > 0).
    pub fn resolved_elements(&self) -> usize {
        if self.coil_resolution > 0.0 {
            let needed = (self.length * self.coil_resolution / self.coil_scale()).ceil();
            if needed.is_finite() && needed > self.elements as f64 {
                return needed.min(1e7) as usize;
            }
        }
        self.elements
    }
    /// Simulated time: `duration`, or (L − z0)/v_f when the top node reaches z0 (0.19 s baseline).
    pub fn end_time(&self) -> f64 {
        if self.duration > 0.0 {
            self.duration
        } else {
            (self.length - self.laydown_height) / self.fibre_speed
        }
    }

    /// Whether `bounce_check: last_period` can watch a run that ends at `end_time` (s): it
    /// needs the oscillation, and fibre laid for at least one period 1/f before the end
    /// (the first node lands about z0/v_f after the start). Watched for less, a fibre the
    /// air holds up only after it landed could pass.
    /// `longer` names what makes the run longer (for the message).
    pub fn check_lift_watch(&self, end_time: f64, longer: &str) -> Result<(), ParamError> {
        if self.bounce_check != BounceCheck::LastPeriod {
            return Ok(());
        }
        if !(self.effects.oscillation && self.oscillation_frequency > 0.0) {
            return Err(ParamError::Inconsistent(format!(
                "bounce_check last_period watches the last oscillation period and needs the oscillation (effects.oscillation {}, oscillation_frequency {} Hz); use bounce_check: final",
                self.effects.oscillation, self.oscillation_frequency
            )));
        }
        let (laid_for, period) = (end_time - self.laydown_height / self.fibre_speed, 1.0 / self.oscillation_frequency);
        if !(laid_for >= period) {
            return Err(ParamError::Inconsistent(format!(
                "bounce_check last_period watches the last oscillation period (1/f = {period:.4e} s) of laid fibre, but the run lays fibre for about {laid_for:.4e} s \
                 (end time {end_time:.4e} s less the fall z0/v_f = {:.4e} s); run longer ({longer}), raise oscillation_frequency, or use bounce_check: final",
                self.laydown_height / self.fibre_speed
            )));
        }
        Ok(())
    }

    /// The watch of `bounce_check: last_period` for a run that ends at `end_time` (s): the
    /// last oscillation period 1/f before it, at `bounce_tolerance`; None for the other
    /// checks.
    pub fn lift_watch_until(&self, end_time: f64) -> Option<LiftWatch> {
        (self.bounce_check == BounceCheck::LastPeriod).then(|| LiftWatch::new(end_time - 1.0 / self.oscillation_frequency, self.bounce_tolerance))
    }
}

fn check(spec: &ParamSpec, value: f64) -> Result<(), ParamError> {
    Ok(spec.check_number(value)?)
}

/// The parameter table as Markdown (name | unit | default | range | doc), effect flags and
/// integrators included, for `--help` output and documentation.
pub fn parameter_table_markdown() -> String {
    let mut s = String::from("| name | unit | default | allowed | description |\n|---|---|---|---|---|\n");
    for p in PARAMETERS {
        s += &format!("| {} | {} | {} | {} | {} |\n", p.name, p.unit, p.default, p.allowed(), p.doc);
    }
    for (name, doc) in Effects::FLAGS {
        s += &format!("| effects.{name} | bool | true | | {doc} |\n");
    }
    // a choice parameter: its default and its words, then what it picks
    let mut choice = |name: &str, default: &str, words: &[&str], doc: &str| s += &format!("| {name} | | {default} | | one of {}{doc} |\n", words.join(", "));
    choice("bounce_check", BounceCheck::default().name(), BounceCheck::NAMES, ": lift of landed nodes in the final profile (paper), at any time, or for more than half of the last oscillation period");
    choice(
        "belt_removal",
        super::metrics::BeltRemoval::default().name(),
        super::metrics::BeltRemoval::NAMES,
        ": belt travel taken off since each node landed (the paper's reading) or since it was fed (x + (v_b/v_f) s; converges with the mesh)",
    );
    choice("air_field", AirField::default().name(), AirField::NAMES, ": air (0, 0, -air_speed) everywhere, or a round / slot jet turned sideways near a belt of belt_permeability over stagnation_height");
    choice("integrator", Integrator::default().name(), Integrator::NAMES, "");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_default_and_validates() {
        let p = LaydownParams::default();
        for spec in PARAMETERS {
            let default = spec.default.number().unwrap();
            assert_eq!(p.get(spec.name), Some(default), "{}", spec.name);
            spec.check_number(default).unwrap();
            let mut q = p.clone();
            q.set(spec.name, default).unwrap();
            assert_eq!(q, p);
        }
        p.validate().unwrap();
        assert!((p.end_time() - 0.19).abs() < 1e-12);
        assert_eq!(p.resolved_elements(), 1000);
    }

    /// The default scheme is cautioned against above μ = 2 only where belt friction acts
    /// (contact on), at a step above the one that held, and never with a scheme that damps
    /// the axial waves.
    #[test]
    fn high_friction_cautions_against_the_default_scheme_only() {
        let at = |mu: f64, integrator: Integrator, contact: bool| {
            let mut p = LaydownParams { friction_coefficient: mu, integrator, ..LaydownParams::default() };
            p.effects.contact = contact;
            p.cautions()
        };
        assert!(LaydownParams::default().cautions().is_empty());
        assert!(at(HIGH_FRICTION, Integrator::TrapezoidalAxial, true).is_empty());
        let c = at(3.0, Integrator::TrapezoidalAxial, true);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].key, "friction_coefficient");
        assert!(c[0].message.starts_with("3 is above 2") && c[0].message.contains("integrator: implicit_axial"), "{}", c[0].message);
        for other in [Integrator::ImplicitAxial, Integrator::Explicit, Integrator::Inextensible, Integrator::ImplicitBending] {
            assert!(at(3.0, other, true).is_empty(), "{other:?}");
        }
        assert!(at(3.0, Integrator::TrapezoidalAxial, false).is_empty(), "no belt, no friction");
        let small_step = LaydownParams { friction_coefficient: 10.0, time_step_factor: SAFE_HIGH_FRICTION_STEP, ..LaydownParams::default() };
        assert!(small_step.cautions().is_empty(), "the step that held");
    }

    #[test]
    fn validate_names_the_parameter() {
        let mut p = LaydownParams::default();
        p.diameter = -1.0;
        let err = p.validate().unwrap_err().to_string();
        assert!(err.contains("diameter") && err.contains("allowed: a number from"), "{err}");
        let mut p = LaydownParams::default();
        p.laydown_height = 2.0;
        assert!(p.validate().unwrap_err().to_string().contains("laydown_height"));
        assert!(LaydownParams::default().set("nonsense", 1.0).is_err());
        let mut p = LaydownParams::default();
        p.duration = 0.5;
        assert!(p.validate().unwrap_err().to_string().contains("duration"));
    }

    #[test]
    fn last_period_watches_the_last_oscillation_period_and_needs_the_oscillation() {
        let mut p = LaydownParams { bounce_check: BounceCheck::LastPeriod, ..LaydownParams::default() };
        p.validate().unwrap();
        // Table 1: f = 10 Hz, end time 0.19 s
        let watch = p.lift_watch_until(p.end_time()).unwrap();
        assert!((watch.from - 0.09).abs() < 1e-12 && watch.tolerance == p.bounce_tolerance);
        assert!((p.lift_watch_until(0.5).unwrap().from - 0.4).abs() < 1e-12);
        assert!(LaydownParams::default().lift_watch_until(0.19).is_none());
        p.effects.oscillation = false;
        let err = p.validate().unwrap_err().to_string();
        assert!(err.contains("last_period") && err.contains("effects.oscillation false"), "{err}");
        p.effects.oscillation = true;
        p.oscillation_frequency = 0.0;
        assert!(p.validate().unwrap_err().to_string().contains("oscillation_frequency 0 Hz"));
        // laid for 0.19 - 0.01 s, less than a period at 5 Hz
        p.oscillation_frequency = 5.0;
        let err = p.validate().unwrap_err().to_string();
        assert!(err.contains("lays fibre for about 1.8000e-1 s"), "{err}");
        assert!(p.check_lift_watch(0.22, "duration").is_ok());
    }
}
