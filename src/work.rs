//! Long work — rendering a scene, a batch, a fit, an evaluation — reports its progress to one
//! [`Observer`] and polls it for a stop. Each front end provides one adapter: the CLI a
//! terminal progress bar, the Python module Ctrl-C as a stop (with the GIL released), the
//! plugin editor the fit panel's progress and its Cancel button. [`catch_panic`] keeps a panic
//! in one piece of work from losing the rest (a fit's other files, a host's thread).

/// Watches long work and may stop it. Every method has a default that does nothing, so an
/// adapter implements what it shows.
pub trait Observer: Sync {
    /// Work of `total` steps starts (0: a count with no known end); a later call starts a new
    /// count.
    fn started(&self, _total: u64) {}
    /// `steps` more steps of kind `what` are done ("file", "recording", "draw", "item",
    /// "sample"), called from the working threads in completion order.
    fn advanced(&self, _what: &str, _steps: u64) {}
    /// The work enters a stage, with a line saying what it does.
    fn stage(&self, _what: &str) {}
    /// Polled between steps; true makes the work stop early with an error.
    fn cancelled(&self) -> bool {
        false
    }
}

/// An observer that neither shows nor stops anything.
pub struct Silent;

impl Observer for Silent {}

/// Runs `f`, turning a panic into `Err` with the panic's message. Why: a bug in one recording's
/// fit must not throw away the other files' minutes of work, nor a panic cross into a host or
/// into Python.
pub fn catch_panic<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into())
    })
}
