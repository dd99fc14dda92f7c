//! Deterministic math.
//!
//! The platform C library may round `sin`, `cos`, `atan2`… differently from
//! one machine (or glibc version) to the next. litesim promises identical
//! bytes on every machine, so every transcendental function used by a model
//! goes through these wrappers over the pure-Rust `libm` crate. `sqrt`,
//! `+ − × ÷` are exactly rounded by IEEE 754 and need no wrapper.

/// Sine (radians).
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
/// Cosine (radians).
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
/// Sine and cosine at once.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}
/// Tangent (radians).
#[inline]
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}
/// Arc tangent.
#[inline]
pub fn atan(x: f64) -> f64 {
    libm::atan(x)
}
/// Four-quadrant arc tangent of `y / x`.
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
/// Euclidean length `sqrt(x² + y²)` (exactly rounded sqrt; no hypot scaling).
#[inline]
pub fn hypot(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}
