//! An actor's observed state at one step ([`BodyState`]): the one struct
//! that the checks and KPIs (box against box), the gap goals (the gap along
//! a heading) and coverage (the fields an item reads) take. The SUT's
//! [`crate::sut::ObjectState`] is the same state as the wire carries it
//! (with id and kind); the runtime's world converts it where a controller
//! reads it.

/// An actor's pose, box and motion at one step, in the plane (not the
/// simulator's 6-DoF [`litesim_core::ActorState`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyState {
    /// Centre x (m).
    pub x: f64,
    /// Centre y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
    /// Box length (m).
    pub length: f64,
    /// Box width (m).
    pub width: f64,
    /// World velocity x (m/s).
    pub vx: f64,
    /// World velocity y (m/s).
    pub vy: f64,
    /// Speed along the heading (m/s; negative reversing).
    pub speed: f64,
    /// Acceleration along the heading (m/s²; 0 where nobody reads it).
    pub acceleration: f64,
}
