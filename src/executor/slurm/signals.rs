//! Waiting for a Slurm array with SIGINT and SIGTERM caught: the driver `scancel`s the
//! array it waits for and dies of the signal, so Ctrl-C does not leave tasks running.

use anyhow::{bail, Result};
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::{Duration, Instant};

/// The signal (SIGINT or SIGTERM) received while a [`SignalGuard`] was installed; 0: none.
static INTERRUPTED: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(sig: libc::c_int) {
    // Only an atomic store: async-signal-safe. The waiting loop acts on it.
    INTERRUPTED.store(sig, Ordering::SeqCst);
}

/// SIGINT and SIGTERM recorded in [`INTERRUPTED`] instead of ending the process, while
/// the guard lives; the previous dispositions are restored when it is dropped.
pub(super) struct SignalGuard {
    _handlers: crate::signal_scope::Handlers,
}

impl SignalGuard {
    pub(super) fn install() -> Self {
        INTERRUPTED.store(0, Ordering::SeqCst);
        SignalGuard { _handlers: crate::signal_scope::Handlers::install(&[libc::SIGINT, libc::SIGTERM], on_signal, libc::SA_RESTART) }
    }
}

/// Whether Slurm still has tasks of `job_id` pending or running: `Some(true/false)`, or
/// `None` when `squeue` could not tell.
fn in_queue(job_id: &str) -> Option<bool> {
    let out = Command::new("squeue").args(["-h", "-j", job_id, "-o", "%i"]).output().ok()?;
    if out.status.success() {
        return Some(!String::from_utf8_lossy(&out.stdout).trim().is_empty());
    }
    // A job purged from slurmctld's memory (MinJobAge) is unknown: it has finished.
    let err = String::from_utf8_lossy(&out.stderr);
    if err.contains("Invalid job id") {
        return Some(false);
    }
    None
}

/// Wait until the array `job_id` has left the queue (polling `squeue` every 0.5 s at
/// first, backing off to 5 s). On SIGINT or SIGTERM, `scancel` it and die of the signal.
pub(super) fn wait_for_array(name: &str, job_id: &str, dir: &Path) -> Result<()> {
    let mut delay = Duration::from_millis(500);
    let mut failures = 0;
    loop {
        let until = Instant::now() + delay;
        while Instant::now() < until {
            let sig = INTERRUPTED.load(Ordering::SeqCst);
            if sig != 0 {
                cancel_and_die(name, job_id, dir, sig);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        match in_queue(job_id) {
            Some(false) => return Ok(()),
            Some(true) => failures = 0,
            None => {
                failures += 1;
                if failures == 20 {
                    bail!("squeue cannot tell whether Slurm job {job_id} is still running (20 tries); its tasks may still run: rerun the same command later to gather them ({})", dir.display());
                }
            }
        }
        delay = (delay * 3 / 2).min(Duration::from_secs(5));
    }
}

fn cancel_and_die(name: &str, job_id: &str, dir: &Path, sig: i32) -> ! {
    let signame = if sig == libc::SIGINT { "SIGINT" } else { "SIGTERM" };
    let status = Command::new("scancel").arg(job_id).status();
    match status {
        Ok(s) if s.success() => eprintln!(
            "{name}: interrupted ({signame}): cancelled Slurm job {job_id} (scancel {job_id}); complete tasks are kept in {} and a rerun submits only the rest",
            dir.display()
        ),
        Ok(s) => eprintln!("{name}: interrupted ({signame}): scancel {job_id} failed ({s}); cancel the array by hand"),
        Err(e) => eprintln!("{name}: interrupted ({signame}): cannot run scancel {job_id} ({e}); cancel the array by hand"),
    }
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    // Die of the signal itself, so that the caller sees what happened.
    // SAFETY: resetting the default disposition and raising the signal.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
    std::process::exit(128 + sig)
}
