//! Static parameter tables shared by the stages (laydown, spectra, web, grid, image).
//!
//! Each stage exposes `PARAMS: &[ParamSpec]`, one row per field of its params
//! struct. The pipeline uses the rows for YAML validation, `--help` and a JSON
//! schema; each stage's `validate()` checks its numeric fields against the same
//! rows (via [`ParamSpec::check`]), so the table and the checks cannot drift apart.

/// Default value of a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamDefault {
    Real(f64),
    Integer(u64),
    /// One of [`ParamSpec::choices`].
    Choice(&'static str),
    /// A switch (bounds 0 and 1).
    Bool(bool),
    /// No default: optional, the doc says what happens when absent.
    Unset,
}

/// One row of a stage's parameter table. Bounds are inclusive; a strictly
/// positive quantity has `min = f64::MIN_POSITIVE`. For choices the bounds are unused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Field name (also the YAML key).
    pub name: &'static str,
    /// SI unit ("1" for dimensionless, "" for choices).
    pub unit: &'static str,
    pub default: ParamDefault,
    pub min: f64,
    pub max: f64,
    /// Allowed values of a choice parameter (empty otherwise).
    pub choices: &'static [&'static str],
    /// One-line description with the paper's symbol and equation.
    pub doc: &'static str,
}

/// A parameter outside its allowed range (or not an allowed choice).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{name}` = {value} is outside its allowed range {range}")]
pub struct ParamError {
    pub name: &'static str,
    pub value: String,
    pub range: String,
}

impl ParamSpec {
    /// A real-valued row.
    pub const fn real(name: &'static str, unit: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> Self {
        ParamSpec { name, unit, default: ParamDefault::Real(default), min, max, choices: &[], doc }
    }

    /// A dimensionless integer row.
    pub const fn integer(name: &'static str, default: u64, min: f64, max: f64, doc: &'static str) -> Self {
        ParamSpec { name, unit: "1", default: ParamDefault::Integer(default), min, max, choices: &[], doc }
    }

    /// The default of a numeric row as a number (None for choices, switches, unset).
    pub fn default_number(&self) -> Option<f64> {
        match self.default {
            ParamDefault::Real(v) => Some(v),
            ParamDefault::Integer(n) => Some(n as f64),
            _ => None,
        }
    }

    /// Whether the row takes whole numbers only.
    pub fn is_integer(&self) -> bool {
        matches!(self.default, ParamDefault::Integer(_))
    }

    /// Checks a numeric value against the row's bounds (NaN is always rejected).
    pub fn check(&self, value: f64) -> Result<(), ParamError> {
        let integer_ok = !self.is_integer() || value.fract() == 0.0;
        if value >= self.min && value <= self.max && integer_ok {
            Ok(())
        } else {
            Err(ParamError { name: self.name, value: format!("{value}"), range: self.range_text() })
        }
    }

    /// Checks a choice against the row's allowed values.
    pub fn check_choice(&self, value: &str) -> Result<(), ParamError> {
        if self.choices.contains(&value) {
            Ok(())
        } else {
            Err(ParamError { name: self.name, value: value.to_string(), range: self.range_text() })
        }
    }

    /// Human-readable allowed range, e.g. `[1e-6, 1] m` or `one of {a, b}`.
    pub fn range_text(&self) -> String {
        if !self.choices.is_empty() {
            return format!("one of {{{}}}", self.choices.join(", "));
        }
        let lo = if self.min == f64::MIN_POSITIVE { "(0".to_string() } else { format!("[{}", self.min) };
        let kind = if matches!(self.default, ParamDefault::Integer(_)) { " (integer)" } else { "" };
        format!("{lo}, {}] {}{kind}", self.max, self.unit)
    }
}

/// Looks a row up by name. Panics if the table has no such row (a programming error).
pub fn spec(table: &'static [ParamSpec], name: &str) -> &'static ParamSpec {
    table.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no parameter `{name}` in table"))
}

#[cfg(test)]
mod tests {
    use super::*;
    const T: &[ParamSpec] = &[ParamSpec {
        name: "n",
        unit: "1",
        default: ParamDefault::Integer(3),
        min: 1.0,
        max: 10.0,
        choices: &[],
        doc: "count",
    }];

    #[test]
    fn checks_bounds_and_integers() {
        let s = spec(T, "n");
        assert!(s.check(3.0).is_ok());
        assert!(s.check(0.0).is_err());
        assert!(s.check(2.5).is_err());
        assert!(s.check(f64::NAN).is_err());
        let msg = s.check(11.0).unwrap_err().to_string();
        assert!(msg.contains("`n`") && msg.contains("[1, 10]"), "{msg}");
    }
}
