//! One module per pipeline stage.
pub mod grid;
pub mod param_table;
pub mod spectra;
pub mod web;
