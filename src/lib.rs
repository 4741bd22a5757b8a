//! laydown: single-fibre laydown on a moving belt, curvature spectra, stochastic
//! nonwoven webs and their uniformity, after Battocchio & Sutcliffe, "Modelling fibre
//! laydown and web uniformity in nonwoven fabric".
//!
//! The crate is organised like the pipeline it runs:
//! - [`pipeline`]: YAML pipeline files, checked with file/line/column diagnostics;
//! - [`stages`]: one module per pipeline stage behind the [`stages::Stage`] contract;
//! - [`archive`]: the versioned HDF5 archive with provenance;
//! - [`runner`]: decides what to (re)run and records it;
//! - [`executor`]: where a stage's units run (local threads or a Slurm job array);
//! - [`rod`]: the fibre physics (discrete elastic rod, drag, oscillation, belt contact)
//!   that the laydown and laid_web stages compose;
//! - [`geometry`], [`uniformity`]: shared science (eq 5, eq 6, CV, formation);
//! - [`memory`]: the memory limit, stage estimates and fallible allocation;
//! - [`plot`], [`table`]: figures and tables of a stage version, read back from the archive;
//! - [`listing`]: what `ls` and `stages` print, as text or JSON.
pub mod archive;
pub mod cli;
/// What source code each stage kind's results depend on, hashed at build time (see build.rs).
pub mod code_hash;
pub mod executor;
pub mod geometry;
/// What `ls` and `stages` print, as text or JSON.
pub mod listing;
pub mod memory;
pub mod param_table;
pub mod params;
pub mod pipeline;
pub mod plot;
pub mod progress;
pub mod rod;
pub mod runner;
pub mod schema;
pub mod stages;
pub mod table;
pub mod uniformity;
