//! Why a fit stopped, as a type a caller can match instead of reading an error's text.

use std::fmt;

/// Why fitting a recording, or a whole fit, stopped. Carried inside `anyhow::Error`; find it
/// with [`FitError::of`].
#[derive(Debug, Clone, PartialEq)]
pub enum FitError {
    /// The observer asked the fit to stop ([`crate::work::Observer::cancelled`]).
    Cancelled,
    /// The recording cannot be read as audio, or its audio cannot be fitted (the reason in words).
    Unreadable(String),
    /// The fit of a recording holds non-finite modes or strike noise (the reason in words).
    NonFinite(String),
    /// The fit panicked, which is a bug (the panic's message).
    Panicked(String),
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FitError::Cancelled => f.write_str("fit cancelled"),
            FitError::Unreadable(why) | FitError::NonFinite(why) => f.write_str(why),
            FitError::Panicked(msg) => write!(f, "internal error while fitting ({msg})"),
        }
    }
}

impl std::error::Error for FitError {}

impl FitError {
    /// The fit error inside `e`, if `e` is one (at any depth of its context chain).
    pub fn of(e: &anyhow::Error) -> Option<&FitError> {
        e.chain().find_map(|c| c.downcast_ref::<FitError>())
    }

    /// Whether `e` says the fit was cancelled.
    pub fn is_cancelled(e: &anyhow::Error) -> bool {
        Self::of(e) == Some(&FitError::Cancelled)
    }
}
