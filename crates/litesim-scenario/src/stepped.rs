//! A run from its plan to its summary: set up (`start`), stepped by
//! the runtime, concluded (the verdict, the drivers' notes). `run_here`
//! does all three for a SUT the run calls itself; [`Stepped`] lets the
//! caller be the SUT: it reads each step's observation and gives the
//! command, with no thread and no channel between them (the gymnasium
//! environment, the Python `SteppedRun`).

use crate::runtime::run::Runtime;
use crate::runtime::{Finished, Head, SspSlot, SutSlot};
use crate::sut::{Observation, SutCommand};
use crate::{
    DriveMode, Npc, Prepared, RunOptions, RunResult, ScenarioError, Summary, Verdict, judge,
    load::conflict_areas, plan_test, plan_test_with, postplan, runtime, simulator_of,
};
use litesim_map::RoadNetwork;
use litesim_ssp::Ssp;
use std::collections::BTreeMap;
use std::ops::Deref;
use std::sync::Arc;

/// [`crate::run`] on the calling thread.
pub(crate) fn run_here(
    prep: &Prepared,
    ssp: &mut dyn Ssp,
    opts: &RunOptions,
) -> Result<RunResult, ScenarioError> {
    match start(prep, SspSlot::Borrowed(ssp), opts, false)? {
        Setup::Done(r) => Ok(*r),
        Setup::Ready(mut s) => {
            while s.head()? {
                if !s.rt.tail()? {
                    break;
                }
            }
            s.conclude()
        }
    }
}

/// Sets a run up: solve, plan, the post-plan checks, the SUT made (or
/// left `outside`), the drivers placed, the runtime built. `prep` is a
/// reference or an `Arc` (what re-planning keeps for the run's length).
fn start<'a, P>(
    prep: P,
    ssp: SspSlot<'a>,
    opts: &RunOptions,
    outside: bool,
) -> Result<Setup<'a>, ScenarioError>
where
    P: Deref<Target = Prepared> + Clone + Send + 'a,
{
    if let Some(x) = prep.xosc.clone() {
        return start_xosc(prep, ssp, opts, outside, &x);
    }
    let seed = opts.seed.or(prep.test.config.seed).unwrap_or(1);
    let (profile, model) = simulator_of(&prep.test);
    let profile = opts.profile.clone().unwrap_or(profile);
    let prof = litesim_ssp::Profile::builtin(&profile).ok();
    let step_ms = opts
        .step_ms
        .or(prep.test.config.step_ms)
        .or(prof.as_ref().map(|p| p.step_ms))
        .unwrap_or(20);
    let (sol, plan) = plan_test(&prep, seed, step_ms)?;
    let mut notes = prep.test.notes.clone();
    notes.extend(sol.notes.iter().cloned());
    notes.extend(plan.notes.iter().cloned());
    // A plan that breaks the profile's post-plan limits is a failed test,
    // not a crash: it is not executed, and the summary says why.
    let violations: Vec<String> = postplan::check(&plan, prof.as_ref(), prep.net.as_deref())
        .into_iter()
        .map(|v| format!("post-plan check: {v}"))
        .collect();
    if !violations.is_empty() {
        notes.push("the plan failed the profile's post-plan checks: it was not executed".into());
    } else if !plan.unplaced.is_empty() {
        notes.push("an actor could not be placed with this seed: the run was not executed".into());
    }
    let mode = opts.mode.unwrap_or(if prep.test.config.dynamic {
        DriveMode::Dynamic
    } else {
        DriveMode::Kinematic
    });
    let (head, calibration) = heading(&prep, opts, (&profile, &model), (seed, mode), opts.npc)?;
    let (test_name, calibration_src) = (head.test.clone(), head.calibration.clone());
    if opts.plan_only || !violations.is_empty() || !plan.unplaced.is_empty() {
        // A plan that breaks its checks fails; one whose actors could not
        // all be placed is a scenario that did not happen (`invalid`).
        let verdict = if !violations.is_empty() {
            Verdict::Fail
        } else if !plan.unplaced.is_empty() {
            Verdict::Invalid
        } else {
            Verdict::Pass
        };
        let r = unrun(&prep, head, verdict, violations, plan, sol.roads, notes);
        return Ok(Setup::Done(Box::new(r)));
    }
    let cfg = exec_config(&prep, opts, &head, (step_ms, calibration), &sol.values);
    let sut = sut_slot(opts, outside)?;
    let closed_loop = sut.is_some();
    let (plan, drivers, traffic_actors) =
        place_drivers(&prep, plan, opts.npc, step_ms, seed, &mut notes)?;
    let replanning = prep.clone();
    let replan: Box<crate::runtime::Replan<'a>> = Box::new(move |fixed: &BTreeMap<String, f64>| {
        plan_test_with(&replanning, seed, step_ms, fixed).map(|(_, mut p)| {
            p.actors.extend(traffic_actors.iter().cloned());
            p
        })
    });
    let mut rt = Runtime::new(ssp, plan, cfg, sut, drivers)?;
    rt.replans = true;
    Ok(Setup::Ready(Box::new(Started {
        rt,
        replan: Some(replan),
        ctx: Context {
            test_name,
            seed,
            mode,
            notes,
            roads: sol.roads,
            calibration: calibration_src,
            sut_name: opts.sut.name(),
            npc: opts.npc,
            closed_loop,
            thresholds: prep.test.config.thresholds.clone(),
            map_name: prep.map_name.clone(),
            net: prep.net.clone(),
        },
    })))
}

/// Sets an OpenSCENARIO XML run up: the entities placed by the Init
/// actions, the storyboard controller driving them (every one but the
/// SUT's car), the runtime built. Nothing is planned ahead: the
/// storyboard runs live.
fn start_xosc<'a, P>(
    prep: P,
    ssp: SspSlot<'a>,
    opts: &RunOptions,
    outside: bool,
    x: &crate::xosc::XoscTest,
) -> Result<Setup<'a>, ScenarioError>
where
    P: Deref<Target = Prepared> + Clone + Send + 'a,
{
    let seed = opts.seed.unwrap_or(1);
    let (profile, model) = simulator_of(&prep.test);
    let profile = opts.profile.clone().unwrap_or(profile);
    let prof = litesim_ssp::Profile::builtin(&profile).ok();
    let step_ms = opts
        .step_ms
        .unwrap_or_else(|| prof.as_ref().map_or(20, |p| p.step_ms));
    let mode = opts.mode.unwrap_or(DriveMode::Kinematic);
    let (head, calibration) = heading(&prep, opts, (&profile, &model), (seed, mode), Npc::Planned)?;
    let (test_name, calibration_src) = (head.test.clone(), head.calibration.clone());
    let sut = sut_slot(opts, outside)?;
    let closed_loop = sut.is_some();
    if closed_loop && x.ego.is_none() {
        return Err(ScenarioError::Plan(format!(
            "{}: a system under test needs an entity to drive: give one an ObjectController named ExternalController, or pass --ego NAME",
            prep.path.display()
        )));
    }
    let net = prep
        .net
        .clone()
        .ok_or_else(|| ScenarioError::Map("an OpenSCENARIO XML run needs its map".into()))?;
    let (plan, story, notes) =
        crate::xosc::setup(x.scenario.clone(), net, step_ms, x.ego, closed_loop)?;
    if opts.plan_only {
        let r = unrun(
            &prep,
            head,
            Verdict::Pass,
            Vec::new(),
            plan,
            BTreeMap::new(),
            notes,
        );
        return Ok(Setup::Done(Box::new(r)));
    }
    let cfg = exec_config(&prep, opts, &head, (step_ms, calibration), &BTreeMap::new());
    let claims = story.driven.clone();
    let mut rt = Runtime::new(ssp, plan, cfg, sut, None)?;
    rt.set_story(Box::new(story), &claims);
    Ok(Setup::Ready(Box::new(Started {
        rt,
        // Nothing is planned ahead: the runtime never asks (`replans` is
        // off).
        replan: None,
        ctx: Context {
            test_name,
            seed,
            mode,
            notes,
            roads: BTreeMap::new(),
            calibration: calibration_src,
            sut_name: opts.sut.name(),
            npc: Npc::Planned,
            closed_loop,
            thresholds: prep.test.config.thresholds.clone(),
            map_name: prep.map_name.clone(),
            net: prep.net.clone(),
        },
    })))
}

/// What the runtime is told of a run: the simulator, profile and model,
/// the seed, step and mode, the map, the SUT's timeout, pacing, coverage
/// items and the solved values.
fn exec_config(
    prep: &Prepared,
    opts: &RunOptions,
    head: &Heading,
    (step_ms, calibration): (u32, Option<litesim_ssp::profile::Calibration>),
    values: &BTreeMap<String, crate::elab::Value>,
) -> runtime::ExecConfig {
    runtime::ExecConfig {
        profile: head.profile.clone(),
        model: head.model.clone(),
        seed: head.seed,
        step_ms,
        // The Model SSP reads the map for its traffic lights only; a map
        // without dynamic signals is not sent (it would be parsed again
        // for every run of a batch, for nothing).
        map_text: prep.map_text.clone().filter(|_| prep.has_lights),
        mode: head.mode,
        calibration,
        record: opts.record,
        observer: opts.observer.clone(),
        test_name: head.test.clone(),
        map_path: prep.map_name.clone(),
        map: prep.net.clone(),
        sut_timeout: opts
            .sut_timeout
            .or(prep.test.config.thresholds.sut_timeout)
            .unwrap_or(1.0),
        realtime: opts.realtime,
        covers: prep.test.covers.clone(),
        values: values.clone(),
        people_yield: opts.npc == Npc::Driver,
        conflict_areas: conflict_areas(prep),
    }
}

/// The SUT of a run: its caller (`outside`), or the one `opts` names.
fn sut_slot<'a>(opts: &RunOptions, outside: bool) -> Result<Option<SutSlot<'a>>, ScenarioError> {
    if outside {
        return Ok(Some(SutSlot::Outside));
    }
    Ok(opts
        .sut
        .instantiate()
        .map_err(|source| ScenarioError::Sut {
            name: opts.sut.name(),
            source,
        })?
        .map(SutSlot::Owned))
}

/// Drivers take over the scenario's other vehicles (`--npc driver`) and
/// the ambient traffic, which joins the plan's actors at its start: the
/// plan with them, the engine (when it drives anything) and the traffic
/// actors (re-planning appends them again).
fn place_drivers(
    prep: &Prepared,
    mut plan: crate::plan::Plan,
    npc: Npc,
    step_ms: u32,
    seed: u64,
    notes: &mut Vec<String>,
) -> Result<
    (
        crate::plan::Plan,
        Option<runtime::traffic::driven::Driven>,
        Vec<crate::plan::ActorPlan>,
    ),
    ScenarioError,
> {
    let npc = npc == Npc::Driver;
    let Some(net) = prep
        .net
        .as_deref()
        .filter(|_| npc || prep.test.config.traffic.is_some())
    else {
        return Ok((plan, None, Vec::new()));
    };
    let graph = prep
        .lane_graph()
        .unwrap_or_else(|| Arc::new(runtime::traffic::LaneGraph::new(net)));
    let (d, actors) = runtime::traffic::driven::Driven::place(
        prep.test.config.traffic.as_ref(),
        npc,
        graph,
        net,
        &plan,
        f64::from(step_ms) / 1000.0,
        seed,
    )?;
    plan.actors.extend(actors.iter().cloned());
    notes.extend(d.notes.iter().cloned());
    let drivers = (!d.traffic.vehicles.is_empty()).then_some(d);
    Ok((plan, drivers, actors))
}

/// A run's heading (what its summary says before anything ran) and the
/// driver gains it uses.
fn heading(
    prep: &Prepared,
    opts: &RunOptions,
    (profile, model): (&str, &str),
    (seed, mode): (u64, DriveMode),
    npc: Npc,
) -> Result<(Heading, Option<litesim_ssp::profile::Calibration>), ScenarioError> {
    let (calibration, calibration_src) = match &opts.calibration {
        Some(c) => (Some(*c), "given".to_string()),
        None => prep
            .calibration_read(opts, profile)
            .map_err(ScenarioError::Shared)?,
    };
    let test = prep
        .path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    Ok((
        Heading {
            test,
            seed,
            mode,
            profile: profile.to_string(),
            model: model.to_string(),
            sut: opts.sut.name(),
            npc,
            calibration: calibration_src,
        },
        calibration,
    ))
}

/// What a summary says of its run before anything ran.
struct Heading {
    test: String,
    seed: u64,
    mode: DriveMode,
    profile: String,
    model: String,
    sut: String,
    npc: Npc,
    calibration: String,
}

/// The result of a run that is not executed (plan only, a plan that
/// failed its checks, an actor that could not be placed).
fn unrun(
    prep: &Prepared,
    h: Heading,
    verdict: Verdict,
    failures: Vec<String>,
    plan: crate::plan::Plan,
    roads: BTreeMap<String, String>,
    notes: Vec<String>,
) -> RunResult {
    RunResult {
        summary: Summary {
            test: h.test,
            seed: h.seed,
            pass: verdict == Verdict::Pass,
            verdict,
            failures,
            invalid: plan.unplaced.clone(),
            map: prep.map_name.clone(),
            profile: h.profile,
            model: h.model,
            mode: h.mode,
            sut: h.sut,
            npc: h.npc,
            duration: plan.duration,
            steps: 0,
            roads,
            actors: Vec::new(),
            pairs: Vec::new(),
            ego: None,
            goals: Vec::new(),
            lane_goals: Vec::new(),
            conditions: Vec::new(),
            calibration: h.calibration,
            realtime: None,
            coverage: Vec::new(),
            triggers: Vec::new(),
            notes,
        },
        plan,
        log: None,
    }
}

/// What the summary needs besides what the runtime records.
struct Context {
    test_name: String,
    seed: u64,
    mode: DriveMode,
    notes: Vec<String>,
    roads: BTreeMap<String, String>,
    calibration: String,
    sut_name: String,
    npc: Npc,
    closed_loop: bool,
    thresholds: crate::elab::Thresholds,
    map_name: String,
    net: Option<Arc<RoadNetwork>>,
}

/// A run set up and ready to step.
pub(crate) struct Started<'a> {
    rt: Runtime<'a>,
    /// The re-planning stage: the test planned again with some condition
    /// times fixed (what the runtime asks for with [`Head::Replan`]); none
    /// for a run not planned ahead (an OpenSCENARIO XML storyboard).
    replan: Option<Box<crate::runtime::Replan<'a>>>,
    ctx: Context,
}

/// A run set up: ready to step, or already summarised (plan only, or a
/// plan that cannot be executed).
pub(crate) enum Setup<'a> {
    Done(Box<RunResult>),
    Ready(Box<Started<'a>>),
}

impl Started<'_> {
    /// The head of the step to come, re-planning as often as the runtime
    /// asks; false once the run is over.
    fn head(&mut self) -> Result<bool, ScenarioError> {
        loop {
            match self.rt.head()? {
                Head::Ready => return Ok(true),
                Head::Over => return Ok(false),
                Head::Replan(fixed) => {
                    let replan = self.replan.as_ref().ok_or_else(|| {
                        ScenarioError::Plan(
                            "an OpenSCENARIO XML run is not planned ahead: nothing to plan again"
                                .into(),
                        )
                    })?;
                    let plan = replan(&fixed)?;
                    self.rt.adopt(plan)?;
                }
            }
        }
    }

    /// The summary of the finished run: the verdict and its reasons, the
    /// drivers' notes.
    fn conclude(self) -> Result<RunResult, ScenarioError> {
        let Started { rt, ctx, .. } = self;
        let Context {
            test_name,
            seed,
            mode,
            mut notes,
            roads,
            calibration: calibration_src,
            sut_name,
            npc,
            closed_loop,
            thresholds,
            map_name,
            net,
        } = ctx;
        let Finished {
            mut ex,
            plan,
            drivers,
        } = rt.finish()?;
        if let Some(d) = &drivers {
            drivers_say(d, &plan, net.as_deref(), &mut ex.goals, &mut notes);
        }
        notes.append(&mut ex.sut_notes);
        notes.append(&mut ex.environment_notes);
        let mut triggers = Vec::new();
        if let Some(r) = ex.story.take() {
            notes.extend(r.notes);
            notes.extend(r.ended);
            triggers = r.triggers;
        }
        // `plan`: the plan in force at the end (conditions that held at
        // other times than planned made a new one).
        let ego_id = plan.actors.iter().find(|a| a.ego).map(|a| a.id.clone());
        let judged = judge::verdict(&ex, &thresholds, mode, closed_loop, ego_id.as_deref());
        notes.extend(judged.notes);
        let mut pairs = ex.kpis.pairs;
        for p in &mut pairs {
            if !p.min_distance.is_finite() {
                p.min_distance = -1.0;
            }
        }
        Ok(RunResult {
            summary: Summary {
                test: test_name,
                seed,
                pass: judged.verdict == Verdict::Pass,
                verdict: judged.verdict,
                failures: judged.failures,
                invalid: judged.invalid,
                map: map_name,
                profile: ex.profile,
                model: ex.model,
                mode,
                sut: sut_name,
                npc,
                duration: plan.duration,
                steps: ex.steps,
                roads,
                actors: ex.kpis.actors,
                pairs,
                ego: ex.ego,
                goals: ex.goals,
                lane_goals: ex.lane_goals,
                conditions: ex.live_events,
                calibration: calibration_src,
                realtime: ex.realtime,
                coverage: ex.coverage,
                triggers,
                notes,
            },
            plan,
            log: ex.log,
        })
    }
}

/// A run whose SUT is its caller: each step, the caller reads sut.car's
/// observation ([`Stepped::observation`]) and gives the command
/// ([`Stepped::step`]); [`Stepped::finish`] gives the summary. The run
/// lives in this value, on the caller's thread: no thread and no channel
/// between the caller and the simulation.
pub struct Stepped {
    state: State,
}

enum State {
    Running(Box<Started<'static>>),
    Over(Box<RunResult>),
    Taken,
}

impl Stepped {
    /// Sets up a run of `prep` under `opts` (its seed, mode, profile;
    /// `opts.sut` is the caller) on a fresh in-process simulator.
    pub fn start(prep: Arc<Prepared>, opts: &RunOptions) -> Result<Stepped, ScenarioError> {
        let ssp: Box<dyn Ssp> = Box::new(crate::in_process());
        let state = match start(prep, SspSlot::Owned(ssp), opts, true)? {
            Setup::Done(r) => State::Over(r),
            Setup::Ready(s) => State::Running(s),
        };
        Ok(Stepped { state })
    }

    /// sut.car's observation for the step to come; `None` once the run
    /// is over (then [`Stepped::finish`]).
    pub fn observation(&mut self) -> Result<Option<&Arc<Observation>>, ScenarioError> {
        match &mut self.state {
            State::Running(s) => {
                if s.head()? {
                    Ok(s.rt.observation())
                } else {
                    Ok(None)
                }
            }
            _ => Ok(None),
        }
    }

    /// Gives the command for the step to come and runs it; false once the
    /// run is over.
    pub fn step(&mut self, cmd: SutCommand) -> Result<bool, ScenarioError> {
        let State::Running(s) = &mut self.state else {
            return Ok(false);
        };
        if !s.head()? {
            return Ok(false);
        }
        s.rt.give(cmd);
        s.rt.tail()
    }

    /// The time of the step to come (s).
    pub fn time(&self) -> f64 {
        match &self.state {
            State::Running(s) => s.rt.time(),
            _ => 0.0,
        }
    }

    /// Whether the run is over.
    pub fn over(&self) -> bool {
        match &self.state {
            State::Running(s) => s.rt.over(),
            _ => true,
        }
    }

    /// Ends the run (wherever it stands) and gives its summary.
    pub fn finish(&mut self) -> Result<RunResult, ScenarioError> {
        match std::mem::replace(&mut self.state, State::Taken) {
            State::Running(s) => s.conclude(),
            State::Over(r) => Ok(*r),
            State::Taken => Err(ScenarioError::Plan("the run was finished already".into())),
        }
    }
}

/// What the drivers add to a summary: each gap goal's deceleration asked
/// beyond its limit (the reason an invalid verdict names), who they drove,
/// the ambient traffic, vehicles stopped at a dead end, lane changes.
fn drivers_say(
    d: &runtime::traffic::driven::Driven,
    plan: &crate::plan::Plan,
    net: Option<&RoadNetwork>,
    goals: &mut [crate::reactive::GoalResult],
    notes: &mut Vec<String>,
) {
    // What each driver's gap pursuit asked beyond its limit: the
    // reason an invalid verdict names.
    for g in goals.iter_mut() {
        if let Some((asked, limit)) = d.asked(&g.actor, &g.at)
            && asked > limit
        {
            g.needed = Some((asked, limit));
        }
    }
    let ids = |slots: &[(usize, u32)]| {
        slots
            .iter()
            .map(|&(i, _)| plan.actors[i].id.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if !d.npcs.is_empty() {
        notes.push(format!(
            "driven by drivers (--npc driver): {}",
            ids(&d.npcs)
        ));
    }
    if d.decl.is_some() {
        notes.push(format!(
            "ambient traffic: {} vehicles (traffic.0 …), {} re-entries around sut.car",
            d.traffic.vehicles.len() - d.npcs.len(),
            d.recycled,
        ));
    }
    for (k, v) in d.traffic.vehicles.iter().enumerate() {
        if v.at_dead_end {
            let id = &plan.actors[d.actor_of(k)].id;
            let info = &d.graph.lanes[v.lane as usize];
            let road = net.map_or(String::new(), |n| n.roads()[info.node.road].id.clone());
            notes.push(format!(
                    "{id} stopped where its lane ends (road {road} lane {}): a dead end or the map's edge",
                    info.node.lane
                ));
        }
    }
    notes.push(format!(
        "drivers: {} lane changes, {} contacts seen by the drivers",
        d.traffic
            .vehicles
            .iter()
            .map(|v| u64::from(v.lane_changes))
            .sum::<u64>(),
        d.traffic.contacts.len(),
    ));
}

#[cfg(test)]
mod tests {
    /// A stepped run lives in a Python object: it must move between
    /// threads.
    #[test]
    fn a_stepped_run_is_send() {
        fn send<T: Send>() {}
        send::<super::Stepped>();
    }
}
