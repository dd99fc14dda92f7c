//! Placing driven vehicles on lanes at a density, under a seed.

use super::{LaneGraph, Obstacle, Traffic, Vehicle};
use crate::runtime::driver::DriverParams;
use litesim_core::rng::Rng;

/// The most vehicles one declaration may place (a bound a typo in the
/// density cannot get past: 20,000 vehicles is a 130 km three-lane
/// motorway at jam density).
pub const MAX_VEHICLES: usize = 20_000;

/// How densely and how fast vehicles are placed.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Density {
    /// Vehicles per km per lane.
    pub per_km_per_lane: f64,
    /// Desired speeds, drawn uniformly (m/s).
    pub speed: (f64, f64),
    /// Vehicle length and width (m).
    pub size: (f64, f64),
}

/// [`fill`] would place more than [`MAX_VEHICLES`] vehicles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "ambient traffic would place more than {MAX_VEHICLES} vehicles (the documented bound): lower the density or the radius"
)]
pub struct TooManyVehicles;

/// Places vehicles on `lanes` (all of the graph's when `None`) at the
/// density, each at a seeded spacing around the mean, skipping spots
/// where `keep` (a lane and `u`) says no or an obstacle stands; speeds
/// start at most at what the gap ahead allows (`(gap − s0)/T`), so no
/// vehicle starts in a collision course. Returns the slots added, or an
/// error when more than [`MAX_VEHICLES`] would be placed.
pub fn fill(
    traffic: &mut Traffic,
    g: &LaneGraph,
    d: &Density,
    rng: &mut Rng,
    obstacles: &[Obstacle],
    mut keep: impl FnMut(u32, f64) -> bool,
) -> Result<Vec<u32>, TooManyVehicles> {
    let spacing = 1000.0 / d.per_km_per_lane;
    let (len, width) = d.size;
    let mut placed: Vec<(u32, f64, f64)> = Vec::new();
    for (lane, info) in g.lanes.iter().enumerate() {
        let lane = lane as u32;
        // Not inside junctions: their lanes overlap one another.
        if info.junction {
            continue;
        }
        let mut u = rng.unit() * spacing + 0.5 * len;
        while u < info.length - 0.5 * len {
            // Clear of every obstacle, and ahead of one by at least the gap
            // it keeps at its speed (a jam gap plus 1.5 s), so that nothing
            // starts on a collision course with a faster actor behind.
            let clear = obstacles.iter().filter(|o| o.lane == lane).all(|o| {
                let apart = (o.u - u).abs() - 0.5 * (o.length + len);
                if u > o.u {
                    apart > 2.0 + 1.5 * o.v
                } else {
                    apart > 4.0
                }
            });
            if clear && keep(lane, u) {
                let v0 = d.speed.0 + rng.unit() * (d.speed.1 - d.speed.0);
                placed.push((lane, u, v0));
                if traffic.vehicles.len() + placed.len() > MAX_VEHICLES {
                    return Err(TooManyVehicles);
                }
            }
            // Spacing varies ±30 % around the mean, never below a car and its jam gap.
            u += (spacing * (0.7 + 0.6 * rng.unit())).max(len + 2.5);
        }
    }
    let mut slots = Vec::with_capacity(placed.len());
    for (k, &(lane, u, v0)) in placed.iter().enumerate() {
        let params = DriverParams::for_category("car", v0);
        // The nearest thing ahead in the same lane: the next placed vehicle
        // or an obstacle.
        let next_placed = placed
            .get(k + 1)
            .filter(|n| n.0 == lane)
            .map(|n| n.1 - u - len);
        let next_obstacle = obstacles
            .iter()
            .filter(|o| o.lane == lane && o.u > u)
            .map(|o| o.u - u - 0.5 * (o.length + len))
            .reduce(f64::min);
        let gap = match (next_placed, next_obstacle) {
            (Some(a), Some(b)) => a.min(b),
            (a, b) => a.or(b).unwrap_or(f64::INFINITY),
        };
        let mut v = v0.min(((gap - params.min_gap) / params.time_gap).max(0.0));
        // Before a lane's end that goes nowhere (a dead end, the map's
        // edge): no faster than it can stop there comfortably.
        let info = &g.lanes[lane as usize];
        if info.next.is_empty() {
            let room = (info.length - u - 0.5 * len).max(0.0);
            v = v.min((2.0 * params.comfort_decel * room).sqrt());
        }
        slots.push(traffic.add(Vehicle {
            lane,
            u,
            v,
            a: 0.0,
            lat: 0.0,
            from: None,
            length: len,
            width,
            params,
            route: rng.next_u64(),
            at_dead_end: false,
            lane_changes: 0,
            active: true,
            goals: Default::default(),
        }));
    }
    Ok(slots)
}
