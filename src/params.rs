//! Stage parameters: the typed table every stage publishes (name, unit, default,
//! allowed range, doc) and the validated values a pipeline gives them.
//!
//! One table serves YAML validation, `--help`, the JSON schema and the canonical
//! parameter YAML stored as provenance.
use std::collections::BTreeMap;
use std::fmt;

/// A parameter value as written in a pipeline (SI units for quantities).
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Text(String),
    /// A list of texts (file names, globs, labels).
    List(Vec<String>),
    /// No value: the parameter is derived automatically (documented per parameter).
    Auto,
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{}", format_float(*v)),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Text(v) => write!(f, "{v}"),
            ParamValue::List(v) => write!(f, "[{}]", v.join(", ")),
            ParamValue::Auto => write!(f, "auto"),
        }
    }
}

/// Shortest round-tripping form of a float in the style people write (5e-05, 0.2, 1000.0).
pub fn format_float(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e7) {
        let s = format!("{v:e}");
        // Rust prints 5e-5; write the exponent with two digits like YAML/Python do.
        match s.split_once('e') {
            Some((m, e)) => {
                let (sign, digits) = e.strip_prefix('-').map(|d| ("-", d)).unwrap_or(("+", e));
                format!("{m}e{sign}{digits:0>2}")
            }
            None => s,
        }
    } else {
        format!("{v:?}")
    }
}

/// What values a parameter accepts.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamKind {
    /// A real number in [min, max] (either bound may be infinite).
    Float { min: f64, max: f64 },
    /// An integer in [min, max].
    Int { min: i64, max: i64 },
    Bool,
    /// One of a fixed set of words.
    Choice(&'static [&'static str]),
    /// Free text (file names, globs, labels).
    Text,
    /// A list of texts; a single text is accepted as a list of one.
    TextList,
}

/// One entry of a stage's parameter table.
#[derive(Debug, Clone)]
pub struct ParamSpec {
    /// Dotted name as written under `params:` (`effects.drag` is `effects: {drag: ...}`).
    pub name: &'static str,
    /// SI unit, or "1" for dimensionless, "" for non-quantities.
    pub unit: &'static str,
    pub kind: ParamKind,
    pub default: ParamValue,
    /// `true` when `auto` (YAML null) is allowed and means "derive from other parameters".
    pub auto: bool,
    pub doc: &'static str,
}

impl ParamSpec {
    pub fn float(name: &'static str, unit: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> Self {
        ParamSpec { name, unit, kind: ParamKind::Float { min, max }, default: ParamValue::Float(default), auto: false, doc }
    }
    pub fn int(name: &'static str, unit: &'static str, default: i64, min: i64, max: i64, doc: &'static str) -> Self {
        ParamSpec { name, unit, kind: ParamKind::Int { min, max }, default: ParamValue::Int(default), auto: false, doc }
    }
    pub fn flag(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Bool, default: ParamValue::Bool(default), auto: false, doc }
    }
    pub fn choice(name: &'static str, choices: &'static [&'static str], default: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Choice(choices), default: ParamValue::Text(default.into()), auto: false, doc }
    }
    pub fn text(name: &'static str, default: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Text, default: ParamValue::Text(default.into()), auto: false, doc }
    }
    /// A list of texts, empty by default.
    pub fn text_list(name: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::TextList, default: ParamValue::List(vec![]), auto: false, doc }
    }
    /// Allow `auto` (YAML `null` or the word `auto`), and make it the default.
    pub fn auto_default(mut self) -> Self {
        self.auto = true;
        self.default = ParamValue::Auto;
        self
    }

    /// Human description of the allowed values, used in error messages and --help.
    pub fn allowed(&self) -> String {
        let unit = if self.unit.is_empty() || self.unit == "1" { String::new() } else { format!(" {}", self.unit) };
        let base = match &self.kind {
            ParamKind::Float { min, max } => match (min.is_finite(), max.is_finite()) {
                (true, true) if *min == f64::MIN_POSITIVE => format!("a number > 0 and ≤ {}{unit}", format_float(*max)),
                (true, false) if *min == f64::MIN_POSITIVE => format!("a number > 0{unit}"),
                (true, true) => format!("a number from {} to {}{unit}", format_float(*min), format_float(*max)),
                (true, false) => format!("a number ≥ {}{unit}", format_float(*min)),
                (false, true) => format!("a number ≤ {}{unit}", format_float(*max)),
                (false, false) => format!("a number{unit}"),
            },
            ParamKind::Int { min, max } => format!("a whole number from {min} to {max}{unit}"),
            ParamKind::Bool => "true or false".into(),
            ParamKind::Choice(c) => format!("one of {}", c.join(", ")),
            ParamKind::Text => "text".into(),
            ParamKind::TextList => "a list of texts".into(),
        };
        if self.auto { format!("{base}, or auto") } else { base }
    }

    /// Check a value against this spec. Integers are accepted where floats are asked.
    pub fn check(&self, value: &ParamValue) -> Result<ParamValue, String> {
        let bad = || Err(format!("expected {}, found {}", self.allowed(), describe(value)));
        match (&self.kind, value) {
            (_, ParamValue::Auto) if self.auto => Ok(ParamValue::Auto),
            (ParamKind::Float { min, max }, ParamValue::Float(_) | ParamValue::Int(_)) => {
                let v = match value {
                    ParamValue::Float(v) => *v,
                    ParamValue::Int(i) => *i as f64,
                    _ => unreachable!(),
                };
                if !v.is_finite() || v < *min || v > *max {
                    return Err(format!("{} is out of range; allowed: {}", format_float(v), self.allowed()));
                }
                Ok(ParamValue::Float(v))
            }
            (ParamKind::Int { min, max }, ParamValue::Int(v)) => {
                if v < min || v > max {
                    return Err(format!("{v} is out of range; allowed: {}", self.allowed()));
                }
                Ok(value.clone())
            }
            (ParamKind::Bool, ParamValue::Bool(_)) => Ok(value.clone()),
            (ParamKind::Choice(c), ParamValue::Text(s)) => {
                if c.contains(&s.as_str()) {
                    Ok(value.clone())
                } else {
                    Err(format!("`{s}` is not allowed; allowed: {}", self.allowed()))
                }
            }
            (ParamKind::Text, ParamValue::Text(_)) => Ok(value.clone()),
            (ParamKind::TextList, ParamValue::List(_)) => Ok(value.clone()),
            (ParamKind::TextList, ParamValue::Text(s)) => Ok(ParamValue::List(vec![s.clone()])),
            _ => bad(),
        }
    }
}

fn describe(v: &ParamValue) -> String {
    match v {
        ParamValue::Float(x) => format!("the number {}", format_float(*x)),
        ParamValue::Int(x) => format!("the number {x}"),
        ParamValue::Bool(b) => format!("the boolean {b}"),
        ParamValue::Text(s) => format!("the text `{s}`"),
        ParamValue::List(v) => format!("the list [{}]", v.join(", ")),
        ParamValue::Auto => "null".into(),
    }
}

/// Resolved parameters of one stage (or one sweep point): every parameter of the
/// table present, defaults filled in, keyed by dotted name.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamSet(pub BTreeMap<String, ParamValue>);

impl ParamSet {
    /// Defaults of the table overlaid with the given (already checked) values.
    pub fn resolve(specs: &[ParamSpec], given: &BTreeMap<String, ParamValue>) -> Self {
        let mut map = BTreeMap::new();
        for s in specs {
            map.insert(s.name.to_string(), given.get(s.name).cloned().unwrap_or_else(|| s.default.clone()));
        }
        ParamSet(map)
    }
    fn get(&self, name: &str) -> &ParamValue {
        self.0.get(name).unwrap_or_else(|| panic!("parameter `{name}` is not in the stage's table"))
    }
    pub fn f64(&self, name: &str) -> f64 {
        match self.get(name) {
            ParamValue::Float(v) => *v,
            ParamValue::Int(v) => *v as f64,
            other => panic!("parameter `{name}` is {other:?}, not a number"),
        }
    }
    /// A float parameter that may be `auto`.
    pub fn f64_or_auto(&self, name: &str) -> Option<f64> {
        match self.get(name) {
            ParamValue::Auto => None,
            _ => Some(self.f64(name)),
        }
    }
    pub fn int(&self, name: &str) -> i64 {
        match self.get(name) {
            ParamValue::Int(v) => *v,
            other => panic!("parameter `{name}` is {other:?}, not an integer"),
        }
    }
    pub fn usize(&self, name: &str) -> usize {
        self.int(name).max(0) as usize
    }
    pub fn bool(&self, name: &str) -> bool {
        match self.get(name) {
            ParamValue::Bool(v) => *v,
            other => panic!("parameter `{name}` is {other:?}, not a boolean"),
        }
    }
    pub fn text(&self, name: &str) -> &str {
        match self.get(name) {
            ParamValue::Text(v) => v,
            other => panic!("parameter `{name}` is {other:?}, not text"),
        }
    }

    pub fn text_list(&self, name: &str) -> &[String] {
        match self.get(name) {
            ParamValue::List(v) => v,
            other => panic!("parameter `{name}` is {other:?}, not a list of texts"),
        }
    }

    /// Canonical YAML: nested maps from dotted names, keys sorted, floats in shortest
    /// round-trip form. Equal parameter sets give byte-identical text.
    pub fn canonical_yaml(&self) -> String {
        let mut root = serde_yaml_ng::Mapping::new();
        for (name, value) in &self.0 {
            let parts: Vec<&str> = name.split('.').collect();
            insert_nested(&mut root, &parts, to_yaml(value));
        }
        if root.is_empty() {
            return "{}\n".into();
        }
        serde_yaml_ng::to_string(&serde_yaml_ng::Value::Mapping(root)).expect("parameters serialise")
    }
}

fn to_yaml(v: &ParamValue) -> serde_yaml_ng::Value {
    use serde_yaml_ng::Value;
    match v {
        ParamValue::Float(x) => Value::Number((*x).into()),
        ParamValue::Int(x) => Value::Number((*x).into()),
        ParamValue::Bool(b) => Value::Bool(*b),
        ParamValue::Text(s) => Value::String(s.clone()),
        ParamValue::List(v) => Value::Sequence(v.iter().map(|s| Value::String(s.clone())).collect()),
        ParamValue::Auto => Value::Null,
    }
}

fn insert_nested(map: &mut serde_yaml_ng::Mapping, parts: &[&str], value: serde_yaml_ng::Value) {
    let key = serde_yaml_ng::Value::String(parts[0].to_string());
    if parts.len() == 1 {
        map.insert(key, value);
        return;
    }
    let entry = map
        .entry(key)
        .or_insert_with(|| serde_yaml_ng::Value::Mapping(Default::default()));
    if let serde_yaml_ng::Value::Mapping(inner) = entry {
        insert_nested(inner, &parts[1..], value);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_range_and_int_promotion() {
        let s = ParamSpec::float("diameter", "m", 5e-5, 1e-6, 1e-3, "fibre diameter");
        assert_eq!(s.check(&ParamValue::Int(0)).unwrap_err(), "0.0 is out of range; allowed: a number from 1e-06 to 0.001 m");
        assert_eq!(s.check(&ParamValue::Float(2e-5)).unwrap(), ParamValue::Float(2e-5));
        assert!(s.check(&ParamValue::Text("x".into())).unwrap_err().contains("found the text `x`"));
        assert!(s.check(&ParamValue::Float(f64::NAN)).is_err());
    }

    #[test]
    fn canonical_yaml_nests_and_sorts() {
        let mut m = BTreeMap::new();
        m.insert("effects.drag".to_string(), ParamValue::Bool(false));
        m.insert("diameter".to_string(), ParamValue::Float(5e-5));
        m.insert("elements".to_string(), ParamValue::Int(1000));
        let y = ParamSet(m).canonical_yaml();
        assert_eq!(y, "diameter: 0.00005\neffects:\n  drag: false\nelements: 1000\n");
    }

    #[test]
    fn text_lists_accept_one_text_and_serialise_as_sequences() {
        let s = ParamSpec::text_list("files", "image files");
        assert_eq!(s.check(&ParamValue::Text("a.png".into())).unwrap(), ParamValue::List(vec!["a.png".into()]));
        assert!(s.check(&ParamValue::Int(3)).unwrap_err().contains("expected a list of texts"));
        let mut m = BTreeMap::new();
        m.insert("files".to_string(), ParamValue::List(vec!["b/*.png".into(), "a.tif".into()]));
        assert_eq!(ParamSet(m).canonical_yaml(), "files:\n- b/*.png\n- a.tif\n");
    }

    #[test]
    fn float_formatting() {
        assert_eq!(format_float(5e-5), "5e-05");
        assert_eq!(format_float(0.2), "0.2");
        assert_eq!(format_float(1000.0), "1000.0");
    }
}

/// The numerics modules keep their own static tables (`stages::param_table`); this
/// turns a row into the pipeline's spec so there is one source of truth per parameter.
impl From<&crate::param_table::ParamSpec> for ParamSpec {
    fn from(p: &crate::param_table::ParamSpec) -> Self {
        use crate::param_table::ParamDefault;
        let (kind, default) = match p.default {
            ParamDefault::Real(v) => (ParamKind::Float { min: p.min, max: p.max }, ParamValue::Float(v)),
            ParamDefault::Integer(v) => (
                ParamKind::Int { min: p.min as i64, max: if p.max >= i64::MAX as f64 { i64::MAX } else { p.max as i64 } },
                ParamValue::Int(v as i64),
            ),
            ParamDefault::Choice(c) => (ParamKind::Choice(p.choices), ParamValue::Text(c.to_string())),
            ParamDefault::Bool(b) => (ParamKind::Bool, ParamValue::Bool(b)),
            ParamDefault::Unset => (ParamKind::Float { min: p.min, max: p.max }, ParamValue::Auto),
        };
        let auto = matches!(p.default, ParamDefault::Unset);
        ParamSpec { name: p.name, unit: p.unit, kind, default, auto, doc: p.doc }
    }
}
