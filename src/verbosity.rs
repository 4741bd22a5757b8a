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

/// While alive under `-q`, what the process writes to stderr (fd 2) goes to a temporary
/// file instead; on drop, stderr is restored and only the lines naming a warning or an
/// error (`warning:`, `error:`, `panicked`) are written to it. The runner holds one
/// around each stage's computation, so that a stage's own summary (an image stage's
/// table, pixel sizes) is silenced without each stage checking the level. Does nothing
/// at the other levels or when stderr cannot be redirected.
pub struct QuietStderr {
    saved: Option<(i32, std::fs::File)>,
}

impl QuietStderr {
    pub fn new() -> QuietStderr {
        if !quiet() {
            return QuietStderr { saved: None };
        }
        use std::os::fd::AsRawFd;
        let Ok(file) = tempfile_in_tmp() else { return QuietStderr { saved: None } };
        // SAFETY: dup/dup2 on the process's own stderr and a file we hold open.
        unsafe {
            let saved = libc::dup(2);
            if saved < 0 {
                return QuietStderr { saved: None };
            }
            if libc::dup2(file.as_raw_fd(), 2) < 0 {
                libc::close(saved);
                return QuietStderr { saved: None };
            }
            QuietStderr { saved: Some((saved, file)) }
        }
    }
}

impl Default for QuietStderr {
    fn default() -> Self {
        QuietStderr::new()
    }
}

impl Drop for QuietStderr {
    fn drop(&mut self) {
        let Some((saved, mut file)) = self.saved.take() else { return };
        // SAFETY: restores the descriptor saved in `new`.
        unsafe {
            libc::dup2(saved, 2);
            libc::close(saved);
        }
        use std::io::{Read, Seek};
        let mut text = String::new();
        if file.seek(std::io::SeekFrom::Start(0)).is_ok() && file.read_to_string(&mut text).is_ok() {
            for line in text.lines().filter(|l| l.contains("warning:") || l.contains("error:") || l.contains("panicked")) {
                eprintln!("{line}");
            }
        }
    }
}

/// An anonymous file (unlinked at once) for [`QuietStderr`].
fn tempfile_in_tmp() -> std::io::Result<std::fs::File> {
    let dir = std::env::temp_dir();
    for i in 0..100u32 {
        let path = dir.join(format!("laydown-quiet-{}-{i}", std::process::id()));
        match std::fs::OpenOptions::new().read(true).write(true).create_new(true).open(&path) {
            Ok(f) => {
                let _ = std::fs::remove_file(&path);
                return Ok(f);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::other("no temporary file name free"))
}
