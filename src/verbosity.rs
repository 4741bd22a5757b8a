//! How much the command line says: the one place that decides it (`-q/--quiet`,
//! `-v/--verbose`, and whether `run --json` owns stdout). Everything else asks here
//! through [`status!`](crate::status), [`info!`](crate::info) and
//! [`detail!`](crate::detail) rather than checking flags itself.
//!
//! | level | run's per-stage lines | notes, stage summaries | progress bars | detail | warnings, errors |
//! |---|---|---|---|---|---|
//! | quiet (`-q`) | – | – | – | – | yes |
//! | normal | yes | yes | on a terminal | – | yes |
//! | verbose (`-v`) | yes | yes | on a terminal | yes | yes |
//!
//! Per-stage lines go to stdout, or to stderr when stdout carries a JSON document
//! ([`set_json_stdout`]). Detail always goes to stderr. Errors are printed by their caller
//! whatever the level, and exit codes do not depend on it.
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Quiet = 0,
    Normal = 1,
    Verbose = 2,
}

static LEVEL: AtomicU8 = AtomicU8::new(Level::Normal as u8);
static JSON_STDOUT: AtomicBool = AtomicBool::new(false);

/// Set once by the command line, before anything prints.
pub fn set(level: Level) {
    LEVEL.store(level as u8, Ordering::Relaxed);
}

/// The level from the flags (`-q` and `-v` exclude each other; clap checks that).
pub fn from_flags(quiet: bool, verbose: bool) -> Level {
    match (quiet, verbose) {
        (true, _) => Level::Quiet,
        (false, true) => Level::Verbose,
        (false, false) => Level::Normal,
    }
}

pub fn level() -> Level {
    match LEVEL.load(Ordering::Relaxed) {
        0 => Level::Quiet,
        2 => Level::Verbose,
        _ => Level::Normal,
    }
}

pub fn quiet() -> bool {
    level() == Level::Quiet
}

pub fn verbose() -> bool {
    level() == Level::Verbose
}

/// Stdout carries one JSON document (`run --json`): per-stage lines go to stderr instead.
pub fn set_json_stdout(on: bool) {
    JSON_STDOUT.store(on, Ordering::Relaxed);
}

pub fn json_stdout() -> bool {
    JSON_STDOUT.load(Ordering::Relaxed)
}

/// Whether progress bars are drawn: not under `-q`, and only when stderr is a terminal.
pub fn progress_bars() -> bool {
    use std::io::IsTerminal;
    !quiet() && std::io::stderr().is_terminal()
}

/// A per-stage status line of `run` (stdout, or stderr under `--json`; nothing under `-q`).
pub fn status_line(line: std::fmt::Arguments) {
    if quiet() {
        return;
    }
    if json_stdout() {
        eprintln!("{line}");
    } else {
        println!("{line}");
    }
}

/// A note or summary on stderr (nothing under `-q`).
pub fn info_line(line: std::fmt::Arguments) {
    if !quiet() {
        eprintln!("{line}");
    }
}

/// Verbose detail on stderr (only under `-v`).
pub fn detail_line(line: std::fmt::Arguments) {
    if verbose() {
        eprintln!("{line}");
    }
}

/// `status!(...)`: see [`status_line`].
#[macro_export]
macro_rules! status {
    ($($t:tt)*) => { $crate::verbosity::status_line(format_args!($($t)*)) };
}

/// `info!(...)`: see [`info_line`].
#[macro_export]
macro_rules! info {
    ($($t:tt)*) => { $crate::verbosity::info_line(format_args!($($t)*)) };
}

/// `detail!(...)`: see [`detail_line`].
#[macro_export]
macro_rules! detail {
    ($($t:tt)*) => { $crate::verbosity::detail_line(format_args!($($t)*)) };
}

