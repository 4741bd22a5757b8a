//! Stage parameters: the table every stage publishes and the values a pipeline gives it.
//!
//! - A table is a `const` slice of [`ParamSpec`] rows (name, SI unit, default, allowed
//!   values, doc). The same rows serve the pipeline checker, `laydown stages KIND`, the
//!   JSON schema, the canonical parameter YAML stored as provenance, and the numerics'
//!   own `validate()` ([`ParamSpec::check_number`]).
//! - A [`ParamSet`] holds one sweep point's checked values; [`ParamSet::to_typed`] turns
//!   it into the stage's typed parameters (a serde struct whose fields are named as the
//!   rows), the one way a stage reads its parameters.
//! - A choice parameter's enum is declared once with its words by `choice_enum!`.
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

/// Declares the enum of a choice parameter with the word each variant is written as,
/// once: the enum gets `NAMES` (for the parameter table), `name()`, `from_name()` and
/// serde (de)serialisation by those words, so a [`ParamSet`] converts to it
/// ([`ParamSet::to_typed`]). The variant marked `#[default]` is the default.
///
/// ```ignore
/// choice_enum! {
///     /// How mass reaches the cells.
///     pub enum Deposit {
///         #[default]
///         PointMass = "point_mass",
///         SegmentClipping = "segment_clipping",
///     }
/// }
/// assert_eq!(Deposit::from_name("segment_clipping"), Ok(Deposit::SegmentClipping));
/// assert_eq!(Deposit::NAMES, &["point_mass", "segment_clipping"]);
/// ```
macro_rules! choice_enum {
    ($(#[$meta:meta])* $vis:vis enum $name:ident { $($(#[$vmeta:meta])* $variant:ident = $word:literal),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
        $vis enum $name {
            $($(#[$vmeta])* $variant),+
        }
        impl $name {
            /// The words of the variants, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($word),+];
            /// The word of this variant.
            pub fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $word),+
                }
            }
            /// The variant written as `word`.
            pub fn from_name(word: &str) -> Result<Self, $crate::params::UnknownChoice> {
                match word {
                    $($word => Ok(Self::$variant),)+
                    _ => Err($crate::params::UnknownChoice { choice: stringify!($name), word: word.to_string(), allowed: Self::NAMES }),
                }
            }
        }
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                serializer.serialize_str(self.name())
            }
        }
        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                let word = <String as serde::Deserialize>::deserialize(deserializer)?;
                Self::from_name(&word).map_err(|_| <D::Error as serde::de::Error>::unknown_variant(&word, Self::NAMES))
            }
        }
    };
}
pub(crate) use choice_enum;

/// A word that is none of a choice's variants.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{word}` is not a {choice}; allowed: {}", allowed.join(", "))]
pub struct UnknownChoice {
    pub choice: &'static str,
    pub word: String,
    pub allowed: &'static [&'static str],
}

/// What values a parameter accepts.
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// The default of a parameter (a [`ParamValue`] that can live in a `const` table).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamDefault {
    Float(f64),
    Int(i64),
    Bool(bool),
    /// A choice's word or a text.
    Text(&'static str),
    /// An empty list of texts.
    NoTexts,
    /// Derived from other parameters or the input (documented per parameter).
    Auto,
}

impl ParamDefault {
    /// The default as a pipeline value.
    pub fn value(self) -> ParamValue {
        match self {
            ParamDefault::Float(v) => ParamValue::Float(v),
            ParamDefault::Int(v) => ParamValue::Int(v),
            ParamDefault::Bool(b) => ParamValue::Bool(b),
            ParamDefault::Text(t) => ParamValue::Text(t.to_string()),
            ParamDefault::NoTexts => ParamValue::List(vec![]),
            ParamDefault::Auto => ParamValue::Auto,
        }
    }
    /// A numeric default as a number (None for the other kinds).
    pub fn number(self) -> Option<f64> {
        match self {
            ParamDefault::Float(v) => Some(v),
            ParamDefault::Int(v) => Some(v as f64),
            _ => None,
        }
    }
}

impl fmt::Display for ParamDefault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.value().fmt(f)
    }
}

/// A value outside its parameter's allowed values, as the numerics library reports it
/// (the pipeline checker reports the same rows with file, line and column).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{name}` = {value} is not allowed; allowed: {allowed}")]
pub struct ParamError {
    pub name: &'static str,
    pub value: String,
    pub allowed: String,
}

/// One row of a stage's parameter table: the one description of a parameter that the
/// pipeline checker, `--help`, the JSON schema, the provenance YAML and the numerics'
/// own `validate()` all use. Tables are `const` slices of rows, e.g.
///
/// ```
/// use laydown::params::ParamSpec;
/// const TABLE: &[ParamSpec] = &[
///     ParamSpec::float("cell_size", "m", 1e-3, 1e-6, 1.0, "Δh, grid cell side"),
///     ParamSpec::int("zones_per_octave", "1", 2, 1, 64, "zone sizes per doubling"),
/// ];
/// let row = ParamSpec::find(TABLE, "cell_size");
/// assert!(row.check_number(5e-4).is_ok());
/// assert_eq!(row.check_number(2.0).unwrap_err().to_string(),
///            "parameter `cell_size` = 2 is not allowed; allowed: a number from 1e-06 to 1.0 m");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Dotted name as written under `params:` (`effects.drag` is `effects: {drag: ...}`).
    pub name: &'static str,
    /// SI unit, or "1" for dimensionless, "" for non-quantities.
    pub unit: &'static str,
    pub kind: ParamKind,
    pub default: ParamDefault,
    /// `true` when `auto` (YAML null) is allowed and means "derive from other parameters".
    pub auto: bool,
    pub doc: &'static str,
}

impl ParamSpec {
    pub const fn float(name: &'static str, unit: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> Self {
        ParamSpec { name, unit, kind: ParamKind::Float { min, max }, default: ParamDefault::Float(default), auto: false, doc }
    }
    pub const fn int(name: &'static str, unit: &'static str, default: i64, min: i64, max: i64, doc: &'static str) -> Self {
        ParamSpec { name, unit, kind: ParamKind::Int { min, max }, default: ParamDefault::Int(default), auto: false, doc }
    }
    pub const fn flag(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Bool, default: ParamDefault::Bool(default), auto: false, doc }
    }
    pub const fn choice(name: &'static str, choices: &'static [&'static str], default: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Choice(choices), default: ParamDefault::Text(default), auto: false, doc }
    }
    pub const fn text(name: &'static str, default: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::Text, default: ParamDefault::Text(default), auto: false, doc }
    }
    /// A real number that is `auto` (derived) unless given.
    pub const fn auto_float(name: &'static str, unit: &'static str, min: f64, max: f64, doc: &'static str) -> Self {
        ParamSpec { name, unit, kind: ParamKind::Float { min, max }, default: ParamDefault::Auto, auto: true, doc }
    }
    /// A list of texts, empty by default.
    pub const fn text_list(name: &'static str, doc: &'static str) -> Self {
        ParamSpec { name, unit: "", kind: ParamKind::TextList, default: ParamDefault::NoTexts, auto: false, doc }
    }
    /// Allow `auto` (YAML `null` or the word `auto`), and make it the default.
    pub const fn auto_default(self) -> Self {
        ParamSpec { auto: true, default: ParamDefault::Auto, ..self }
    }
    /// The same row with another description.
    pub const fn with_doc(self, doc: &'static str) -> Self {
        ParamSpec { doc, ..self }
    }

    /// The row named `name` of `table`. Panics if there is none (a programming error).
    pub fn find<'t>(table: &'t [ParamSpec], name: &str) -> &'t ParamSpec {
        table.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no parameter `{name}` in the table"))
    }

    /// Checks a number held by the numerics against the row (NaN is never allowed;
    /// an integer row takes whole numbers only).
    pub fn check_number(&self, value: f64) -> Result<(), ParamError> {
        let ok = match self.kind {
            ParamKind::Float { min, max } => value.is_finite() && value >= min && value <= max,
            ParamKind::Int { min, max } => value.fract() == 0.0 && value >= min as f64 && value <= max as f64,
            ParamKind::Bool => value == 0.0 || value == 1.0,
            _ => false,
        };
        if ok {
            Ok(())
        } else {
            Err(ParamError { name: self.name, value: format!("{value}"), allowed: self.allowed() })
        }
    }

    /// Checks a word against a choice row.
    pub fn check_choice(&self, word: &str) -> Result<(), ParamError> {
        match self.kind {
            ParamKind::Choice(c) if c.contains(&word) => Ok(()),
            _ => Err(ParamError { name: self.name, value: word.to_string(), allowed: self.allowed() }),
        }
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

/// Parameters that do not fit a stage's typed parameters: a table and a struct that
/// disagree (a programming error the stages' tests catch), never bad input (the
/// pipeline checker has checked every value against its row).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameters do not fit {target}: {message}")]
pub struct TypedParamsError {
    pub target: &'static str,
    pub message: String,
}

/// A valid parameter setting known to give poor results (e.g. a scheme that loses
/// replicates in that range): its key as written in the pipeline file and what to do
/// instead. `validate` and `run` print it as a warning with the key's file, line and
/// column; the pipeline still runs (see `Stage::cautions`).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamCaution {
    pub key: String,
    pub message: String,
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
            map.insert(s.name.to_string(), given.get(s.name).cloned().unwrap_or_else(|| s.default.value()));
        }
        ParamSet(map)
    }
    /// The table's defaults.
    pub fn defaults(specs: &[ParamSpec]) -> Self {
        Self::resolve(specs, &BTreeMap::new())
    }

    /// The typed parameters `T` of this set, the one way from a pipeline's parameters to
    /// a stage's: every row becomes the field of its name (a dotted name `a.b` the field
    /// `b` of the struct in field `a`), a choice the enum variant of its word
    /// (`choice_enum!`), `auto` `None` (an `Option` field), an integer row any integer
    /// field. Rows `T` has no field for are left to the caller (a library struct inside
    /// a stage's); a field with no row, or a value its type cannot hold, is an error
    /// naming the field.
    ///
    /// ```
    /// use laydown::params::{ParamSet, ParamSpec};
    /// #[derive(serde::Deserialize)]
    /// struct Window { cell_size: f64, zones_per_octave: usize, offset: Offset }
    /// #[derive(serde::Deserialize)]
    /// struct Offset { md: f64, cd: Option<f64> }
    /// let table = [
    ///     ParamSpec::float("cell_size", "m", 1e-3, 1e-6, 1.0, "Δh"),
    ///     ParamSpec::int("zones_per_octave", "1", 2, 1, 64, "zone sizes per doubling"),
    ///     ParamSpec::float("offset.md", "m", 0.0, -1.0, 1.0, "MD shift"),
    ///     ParamSpec::float("offset.cd", "m", 0.0, -1.0, 1.0, "CD shift").auto_default(),
    /// ];
    /// let w: Window = ParamSet::defaults(&table).to_typed().unwrap();
    /// assert_eq!((w.cell_size, w.zones_per_octave, w.offset.md, w.offset.cd), (1e-3, 2, 0.0, None));
    /// ```
    pub fn to_typed<T: serde::de::DeserializeOwned>(&self) -> Result<T, TypedParamsError> {
        use serde_json::{Map, Value};
        fn insert(map: &mut Map<String, Value>, parts: &[&str], value: Value) {
            match parts {
                [leaf] => {
                    map.insert(leaf.to_string(), value);
                }
                [head, rest @ ..] => {
                    let inner = map.entry(head.to_string()).or_insert_with(|| Value::Object(Map::new()));
                    if let Value::Object(inner) = inner {
                        insert(inner, rest, value);
                    }
                }
                [] => {}
            }
        }
        let mut root = Map::new();
        for (name, value) in &self.0 {
            let v = match value {
                ParamValue::Float(f) => serde_json::json!(f),
                ParamValue::Int(i) => serde_json::json!(i),
                ParamValue::Bool(b) => serde_json::json!(b),
                ParamValue::Text(s) => serde_json::json!(s),
                ParamValue::List(v) => serde_json::json!(v),
                ParamValue::Auto => Value::Null,
            };
            insert(&mut root, &name.split('.').collect::<Vec<_>>(), v);
        }
        serde_json::from_value(Value::Object(root)).map_err(|e| TypedParamsError { target: std::any::type_name::<T>(), message: e.to_string() })
    }

    /// The inverse of [`ParamSet::to_typed`]: the rows a typed value stands for, keyed by
    /// dotted name. A stage's tests check `from_typed(to_typed(defaults)) == defaults`,
    /// which holds only when every row is a field and every field a row.
    pub fn from_typed<T: serde::Serialize>(value: &T) -> Result<Self, TypedParamsError> {
        use serde_json::Value;
        let error = |message: String| TypedParamsError { target: std::any::type_name::<T>(), message };
        fn walk(prefix: &str, value: &Value, out: &mut BTreeMap<String, ParamValue>) -> Result<(), String> {
            let v = match value {
                Value::Object(map) => {
                    for (key, inner) in map {
                        let name = if prefix.is_empty() { key.clone() } else { format!("{prefix}.{key}") };
                        walk(&name, inner, out)?;
                    }
                    return Ok(());
                }
                Value::Null => ParamValue::Auto,
                Value::Bool(b) => ParamValue::Bool(*b),
                Value::Number(n) => match n.as_i64() {
                    Some(i) if !n.is_f64() => ParamValue::Int(i),
                    _ => ParamValue::Float(n.as_f64().ok_or_else(|| format!("`{prefix}`: {n} is not a number a row holds"))?),
                },
                Value::String(t) => ParamValue::Text(t.clone()),
                Value::Array(items) => ParamValue::List(items.iter().map(|i| i.as_str().map(str::to_string).ok_or_else(|| format!("`{prefix}`: a list of non-texts"))).collect::<Result<_, _>>()?),
            };
            out.insert(prefix.to_string(), v);
            Ok(())
        }
        let json = serde_json::to_value(value).map_err(|e| error(e.to_string()))?;
        let mut out = BTreeMap::new();
        walk("", &json, &mut out).map_err(error)?;
        Ok(ParamSet(out))
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

/// Checks that a table and a typed struct describe the same parameters: the table's
/// defaults convert to `default` and back to the same rows (so every row is a field and
/// every field a row, with the same default), and every numeric default is allowed.
#[cfg(test)]
pub(crate) fn assert_table_matches<T>(table: &[ParamSpec], default: &T)
where
    T: serde::Serialize + serde::de::DeserializeOwned + PartialEq + fmt::Debug,
{
    let rows = ParamSet::defaults(table);
    let typed: T = rows.to_typed().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(&typed, default, "the table's defaults are not the typed defaults");
    assert_eq!(ParamSet::from_typed(&typed).unwrap(), rows, "rows and fields differ");
    for row in table {
        if let Some(v) = row.default.number() {
            row.check_number(v).unwrap_or_else(|e| panic!("default: {e}"));
        }
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
