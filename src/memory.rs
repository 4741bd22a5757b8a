//! Memory: what a run may use, what a stage estimates it needs, and fallible allocation.
//!
//! Every stage estimates the peak memory of its run from its resolved parameters and
//! its inputs' declarations ([`crate::stages::Stage::estimate_memory`]). `validate` and
//! `run` refuse a pipeline with a stage above the limit ([`Limit`]: MemAvailable, or
//! `--max-memory`) with exit 2 before anything is computed. The estimates count the
//! large buffers (per node, pixel, cell or fibre) that are alive at once, not the small
//! per-point bookkeeping, plus [`PROCESS_BYTES`]; each stage's doc says what it counts.
//! Slurm array tasks are not checked again ([`Limit::Unchecked`]). Large buffers that are
//! still allocated are allocated with [`try_vec`] / [`try_array`], so a failure is an
//! error (exit 1), not an abort.
use ndarray::{Array, Dimension, IntoDimension};

/// What the process holds besides a stage's large buffers (code, the HDF5 library,
/// thread stacks, small values), added to every estimate: a trivial run peaks at 19 MB.
pub const PROCESS_BYTES: f64 = (32u64 << 20) as f64;

/// Memory available to a run (bytes): MemAvailable of /proc/meminfo, or 8 GiB where
/// that cannot be read.
pub fn available_memory() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("MemAvailable:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok()))
        .map(|kib| kib.saturating_mul(1024))
        .unwrap_or(8 << 30)
}

/// The memory a pipeline's stages may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Limit {
    /// The machine's available memory ([`available_memory`]), read when checked.
    #[default]
    Available,
    /// `--max-memory`: this many bytes, whatever the machine has.
    Bytes(u64),
    /// No check (a Slurm array task: its driver checked the pipeline).
    Unchecked,
}

impl Limit {
    /// (bytes, where the number comes from), or `None` for [`Limit::Unchecked`].
    pub fn resolve(self) -> Option<(f64, &'static str)> {
        match self {
            Limit::Available => Some((available_memory() as f64, "available (MemAvailable; --max-memory overrides)")),
            Limit::Bytes(b) => Some((b as f64, "allowed by --max-memory")),
            Limit::Unchecked => None,
        }
    }
}

/// A stage's estimate of its peak memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Bytes alive at once at the peak.
    pub bytes: f64,
    /// What dominates, for messages: `n_w = 4000000000 fibre displacements of the input web`.
    pub what: String,
    /// The parameters that raise it, most responsible first: (stage name, parameter).
    pub params: Vec<(String, String)>,
    /// Parameters that lower it as they grow (a cell or element size).
    pub inverse: Vec<(String, String)>,
}

impl Estimate {
    /// An estimate that grows with `params` of `stage`.
    pub fn new(bytes: f64, what: impl Into<String>, stage: &str, params: &[&str]) -> Self {
        Self { bytes, what: what.into(), params: params.iter().map(|p| (stage.to_string(), p.to_string())).collect(), inverse: vec![] }
    }
    /// ... and falls as `params` of `stage` grow.
    pub fn falling_with(mut self, stage: &str, params: &[&str]) -> Self {
        self.inverse.extend(params.iter().map(|p| (stage.to_string(), p.to_string())));
        self
    }
    /// Every parameter involved, those that raise it first.
    pub fn drivers(&self) -> impl Iterator<Item = &(String, String)> {
        self.params.iter().chain(&self.inverse)
    }
}

/// `2GiB`, `512 MiB`, `1.5GB`, `4G`, `1000000`: binary units KiB..TiB and K..T (as Slurm's
/// `--mem`), decimal kB..TB, bare numbers in bytes.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = (&t[..split], t[split..].trim());
    let value: f64 = number.parse().map_err(|_| format!("`{text}` is not a size; allowed: a number with an optional unit, e.g. 2GiB, 512MiB, 1.5GB, 4G"))?;
    let scale = match unit.to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kib" => 1024.0,
        "m" | "mib" => 1024f64.powi(2),
        "g" | "gib" => 1024f64.powi(3),
        "t" | "tib" => 1024f64.powi(4),
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        "tb" => 1e12,
        _ => return Err(format!("unknown unit `{unit}` in `{text}`; allowed: B, KiB, MiB, GiB, TiB (or K, M, G, T), kB, MB, GB, TB")),
    };
    let bytes = value * scale;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("`{text}` is out of range; allowed: at least 1 byte"));
    }
    Ok(bytes as u64)
}

/// Bytes for messages: `64.0 GiB`, `3.2 MiB`, `8.0e3 TiB`.
pub fn format_size(bytes: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if v >= 1e4 {
        format!("{v:.1e} {}", UNITS[u])
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Memory that could not be had (a runtime failure, exit 1).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot allocate {} for {what}: out of memory (lower the stage's size, or free memory)", format_size(*.bytes as f64))]
pub struct AllocError {
    pub bytes: usize,
    pub what: String,
}

/// `n` copies of `value`, allocated fallibly: an [`AllocError`] naming `what` instead of
/// an abort.
pub fn try_vec<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, AllocError> {
    let bytes = n.saturating_mul(std::mem::size_of::<T>());
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| AllocError { bytes, what: what.to_string() })?;
    v.resize(n, value);
    Ok(v)
}

/// An array of `shape` filled with `value`, allocated fallibly (see [`try_vec`]).
pub fn try_array<T: Clone, D: Dimension>(shape: impl IntoDimension<Dim = D>, value: T, what: &str) -> Result<Array<T, D>, AllocError> {
    let shape = shape.into_dimension();
    let n = shape.slice().iter().try_fold(1usize, |a, &b| a.checked_mul(b)).ok_or_else(|| AllocError { bytes: usize::MAX, what: what.to_string() })?;
    let v = try_vec(n, value, what)?;
    Ok(Array::from_shape_vec(shape, v).expect("the length is the shape's product"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_and_decimal_units() {
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        assert_eq!(parse_size("2 GiB"), Ok(2 << 30));
        assert_eq!(parse_size("4G"), Ok(4 << 30));
        assert_eq!(parse_size("512MiB"), Ok(512 << 20));
        assert_eq!(parse_size("1.5GB"), Ok(1_500_000_000));
        assert_eq!(parse_size("1000"), Ok(1000));
        assert!(parse_size("lots").is_err());
        assert!(parse_size("2 parsecs").unwrap_err().contains("unknown unit"));
        assert!(parse_size("0").is_err());
    }

    #[test]
    fn a_failed_allocation_is_an_error_not_an_abort() {
        let e = try_vec(usize::MAX / 2, 0u64, "a test buffer").unwrap_err();
        assert!(e.to_string().contains("a test buffer"), "{e}");
        let e = try_array((usize::MAX / 4, 8), 0.0f64, "a test array").unwrap_err();
        assert!(e.to_string().contains("cannot allocate"), "{e}");
        assert_eq!(try_array((2, 3), 1.5f64, "small").unwrap().sum(), 9.0);
    }

    #[test]
    fn sizes_format_in_binary_units() {
        assert_eq!(format_size(64.0 * (1u64 << 30) as f64), "64.0 GiB");
        assert_eq!(format_size(512.0), "512.0 B");
    }
}
