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

impl SspError {
    /// A new error.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
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
