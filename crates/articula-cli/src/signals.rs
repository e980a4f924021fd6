//! SIGINT and SIGTERM during a long run: the first one raises a flag that the run reads at
//! its next step boundary (it then flushes complete rows, prints the partial summary with its
//! `stop_reason` and exits 128 + the signal number: 130, 143); a second one ends the process
//! at once with that code.
//!
//! `signal-hook` rather than `ctrlc`: it handles SIGTERM as well as SIGINT without a feature
//! flag, records which signal came, and has the "second signal exits now" pattern built in.

use crate::CliError;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

/// The interrupt flag of a run and the signal that raised it.
pub struct Interrupt {
    /// Raised by SIGINT or SIGTERM.
    pub flag: Arc<AtomicBool>,
    /// The signal number that came (0: none).
    signal: Arc<AtomicUsize>,
}

impl Interrupt {
    /// Installs the handlers of SIGINT and SIGTERM.
    pub fn install() -> Result<Interrupt, CliError> {
        let flag = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        #[cfg(unix)]
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            let code = 128 + sig as u32;
            let install = || -> std::io::Result<()> {
                // Registered first, it runs before the flag is raised: only a second signal
                // finds it raised and exits.
                signal_hook::flag::register_conditional_shutdown(sig, code as i32, flag.clone())?;
                signal_hook::flag::register_usize(sig, signal.clone(), sig as usize)?;
                signal_hook::flag::register(sig, flag.clone())?;
                Ok(())
            };
            install().map_err(|e| CliError(format!("cannot install a signal handler: {e}")))?;
        }
        Ok(Interrupt { flag, signal })
    }

    /// The name of the signal that came (`SIGINT`, `SIGTERM`).
    pub fn name(&self) -> &'static str {
        match self.signal.load(Ordering::Relaxed) as i32 {
            2 => "SIGINT",
            15 => "SIGTERM",
            _ => "a signal",
        }
    }

    /// The exit code after the signal: 128 + its number (130 for SIGINT, 143 for SIGTERM).
    pub fn exit_code(&self) -> u8 {
        match self.signal.load(Ordering::Relaxed) {
            0 => 130,
            s => (128 + s).min(255) as u8,
        }
    }
}
