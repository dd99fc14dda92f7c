//! # litesim-map
//!
//! OpenDRIVE (1.4–1.8) road networks: [`parse()`] turns `.xodr` text into the
//! [`model`] with precise errors ([`MapError`]: file, line, column, element
//! path) and warnings (ignored elements, reference-line gaps); [`RoadNetwork`]
//! adds what queries need — a spatial index of the reference lines for
//! point → (road, lane, s, t), a lane graph across lane sections, roads and
//! junctions for routing — and answers what a scenario engine asks (roads by
//! kind, poses at (road, lane, s), spawn positions). [`OccupancyGrid`] is the
//! raster type shared with the planner.
//!
//! Invariants: loading never panics on any input (it returns an error);
//! every geometry piece is evaluated from its own start, never by chaining;
//! all iteration orders are file order or sorted, so outputs are stable.
#![warn(missing_docs)]

pub mod export;
pub mod geometry;
pub mod grid;
pub mod lanes;
pub mod model;
pub mod network;
pub mod parse;
pub mod road;
pub mod synth;
pub mod xml;

pub use grid::{GridError, Obstacle, OccupancyGrid};
pub use lanes::LanePos;
pub use network::{
    LanePolyline, LaneRef, LocateMemo, Located, MarkRun, NearQuery, RoadNetwork, RoadPosition,
    RoadSummary, SurelyOnRoad,
};
pub use parse::{MapError, Warning, parse};
pub use road::{Direction, LaneSpan};
