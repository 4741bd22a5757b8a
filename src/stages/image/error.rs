//! The image stage's error type: every variant that concerns a file names it.

use std::path::{Path, PathBuf};

/// Errors of the image stage. Every variant that concerns a file names it.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("cannot read image {}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("cannot decode image {}: {message}", path.display())]
    Decode { path: PathBuf, message: String },
    #[error("cannot write {}: {message}", path.display())]
    Write { path: PathBuf, message: String },
    #[error("bad glob pattern {pattern:?}: {message}")]
    BadPattern { pattern: String, message: String },
    #[error("no files match {pattern:?}")]
    NoFiles { pattern: String },
    #[error("image{} is {rows}×{cols} pixels; at least {min}×{min} are needed", at(path))]
    TooSmall { path: Option<PathBuf>, rows: usize, cols: usize, min: usize },
    #[error("image{} has {count} non-finite grey levels (NaN or infinite)", at(path))]
    NonFinite { path: Option<PathBuf>, count: usize },
    #[error("image{} has mean grey level {mean}: the CV (std/mean) needs a positive mean", at(path))]
    NonPositiveMean { path: Option<PathBuf>, mean: f64 },
    #[error("image {}: {message}; give pixel_size or dpi to override it", path.display())]
    BadResolution { path: PathBuf, message: String },
    #[error("parameter `{name}` = {value} is invalid: allowed {allowed}")]
    InvalidParam { name: &'static str, value: String, allowed: String },
}

fn at(path: &Option<PathBuf>) -> String {
    path.as_ref().map(|p| format!(" {}", p.display())).unwrap_or_default()
}

impl ImageError {
    /// Attaches a file path to the errors that can carry one and have none yet.
    pub fn with_path(self, p: &Path) -> Self {
        match self {
            ImageError::TooSmall { path: None, rows, cols, min } => ImageError::TooSmall { path: Some(p.into()), rows, cols, min },
            ImageError::NonFinite { path: None, count } => ImageError::NonFinite { path: Some(p.into()), count },
            ImageError::NonPositiveMean { path: None, mean } => ImageError::NonPositiveMean { path: Some(p.into()), mean },
            other => other,
        }
    }
}
