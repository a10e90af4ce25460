//! SIGTERM and SIGINT during a render: the first asks for a clean stop with
//! a checkpoint, a second exits at once; [`Interrupted`] carries the signal
//! to the exit code.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use anyhow::Context;

/// Set by SIGTERM or SIGINT: stop after the current wave, with a checkpoint.
pub static STOP: AtomicBool = AtomicBool::new(false);
/// The signal that set [`STOP`].
static SIGNAL: AtomicUsize = AtomicUsize::new(0);

/// A render stopped by a signal after writing its checkpoint; the process
/// exits with 128 + the signal's number, as if killed by it.
#[derive(Debug)]
pub struct Interrupted(pub i32);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "stopped by signal {}", self.0)
    }
}

impl std::error::Error for Interrupted {}

/// The first SIGTERM or SIGINT asks for a clean stop; a second one exits at once.
pub fn catch_signals() -> anyhow::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    for sig in [SIGTERM, SIGINT] {
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, &STOP)
            .context("installing signal handlers")?;
        signal_hook::flag::register_usize(sig, &SIGNAL, sig as usize).context("installing signal handlers")?;
        signal_hook::flag::register(sig, &STOP).context("installing signal handlers")?;
    }
    Ok(())
}

/// The signal that set [`STOP`] (0 when none has).
pub fn signal() -> i32 {
    SIGNAL.load(Ordering::SeqCst) as i32
}
