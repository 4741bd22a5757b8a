//! Checks of a declared stage against its inputs as declared: what `run` would otherwise
//! find only after computing the upstream stages (e.g. a web reading one point of a swept
//! spectra stage, an image stage given both a grid input and files). Made by `validate` and `run` before anything is computed, once every
//! stage is valid on its own, its inputs exist with allowed kinds and form no cycle.
//!
//! These live here, outside the stage modules, because they concern the flow between
//! stages, not a stage's results: the stage modules are part of their kinds' code hash
//! ([`crate::code_hash`]), and a check added there would rerun every stored version once.
//! The stages' run-time checks stay as they are (a pipeline checked here passes them).
use crate::error::InvalidParam;
use super::StageDecl;
use crate::params::ParamValue;
use crate::stages::{spectra::declared_spectra, Declared};

/// `Err(InvalidParam::new(parameter or stage key, message))` for the first problem of `decl` (declared
/// with its inputs as `stage`) with its inputs.
pub fn check(decl: &StageDecl, stage: &Declared) -> Result<(), InvalidParam> {
    match stage.kind.as_str() {
        "web" => web_source(stage).and_then(|()| web_input_point(stage)),
        "spectra" => spectra_own_sweep(decl, stage),
        "image" => image_source(stage),
        "grid" => grid_own_sweep(decl, stage),
        _ => Ok(()),
    }
}

/// A grid of a swept web (or laid web) takes the input's points, so no sweep of its own.
fn grid_own_sweep(decl: &StageDecl, stage: &Declared) -> Result<(), InvalidParam> {
    match stage.inputs.first() {
        Some(input) if input.points.len() > 1 && !decl.sweep.is_empty() => Err(InvalidParam::new(
            "sweep".into(),
            format!(
                "the input {} `{}` has {} points; a grid reading it takes those points and cannot have a sweep of its own; allowed: one grid stage per setting",
                input.kind,
                input.name,
                input.points.len()
            ),
        )),
        _ => Ok(()),
    }
}

/// What a web's fibres are made from, by generator: random_phase needs a spectrum (an
/// input spectra stage or a preset, not both); laid_segments needs an input of laid
/// fibres; lay_down_sde needs its two parameters or an input to calibrate them on.
fn web_source(stage: &Declared) -> Result<(), InvalidParam> {
    for p in &stage.points {
        let p = crate::stages::web::WebStageParams::of(p);
        let (preset, generator) = (p.preset.as_str(), p.generator.name());
        let input = stage.inputs.first();
        if generator != "random_phase" && preset != "none" {
            return Err(InvalidParam::new("preset".into(), format!("a preset spectrum is for generator random_phase; generator {generator} does not use one; allowed: none")));
        }
        match (generator, input) {
            ("random_phase", None) if preset == "none" => {
                return Err(InvalidParam::new("preset".into(), "a web needs a spectrum; allowed: `input: <spectra stage>` or `preset: spectrum1|spectrum2|spectrum3`".into()));
            }
            ("random_phase", Some(input)) if preset != "none" => {
                return Err(InvalidParam::new("preset".into(), format!("give either an input spectra stage or `preset`, not both (input `{}`, preset {preset}); allowed with an input: none", input.name)));
            }
            ("laid_segments", None) => {
                return Err(InvalidParam::new("generator".into(), "generator laid_segments joins laid fibres; allowed: with `input: <spectra stage>` computed from a laydown or laid_web stage".into()));
            }
            ("lay_down_sde", input) => {
                let given = (p.sde_potential_length.is_some(), p.sde_noise.is_some());
                match (given, input) {
                    ((true, false), _) => return Err(InvalidParam::new("sde_noise".into(), "lay_down_sde: sde_potential_length is given, sde_noise is not; allowed: both, or neither to calibrate them on the input".into())),
                    ((false, true), _) => return Err(InvalidParam::new("sde_potential_length".into(), "lay_down_sde: sde_noise is given, sde_potential_length is not; allowed: both, or neither to calibrate them on the input".into())),
                    ((false, false), None) => {
                        return Err(InvalidParam::new("generator".into(), "generator lay_down_sde has nothing to calibrate its parameters on; allowed: give `sde_potential_length` and `sde_noise`, or an input spectra stage of laid fibres".into()))
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// An image stage reads one source: image files, a grid input (whose cell size is the
/// pixel size) or a synthetic image; and it is deterministic (one replicate).
fn image_source(stage: &Declared) -> Result<(), InvalidParam> {
    if stage.replicates != 1 {
        return Err(InvalidParam::new("replicates".into(), format!("an image stage is deterministic; allowed: 1, not {}", stage.replicates)));
    }
    for p in &stage.points {
        let p = crate::stages::image::stage::ImageStageParams::of(p);
        let (files, synthetic) = (!p.files.is_empty(), p.synthetic.kind != crate::stages::image::stage::SyntheticKind::None);
        match stage.inputs.first() {
            Some(input) => {
                if files {
                    return Err(InvalidParam::new("files".into(), format!("give `files` or a grid `input`, not both (input `{}`)", input.name)));
                }
                for (size, given) in [("pixel_size", p.analysis.pixel_size), ("dpi", p.analysis.dpi)] {
                    if given.is_some() {
                        return Err(InvalidParam::new(size.into(), format!("with a grid input the pixel size is the grid's cell_size (input `{}`); allowed: no {size}", input.name)));
                    }
                }
                if synthetic {
                    return Err(InvalidParam::new("synthetic.kind".into(), format!("give a grid `input` or a synthetic source, not both (input `{}`); allowed with an input: none", input.name)));
                }
            }
            None if !files && !synthetic => {
                return Err(InvalidParam::new("files".into(), "an image stage needs `files` (paths or globs), an `input` grid stage or a synthetic source (synthetic.kind)".into()));
            }
            None => {}
        }
    }
    Ok(())
}

/// A spectra stage reading laid fibres has one point per point of its input, so no
/// sweep of its own (refused by the stage at run time).
fn spectra_own_sweep(decl: &StageDecl, stage: &Declared) -> Result<(), InvalidParam> {
    match stage.inputs.first() {
        Some(input) if !decl.sweep.is_empty() => Err(InvalidParam::new(
            "sweep".into(),
            format!("a spectra stage reading laid fibres takes the sweep points of its input `{}`; it cannot have a sweep of its own; allowed: a sweep of the input stage", input.name),
        )),
        _ => Ok(()),
    }
}

/// A web's `input_point` names one point of its input spectra stage: needed when that
/// stage has several points (as the web stage requires at run time), and within them.
fn web_input_point(stage: &Declared) -> Result<(), InvalidParam> {
    let Some(input) = stage.inputs.first() else { return Ok(()) };
    let n = declared_spectra(input).len();
    for p in &stage.points {
        match p.0.get("input_point") {
            Some(ParamValue::Int(i)) if *i as usize >= n => {
                return Err(InvalidParam::new("input_point".into(), format!("input_point {i} is beyond the {n} point(s) of input `{}`; allowed: 0 to {}", input.name, n - 1)));
            }
            Some(ParamValue::Int(_)) => {}
            _ if n > 1 => {
                return Err(InvalidParam::new(
                    "input_point".into(),
                    format!("input `{}` has {n} points; choose one with `input_point`; allowed: 0 to {} (one web stage per spectrum, or a sweep of input_point)", input.name, n - 1),
                ));
            }
            _ => {}
        }
    }
    Ok(())
}
