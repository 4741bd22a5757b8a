//! The `executor:` block of a pipeline file: where its stages' units of work run (this
//! process, or a Slurm job array) and how they are submitted. Parsed and checked with the
//! rest of the pipeline ([`super::parse`]); the executors themselves are in
//! [`crate::executor`].

crate::params::choice_enum! {
    pub enum ExecutorKind {
        /// All units in this process, on all cores.
        #[default]
        Local = "local",
        /// One Slurm job array per stage.
        Slurm = "slurm",
    }
}


/// The `executor:` block of a pipeline file, overridden by `laydown run --executor ...`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExecutorConfig {
    pub kind: ExecutorKind,
    /// Slurm partition (`sbatch --partition`); the cluster's default otherwise.
    pub partition: Option<String>,
    /// At most this many array tasks at once (`--array=...%N`).
    pub max_parallel: Option<usize>,
    /// Units (replicates) per array task; 1 when unset (more when a stage has over
    /// [`crate::executor::slurm::MAX_TASKS`] units).
    pub units_per_task: Option<usize>,
    /// Extra `sbatch` arguments, e.g. `--time=02:00:00`, `--mem=4G`.
    pub sbatch_args: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn parse(executor: &str) -> Result<crate::pipeline::Pipeline, crate::pipeline::Diagnostics> {
        let text = format!("pipeline: p\narchive: a.h5\n{executor}stages:\n  - {{name: s, kind: spectra}}\n");
        crate::pipeline::parse(&text, Path::new("p.yaml"))
    }

    #[test]
    fn default_is_local() {
        assert_eq!(parse("").unwrap().executor, ExecutorConfig::default());
        assert_eq!(ExecutorConfig::default().kind, ExecutorKind::Local);
    }

    #[test]
    fn executor_block_and_shorthand() {
        assert_eq!(parse("executor: slurm\n").unwrap().executor.kind, ExecutorKind::Slurm);
        let e = parse("executor:\n  kind: slurm\n  partition: short\n  max_parallel: 3\n  units_per_task: 4\n  sbatch_args: [--time=00:10:00, --mem=1G]\n")
            .unwrap()
            .executor;
        assert_eq!(
            e,
            ExecutorConfig {
                kind: ExecutorKind::Slurm,
                partition: Some("short".into()),
                max_parallel: Some(3),
                units_per_task: Some(4),
                sbatch_args: vec!["--time=00:10:00".into(), "--mem=1G".into()],
            }
        );
    }

    #[test]
    fn bad_executor_blocks_are_located() {
        let d = parse("executor:\n  kind: slurm\n  max_paralel: 3\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:5:3: executor.max_paralel: unknown key in the executor"), "{d}");
        assert!(d.contains("did you mean `max_parallel`?"), "{d}");
        let d = parse("executor:\n  kind: slurm\n  max_parallel: 0\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:5:17: executor.max_parallel: 0 is out of range"), "{d}");
        let d = parse("executor:\n  partition: x\n").unwrap_err().to_string();
        assert!(d.contains("executor.kind: required key is missing; allowed: local, slurm"), "{d}");
        let d = parse("executor: 3\n").unwrap_err().to_string();
        assert!(d.contains("p.yaml:3:11: executor: expected text"), "{d}");
    }
}
