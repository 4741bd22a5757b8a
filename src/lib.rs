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
//! - [`listing`]: what `ls` and `stages` print, as text or JSON;
//! - [`rng`]: the one random-number scheme, shared by the stages and the library API;
//! - [`error`]: whose fault a failure is ([`error::BadInput`], exit code 2).
//!
//! The modules are layers, each using only those below it (`tests/layers.rs` fails on
//! an import cycle): `error`, `rng`, `params` and the shared science at the bottom, then
//! `archive`, `rod`, `stages`, `pipeline`, `executor`, `runner`, and the commands' own
//! modules (`table`, `plot`, `listing`, `schema`, `cli`) on top.
//!
//! # Reproducing a replicate of an archive
//! The stages and the library draw from the same random streams ([`rng`]), so the library
//! recomputes what an archive holds, bit for bit. Here a tiny laydown stage runs through
//! the runner into a temporary archive, and its replicate 1 is simulated again with
//! [`rod::simulate`] on the stream of replicate 1 ([`rod::replicate_rng`]):
//! ```
//! use laydown::{archive::{hdf, Archive}, pipeline, rod, runner};
//! let dir = tempfile::tempdir()?;
//! let file = dir.path().join("tiny.yaml");
//! std::fs::write(&file, "pipeline: tiny
//! archive: tiny.h5
//! seed: 7
//! stages:
//!   - name: fibre
//!     kind: laydown
//!     params: {length: 0.1, elements: 100}
//!     replicates: 2
//! ")?;
//! let study = pipeline::load(&file).map_err(|d| anyhow::anyhow!("{d}"))?;
//! runner::run(&study, &runner::RunOptions::default())?;
//! let archive = Archive::open_read(&dir.path().join("tiny.h5"))?;
//! let group = archive.version("fibre", None)?.open()?;
//! let stored = hdf::read_f64(&group, "positions")?; // (point, replicate, node, xyz)
//! let stored_s = hdf::read_f64(&group, "radius_of_gyration")?; // (point, replicate)
//!
//! let scene = rod::LaydownParams { length: 0.1, elements: 100, ..Default::default() };
//! let mine = rod::simulate(&scene, &mut rod::replicate_rng(7, 1));
//! assert_eq!(stored.shape()[2], mine.positions.len());
//! for (i, x) in mine.positions.iter().enumerate() {
//!     for k in 0..3 {
//!         assert_eq!(stored[[0, 1, i, k]].to_bits(), x[k].to_bits(), "node {i}");
//!     }
//! }
//! assert_eq!(stored_s[[0, 1]].to_bits(), mine.radius_of_gyration.to_bits());
//! # Ok::<(), anyhow::Error>(())
//! ```
pub mod archive;
pub mod cli;
/// What source code each stage kind's results depend on, hashed at build time (see build.rs).
pub mod code_hash;
pub mod coordinates;
pub mod error;
pub mod executor;
pub mod geometry;
/// What `ls` and `stages` print, as text or JSON.
pub mod listing;
pub mod memory;
pub mod params;
pub mod pipeline;
pub mod plot;
pub mod progress;
pub mod rng;
pub mod rod;
pub mod run_summary;
pub mod run_time;
pub mod runner;
pub mod schema;
pub mod signal_scope;
pub(crate) mod simd;
pub mod stages;
pub mod table;
pub mod uniformity;
pub mod verbosity;
