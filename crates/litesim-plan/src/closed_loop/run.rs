//! The run: plan (FMT*, then the curvature-bounded search where FMT*'s
//! path cannot be driven), then track with the MPC in the simulated world.

use super::*;

/// Plans, tracks and logs one run. `grid` is the occupancy (already loaded).
pub fn run_closed_loop(
    cfg: &ClosedLoopConfig,
    grid: OccupancyGrid,
) -> Result<ClosedLoopResult, PlanError> {
    run_closed_loop_timed(cfg, grid, &|| 0.0).map(|(r, _)| r)
}

/// Where FMT*'s path cannot be driven (or FMT* found none, or its goal is
/// inside the margin): the curvature-bounded search over forward and
/// reversing motion (a cusp and a metre backwards cost more than one
/// forwards), at 80 % then 95 % of the turning limit, ending within half
/// the goal tolerance, then within it less 10 cm; where none finds a
/// drivable path, the exhaustive search that may prove the run impossible. Returns the
/// search's path in FMT*'s shape (for the views), the legs, and the
/// planner used; `first` is FMT*'s failure, which a refusal quotes.
#[allow(clippy::too_many_arguments)]
pub(super) fn search_fallback<'g>(
    pgrid: &'g PlanningGrid,
    grid_for: &dyn Fn(bool) -> &'g PlanningGrid,
    drivable: &dyn Fn(&Corridor, &PlanningGrid) -> Result<(), PlanError>,
    (from, from_yaw, goal): (Vec2, f64, Vec2),
    cfg: &ClosedLoopConfig,
    kappa_max: f64,
    limits: &SpeedLimits,
    first: PlanError,
) -> Result<(FmtResult, Vec<Leg>, PathPlanner), PlanError> {
    let pl = &cfg.planner;
    // Curves at 80 % of the limit, so that the controller keeps a
    // fifth of the steering to correct with; where that finds
    // nothing, at 95 %. When no shot reaches the goal itself, a
    // path may end short of it: first within half the goal
    // tolerance; where neither finds a drivable path, within the
    // tolerance less 10 cm for tracking and stopping (the matrix's
    // worst cross-track error is 21 mm) — a search that stops
    // earlier, so it finds paths the first did not (a long truck
    // ending 0.31 m from the goal of the S-bend).
    let half = 0.5 * cfg.goal.tolerance;
    let wide = cfg.goal.tolerance - 0.1;
    let attempt = |share: f64, end_within: f64| {
        let base = HybridConfig::new(share * kappa_max, pgrid.grid.resolution);
        let hcfg = HybridConfig {
            goal_tolerance: end_within,
            reverse: true,
            // Reversing doubles the states, and a manoeuvre with
            // several cusps lies deeper in them.
            max_expansions: 2 * base.max_expansions,
            ..base
        };
        // The error, whether it is the start (which no other
        // turning limit changes), and how close the search came.
        hybrid_astar(pgrid, from, from_yaw, goal, &hcfg)
            .map_err(|e| {
                // (A search pruned before it began — a goal
                // whose nearer end cells the body cannot reach —
                // says nothing of a wider end.)
                let closest = match &e {
                    HybridError::NoPath {
                        closest,
                        expansions,
                        ..
                    } if *expansions > 0 => Some(*closest),
                    _ => None,
                };
                (
                    matches!(e, HybridError::StartBlocked { .. }),
                    closest,
                    e.to_string(),
                )
            })
            .and_then(|h| {
                let legs = legs_along(&h.segments, &grid_for, pl.corridor_ds, limits);
                for leg in &legs {
                    drivable(&leg.corridor, grid_for(leg.reverse))
                        .map_err(|e| (false, None, e.to_string()))?;
                }
                Ok((h, legs, hcfg))
            })
    };
    let mut tries = vec![(0.8, half), (0.95, half)];
    if wide > half {
        tries.extend([(0.8, wide), (0.95, wide)]);
    }
    // How close each curvature's first search came. A search with a
    // wider end expands the same poses in the same order and stops
    // at the first within its end, so it can only succeed where one
    // came that close (or where the first found a path the vehicle
    // could not drive): otherwise it is not run.
    let closest_of = |r: &Result<_, (bool, Option<f64>, String)>| match r {
        Err((_, c, _)) => *c,
        Ok(_) => None,
    };
    let mut found = Err((false, None, String::new()));
    // One search over forward and reversing motion: a cusp and every
    // metre backwards cost more than driving on, so a forward path is
    // taken wherever one costs less, and a manoeuvre with cusps (into a
    // dead end and back out, a turn in three moves, backing into the
    // goal) is found without waiting for forward searches to fail.
    let mut came: Vec<(f64, Option<f64>)> = Vec::new();
    for &(share, end_within) in &tries {
        // A start the body does not fit ends the search: no other
        // turning limit or end changes it.
        let Err((false, _, _)) = found else { break };
        let hopeless = end_within > half
            && came
                .iter()
                .any(|&(s, c)| s == share && c.is_some_and(|c| c > end_within));
        if hopeless {
            continue;
        }
        found = attempt(share, end_within);
        if end_within <= half {
            came.push((share, closest_of(&found)));
        }
    }
    let found = found.map_err(|(_, _, e)| e);
    Ok(match found {
        Ok((h, legs, hcfg)) => {
            let used = PathPlanner::Hybrid {
                radius: 1.0 / hcfg.kappa,
                expansions: h.expansions,
                cusps: h.segments.len().saturating_sub(1),
                fmt_failure: first.to_string(),
            };
            (tree_view(h, from, goal), legs, used)
        }
        Err(second) => {
            let proof = exhausted(pgrid, from, from_yaw, goal, kappa_max, half);
            return Err(refusal(first, &second, proof));
        }
    })
}

/// The refusal when neither FMT* (`first`) nor the search (`second`)
/// found a drivable path: impossible with the exhaustive search's proof,
/// else infeasible.
fn refusal(first: PlanError, second: &str, proof: Option<String>) -> PlanError {
    let first = match first {
        PlanError::Infeasible(m) => m,
        e => e.to_string(),
    };
    let why = format!("{first}; and a search within the turning limit found none: {second}");
    match proof {
        Some(proof) => PlanError::Impossible(format!("{why}; {proof}")),
        None => PlanError::Infeasible(why),
    }
}

/// The search's tree in the planner views: its expanded positions after
/// start and goal, its edges in expansion order (the exploration GIF
/// replays them), and its path.
fn tree_view(h: crate::HybridPath, from: Vec2, goal: Vec2) -> FmtResult {
    let n = h.explored.len();
    let mut samples = vec![from, goal];
    samples.extend(&h.explored);
    let mut cost = vec![0.0, h.length];
    cost.resize(n + 2, f64::INFINITY);
    FmtResult {
        samples,
        parent: vec![None; n + 2],
        cost,
        edges: h.tree.iter().map(|&(a, b)| (a + 2, b + 2)).collect(),
        path: h.points,
        path_cost: h.length,
        radius: 0.0,
        collision_checks: 0,
    }
}

/// What planning made, before anything is driven.
#[derive(Debug)]
pub struct Planned {
    /// The grids the planners used (the vehicle's footprint and margin;
    /// the body mirrored for reversing legs).
    pub grids: Grids,
    /// The leg out of the margin, when the start was inside it.
    pub escape: Option<crate::escape::Escape>,
    /// FMT*'s output (or the search's path and tree in its shape).
    pub fmt: FmtResult,
    /// The legs to drive, in order (the escape's first).
    pub legs: Vec<Leg>,
    /// Which planner made the path.
    pub planner: PathPlanner,
}

/// The planning chain of [`run_closed_loop`] alone, from the
/// configuration's start (pose and speed) to its goal on `grid`: the
/// escape from the margin, FMT*, the curvature-bounded search over
/// forward and reversing motion where FMT*'s path cannot be driven, the
/// exhaustive search that may prove the run impossible; then the legs to
/// drive ([`crate::follow::LegFollower`]). What a system under test that
/// plans for itself calls (the `fmt-mpc` SUT of scenarios).
pub fn plan(cfg: &ClosedLoopConfig, grid: OccupancyGrid) -> Result<Planned, PlanError> {
    let veh = cfg.vehicle.resolve()?;
    let kappa_max = litesim_core::math::tan(veh.max_steer) / veh.wheelbase;
    plan_path(cfg, &veh, grid, kappa_max)
}

/// The planning chain of a closed-loop run: the start's escape from the
/// margin, FMT*, and where its path cannot be driven the curvature-bounded
/// search (forwards, then reversing; where none finds a path, the
/// exhaustive search that may prove the run impossible); then the legs,
/// each a corridor to track. `kappa_max` is the vehicle's tightest
/// curvature (1/m).
pub(super) fn plan_path(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    grid: OccupancyGrid,
    kappa_max: f64,
) -> Result<Planned, PlanError> {
    let pl = &cfg.planner;
    if !(pl.margin.is_finite() && pl.margin >= 0.0) {
        return Err(PlanError::Config(format!(
            "planner.margin must be ≥ 0, got {}",
            pl.margin
        )));
    }
    let pgrid = PlanningGrid::with_footprint(
        grid,
        veh.length,
        veh.width,
        (veh.length - veh.wheelbase) / 2.0,
        pl.margin,
    );
    let start = Vec2::new(cfg.start.x, cfg.start.y);
    let goal = Vec2::new(cfg.goal.x, cfg.goal.y);
    let escape = start_escape(cfg, veh, &pgrid, (start, kappa_max))?;
    let (from, from_yaw) = escape
        .as_ref()
        .map_or((start, cfg.start.yaw), |e| (e.end, e.end_yaw));
    goal_on_the_map(&pgrid, goal)?;
    let radius = match (pl.radius, pl.k_nearest) {
        (Some(r), _) => Radius::Fixed(r),
        (None, Some(k)) => Radius::KNearest(k),
        _ => Radius::Eta(pl.eta),
    };
    let limits = speed_limits(cfg, veh, kappa_max, (escape.is_some(), from_yaw));
    // A path the vehicle cannot drive is refused before it is driven: too
    // tight a turn, or a body that does not fit where the path goes.
    let drivable =
        |corridor: &Corridor, pgrid: &PlanningGrid| drivable(corridor, pgrid, cfg, veh, kappa_max);
    // FMT* first (shortest, fast); when its path cannot be driven — its
    // straight edges leave no room for this body, or its corners are
    // tighter than the vehicle turns — the curvature-bounded search plans
    // arcs the vehicle can follow.
    let by_fmt = fmt_star(
        &pgrid,
        from,
        goal,
        &FmtConfig {
            samples: pl.samples,
            radius,
            seed: pl.seed,
        },
    )
    .map_err(PlanError::from)
    .and_then(|fmt| {
        let corridor = Corridor::build(&fmt.path, &pgrid, pl.corridor_ds, &limits);
        drivable(&corridor, &pgrid)?;
        Ok((fmt, corridor))
    });
    // The body mirrored, for stretches driven backwards (made only when a
    // path reverses).
    let grids = Grids::new(pgrid);
    let pgrid = &grids.forward;
    let grid_for = |reverse: bool| grids.for_direction(reverse);
    let (fmt, mut legs, planner) = match by_fmt {
        Ok((fmt, corridor)) => {
            let used = PathPlanner::Fmt {
                samples: fmt.samples.len() - 2,
                radius: fmt.radius,
            };
            let legs = vec![Leg::forward(corridor, &limits)];
            (fmt, legs, used)
        }
        // A goal inside the margin (on the map, not in an obstacle:
        // checked above) is FMT*'s refusal, not the search's: its path may
        // end within the goal's tolerance where the body keeps the margin.
        Err(
            first @ (PlanError::Infeasible(_)
            | PlanError::Plan(FmtError::NoPath { .. } | FmtError::GoalInCollision(..))),
        ) => search_fallback(
            pgrid,
            &grid_for,
            &drivable,
            (from, from_yaw, goal),
            cfg,
            kappa_max,
            &limits,
            first,
        )?,
        Err(e) => return Err(e),
    };
    if let Some(e) = &escape {
        legs.insert(
            0,
            escape_leg(
                e,
                cfg.start.yaw,
                &grid_for,
                pl.corridor_ds,
                &limits,
                cfg.start.speed,
            ),
        );
    }
    Ok(Planned {
        grids,
        escape,
        fmt,
        legs,
        planner,
    })
}

/// A start inside the margin (the body free, but closer to an obstacle
/// or the map's edge than the planners keep it) is left along one short
/// leg, and the path planned from where that leg ends ([`crate::escape`]);
/// a body that overlaps an obstacle or leaves the map is refused here.
fn start_escape(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    pgrid: &PlanningGrid,
    (start, kappa_max): (Vec2, f64),
) -> Result<Option<crate::escape::Escape>, PlanError> {
    crate::escape::from_start(
        pgrid,
        start,
        cfg.start.yaw,
        0.8 * kappa_max,
        0.5 * pgrid.grid.resolution,
        crate::escape::max_escape(veh.length),
    )
    .map_err(|e| match e {
        // A body that cannot stand where the vehicle starts: no planner
        // can start there.
        crate::escape::StartError::Overlap { .. } => PlanError::Impossible(e.to_string()),
        _ => PlanError::Infeasible(e.to_string()),
    })
}

/// Whether the vehicle can drive `corridor` on `pgrid`: no turn tighter
/// than its limit (with slack), and the body with its margin fits all
/// along it; the refusal names where and why.
fn drivable(
    corridor: &Corridor,
    pgrid: &PlanningGrid,
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    kappa_max: f64,
) -> Result<(), PlanError> {
    let pl = &cfg.planner;
    let turn = corridor.turn_curvature(TURN_HALF_ARC);
    if let Some(i) = (0..turn.len())
        .filter(|&i| turn[i].abs() > kappa_max * TURN_SLACK)
        .max_by(|&a, &b| turn[a].abs().total_cmp(&turn[b].abs()))
    {
        let p = corridor.points[i];
        return Err(PlanError::Infeasible(format!(
            "the smoothed path turns with a {:.2} m radius at ({:.1}, {:.1}); the {} turns no tighter than {:.2} m (wheelbase {} m, steering {:.0}°)",
            1.0 / turn[i].abs(),
            p.x,
            p.y,
            cfg.vehicle.preset,
            1.0 / kappa_max,
            veh.wheelbase,
            veh.max_steer.to_degrees()
        )));
    }
    if let Some(p) = corridor.first_blocked(pgrid) {
        return Err(PlanError::Infeasible(format!(
            "the {} m × {} m body does not fit along the path at ({:.1}, {:.1}) with a {} m margin",
            veh.length, veh.width, p.x, p.y, pl.margin
        )));
    }
    Ok(())
}

/// The limits a path's speed profile keeps to: the vehicle's, half its
/// steering rate (the other half is the controller's), the start's speed
/// (at rest after an escape leg) and heading.
fn speed_limits(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    kappa_max: f64,
    (escaped, from_yaw): (bool, f64),
) -> SpeedLimits {
    SpeedLimits {
        v_max: veh.max_speed,
        a_lat_max: veh.max_lat_accel,
        a_max: veh.max_accel * 0.8,
        d_max: veh.max_decel * 0.5,
        // After an escape leg the vehicle has stopped where the path starts.
        v_start: if escaped {
            0.0
        } else {
            cfg.start.speed.max(0.5)
        },
        // Half the steering rate: the other half is the controller's
        // to correct errors with.
        kappa_rate_max: 0.5 * veh.max_steer_rate / veh.wheelbase,
        kappa_max,
        jerk_max: JERK_MAX,
        start_heading: Some(from_yaw),
    }
}

/// [`run_closed_loop`], also timing planning and each MPC solve with
/// `clock` (seconds from any origin). The clock never influences results.
pub fn run_closed_loop_timed(
    cfg: &ClosedLoopConfig,
    grid: OccupancyGrid,
    clock: &dyn Fn() -> f64,
) -> Result<(ClosedLoopResult, Timings), PlanError> {
    let mut timings = Timings::default();
    let veh = cfg.vehicle.resolve()?;
    let (mpc, every) = tracker_of(cfg, &veh)?;
    // The tightest turn the vehicle can drive (1/m): the corridor is
    // shaped towards it, and a path beyond it is refused below.
    let kappa_max = litesim_core::math::tan(veh.max_steer) / veh.wheelbase;
    let t_plan = clock();
    let Planned {
        grids,
        escape,
        fmt,
        legs,
        planner,
    } = plan_path(cfg, &veh, grid, kappa_max)?;
    timings.plan_s = clock() - t_plan;

    let (mut world, bike) = ego_world(cfg, &veh, legs.first().is_some_and(|l| l.reverse))?;
    let mut rec = recorder(cfg, &planner);
    rec.record_world(&world);
    let follower = LegFollower::new(
        legs,
        FollowerVehicle {
            wheelbase: veh.wheelbase,
            max_steer: veh.max_steer,
            max_steer_rate: veh.max_steer_rate,
        },
        cfg.planner.corridor_ds,
    );
    let mut tracker = Tracker {
        follower,
        mpc,
        every,
        dt: cfg.tracker.dt,
        bike,
        tracking: TrackingColumns::default(),
    };
    let stop = litesim_core::StopCondition {
        actor: "ego".into(),
        goal: Vec2::new(cfg.goal.x, cfg.goal.y),
        radius: cfg.goal.tolerance,
        speed_threshold: cfg.goal.stop_speed,
    };
    let driven = drive(
        cfg,
        &veh,
        &mut world,
        &mut rec,
        (&grids, escape.is_some()),
        &mut tracker,
        &stop,
        (clock, &mut timings),
    )?;
    let run = Outcome {
        world,
        rec,
        tracking: tracker.tracking,
        legs: tracker.follower.into_legs(),
        driven,
        stop,
        escape,
    };
    let result = run.result(cfg, grids, fmt, planner);
    Ok((result, timings))
}

/// The MPC tracker of the run's legs: it steers the ego every `every`
/// ticks (the tracker's period `dt`), switching the bicycle's gear with
/// the leg, and records what it did.
struct Tracker {
    follower: LegFollower,
    mpc: Mpc,
    every: u64,
    dt: f64,
    /// The ego's model, for its gear changes.
    bike: KinematicBicycle,
    tracking: TrackingColumns,
}

impl Tracker {
    /// Sets the ego's command for this tick (when one is due).
    fn control(
        &mut self,
        w: &mut World,
        grids: &Grids,
        clock: &dyn Fn() -> f64,
        timings: &mut Timings,
    ) -> Result<(), MpcError> {
        if !w.tick().is_multiple_of(self.every) {
            return Ok(());
        }
        let Some(a) = w.actor("ego") else {
            return Ok(());
        };
        let st = a.state();
        let state = (st.pose.position.xy(), st.pose.yaw, st.speed);
        let steer = self
            .follower
            .command(grids, &mut self.mpc, state, self.dt, clock)?;
        timings.mpc_s.push(steer.solve_s);
        // The gear changes with the leg.
        if steer.gear_changed {
            let mut geared = self.bike.clone();
            geared.reverse = steer.reverse;
            let _ = w.set_model("ego", VehicleModelKind::Bicycle(geared));
        }
        let _ = w.set_mode(
            "ego",
            ControlMode::Dynamic {
                input: VehicleInput::Direct {
                    acceleration: steer.acceleration,
                    steering_angle: steer.steering,
                },
                valid_until_tick: None,
            },
        );
        track(&mut self.tracking, w.tick(), steer);
        Ok(())
    }
}

/// What the drive left: the steps taken, the contact that ended it, the
/// smallest clearance, and when a start inside the margin left it.
struct Driven {
    steps: u64,
    collided: bool,
    collision: Option<(f64, [f64; 2])>,
    min_clear: f64,
    inside_until: Option<f64>,
}

/// The loop of `run_loop`, plus the verdict: the run ends at the first
/// contact of the footprint with an obstacle (driving on through a wall
/// says nothing more about the controller), at the goal's stop rule, or
/// at the horizon. `(grids, escaping)`: the planning grids, and whether
/// the start was inside the margin.
#[allow(clippy::too_many_arguments)]
fn drive(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    world: &mut World,
    rec: &mut LogRecorder,
    (grids, escaping): (&Grids, bool),
    tracker: &mut Tracker,
    stop: &litesim_core::StopCondition,
    (clock, timings): (&dyn Fn() -> f64, &mut Timings),
) -> Result<Driven, PlanError> {
    let sim = cfg.simulation;
    let pgrid = &grids.forward;
    let mut d = Driven {
        steps: 0,
        collided: false,
        collision: None,
        min_clear: f64::INFINITY,
        inside_until: None,
    };
    let mut mpc_error = None;
    for _ in 0..litesim_core::steps_for_horizon(sim.horizon, sim.dt) {
        if mpc_error.is_none()
            && let Err(e) = tracker.control(world, grids, clock, timings)
        {
            mpc_error = Some(e);
        }
        world.step();
        d.steps += 1;
        rec.record_world(world);
        body_check(world, veh, pgrid, &mut d.min_clear, &mut d.collided);
        // A start inside the margin: until when the body stayed inside it.
        if escaping
            && d.inside_until.is_none()
            && let Some(a) = world.actor("ego")
        {
            let p = a.state().pose;
            if pgrid.pose_free(p.position.xy(), p.yaw) {
                d.inside_until = Some(world.time());
            }
        }
        if d.collided {
            let p = world.actor("ego").map(|a| a.state().pose.position.xy());
            d.collision = Some((world.time(), p.map_or([f64::NAN; 2], |p| [p.x, p.y])));
            break;
        }
        if stop.reached(world) {
            break;
        }
    }
    if let Some((t, [x, y])) = d.collision {
        rec.meta(
            "verdict",
            format!("collision at t = {t:.2} s, rear axle at ({x:.2}, {y:.2})"),
        );
    }
    match mpc_error {
        Some(e) => Err(PlanError::Mpc(e)),
        None => Ok(d),
    }
}

/// A run that was driven, before its result is assembled.
struct Outcome {
    world: World,
    rec: LogRecorder,
    tracking: TrackingColumns,
    legs: Vec<Leg>,
    driven: Driven,
    stop: litesim_core::StopCondition,
    escape: Option<crate::escape::Escape>,
}

impl Outcome {
    /// The run's result: the goal reached or not, the tracking errors, the
    /// log with the plan and the tracking columns.
    fn result(
        self,
        cfg: &ClosedLoopConfig,
        grids: Grids,
        fmt: FmtResult,
        planner: PathPlanner,
    ) -> ClosedLoopResult {
        let Outcome {
            world,
            rec,
            tracking,
            legs,
            driven,
            stop,
            escape,
        } = self;
        let goal = stop.goal;
        let reached = stop.reached(&world);
        let (goal_distance, final_speed) = world.actor("ego").map_or((f64::NAN, f64::NAN), |a| {
            let st = a.state();
            (st.pose.position.xy().distance(goal), st.speed.abs())
        });
        let (max_cte, mean_cte) = cross_track(&tracking.lateral_error);
        let mut log = rec.finish();
        let corridor = joined(&legs);
        log.plan = Some(plan_record(&fmt, &corridor, &grids.forward));
        log.tracking = Some(tracking);
        let start_escape = escape.as_ref().map(|e| StartEscape {
            depth: e.depth,
            length: e.length,
            reverse: e.reverse,
            inside_s: driven.inside_until,
        });
        if let Some(e) = &start_escape {
            log.meta.insert("start".into(), e.to_string());
        }
        ClosedLoopResult {
            time: world.time(),
            steps: driven.steps,
            reached_goal: reached,
            goal_rule: (cfg.goal.tolerance, cfg.goal.stop_speed),
            goal_distance,
            final_speed,
            path_length: fmt.path_cost,
            max_cross_track: max_cte,
            mean_cross_track: mean_cte,
            min_clearance: driven.min_clear,
            collided: driven.collided,
            collision: driven.collision,
            log,
            fmt,
            corridor,
            legs,
            grid: grids.into_forward(),
            planner,
            start_escape,
        }
    }
}

/// The footprint at the ego's pose against the grid: a collision on an
/// obstacle or off the map (beyond touching: a body parked on the map's
/// edge is not one), and the smallest clearance so far.
fn body_check(
    w: &World,
    veh: &Vehicle,
    pgrid: &PlanningGrid,
    min_clear: &mut f64,
    collided: &mut bool,
) {
    if let Some(a) = w.actor("ego") {
        let p = a.state().pose;
        for q in footprint(veh, p.position.x, p.position.y, p.yaw) {
            if crate::escape::blocked(pgrid, q) {
                *collided = true;
            }
            let d = pgrid.clearance(q);
            if d < *min_clear {
                *min_clear = d;
            }
        }
    }
}

/// One tracker cycle into the log's tracking columns.
fn track(tracking: &mut TrackingColumns, tick: u64, steer: crate::follow::Steer) {
    if let Some(why) = steer.fallback {
        tracking.fallback.push((tick, why));
    }
    tracking.tick.push(tick);
    tracking.lateral_error.push(steer.lateral_error);
    tracking.heading_error.push(steer.heading_error);
    tracking.progress.push(steer.progress);
    tracking.cmd_acceleration.push(steer.acceleration);
    tracking.cmd_steering.push(steer.steering);
    tracking.predictions.push(steer.predicted);
}

/// The largest and the mean absolute cross-track error (0 without any).
fn cross_track(lateral: &[f64]) -> (f64, f64) {
    let abs: Vec<f64> = lateral.iter().map(|e| e.abs()).collect();
    let max = abs.iter().copied().fold(0.0, f64::max);
    let mean = if abs.is_empty() {
        0.0
    } else {
        abs.iter().sum::<f64>() / abs.len() as f64
    };
    (max, mean)
}

/// The MPC the run tracks with, and how many simulation steps apart it
/// runs; refuses a simulation step or horizon that is not positive and a
/// tracker step that is not a whole multiple of the simulation's.
fn tracker_of(cfg: &ClosedLoopConfig, veh: &Vehicle) -> Result<(Mpc, u64), PlanError> {
    let sim = cfg.simulation;
    if !(sim.dt.is_finite() && sim.dt > 0.0 && sim.horizon.is_finite() && sim.horizon > 0.0) {
        return Err(PlanError::Config(format!(
            "simulation: dt ({}) and horizon ({}) must be positive",
            sim.dt, sim.horizon
        )));
    }
    let ratio = cfg.tracker.dt / sim.dt;
    if !(ratio.is_finite() && ratio >= 1.0 - 1e-9 && (ratio - ratio.round()).abs() < 1e-6) {
        return Err(PlanError::Config(format!(
            "tracker.dt = {} s must be a whole multiple of simulation.dt = {} s",
            cfg.tracker.dt, sim.dt
        )));
    }
    let every = ratio.round() as u64;
    let mpc = Mpc::new(MpcConfig {
        horizon: cfg.tracker.horizon,
        dt: cfg.tracker.dt,
        wheelbase: veh.wheelbase,
        q: cfg.tracker.q,
        q_terminal: cfg.tracker.q_terminal,
        r: cfg.tracker.r,
        r_rate: cfg.tracker.r_rate,
        max_steer: veh.max_steer,
        max_steer_rate: veh.max_steer_rate,
        min_accel: -veh.max_decel,
        max_accel: veh.max_accel,
        // Predict with the world's own integration step.
        substeps: every as usize,
    })?;
    Ok((mpc, every))
}

/// The world: one vehicle (the preset's bicycle model, in reverse gear
/// when the first leg reverses) at the start, on direct control.
fn ego_world(
    cfg: &ClosedLoopConfig,
    veh: &Vehicle,
    reverse: bool,
) -> Result<(World, KinematicBicycle), PlanError> {
    let sim = cfg.simulation;
    let start = Vec2::new(cfg.start.x, cfg.start.y);
    let mut world = World::new(sim.dt)?;
    let mut bike = KinematicBicycle::new(veh.wheelbase);
    bike.max_steering_angle = veh.max_steer;
    bike.max_acceleration = veh.max_accel;
    bike.max_deceleration = veh.max_decel;
    bike.max_speed = veh.max_speed;
    bike.reverse = reverse;
    let desc = ActorDescription {
        kind: ActorKind::Vehicle(VehicleCategory::Car),
        actor_type: "Ego".into(),
        model: cfg.vehicle.preset.clone(),
        length: veh.length,
        width: veh.width,
        height: 1.5,
        mass: veh.mass,
        properties: Default::default(),
    };
    let mut st = ActorState::at_rest(Pose::planar(start.x, start.y, cfg.start.yaw));
    st.speed = cfg.start.speed.max(0.0);
    world.add_actor(Actor::new(
        "ego",
        desc,
        st,
        Some(VehicleModelKind::Bicycle(bike.clone())),
    ))?;

    Ok((world, bike))
}

/// The log's recorder, named after the run's planner, tracker and vehicle.
fn recorder(cfg: &ClosedLoopConfig, planner: &PathPlanner) -> LogRecorder {
    let (sim, pl) = (cfg.simulation, &cfg.planner);
    let mut rec = LogRecorder::new(sim.dt);
    rec.meta("kind", "closed_loop");
    rec.meta(
        "planner",
        match planner {
            PathPlanner::Fmt { .. } => format!("FMT* n={} seed={}", pl.samples, pl.seed),
            other => other.to_string(),
        },
    );
    rec.meta(
        "tracker",
        format!("MPC N={} dt={}", cfg.tracker.horizon, cfg.tracker.dt),
    );
    rec.meta("vehicle", &cfg.vehicle.preset);
    rec
}

/// The plan as the log keeps it: FMT*'s tree and path, the corridor and
/// its bounds, the planning grid.
fn plan_record(fmt: &FmtResult, corridor: &Corridor, pgrid: &PlanningGrid) -> PlanRecord {
    let g = &pgrid.grid;
    let cells: Vec<u8> = pgrid
        .layers()
        .iter()
        .map(|l| match l {
            Layer::Free => 0,
            Layer::Inflated => 1,
            Layer::Hard => 2,
        })
        .collect();
    PlanRecord {
        samples: fmt.samples.iter().map(|p| [p.x, p.y]).collect(),
        edges: fmt.edges.iter().map(|&(a, b)| [a, b]).collect(),
        radius: fmt.radius,
        raw_path: fmt.path.iter().map(|p| [p.x, p.y]).collect(),
        corridor: corridor.points.iter().map(|p| [p.x, p.y]).collect(),
        corridor_speed: corridor.speed.clone(),
        left_bound: corridor.left_bound.clone(),
        right_bound: corridor.right_bound.clone(),
        smoothed: corridor.smoothed,
        grid: GridRecord {
            width: g.width,
            height: g.height,
            resolution: g.resolution,
            origin: [g.origin.x, g.origin.y],
            cells,
        },
        reference_name: String::new(),
    }
}
