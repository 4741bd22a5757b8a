//! Whose fault a failure is: [`BadInput`] marks a problem with the user's input (a
//! pipeline, an archive path, a stage reference, an image file), reported with exit
//! code 2; every other error is a runtime failure (exit code 1). The lowest layer, so
//! that the archive, the stages and the commands above them can all say it.

/// A problem with the user's input found while running (exit code 2), as opposed to
/// a runtime failure (exit code 1).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// A parameter that fails a stage's or a pipeline's check: its key as written in the
/// pipeline file (dotted, or e.g. `files[1]`) and why, with what is allowed. The checker
/// adds the file, line and column of the key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct InvalidParam {
    pub key: String,
    pub message: String,
}

impl InvalidParam {
    pub fn new(key: String, message: String) -> Self {
        InvalidParam { key, message }
    }
}
