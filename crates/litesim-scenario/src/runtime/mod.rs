//! The runtime's controllers for the actors litesim drives itself: the
//! driver model ([`driver`]: ACC car-following and MOBIL lane changes) and
//! the traffic engine that runs it on the map's lanes ([`traffic`]), for
//! ambient traffic around sut.car.

pub mod driver;
pub mod traffic;
