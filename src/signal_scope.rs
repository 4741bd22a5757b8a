//! Signal handlers for a scope: [`Handlers::install`] sets one handler for some signals
//! and remembers their previous actions; dropping the value restores them. Used while an
//! archive commit writes its `.partial` file and while the Slurm driver waits for an
//! array. The handler must make only async-signal-safe calls.

/// Previous actions of the signals whose handler was replaced.
pub struct Handlers {
    old: Vec<(libc::c_int, libc::sigaction)>,
}

impl Handlers {
    /// `handler` for each of `signals`, with `flags` (e.g. `libc::SA_RESTART`); a signal
    /// whose action cannot be set keeps its own.
    pub fn install(signals: &[libc::c_int], handler: extern "C" fn(libc::c_int), flags: libc::c_int) -> Self {
        let mut old = Vec::with_capacity(signals.len());
        for &sig in signals {
            // SAFETY: a plain sigaction with a handler the caller vouches for.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = handler as libc::sighandler_t;
                action.sa_flags = flags;
                libc::sigemptyset(&mut action.sa_mask);
                let mut previous: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(sig, &action, &mut previous) == 0 {
                    old.push((sig, previous));
                }
            }
        }
        Handlers { old }
    }
}

impl Drop for Handlers {
    fn drop(&mut self) {
        for (sig, previous) in &self.old {
            // SAFETY: restoring the action saved by `install`.
            unsafe {
                libc::sigaction(*sig, previous, std::ptr::null_mut());
            }
        }
    }
}
