//! One module per pipeline stage.
pub mod image;
