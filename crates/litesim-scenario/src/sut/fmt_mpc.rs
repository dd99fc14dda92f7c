//! The built-in SUT `fmt-mpc`: litesim-plan's FMT* on the occupancy grid
//! of the map's drivable area, a smoothed corridor, and MPC tracking —
//! the planning half of litesim driving the scenario half's ego.
//!
//! The first step plans from the ego to the route's goal around the
//! objects standing on the road. Every MPC cycle (0.1 s) it checks the
//! corridor ahead against the objects that stand (< 1 m/s): one that
//! blocks it and is not yet in the grid makes it plan again from where the
//! ego is. Moving objects ahead on the corridor are kept at a distance by
//! the same IDM gap rule as `acc` (the lower acceleration wins).

use super::acc::{AccParams, idm, lead};
use super::{ObjectState, Observation, Route, Sut, SutCommand, SutError, SutInfo};
use litesim_core::{Vec2, math};
use litesim_map::OccupancyGrid;
use litesim_plan::corridor::{Corridor, RefState, SpeedLimits};
use litesim_plan::fmt::{FmtConfig, Radius, fmt_star};
use litesim_plan::grid::PlanningGrid;
use litesim_plan::mpc::{Mpc, MpcConfig};

/// Objects slower than this are obstacles in the planning grid (m/s).
const STANDING: f64 = 1.0;
/// How far ahead the corridor is checked for blocking objects (m).
const LOOK_AHEAD: f64 = 60.0;
/// Safety margin around obstacles (m).
const MARGIN: f64 = 0.4;

/// FMT* + MPC.
#[derive(Default)]
pub struct FmtMpc {
    info: SutInfo,
    base: Option<OccupancyGrid>,
    pgrid: Option<PlanningGrid>,
    corridor: Option<Corridor>,
    route: Route,
    mpc: Option<Mpc>,
    prev: [f64; 2],
    hint: usize,
    route_hint: usize,
    every: u64,
    /// Obstacles in the current grid: (x, y) of each.
    in_grid: Vec<(f64, f64)>,
    /// Plans made (the first included).
    pub plans: u32,
    /// Time of the last plan (s).
    plan_time: f64,
}

impl std::fmt::Debug for FmtMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FmtMpc")
            .field("plans", &self.plans)
            .finish()
    }
}

/// Distance from a point to an object's box (0 inside).
fn box_distance(o: &ObjectState, x: f64, y: f64) -> f64 {
    let (s, c) = math::sin_cos(o.yaw);
    let (dx, dy) = (x - o.x, y - o.y);
    let lx = (dx * c + dy * s).abs() - 0.5 * o.length;
    let ly = (-dx * s + dy * c).abs() - 0.5 * o.width;
    math::hypot(lx.max(0.0), ly.max(0.0))
}

fn box_quad(o: &ObjectState) -> [Vec2; 4] {
    let (s, c) = math::sin_cos(o.yaw);
    let (hl, hw) = (0.5 * o.length, 0.5 * o.width);
    let p = |a: f64, b: f64| Vec2::new(o.x + a * c - b * s, o.y + a * s + b * c);
    [p(hl, hw), p(-hl, hw), p(-hl, -hw), p(hl, -hw)]
}

impl FmtMpc {
    fn standing<'a>(&self, obs: &'a Observation) -> impl Iterator<Item = &'a ObjectState> {
        obs.objects.iter().filter(|o| o.speed.abs() < STANDING)
    }

    /// Whether a standing object not in the grid blocks the corridor ahead.
    fn blocked(&self, obs: &Observation, s_now: f64) -> bool {
        let Some(c) = &self.corridor else {
            return true;
        };
        let clear = 0.5 * self.info.width + MARGIN;
        self.standing(obs).any(|o| {
            if self
                .in_grid
                .iter()
                .any(|&(x, y)| math::hypot(x - o.x, y - o.y) < 0.5)
            {
                return false;
            }
            c.points
                .iter()
                .zip(&c.s)
                .filter(|(_, s)| **s >= s_now && **s <= s_now + LOOK_AHEAD)
                .any(|(p, _)| box_distance(o, p.x, p.y) < clear)
        })
    }

    fn plan(&mut self, obs: &Observation) -> Result<(), SutError> {
        let base = self
            .base
            .as_ref()
            .ok_or_else(|| SutError("fmt-mpc: no map".into()))?;
        let mut grid = base.clone();
        self.in_grid.clear();
        let standing: Vec<ObjectState> = self.standing(obs).cloned().collect();
        for o in &standing {
            grid.fill_quad(box_quad(o), true);
            self.in_grid.push((o.x, o.y));
        }
        let pgrid = PlanningGrid::new(grid, 0.5 * self.info.width, MARGIN);
        let start = Vec2::new(obs.ego.x, obs.ego.y);
        let goal = self
            .info
            .route
            .goal()
            .map(|g| Vec2::new(g[0], g[1]))
            .ok_or_else(|| SutError("fmt-mpc: the route is empty".into()))?;
        // Sample density: about one sample per 2 m² of the area in play.
        let area = pgrid.free_area();
        let samples = ((area / 2.0) as usize).clamp(400, 3000);
        let fmt = fmt_star(
            &pgrid,
            start,
            goal,
            &FmtConfig {
                samples,
                radius: Radius::Eta(0.5),
                seed: self.info.seed ^ u64::from(self.plans),
            },
        )
        .map_err(|e| SutError(format!("fmt-mpc: planning at t={:.2} s: {e}", obs.time)))?;
        let v_max = self
            .info
            .route
            .speed
            .iter()
            .copied()
            .fold(0.0, f64::max)
            .max(1.0);
        let corridor = Corridor::build(
            &fmt.path,
            &pgrid,
            0.5,
            &SpeedLimits {
                v_max,
                a_lat_max: 3.0,
                a_max: 0.8 * self.info.max_accel,
                d_max: 0.5 * self.info.max_decel,
                v_start: obs.ego.speed.max(0.5),
                // The SUT re-plans from wherever it is: its own heading
                // and steering limits shape the corridor as in `plan`.
                kappa_rate_max: 0.5 * 0.8 / self.info.wheelbase.max(0.5),
                kappa_max: self.info.max_steer.tan() / self.info.wheelbase.max(0.5),
                // Re-planned often and from speed: no jerk program here
                // (its start-speed equality can be infeasible mid-run).
                jerk_max: f64::INFINITY,
                start_heading: Some(obs.ego.yaw),
            },
        );
        let pts: Vec<[f64; 2]> = corridor.points.iter().map(|p| [p.x, p.y]).collect();
        self.route = Route::new(&pts, &corridor.speed);
        self.corridor = Some(corridor);
        self.pgrid = Some(pgrid);
        self.hint = 0;
        self.route_hint = 0;
        self.plans += 1;
        self.plan_time = obs.time;
        Ok(())
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
        let mut res = 0.5;
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
            dt: 0.1,
            wheelbase: info.wheelbase,
            max_steer: info.max_steer,
            max_steer_rate: 0.8,
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
        let cycle = obs.tick.is_multiple_of(self.every) || self.corridor.is_none();
        if cycle {
            let s_now = self
                .corridor
                .as_ref()
                .map_or(0.0, |c| c.project(Vec2::new(z.x, z.y), self.hint).0);
            if self.blocked(obs, s_now) {
                self.plan(obs)?;
            }
            let c = self.corridor.as_ref().expect("planned above");
            let (s, _, i) = c.project(Vec2::new(z.x, z.y), self.hint);
            self.hint = i;
            let t0 = c.time_at_s(s);
            let dt = 0.1;
            let refs: Vec<RefState> = (0..=20).map(|k| c.at_time(t0 + k as f64 * dt)).collect();
            let mpc = self.mpc.as_mut().expect("reset makes the MPC");
            let sol = mpc
                .solve([z.x, z.y, z.yaw, z.speed], &refs, self.prev)
                .map_err(|e| SutError(format!("fmt-mpc: MPC at t={:.2} s: {e}", obs.time)))?;
            self.prev = [sol.acceleration, sol.steering];
        }
        // Keep a gap to moving objects on the corridor (and stop before
        // standing ones the plan could not avoid).
        let rp = self.route.project(z.x, z.y, self.route_hint);
        let mut a = self.prev[0];
        if let Some(p) = rp {
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
        let kappa = math::tan(self.prev[1]) / self.info.wheelbase.max(0.1);
        Ok(SutCommand::Accel {
            acceleration: a,
            curvature: kappa.clamp(-1.0, 1.0),
            reverse: false,
        })
    }
}
