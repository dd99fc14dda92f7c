//! Errors of the SSP API, with the status codes of the gRPC mapping.

use serde::{Deserialize, Serialize};

/// The class of an SSP error; maps one-to-one onto a gRPC status code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum ErrorCode {
    /// A field is missing, NaN, out of range or malformed.
    InvalidArgument,
    /// Unknown session, actor, traffic light, model, profile or blueprint.
    NotFound,
    /// An id already in use, or a call that may happen only once.
    AlreadyExists,
    /// A call that the session's life-cycle state does not allow.
    FailedPrecondition,
    /// A wait ran out of time.
    DeadlineExceeded,
    /// A capability the profile or model lacks.
    Unimplemented,
    /// Too many sessions, actors or points.
    ResourceExhausted,
    /// The session ended concurrently.
    Aborted,
    /// The backend is not reachable.
    Unavailable,
    /// A bug.
    Internal,
    /// The caller may not do this (a map path outside the server's roots).
    PermissionDenied,
    /// The call lacks the server's token.
    Unauthenticated,
}

/// An SSP error: a code and a message that names the field or state at fault.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, thiserror::Error)]
#[error("{code:?}: {message}")]
pub struct SspError {
    /// The class.
    pub code: ErrorCode,
    /// What went wrong, for a person.
    pub message: String,
}

/// Longest quoted client input an error message repeats (bytes, cut at a
/// character boundary): the rest is replaced by `…(N bytes)`.
pub const QUOTE_MAX: usize = 64;

/// Longest error message (bytes). gRPC carries a status message in a
/// header (16 KiB by default): an error about a 1 MiB id must still arrive
/// as that error, not as a transport failure.
pub const MESSAGE_MAX: usize = 2048;

/// Longest id a client may give an actor, traffic light or session (bytes).
pub const ID_MAX: usize = 256;

/// `s` cut to [`QUOTE_MAX`] bytes with its length noted when longer.
pub fn quote(s: &str) -> String {
    cut(s, QUOTE_MAX)
}

fn cut(s: &str, max: usize) -> String {
    if s.len() <= max {
        return s.to_string();
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}…({} bytes)", &s[..end], s.len())
}

/// Bounds a message: every quoted stretch (`'…'`) longer than
/// [`QUOTE_MAX`] is cut, and the whole to [`MESSAGE_MAX`].
fn bounded(message: String) -> String {
    if message.len() <= QUOTE_MAX {
        return message;
    }
    let mut out = String::with_capacity(message.len().min(MESSAGE_MAX + 32));
    let mut rest = message.as_str();
    while let Some(open) = rest.find('\'') {
        out.push_str(&rest[..=open]);
        let after = &rest[open + 1..];
        match after.find('\'') {
            Some(close) => {
                out.push_str(&quote(&after[..close]));
                out.push('\'');
                rest = &after[close + 1..];
            }
            None => {
                out.push_str(&quote(after));
                rest = "";
            }
        }
    }
    out.push_str(rest);
    cut(&out, MESSAGE_MAX)
}

impl SspError {
    /// A new error (its message bounded: see [`quote`]).
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: bounded(message.into()),
        }
    }
    /// `INVALID_ARGUMENT`.
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::InvalidArgument, message)
    }
    /// `NOT_FOUND`.
    pub fn not_found(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::NotFound, message)
    }
    /// `FAILED_PRECONDITION`.
    pub fn precondition(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::FailedPrecondition, message)
    }
    /// `UNIMPLEMENTED`.
    pub fn unimplemented(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::Unimplemented, message)
    }
    /// `RESOURCE_EXHAUSTED`.
    pub fn exhausted(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::ResourceExhausted, message)
    }
}

/// Result of an SSP call.
pub type SspResult<T> = Result<T, SspError>;

/// Checks that a value is finite, naming the field otherwise.
pub(crate) fn finite(field: &str, v: f64) -> SspResult<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(SspError::invalid(format!(
            "{field} must be a finite number, got {v}"
        )))
    }
}
