//! The JSON Schema of pipeline files, generated from the stages' parameter tables so
//! that the schema and the Rust checker cannot drift apart. `schemas/pipeline.schema.json`
//! is this output (a test keeps them equal). Checks a schema cannot express (inputs
//! naming existing stages, cycles, zipped list lengths, cross-parameter rules) are the
//! Rust checker's alone.
use crate::params::{ParamKind, ParamSpec};
use crate::stages;
use serde_json::{json, Map, Value};

/// The JSON Schema of one parameter's value (also in `laydown stages KIND --json`).
pub fn value_schema(p: &ParamSpec) -> Value {
    let mut s = match &p.kind {
        ParamKind::Float { min, max } => {
            let mut m = Map::new();
            m.insert("type".into(), json!("number"));
            if min.is_finite() {
                m.insert("minimum".into(), json!(min));
            }
            if max.is_finite() {
                m.insert("maximum".into(), json!(max));
            }
            Value::Object(m)
        }
        ParamKind::Int { min, max } => json!({"type": "integer", "minimum": min, "maximum": max}),
        ParamKind::Bool => json!({"type": "boolean"}),
        ParamKind::Choice(c) => json!({"type": "string", "enum": c}),
        ParamKind::Text => json!({"type": "string"}),
        ParamKind::TextList => json!({"anyOf": [{"type": "string"}, {"type": "array", "items": {"type": "string"}}]}),
    };
    if p.auto {
        s = json!({"anyOf": [s, {"type": "null"}, {"const": "auto"}]});
    }
    s
}

/// Nested object schema for dotted parameter names; `leaf` maps a spec to its schema.
fn params_object(specs: &[ParamSpec], leaf: &dyn Fn(&ParamSpec) -> Value) -> Value {
    let mut root = Map::new();
    for p in specs {
        let parts: Vec<&str> = p.name.split('.').collect();
        insert(&mut root, &parts, leaf(p), p);
    }
    finish(root)
}

fn insert(obj: &mut Map<String, Value>, parts: &[&str], schema: Value, p: &ParamSpec) {
    if parts.len() == 1 {
        let mut s = schema;
        if let Value::Object(m) = &mut s {
            let unit = if p.unit.is_empty() { String::new() } else { format!(" [{}]", p.unit) };
            m.insert("description".into(), json!(format!("{}{unit}; default {}", p.doc, p.default)));
        }
        obj.insert(parts[0].to_string(), s);
        return;
    }
    let child = obj.entry(parts[0].to_string()).or_insert_with(|| Value::Object(Map::new()));
    if let Value::Object(m) = child {
        insert(m, &parts[1..], schema, p);
    }
}

/// Turn a map of children into an object schema (recursively for nested groups).
fn finish(children: Map<String, Value>) -> Value {
    let props: Map<String, Value> = children
        .into_iter()
        .map(|(k, v)| {
            let is_group = matches!(&v, Value::Object(m) if !m.contains_key("type") && !m.contains_key("anyOf") && !m.contains_key("description"));
            let v = if is_group {
                match v {
                    Value::Object(m) => finish(m),
                    _ => unreachable!(),
                }
            } else {
                v
            };
            (k, v)
        })
        .collect();
    json!({"type": "object", "additionalProperties": false, "properties": props})
}

pub fn pipeline_schema() -> Value {
    let kinds: Vec<Value> = stages::registry()
        .iter()
        .map(|s| {
            let specs = s.params();
            let params = params_object(&specs, &value_schema);
            let list = |p: &ParamSpec| json!({"type": "array", "minItems": 1, "items": value_schema(p)});
            let mut sweep = params_object(&specs, &list);
            // A sweep may also name nested parameters with dots (`effects.drag: [true, false]`).
            if let Some(Value::Object(props)) = sweep.get_mut("properties") {
                for p in specs.iter().filter(|p| p.name.contains('.')) {
                    let mut s = list(p);
                    s["description"] = json!(format!("{} (dotted form of the nested parameter)", p.doc));
                    props.insert(p.name.to_string(), s);
                }
            }
            json!({
                "if": {"properties": {"kind": {"const": s.kind()}}, "required": ["kind"]},
                "then": {"properties": {"params": params, "sweep": sweep}}
            })
        })
        .collect();
    let names = json!({"type": "string", "pattern": "^[a-z][a-z0-9_]*$"});
    json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://laydown.invalid/schemas/pipeline.schema.json",
        "title": "laydown pipeline",
        "description": "A laydown pipeline: stages chained by `input`, results in one versioned HDF5 archive. Units are SI.",
        "type": "object",
        "additionalProperties": false,
        "required": ["pipeline", "archive", "stages"],
        "properties": {
            "pipeline": {"type": "string", "description": "Pipeline name"},
            "archive": {"type": "string", "minLength": 1, "pattern": "\\S", "description": "Path of the HDF5 archive (relative to the pipeline file's directory)"},
            "seed": {"type": "integer", "minimum": 0, "maximum": i64::MAX, "description": "Base seed of every random stream; default 0"},
            "description": {"type": "string"},
            "executor": {
                "description": "Where stages run: local (this process, all cores; the default) or slurm (one job array per stage)",
                "anyOf": [
                    {"enum": crate::executor::ExecutorKind::NAMES},
                    {
                        "type": "object",
                        "additionalProperties": false,
                        "required": ["kind"],
                        "properties": {
                            "kind": {"enum": crate::executor::ExecutorKind::NAMES},
                            "partition": {"type": "string", "description": "Slurm partition (sbatch --partition)"},
                            "max_parallel": {"type": "integer", "minimum": 1, "maximum": 1000000, "description": "At most this many array tasks at once"},
                            "units_per_task": {"type": "integer", "minimum": 1, "maximum": 1000000, "description": "Units (replicates of a sweep point) per array task; default 1"},
                            "sbatch_args": {"type": "array", "items": {"type": "string"}, "description": "Extra sbatch arguments, e.g. --time=01:00:00"}
                        }
                    }
                ]
            },
            "stages": {
                "type": "array",
                "minItems": 1,
                "items": {
                    "type": "object",
                    "additionalProperties": false,
                    "required": ["name", "kind"],
                    "properties": {
                        "name": names,
                        "kind": {"enum": stages::kinds()},
                        "input": {"anyOf": [{"type": "string"}, {"type": "array", "items": {"type": "string"}}]},
                        "params": {"type": "object"},
                        "sweep": {"type": "object"},
                        "sweep_mode": {"enum": ["cartesian", "zip"]},
                        "replicates": {"type": "integer", "minimum": 1, "maximum": 100000},
                        "seed": {"type": "integer", "minimum": 0, "maximum": i64::MAX},
                        "description": {"type": "string"}
                    },
                    "allOf": kinds
                }
            }
        }
    })
}
