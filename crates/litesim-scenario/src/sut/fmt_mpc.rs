//! The built-in SUT `fmt-mpc`: litesim-plan's planning chain on the
//! occupancy grid of the map's drivable area, and MPC tracking — the
//! planning half of litesim driving the scenario half's ego.
//!
//! The first step plans from the ego to the route's goal around the
//! objects standing on the road, with the chain `litesim plan` uses
//! ([`litesim_plan::closed_loop::plan`]): FMT*, and where its path cannot
//! be driven (a long wheelbase, a tight gap) the curvature-bounded search
//! over forward and reversing motion. The legs are driven by the same
//! follower as the closed loop ([`litesim_plan::follow::LegFollower`]):
//! a reversing leg in reverse gear, the gear changing at each cusp with
//! the vehicle at rest. Every MPC cycle (0.1 s) it checks the legs ahead
//! against the objects that stand (< 1 m/s): one that blocks them and is
//! not yet in the grid makes it plan again from where the ego is. Moving
//! objects ahead on a forward leg are kept at a distance by the same IDM
//! gap rule as `acc` (the lower acceleration wins).

use super::acc::{AccParams, idm, lead};
use super::{ObjectState, Observation, Route, Sut, SutCommand, SutError, SutInfo};
use litesim_core::{Vec2, math};
use litesim_map::OccupancyGrid;
use litesim_plan::closed_loop::{
    ClosedLoopConfig, GoalConfig, MapConfig, PlannerConfig, SimulationConfig, StartConfig,
    TrackerConfig, VehicleConfig,
};
use litesim_plan::follow::{FollowerVehicle, Grids, LegFollower};
use litesim_plan::mpc::{Mpc, MpcConfig};

/// Objects slower than this are obstacles in the planning grid (m/s).
const STANDING: f64 = 1.0;
/// How far ahead the corridor is checked for blocking objects (m).
const LOOK_AHEAD: f64 = 60.0;
/// Safety margin around obstacles (m).
const MARGIN: f64 = 0.2;
/// How close to the route's goal the plan ends (m): the legs end at rest
/// within it.
const GOAL_TOLERANCE: f64 = 1.0;
/// The MPC's period (s).
const CYCLE: f64 = 0.1;
/// The steering-rate limit the plan and the MPC assume (rad/s).
const STEER_RATE: f64 = 0.8;

/// The planning chain + MPC.
#[derive(Default)]
pub struct FmtMpc {
    info: SutInfo,
    base: Option<OccupancyGrid>,
    /// The plan's grids and the follower of its legs.
    planned: Option<(Grids, LegFollower)>,
    /// The leg being driven as a route (the IDM gap's reference), and
    /// which leg it is.
    route: Route,
    route_leg: Option<usize>,
    mpc: Option<Mpc>,
    /// The last command: acceleration along the travel, wheels'
    /// curvature, reverse.
    prev: (f64, f64, bool),
    route_hint: usize,
    every: u64,
    /// Obstacles in the current grid: (x, y) of each.
    in_grid: Vec<(f64, f64)>,
    /// Plans made (the first included).
    pub plans: u32,
    /// Time of the last plan (s).
    plan_time: f64,
    /// What it has to report (each plan: which planner, how many cusps).
    notes: Vec<String>,
}

impl std::fmt::Debug for FmtMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmtMpc")
            .field("plans", &self.plans)
            .finish()
    }
}

/// The wheelbase the plan, the MPC and the command's curvature all use:
/// the catalogue's, kept shorter than the body (the planner refuses a
/// wheelbase as long as the vehicle).
fn wheelbase(info: &SutInfo) -> f64 {
    info.wheelbase.min(0.95 * info.length)
}

/// An object's box.
fn rect(o: &ObjectState) -> litesim_core::OrientedBox {
    litesim_core::OrientedBox {
        x: o.x,
        y: o.y,
        yaw: o.yaw,
        length: o.length,
        width: o.width,
    }
}

impl FmtMpc {
    fn standing<'a>(&self, obs: &'a Observation) -> impl Iterator<Item = &'a ObjectState> {
        obs.objects.iter().filter(|o| o.speed.abs() < STANDING)
    }

    /// Whether a standing object not in the grid blocks the legs ahead
    /// (the one being driven from where the ego is, and those after it,
    /// within [`LOOK_AHEAD`]).
    fn blocked(&self, obs: &Observation) -> bool {
        let Some((_, follower)) = &self.planned else {
            return true;
        };
        let clear = 0.5 * self.info.width + MARGIN;
        let here = Vec2::new(obs.ego.x, obs.ego.y);
        let legs = &follower.legs()[follower.leg()..];
        let s_now = legs.first().map_or(0.0, |l| l.corridor.project(here, 0).0);
        self.standing(obs).any(|o| {
            if self
                .in_grid
                .iter()
                .any(|&(x, y)| math::hypot(x - o.x, y - o.y) < 0.5)
            {
                return false;
            }
            let mut before = -s_now;
            legs.iter().any(|l| {
                let c = &l.corridor;
                let hit = c
                    .points
                    .iter()
                    .zip(&c.s)
                    .map(|(p, s)| (p, before + s))
                    .filter(|(_, s)| *s >= 0.0 && *s <= LOOK_AHEAD)
                    .any(|(p, _)| rect(o).distance(*p) < clear);
                before += c.length();
                hit
            })
        })
    }

    /// The planning chain from where the ego stands to the route's goal,
    /// around the objects standing now.
    fn plan(&mut self, obs: &Observation) -> Result<(), SutError> {
        let base = self
            .base
            .as_ref()
            .ok_or_else(|| SutError("fmt-mpc: no map".into()))?;
        let mut grid = base.clone();
        self.in_grid.clear();
        let standing: Vec<ObjectState> = self.standing(obs).cloned().collect();
        for o in &standing {
            grid.fill_quad(rect(o).corners(), true);
            self.in_grid.push((o.x, o.y));
        }
        let goal = self
            .info
            .route
            .goal()
            .ok_or_else(|| SutError("fmt-mpc: the route is empty".into()))?;
        let info = &self.info;
        let v_max = info
            .route
            .speed
            .iter()
            .copied()
            .fold(0.0, f64::max)
            .max(1.0);
        let goal = goal_through(info, goal, &grid);
        // Sample density: about one sample per 2 m² of the area in play.
        let free = grid.free_cells() as f64;
        let samples = ((free * grid.resolution * grid.resolution / 2.0) as usize).clamp(400, 3000);
        let cfg = chain_config(info, obs, goal, (&grid, samples), (v_max, self.plans));
        let planned = litesim_plan::closed_loop::plan(&cfg, grid)
            .map_err(|e| SutError(format!("fmt-mpc: planning at t={:.2} s: {e}", obs.time)))?;
        let backwards = planned.legs.iter().filter(|l| l.reverse).count();
        self.notes.push(format!(
            "fmt-mpc planned at t={:.2} s: {}{}",
            obs.time,
            planned.planner,
            if backwards > 0 {
                format!(", {backwards} leg(s) in reverse gear")
            } else {
                String::new()
            }
        ));
        let follower = LegFollower::new(
            planned.legs,
            FollowerVehicle {
                wheelbase: wheelbase(info),
                max_steer: info.max_steer,
                max_steer_rate: STEER_RATE,
            },
            cfg.planner.corridor_ds,
        );
        self.planned = Some((planned.grids, follower));
        self.route_leg = None;
        self.route_hint = 0;
        self.plans += 1;
        self.plan_time = obs.time;
        Ok(())
    }

    /// The leg being driven as a route, rebuilt when the leg changes.
    fn leg_route(&mut self) -> Option<bool> {
        let (_, follower) = self.planned.as_ref()?;
        let leg = follower.leg();
        let l = &follower.legs()[leg];
        if self.route_leg != Some(leg) {
            let pts: Vec<[f64; 2]> = l.corridor.points.iter().map(|p| [p.x, p.y]).collect();
            self.route = Route::new(&pts, &l.corridor.speed);
            self.route_leg = Some(leg);
            self.route_hint = 0;
        }
        Some(l.reverse)
    }
}

impl Sut for FmtMpc {
    fn name(&self) -> String {
        "fmt-mpc".into()
    }

    fn reset(&mut self, info: &SutInfo) -> Result<(), SutError> {
        let net = info
            .map
            .as_ref()
            .ok_or_else(|| SutError("fmt-mpc needs the test's map".into()))?;
        // Half-metre cells, coarser on big maps (at most ~4 M cells).
        let mut res = 0.25;
        let base = loop {
            match net.rasterise(res, 2.0) {
                Ok(g) if g.width * g.height <= 4_000_000 => break g,
                Ok(_) if res < 4.0 => res *= 2.0,
                Ok(g) => break g,
                Err(e) => return Err(SutError(format!("fmt-mpc: rasterising the map: {e}"))),
            }
        };
        let mpc = Mpc::new(MpcConfig {
            horizon: 20,
            dt: CYCLE,
            wheelbase: wheelbase(info),
            max_steer: info.max_steer,
            max_steer_rate: STEER_RATE,
            min_accel: -info.max_decel.max(0.1),
            max_accel: info.max_accel.max(0.1),
            // The MPC runs every 0.1 s; predict with the world's step.
            substeps: (100 / info.step_ms.max(1)).clamp(1, 100) as usize,
            ..MpcConfig::default()
        })
        .map_err(|e| SutError(format!("fmt-mpc: {e}")))?;
        *self = FmtMpc {
            info: info.clone(),
            base: Some(base),
            mpc: Some(mpc),
            every: u64::from((100 / info.step_ms.max(1)).max(1)),
            ..FmtMpc::default()
        };
        Ok(())
    }

    fn step(&mut self, obs: &Observation) -> Result<SutCommand, SutError> {
        let z = &obs.ego;
        let cycle = obs.tick.is_multiple_of(self.every) || self.planned.is_none();
        if cycle {
            if self.blocked(obs) {
                self.plan(obs)?;
            }
            let (grids, follower) = self.planned.as_mut().expect("planned above");
            let mpc = self.mpc.as_mut().expect("reset makes the MPC");
            let steer = follower
                .command(
                    grids,
                    mpc,
                    (Vec2::new(z.x, z.y), z.yaw, z.speed),
                    CYCLE,
                    &|| 0.0,
                )
                .map_err(|e| SutError(format!("fmt-mpc: MPC at t={:.2} s: {e}", obs.time)))?;
            // The follower's command is the signed speed's rate; the
            // SUT's is along the travel.
            let along = if steer.reverse {
                -steer.acceleration
            } else {
                steer.acceleration
            };
            let kappa = math::tan(steer.steering) / wheelbase(&self.info);
            self.prev = (along, kappa, steer.reverse);
        }
        let (mut a, kappa, reverse) = self.prev;
        // Keep a gap to moving objects on a forward leg (and stop before
        // standing ones the plan could not avoid).
        if self.leg_route() == Some(false)
            && let Some(p) = self.route.project(z.x, z.y, self.route_hint)
        {
            self.route_hint = p.segment;
            let moving: Vec<ObjectState> = obs
                .objects
                .iter()
                .filter(|o| {
                    o.speed.abs() >= STANDING
                        || !self
                            .in_grid
                            .iter()
                            .any(|&(x, y)| math::hypot(x - o.x, y - o.y) < 0.5)
                })
                .cloned()
                .collect();
            let params = AccParams::default();
            if let Some(l) = lead(&self.route, z, p.s, p.segment, &moving, MARGIN) {
                let v0 = self.route.speed_at(p.s).max(obs.requested_speed);
                a = a.min(idm(&params, z.speed, v0, Some(l)));
            }
        }
        let a = a.clamp(
            -self.info.max_decel.clamp(0.1, super::acc::EMERGENCY_DECEL),
            self.info.max_accel.max(0.1),
        );
        Ok(SutCommand::Accel {
            acceleration: a,
            curvature: kappa.clamp(-1.0, 1.0),
            reverse,
        })
    }

    fn notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }
}

/// The plan's goal: a route that ends moving (the scenario's ego still
/// driving when it ends) is driven through its end, not braked to a stop
/// there: the goal lies a braking distance further on along its last
/// heading, where that is free (else nearer, else the end).
fn goal_through(info: &SutInfo, goal: [f64; 2], grid: &OccupancyGrid) -> [f64; 2] {
    let end_speed = info.route.speed.last().copied().unwrap_or(0.0);
    let n = info.route.points.len();
    let brake = end_speed * end_speed / info.max_decel.max(0.1) + end_speed;
    match (end_speed > STANDING, n) {
        (true, 2..) => {
            let [a, b] = [info.route.points[n - 2], info.route.points[n - 1]];
            let dir = Vec2::new(b[0] - a[0], b[1] - a[1]);
            let len = dir.norm();
            let end = Vec2::new(goal[0], goal[1]);
            let on = (1..=8)
                .map(|k| brake * (1.0 - 0.125 * f64::from(k - 1)))
                .map(|d| end + dir * (d / len.max(1e-9)))
                .find(|p| len > 1e-9 && grid.cell(*p).is_some() && !grid.is_occupied(*p))
                .unwrap_or(end);
            [on.x, on.y]
        }
        _ => goal,
    }
}

/// The planning chain's configuration for the SUT's vehicle from where
/// it stands (`obs`) to `goal` on `grid`, with `samples` FMT* samples, the
/// route's top speed `v_max` and the plan count (which varies the seed).
fn chain_config(
    info: &SutInfo,
    obs: &Observation,
    goal: [f64; 2],
    (grid, samples): (&OccupancyGrid, usize),
    (v_max, plans): (f64, u32),
) -> ClosedLoopConfig {
    ClosedLoopConfig {
        map: MapConfig {
            origin: [grid.origin.x, grid.origin.y],
            size: [0.0, 0.0],
            resolution: grid.resolution,
            obstacles: Vec::new(),
            png: None,
            opendrive: None,
        },
        start: StartConfig {
            x: obs.ego.x,
            y: obs.ego.y,
            yaw: obs.ego.yaw,
            speed: obs.ego.speed.max(0.0),
        },
        goal: GoalConfig {
            x: goal[0],
            y: goal[1],
            tolerance: GOAL_TOLERANCE,
            stop_speed: 0.3,
        },
        vehicle: VehicleConfig {
            preset: "passenger".into(),
            length: Some(info.length),
            width: Some(info.width),
            wheelbase: Some(wheelbase(info)),
            mass: None,
            max_steer_deg: Some(info.max_steer.to_degrees()),
            max_steer_rate_deg: Some(STEER_RATE.to_degrees()),
            max_accel: Some(info.max_accel.max(0.1)),
            max_decel: Some(info.max_decel.max(0.1)),
            max_speed: Some(v_max),
            max_lat_accel: Some(3.0),
        },
        planner: PlannerConfig {
            samples,
            eta: 0.5,
            radius: None,
            k_nearest: None,
            seed: info.seed ^ u64::from(plans),
            margin: MARGIN,
            corridor_ds: 0.5,
        },
        tracker: TrackerConfig {
            horizon: 20,
            dt: CYCLE,
            q: MpcConfig::default().q,
            q_terminal: MpcConfig::default().q_terminal,
            r: MpcConfig::default().r,
            r_rate: MpcConfig::default().r_rate,
        },
        simulation: SimulationConfig {
            dt: f64::from(info.step_ms.max(1)) / 1000.0,
            horizon: info.timeout_s.max(1.0),
        },
    }
}
