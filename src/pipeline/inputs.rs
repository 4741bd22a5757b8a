//! Checks of a declared stage against its inputs as declared: what `run` would otherwise
//! find only after computing the upstream stages (e.g. a web reading one point of a swept
//! spectra stage). Made by `validate` and `run` before anything is computed, once every
//! stage is valid on its own, its inputs exist with allowed kinds and form no cycle.
//!
//! These live here, outside the stage modules, because they concern the flow between
//! stages, not a stage's results: the stage modules are part of their kinds' code hash
//! ([`crate::code_hash`]), and a check added there would rerun every stored version once.
//! The stages' run-time checks stay as they are (a pipeline checked here passes them).
use super::StageDecl;
use crate::params::ParamValue;
use crate::stages::{spectra::declared_spectra, Declared};

/// `Err((parameter or stage key, message))` for the first problem of `decl` (declared
/// with its inputs as `stage`) with its inputs.
pub fn check(decl: &StageDecl, stage: &Declared) -> Result<(), (String, String)> {
    match stage.kind.as_str() {
        "web" => web_input_point(stage),
        "spectra" => spectra_own_sweep(decl, stage),
        _ => Ok(()),
    }
}

/// A spectra stage reading laid fibres has one point per point of its input, so no
/// sweep of its own (refused by the stage at run time).
fn spectra_own_sweep(decl: &StageDecl, stage: &Declared) -> Result<(), (String, String)> {
    match stage.inputs.first() {
        Some(input) if !decl.sweep.is_empty() => Err((
            "sweep".into(),
            format!("a spectra stage reading laid fibres takes the sweep points of its input `{}`; allowed: no sweep here (sweep the input stage instead)", input.name),
        )),
        _ => Ok(()),
    }
}

/// A web's `input_point` names one point of its input spectra stage: needed when that
/// stage has several points (as the web stage requires at run time), and within them.
fn web_input_point(stage: &Declared) -> Result<(), (String, String)> {
    let Some(input) = stage.inputs.first() else { return Ok(()) };
    let n = declared_spectra(input).len();
    for p in &stage.points {
        match p.0.get("input_point") {
            Some(ParamValue::Int(i)) if *i as usize >= n => {
                return Err(("input_point".into(), format!("input_point {i} is beyond the {n} point(s) of input `{}`; allowed: 0 to {}", input.name, n - 1)));
            }
            Some(ParamValue::Int(_)) => {}
            _ if n > 1 => {
                return Err((
                    "input_point".into(),
                    format!(
                        "input `{}` has {n} points, so the web must choose one; allowed: `input_point: 0..{}` (one web stage per spectrum, or a sweep of input_point)",
                        input.name,
                        n - 1
                    ),
                ));
            }
            _ => {}
        }
    }
    Ok(())
}
