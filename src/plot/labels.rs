//! Physical labels of the quantities figures show: one table, so every figure names a
//! parameter alike (`v_b/v_f`, `d (µm)`, `zone size (mm)`) instead of its YAML name
//! (`belt_speed_ratio`) or a dataset's whole `long_name` sentence.
//!
//! A parameter missing from [`QUANTITIES`] is shown by its name with underscores as
//! spaces, and an SI length or time in the unit prefix that suits its values (µm, mm,
//! ms), so no axis reads `3.0e-5 m`.

/// How one quantity is labelled: `symbol (unit)` after multiplying SI values by `scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantity {
    /// Symbol or short name, e.g. `v_b/v_f`.
    pub symbol: &'static str,
    /// Display unit ("" for dimensionless).
    pub unit: &'static str,
    /// Factor from the stored SI value to the displayed one.
    pub scale: f64,
}

const fn q(symbol: &'static str, unit: &'static str, scale: f64) -> Quantity {
    Quantity { symbol, unit, scale }
}

/// Parameter (as in the pipeline, dotted) or series name → label. Parameters of every
/// stage kind share one namespace; where two kinds use one name it means one thing.
pub const QUANTITIES: &[(&str, Quantity)] = &[
    // laydown (rod parameters)
    ("length", q("fibre length L", "mm", 1e3)),
    ("fibre_speed", q("v_f", "m/s", 1.0)),
    ("belt_speed", q("v_b", "m/s", 1.0)),
    ("friction_coefficient", q("friction μ", "", 1.0)),
    ("diameter", q("d", "µm", 1e6)),
    ("air_speed", q("air speed", "m/s", 1.0)),
    ("oscillation_amplitude", q("oscillation u₀", "mm", 1e3)),
    ("oscillation_frequency", q("oscillation f", "Hz", 1.0)),
    ("laydown_height", q("laydown height z₀", "mm", 1e3)),
    ("youngs_modulus", q("E", "GPa", 1e-9)),
    ("density", q("ρ", "kg/m³", 1.0)),
    ("elements", q("elements", "", 1.0)),
    ("element_length", q("Δs", "mm", 1e3)),
    ("time_step_factor", q("time-step factor", "", 1.0)),
    ("coil_resolution", q("elements per coil", "", 1.0)),
    // spectra
    ("cutoff_number", q("cut-off number", "", 1.0)),
    ("sample_spacing", q("sample spacing", "mm", 1e3)),
    ("points_per_segment", q("points per segment", "", 1.0)),
    ("preset", q("spectrum", "", 1.0)),
    // web, grid
    ("belt_speed_ratio", q("v_b/v_f", "", 1.0)),
    ("fibres_across", q("n_w", "", 1.0)),
    ("segments_per_fibre", q("n_l", "", 1.0)),
    ("fibre_spacing", q("Δw", "mm", 1e3)),
    ("fibre_diameter", q("d", "µm", 1e6)),
    ("fibre_density", q("ρ", "kg/m³", 1.0)),
    ("cell_size", q("cell size Δh", "mm", 1e3)),
    ("window_side", q("window H", "mm", 1e3)),
    ("zone_size", q("zone size", "mm", 1e3)),
    // laid web
    ("belt_travel", q("belt travel", "mm", 1e3)),
    ("settle_time", q("settle time", "ms", 1e3)),
    // image
    ("pixel_size", q("pixel size", "mm", 1e3)),
    ("dpi", q("resolution", "dpi", 1.0)),
    ("notch_sigma_bins", q("notch width", "bins", 1.0)),
    ("bonds.size1", q("bond size", "mm", 1e3)),
    ("bonds.size2", q("bond size 2", "mm", 1e3)),
    ("bonds.period1", q("bond period 1", "mm", 1e3)),
    ("bonds.period2", q("bond period 2", "mm", 1e3)),
    ("bonds.contrast", q("bond contrast", "", 1.0)),
    ("bonds.angle", q("lattice angle", "°", 1.0)),
    ("synthetic.cv", q("CV of the synthetic web", "", 1.0)),
    // metrics (accuracy stage)
    ("radius_of_gyration", q("radius of gyration S", "mm", 1e3)),
    ("bending_energy", q("bending energy e", "", 1.0)),
    ("cv", q("CV", "", 1.0)),
    ("cv_corr", q("CV_corr", "", 1.0)),
    ("cv_corr_plain", q("CV_corr plain (paper)", "", 1.0)),
    ("cv_raw", q("CV raw", "", 1.0)),
    ("mean_areal_density", q("ρ_av", "g/m²", 1.0)),
    // energy diagnostics of a laydown
    ("kinetic", q("kinetic energy", "", 1.0)),
    ("elastic", q("elastic energy", "", 1.0)),
    ("work_drag", q("work of air drag", "", 1.0)),
    ("work_friction", q("work of friction", "", 1.0)),
    ("work_gravity", q("work of gravity", "", 1.0)),
    ("work_oscillation", q("work of the oscillation", "", 1.0)),
    ("work_damping", q("work of damping", "", 1.0)),
    ("work_contact", q("work of the belt contact", "", 1.0)),
    ("work_feed", q("work of the feed drive", "", 1.0)),
];

/// A label ready to draw: text and the factor from stored values.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    pub text: String,
    pub symbol: String,
    pub unit: String,
    pub scale: f64,
}

/// The label of `name` (a parameter or series name) with SI unit `si_unit`, whose
/// values are `values` (they choose the prefix of a quantity not in the table).
pub fn label(name: &str, si_unit: &str, values: &[f64]) -> Label {
    let (symbol, unit, scale) = match QUANTITIES.iter().find(|(n, _)| *n == name) {
        Some((_, q)) => (q.symbol.to_string(), q.unit.to_string(), q.scale),
        None => {
            let (unit, scale) = prefixed(si_unit, values);
            (name.rsplit('.').next().unwrap_or(name).replace('_', " "), unit, scale)
        }
    };
    Label { text: with_unit(&symbol, &unit), symbol, unit, scale }
}

/// `symbol (unit)`, or the symbol alone for a dimensionless quantity.
pub fn with_unit(symbol: &str, unit: &str) -> String {
    match unit {
        "" | "1" => symbol.to_string(),
        u => format!("{symbol} ({u})"),
    }
}

/// A unit prefix for metres and seconds that keeps the largest value between 1 and 1000.
fn prefixed(si_unit: &str, values: &[f64]) -> (String, f64) {
    let unit = match si_unit {
        "1" => "",
        "m^3" => "m³",
        "m^2" => "m²",
        u => u,
    };
    let largest = values.iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
    if !matches!(unit, "m" | "s") || largest == 0.0 || largest >= 1.0 {
        return (unit.to_string(), 1.0);
    }
    for (prefix, scale) in [("m", 1e3), ("µ", 1e6), ("n", 1e9)] {
        if largest * scale >= 1.0 {
            return (format!("{prefix}{unit}"), scale);
        }
    }
    (format!("n{unit}"), 1e9)
}

/// A value of parameter `name` as text in its display unit: `v_b/v_f = 0.05`,
/// `d = 30 µm`; non-numeric values as they are (`spectrum = spectrum1`).
pub fn value_text(name: &str, si_unit: &str, value: f64, text: &str, all_values: &[f64]) -> String {
    format!("{} = {}", label(name, si_unit, all_values).symbol, value_only(name, si_unit, value, text, all_values))
}

/// The value part of [`value_text`]: `30 µm`, `0.05`, `spectrum1`.
pub fn value_only(name: &str, si_unit: &str, value: f64, text: &str, all_values: &[f64]) -> String {
    let l = label(name, si_unit, all_values);
    if !value.is_finite() {
        return text.to_string();
    }
    let v = super::ticks::format_one(value * l.scale);
    match l.unit.as_str() {
        "" => v,
        "°" => format!("{v}°"),
        u => format!("{v} {u}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_get_physical_labels() {
        assert_eq!(label("belt_speed_ratio", "1", &[0.05]).text, "v_b/v_f");
        assert_eq!(label("fibre_diameter", "m", &[3e-5]).text, "d (µm)");
        assert_eq!(value_text("fibre_diameter", "m", 3e-5, "3e-05", &[3e-5]), "d = 30 µm");
        // not in the table: name without underscores, length in a prefix that suits it
        let l = label("bonds.offset_md", "m", &[2e-3, 5e-3]);
        assert_eq!((l.text.as_str(), l.scale), ("offset md (mm)", 1e3));
        assert_eq!(label("work_drag", "J", &[]).text, "work of air drag");
    }

    #[test]
    fn names_are_unique() {
        for (i, (a, _)) in QUANTITIES.iter().enumerate() {
            assert!(QUANTITIES[i + 1..].iter().all(|(b, _)| a != b), "{a} twice");
        }
    }
}
