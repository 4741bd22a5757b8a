//! What one run of a declared stage is, for the runner and for a Slurm array task alike:
//! its fingerprint ([`fingerprint`], which decides whether a version in the archive is up
//! to date) and the [`RunContext`] the stage computes in ([`stage_context`]).
use super::{Pipeline, StageDecl};
use crate::archive::VersionInfo;
use crate::stages::{self, Input, RunContext};

/// The fingerprint of a run of `decl`: blake3 over its kind, `cache_version`, the hash
/// of the stage code, canonical parameters, sweep, replicates, seed and the content
/// hashes of its input versions (`inputs`: name, hash). Equal fingerprints mean equal
/// results.
pub fn fingerprint(decl: &StageDecl, cache_version: u32, seed: u64, inputs: &[(String, String)]) -> String {
    fingerprint_with_code(decl, cache_version, stages::code_hash(&decl.kind), seed, inputs)
}

/// [`fingerprint`] with the stage code's hash given.
fn fingerprint_with_code(decl: &StageDecl, cache_version: u32, code: &str, seed: u64, inputs: &[(String, String)]) -> String {
    let mut h = blake3::Hasher::new();
    let mut field = |k: &str, v: &str| {
        h.update(k.as_bytes());
        h.update(b"=");
        h.update(v.as_bytes());
        h.update(b"\n");
    };
    field("kind", &decl.kind);
    field("cache_version", &cache_version.to_string());
    field("code", code);
    field("params", &decl.params.canonical_yaml());
    field("sweep", &decl.sweep_yaml());
    field("replicates", &decl.replicates.to_string());
    field("seed", &seed.to_string());
    for (name, hash) in inputs {
        field(&format!("input.{name}"), hash);
    }
    h.finalize().to_hex()[..32].to_string()
}

/// The context of a whole stage run (all its sweep points) on the given input versions;
/// `version` is the number the run will commit as.
pub fn stage_context(pipeline: &Pipeline, decl: &StageDecl, inputs: &[VersionInfo], progress: bool, version: u32) -> RunContext {
    let (points, sweep) = decl.points();
    RunContext {
        stage_name: decl.name.clone(),
        points,
        sweep,
        replicates: decl.replicates,
        seed: decl.seed.unwrap_or(pipeline.seed),
        inputs: decl
            .inputs
            .iter()
            .zip(inputs)
            .map(|(n, v)| Input { name: n.clone(), kind: pipeline.stage(n).unwrap().kind.clone(), version: v.clone() })
            .collect(),
        progress,
        pipeline_dir: pipeline_dir(pipeline),
        figure_dir: crate::archive::figure_dir(&pipeline.archive, &decl.name, version),
    }
}

/// The directory of the pipeline file (relative parameter paths are relative to it).
pub fn pipeline_dir(pipeline: &Pipeline) -> std::path::PathBuf {
    match pipeline.file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_code_hash_is_part_of_the_fingerprint() {
        let p = crate::pipeline::parse("pipeline: t\narchive: t.h5\nstages:\n  - {name: s, kind: spectra}\n", std::path::Path::new("t.yaml")).unwrap();
        let decl = &p.stages[0];
        let with = |code: &str| fingerprint_with_code(decl, 1, code, 0, &[]);
        assert_ne!(with("old code"), with("new code"));
        assert_eq!(fingerprint(decl, 1, 0, &[]), with(stages::code_hash("spectra")));
    }
}
