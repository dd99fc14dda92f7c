//! `litesim run`, `litesim batch`, `litesim merge`, `litesim calibrate`.

use anyhow::{Context, Result, anyhow, bail};
use litesim_log::{ActorSample, LogRecorder, SimulationLog};
use litesim_scenario::sut::SutChoice;
use litesim_scenario::{DriveMode, LoadOptions, RunOptions, Verdict, batch, calibrate, plan::Plan};
use std::path::{Path, PathBuf};

/// A value on the command line that cannot be used (`--seeds abc`, an
/// unknown `--sut`): `litesim` exits with 64, as for the errors its
/// argument parser finds, so that scripts can tell a mistyped command from
/// a run that could not run (1) or failed (2).
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// A [`UsageError`] from a format string.
macro_rules! usage {
    ($($arg:tt)*) => {
        anyhow::Error::new(UsageError(format!($($arg)*)))
    };
}

/// Options shared by `run` and `batch`.
#[derive(clap::Args, Clone, Debug)]
pub struct Common {
    /// Import search paths.
    #[arg(short = 'I', value_name = "DIR")]
    pub include: Vec<PathBuf>,
    /// Map file overriding the test's `test_config.map`.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// OSC dialect: auto (default: CARLA's when the test imports its
    /// `basic.osc` or declares `actor Path`), litesim or carla.
    #[arg(long, default_value = "auto", value_parser = ["auto", "litesim", "carla"])]
    pub dialect: String,
    /// Folder of OpenDRIVE maps for a CARLA scenario's
    /// `path.set_map("Town04")` (Town04.xodr). Default: the test's folder,
    /// then maps/ in it and in each folder above it.
    #[arg(long, value_name = "DIR")]
    pub map_dir: Option<PathBuf>,
    /// Drive actors dynamically (pedals and steering) instead of
    /// kinematically. Default: the test's configuration (the seed's dummy
    /// configuration is dynamic), else kinematic.
    #[arg(long, conflicts_with = "kinematic")]
    pub dynamic: bool,
    /// Drive actors kinematically (trajectories) even where the test's
    /// configuration is dynamic.
    #[arg(long)]
    pub kinematic: bool,
    /// What drives sut.car: planned (its plan; default), acc (the
    /// reference adaptive cruise, ISO 15622 envelope), acc-aeb (with an
    /// emergency-braking stage), fmt-mpc (FMT* + MPC) or grpc://HOST:PORT
    /// (an external process serving litesim.sut.v1).
    #[arg(long, default_value = "planned", value_name = "NAME")]
    pub sut: String,
    /// What drives the other vehicles: driver (default: a driver each —
    /// car-following, the plan's lanes and speeds as goals, gap goals
    /// pursued until their phase ends) or planned (each replays its plan
    /// exactly, as before drivers).
    #[arg(long, default_value = "driver", value_name = "NAME", value_parser = ["driver", "planned"])]
    pub npc: String,
    /// Seconds an external SUT may take per call (default: the test's
    /// `sut_timeout`, else 1).
    #[arg(long, value_name = "S")]
    pub sut_timeout: Option<f64>,
    /// Folder of driver calibrations (`PROFILE.toml` from `litesim
    /// calibrate`). Default: `calibration/` in the test's folder or the
    /// nearest ancestor that has one — never the current directory.
    #[arg(long, value_name = "DIR")]
    pub calibration_dir: Option<PathBuf>,
}

impl Common {
    fn load(&self) -> LoadOptions {
        LoadOptions {
            include: self.include.clone(),
            map: self.map.clone(),
            env: None,
            dialect: dialect_choice(&self.dialect),
            map_dir: self.map_dir.clone(),
        }
    }
    /// The `--npc` choice.
    pub fn npc(&self) -> litesim_scenario::Npc {
        litesim_scenario::Npc::parse(&self.npc).unwrap_or_default()
    }
    /// The `--sut` choice; an unknown name lists the valid ones.
    pub fn sut(&self) -> Result<SutChoice> {
        sut_choice(&self.sut)
    }
    fn sut_timeout(&self) -> Result<Option<f64>> {
        match self.sut_timeout {
            Some(t) if !(t.is_finite() && t > 0.0 && t <= 3600.0) => {
                Err(usage!("--sut-timeout {t}: expected seconds in (0, 3600]"))
            }
            t => Ok(t),
        }
    }
    fn mode(&self) -> Option<DriveMode> {
        if self.dynamic {
            Some(DriveMode::Dynamic)
        } else if self.kinematic {
            Some(DriveMode::Kinematic)
        } else {
            None
        }
    }
}

/// A `--dialect` value (`auto`: detect).
pub fn dialect_choice(name: &str) -> Option<litesim_osc::Dialect> {
    name.parse().ok()
}

/// Parses a `--sut` value.
pub fn sut_choice(name: &str) -> Result<SutChoice> {
    if let Some(c) = litesim_grpc::sut::choice_by_name(name).map_err(|e| usage!("--sut {e}"))? {
        return Ok(c);
    }
    Err(usage!(
        "--sut {name}: unknown system under test; valid: {}, grpc://HOST:PORT",
        litesim_scenario::sut::BUILTIN.join(", ")
    ))
}

/// The plan as a log (one sample per plan step), for pictures.
pub fn plan_log(plan: &Plan) -> SimulationLog {
    let mut rec = LogRecorder::new(plan.dt);
    rec.meta("source", "plan");
    for a in &plan.actors {
        rec.actor(
            &a.id,
            &format!("{:?}", a.kind).to_lowercase(),
            &a.category,
            a.length,
            a.width,
            1500.0,
        );
    }
    let n = plan
        .actors
        .iter()
        .map(|a| a.samples.len())
        .max()
        .unwrap_or(0);
    for k in 0..n {
        rec.begin(k as u64, k as f64 * plan.dt);
        for a in &plan.actors {
            let s = a.samples[k.min(a.samples.len() - 1)];
            let (sy, cy) = litesim_core::math::sin_cos(s.yaw);
            let sample = ActorSample::from_kinematics(
                litesim_core::geometry::Pose::planar(s.x, s.y, s.yaw),
                litesim_core::geometry::Vec3::new(s.v * cy, s.v * sy, 0.0),
                litesim_core::geometry::Vec3::new(s.a * cy, s.a * sy, 0.0),
                0.0,
                s.v,
                1500.0,
            );
            rec.sample(&a.id, "plan", &sample);
        }
    }
    rec.finish()
}

/// The test map's road, borders and marks (no lane centre lines: a
/// scenario replay shows several actors and stays readable).
fn lanes(net: Option<&litesim_map::RoadNetwork>) -> litesim_viz::replay::Background {
    net.map(|n| crate::viz::background(n, false))
        .unwrap_or_default()
}

/// `litesim batch --ray ADDRESS`: the batch on a Ray cluster through the
/// Python package (`python3 -m litesim.ray`), which writes the same folder.
#[allow(clippy::too_many_arguments)]
fn ray_batch(
    address: &str,
    tests: &[PathBuf],
    common: &Common,
    (a, b): (u64, u64),
    shard_text: &str,
    out: &Path,
    force_new: bool,
    quiet: bool,
) -> Result<Outcome> {
    if shard(shard_text)? != (0, 1) {
        bail!(
            "--ray runs the whole job list: --shard does not apply (the cluster spreads the runs)"
        );
    }
    if !common.include.is_empty() || common.map.is_some() || common.sut_timeout.is_some() {
        bail!(
            "--ray: -I, --map and --sut-timeout are not passed to Ray workers yet; run without --ray"
        );
    }
    if common.npc() != litesim_scenario::Npc::Driver {
        bail!(
            "--ray: --npc planned is not passed to Ray workers yet (they run drivers); run without --ray"
        );
    }
    common.sut()?;
    let mut cmd = std::process::Command::new("python3");
    cmd.args(["-m", "litesim.ray", "--ray", address, "--seeds"])
        .arg(format!("{a}..{b}"))
        .arg("-o")
        .arg(out);
    if common.sut != "planned" {
        cmd.args(["--sut", &common.sut]);
    }
    match common.mode() {
        Some(litesim_scenario::DriveMode::Kinematic) => {
            cmd.args(["--mode", "kinematic"]);
        }
        Some(litesim_scenario::DriveMode::Dynamic) => {
            cmd.args(["--mode", "dynamic"]);
        }
        None => {}
    }
    if force_new {
        cmd.arg("--force-new");
    }
    if quiet {
        cmd.arg("-q");
    }
    cmd.args(tests);
    let status = cmd.status().map_err(|e| {
        anyhow!("--ray needs python3 with the litesim package (pip install ./python[ray]): {e}")
    })?;
    match status.code() {
        Some(0) => Ok(Outcome::Pass),
        Some(2) => Ok(Outcome::Fail),
        Some(3) => Ok(Outcome::Invalid),
        _ => Ok(Outcome::CouldNotRun),
    }
}

/// `litesim run`.
#[allow(clippy::too_many_arguments)]
pub fn run(
    test: &Path,
    common: &Common,
    seed: Option<u64>,
    sim: Option<&str>,
    out: Option<PathBuf>,
    plan_only: bool,
    no_pictures: bool,
    gif: bool,
    mcap: Option<&Path>,
    calibration: Option<&Path>,
    style: Option<&Path>,
    trace_rpc: Option<&Path>,
    pacing: Pacing,
) -> Result<Outcome> {
    // A bad stylesheet, SUT name or output file fails before anything runs.
    if let Some(m) = mcap {
        mcap_file_to_write(m)?;
    }
    let style = crate::viz::load_style(style)?;
    let sut = (common.sut()?, common.sut_timeout()?);
    let prep = litesim_scenario::prepare(test, &common.load())?;
    let opts = run_options(&prep, common, sut, seed, (plan_only, calibration), pacing)?;
    // The folder first: a stamp naming what this run is, and no summary
    // from an earlier run (the summary is written last, so a folder with a
    // stamp and no summary — or a summary older than its stamp — is a run
    // that did not finish).
    let run_seed = seed.or(prep.test.config.seed).unwrap_or(1);
    let stem = test
        .file_stem()
        .map_or("test".into(), |s| s.to_string_lossy().into_owned());
    let out = out.unwrap_or_else(|| PathBuf::from("runs").join(format!("{stem}-seed{run_seed}")));
    std::fs::create_dir_all(&out).map_err(|e| anyhow!("{}: {e}", out.display()))?;
    batch::clean_temporaries(&out);
    let run_hash = write_stamp(&out, test, &prep, &opts, run_seed, sim)?;
    // The MCAP writer starts now, on the other core: header, schemas and
    // the map's content while the run is planned, then the ticks in pieces
    // as the run records them; a run that fails before it has a log leaves
    // no file (the streamer's drop waits for that). Not earlier:
    // - cleaning the folder above removes what a killed run left, and
    //   would take a temporary file the writer had already made in it
    //   (`--mcap OUT/run.mcap`);
    // - a new file in the folder while run.json is synced makes that sync
    //   wait for it (−0.2 ms a run);
    // - the run has just come back from that sync with a fresh time
    //   slice, so the new thread waits to be placed instead of preempting
    //   the run. Started before the test was loaded it preempted the run
    //   in 23 runs of 40 and ran its start-up on the run's CPU (traced;
    //   BENCHMARKS.md, eighteenth session).
    let streamer = match mcap {
        Some(m) if !plan_only => Some(McapStreamer::start(
            m,
            prep.net.clone(),
            vec![
                ("test".to_string(), test.display().to_string()),
                ("run".to_string(), run_hash.clone()),
            ],
        )?),
        _ => None,
    };
    let opts = RunOptions {
        observer: streamer.as_ref().map(McapStreamer::observer),
        ..opts
    };
    let result = simulate(&prep, &opts, sim, trace_rpc)?;
    let s = &result.summary;
    let write_plan = || write_plan(&out, &result, test, &run_hash);
    if plan_only {
        print_plan(&result);
        write_plan()?;
        if !no_pictures {
            let log = plan_log(&result.plan);
            let pic = out.join("plan.png");
            litesim_viz::replay::write_png(&log, &lanes(prep.net.as_deref()), &style, &pic)
                .map_err(|e| anyhow!("{e}"))?;
            println!("wrote {}", pic.display());
        }
        return Ok(Outcome::Pass);
    }
    // The log as written: named after its test, seed and run.
    let log = result.log.as_ref().map(|log| {
        let mut log = log.clone();
        log.meta.insert("test".into(), test.display().to_string());
        log.meta.insert("seed".into(), s.seed.to_string());
        log.meta.insert("run".into(), run_hash.clone());
        log
    });
    let log = log.as_ref();
    let rest = |log: &litesim_log::SimulationLog| {
        write_log(log, &out, prep.net.as_deref(), &style, (no_pictures, gif))
    };
    // The rest of the ticks to the MCAP writer, which finishes the file
    // while plan.json, log.json and the pictures are written.
    let streaming = match (streamer, log) {
        (Some(st), Some(log)) => Some(st.end(log)),
        _ => None,
    };
    let drawn = write_plan().and_then(|()| log.map_or(Ok(()), rest));
    if let (Some(job), Some(m), Some(log)) = (streaming, mcap, log) {
        finish_mcap(job, m, log, prep.net.as_deref())?;
    }
    drawn?;
    let p = out.join("summary.json");
    batch::atomic(&p, &(serde_json::to_string_pretty(s)? + "\n"))?;
    println!("wrote {}", p.display());
    print_summary(s);
    Ok(match s.verdict {
        Verdict::Pass => Outcome::Pass,
        Verdict::Invalid => Outcome::Invalid,
        Verdict::Fail => Outcome::Fail,
        Verdict::Error => Outcome::SutError,
    })
}

/// The options of `litesim run`: the CLI's common options, the SUT and its
/// timeout (checked before the test is loaded), a calibration
/// file, and wall-clock pacing (dSPACE's runs keep pace unless told
/// otherwise: it is the hardware-in-the-loop platform).
fn run_options(
    prep: &litesim_scenario::Prepared,
    common: &Common,
    (sut, sut_timeout): (SutChoice, Option<f64>),
    seed: Option<u64>,
    (plan_only, calibration): (bool, Option<&Path>),
    pacing: Pacing,
) -> Result<RunOptions> {
    let calibration = match calibration {
        Some(p) => Some(
            calibrate::from_toml(&crate::read_text(p)?)
                .map_err(|e| anyhow!("{}: {e}", p.display()))?,
        ),
        None => None,
    };
    let opts = RunOptions {
        seed,
        mode: common.mode(),
        record: true,
        plan_only,
        calibration,
        // The summary says which gains were used (path and hash).
        calibration_dir: common.calibration_dir.clone(),
        calibration_near_test: true,
        sut,
        npc: common.npc(),
        sut_timeout,
        ..RunOptions::default()
    };
    // dSPACE is the hardware-in-the-loop platform: its runs keep pace with
    // the wall clock unless told otherwise.
    let paced = pacing.on
        || (!pacing.off && !plan_only && litesim_scenario::profile_of(prep, &opts) == "dspace");
    Ok(RunOptions {
        realtime: paced.then_some(pacing.policy),
        ..opts
    })
}

/// `plan.json`, named after its run: test, seed and the stamp's hash.
fn write_plan(
    out: &Path,
    result: &litesim_scenario::RunResult,
    test: &Path,
    run_hash: &str,
) -> Result<()> {
    let p = out.join("plan.json");
    let mut v = serde_json::to_value(&result.plan)?;
    if let Some(o) = v.as_object_mut() {
        o.insert("test".into(), test.display().to_string().into());
        o.insert("seed".into(), result.summary.seed.into());
        o.insert("run".into(), run_hash.into());
    }
    batch::atomic(&p, &serde_json::to_string_pretty(&v)?)?;
    println!("wrote {}", p.display());
    Ok(())
}

/// Writes the run folder's stamp (`run.json`: what this run is) after
/// removing an earlier summary; gives the stamp's hash, which names the
/// run in its plan, log and MCAP.
fn write_stamp(
    out: &Path,
    test: &Path,
    prep: &litesim_scenario::Prepared,
    opts: &RunOptions,
    run_seed: u64,
    sim: Option<&str>,
) -> Result<String> {
    let stamp = serde_json::json!({
        "litesim": env!("CARGO_PKG_VERSION"),
        "test": test.display().to_string(),
        "test_sources": prep.source_hash,
        "seed": run_seed,
        "mode": format!("{:?}", opts.mode).to_lowercase(),
        "sut": opts.sut.name(),
        "profile": litesim_scenario::profile_of(prep, opts),
        "calibration": litesim_scenario::calibration_used(prep, opts),
        "sim": sim.unwrap_or("in-process"),
    });
    let stamp = serde_json::to_string_pretty(&stamp)? + "\n";
    let run_hash = litesim_scenario::sha256_hex(stamp.as_bytes());
    match std::fs::remove_file(out.join("summary.json")) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            bail!("{}: {e}", out.join("summary.json").display())
        }
        _ => {}
    }
    batch::atomic(&out.join("run.json"), &stamp)?;
    Ok(run_hash)
}

/// The run on the simulator `sim` names (in-process, or `grpc://…`), every
/// SSP call through a tracer into `trace_rpc` when asked.
fn simulate(
    prep: &litesim_scenario::Prepared,
    opts: &RunOptions,
    sim: Option<&str>,
    trace_rpc: Option<&Path>,
) -> Result<litesim_scenario::RunResult> {
    // Every SSP call through a tracer when asked (in-process or remote).
    let traced = |ssp: &mut dyn litesim_ssp::Ssp| -> Result<litesim_scenario::RunResult> {
        match trace_rpc {
            None => Ok(litesim_scenario::run(prep, ssp, opts)?),
            Some(p) => {
                let f = std::fs::File::create(p).map_err(|e| anyhow!("{}: {e}", p.display()))?;
                let mut t = litesim_ssp::trace::TracingSsp::new(ssp, std::io::BufWriter::new(f));
                let r = litesim_scenario::run(prep, &mut t, opts);
                t.finish().map_err(|e| anyhow!("{}: {e}", p.display()))?;
                Ok(r?)
            }
        }
    };
    match sim {
        None | Some("inprocess") | Some("in-process") => {
            traced(&mut litesim_scenario::in_process())
        }
        Some(url) => {
            let addr = url
                .strip_prefix("grpc://")
                .ok_or_else(|| usage!("--sim {url}: expected grpc://HOST:PORT or in-process"))?;
            let mut remote = crate::connect_server(addr)?;
            traced(&mut remote)
        }
    }
}

/// `--plan-only`'s printout: roads chosen, phases, each actor's start and end.
fn print_plan(result: &litesim_scenario::RunResult) {
    let s = &result.summary;
    println!(
        "plan of {} (seed {}), {:.2} s, sampled every {:.2} s:",
        s.test, s.seed, result.plan.duration, result.plan.dt
    );
    for (k, v) in &s.roads {
        println!("  {k} = road {v}");
    }
    for p in &result.plan.phases {
        println!(
            "  [{:6.2} s .. {:6.2} s] {} {}{}",
            p.t0,
            p.t1,
            p.actor,
            p.action,
            p.label
                .as_ref()
                .map_or(String::new(), |l| format!(" ({l})"))
        );
    }
    for a in &result.plan.actors {
        let (f, l) = (a.samples[0], a.samples[a.samples.len() - 1]);
        println!(
            "  {:<10} from ({:8.2}, {:8.2}) at {:5.2} m/s to ({:8.2}, {:8.2}) at {:5.2} m/s",
            a.id, f.x, f.y, f.v, l.x, l.y, l.v
        );
    }
}

/// The log and, unless `no_pictures`, the replay, the dashboard and (with
/// `gif`) the animation, into `out`.
fn write_log(
    log: &litesim_log::SimulationLog,
    out: &Path,
    net: Option<&litesim_map::RoadNetwork>,
    style: &litesim_viz::Style,
    (no_pictures, gif): (bool, bool),
) -> Result<()> {
    let p = out.join("log.json");
    log.write_json(&p).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", p.display());
    if no_pictures {
        return Ok(());
    }
    let l = lanes(net);
    let pic = out.join("replay.png");
    litesim_viz::replay::write_png(log, &l, style, &pic).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", pic.display());
    // The ego's nine-panel dashboard (speed, acceleration, controls, forces, slip).
    let dash = out.join("dashboard.png");
    litesim_viz::dashboard::write_png(log, style, &dash).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", dash.display());
    if gif {
        let g = out.join("replay.gif");
        litesim_viz::replay::write_gif(log, &l, style, &g, 150).map_err(|e| anyhow!("{e}"))?;
        println!("wrote {}", g.display());
    }
    Ok(())
}

/// Waits for the MCAP writer; a run streaming refused (an actor that
/// joined late) is written from the whole log instead.
fn finish_mcap(
    job: Option<StreamJob>,
    m: &Path,
    log: &litesim_log::SimulationLog,
    net: Option<&litesim_map::RoadNetwork>,
) -> Result<()> {
    let made = job.map_or_else(
        || {
            Err(litesim_mcap::McapError::Stopped(
                "it was not running".into(),
            ))
        },
        StreamJob::wait,
    );
    if let Err(e) = made {
        // Streaming refused the run (an actor that joined late): the
        // file is written from the whole log instead.
        match e {
            // The error names the file already.
            litesim_mcap::McapError::Write(_) => bail!("{e}"),
            litesim_mcap::McapError::Log(_) => {}
            _ => bail!("{}: {e}", m.display()),
        }
        litesim_mcap::write(log, net, m).map_err(|e| anyhow!("{}: {e}", m.display()))?;
    }
    println!("wrote {}", m.display());
    Ok(())
}

/// The run's verdict line, driver gains, pacing and notes.
fn print_summary(s: &litesim_scenario::Summary) {
    println!(
        "{} {} seed {}: {} ({} steps, {:.2} s, profile {}, model {}, {:?}, sut {})",
        s.verdict.name().to_uppercase(),
        s.test,
        s.seed,
        match s.verdict {
            Verdict::Pass => "all checks hold".to_string(),
            Verdict::Invalid => s.invalid.join("; "),
            _ => s.failures.join("; "),
        },
        s.steps,
        s.duration,
        s.profile,
        s.model,
        s.mode,
        s.sut
    );
    if s.mode == DriveMode::Dynamic {
        println!("driver gains: {}", s.calibration);
    }
    if let Some(r) = &s.realtime {
        println!(
            "real time ({:?}, {} ms steps): {} steps in {:.3} s; lateness p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms; {} overruns",
            r.policy,
            r.step_ms,
            r.steps,
            r.wall_s,
            r.lateness_p50_ms,
            r.lateness_p99_ms,
            r.lateness_max_ms,
            r.overruns
        );
    }
    for n in &s.notes {
        println!("note: {n}");
    }
}

/// Wall-clock pacing asked on the command line.
#[derive(Clone, Copy, Debug)]
pub struct Pacing {
    /// `--realtime`.
    pub on: bool,
    /// `--no-realtime`.
    pub off: bool,
    /// `--realtime-policy`.
    pub policy: litesim_scenario::realtime::Policy,
}

/// How a run ended, for the exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every check holds (exit 0).
    Pass,
    /// A check failed (exit 2).
    Fail,
    /// The scenario was not realised (exit 3; a batch's only with
    /// `--fail-on-invalid`).
    Invalid,
    /// The system under test failed to answer (exit 1).
    SutError,
    /// Something could not run at all, e.g. a batch's test could not be
    /// read (exit 1).
    CouldNotRun,
}

/// Refuses an `--mcap` path that cannot be written before the run spends
/// its time: a folder, or a path below a file. (Folders that do not exist
/// yet are made when the file is written.)
fn mcap_file_to_write(path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!(
            "--mcap {}: this is a folder; name the file to write in it (e.g. {})",
            path.display(),
            path.join("run.mcap").display()
        );
    }
    if let Some(file) = path
        .ancestors()
        .skip(1)
        .find(|a| !a.as_os_str().is_empty() && a.exists() && !a.is_dir())
    {
        bail!(
            "--mcap {}: {} is a file, not a folder",
            path.display(),
            file.display()
        );
    }
    Ok(())
}

/// Parses `A..B` (inclusive) or a single seed.
pub fn seeds(text: &str) -> Result<(u64, u64)> {
    let parse = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|_| usage!("--seeds {text}: '{s}' is not a seed (expected A..B)"))
    };
    match text.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (parse(a)?, parse(b.trim_start_matches('='))?);
            if b < a {
                return Err(usage!("--seeds {text}: the range is empty"));
            }
            if b - a >= batch::MAX_SEEDS {
                return Err(usage!(
                    "--seeds {text}: {} seeds; a batch takes at most {} (split it with --shard or several folders)",
                    (b - a) as u128 + 1,
                    batch::MAX_SEEDS
                ));
            }
            Ok((a, b))
        }
        None => {
            let a = parse(text)?;
            Ok((a, a))
        }
    }
}

/// Parses `i/N`.
pub fn shard(text: &str) -> Result<(u64, u64)> {
    let bad = || usage!("--shard {text}: expected i/N with 0 ≤ i < N");
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n) = (
        i.trim().parse::<u64>().map_err(|_| bad())?,
        n.trim().parse::<u64>().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// `litesim batch`.
#[allow(clippy::too_many_arguments)]
pub fn batch(
    tests: Vec<PathBuf>,
    common: &Common,
    seed_range: &str,
    shard_text: &str,
    threads: Option<usize>,
    out: PathBuf,
    resume: bool,
    force_new: bool,
    quiet: bool,
    save_failed: bool,
    save_failed_mcap: bool,
    junit: Option<PathBuf>,
    fail_on_holes: bool,
    fail_on_invalid: bool,
    ray: Option<&str>,
) -> Result<Outcome> {
    let (a, b) = seeds(seed_range)?;
    if let Some(address) = ray {
        return ray_batch(
            address,
            &tests,
            common,
            (a, b),
            shard_text,
            &out,
            force_new,
            quiet,
        );
    }
    let spec = batch::BatchSpec {
        tests,
        seed_from: a,
        seed_to: b,
        shard: shard(shard_text)?,
        threads,
        out: out.clone(),
        resume,
        force_new,
        mode: common.mode(),
        load: common.load(),
        calibration_dir: common.calibration_dir.clone(),
        sut: common.sut()?,
        npc: common.npc(),
        sut_timeout: common.sut_timeout()?,
        save_failed,
        save_failed_mcap,
        precomputed: Default::default(),
    };
    let bar = indicatif::ProgressBar::new(0);
    if quiet {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {per_sec}  eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let started = std::time::Instant::now();
    let report = batch::run_batch(&spec, &|done, total| {
        if bar.length() != Some(total) {
            bar.set_length(total);
        }
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    println!(
        "{} runs in this shard ({} resumed, {} run now in {:.2} s, {:.0} runs/s, {} rows of other seeds dropped); {} passed, {} failed ({} invalid, {} errors): {}",
        report.total,
        report.skipped,
        report.ran,
        secs,
        report.ran as f64 / secs.max(1e-9),
        report.foreign,
        report.passed,
        report.failed,
        report.invalid,
        report.errors,
        report.verdict.name()
    );
    println!("wrote {}/results.jsonl and results.csv", out.display());
    if let Some(path) = &junit {
        let lines = batch::read_lines(&out.join("results.jsonl"));
        batch::atomic(path, &batch::junit(&lines))?;
        println!("wrote {}", path.display());
    }
    let holes = coverage_holes(&out)?;
    // The most severe verdict: error, fail, invalid (only with
    // --fail-on-invalid: a scenario that did not happen says nothing of
    // the SUT), pass.
    Ok(
        if report.unreadable > 0 || report.verdict == Verdict::Error {
            Outcome::CouldNotRun
        } else if report.verdict == Verdict::Fail {
            Outcome::Fail
        } else if fail_on_holes && holes > 0 {
            eprintln!("--fail-on-holes: {holes} coverage hole(s)");
            Outcome::Fail
        } else if fail_on_invalid && report.verdict == Verdict::Invalid {
            eprintln!(
                "--fail-on-invalid: {} run(s) whose scenario was not realised",
                report.invalid
            );
            Outcome::Invalid
        } else {
            Outcome::Pass
        },
    )
}

/// The batch's coverage holes (0 without a `coverage.json`), each printed
/// with its item.
fn coverage_holes(out: &Path) -> Result<u64> {
    let Ok(text) = crate::read_text(&out.join("coverage.json")) else {
        return Ok(0);
    };
    let c: litesim_scenario::coverage::CoverageFile =
        serde_json::from_str(&text).with_context(|| format!("{}/coverage.json", out.display()))?;
    let holes = c.holes;
    let items = c.items.iter().filter(|i| i.def.kind == "cover").count();
    println!(
        "wrote {}/coverage.json: {items} cover item(s), {holes} hole(s)",
        out.display()
    );
    for i in c.items.iter().filter(|i| !i.holes.is_empty()) {
        println!("  {} {}: not hit {}", i.test, i.def.name, i.holes.join(" "));
    }
    Ok(holes)
}

/// `litesim merge`.
pub fn merge(dirs: &[PathBuf], out: &Path, allow_partial: bool) -> Result<()> {
    let r = batch::merge(dirs, out, allow_partial)?;
    if !r.missing_shards.is_empty() || !r.missing_jobs.is_empty() {
        eprintln!(
            "partial: missing shard(s) [{}], {} run(s) without a result",
            r.missing_shards.join(", "),
            r.missing_jobs.len()
        );
    }
    println!(
        "merged {} runs into {}/results.jsonl and results.csv{}",
        r.runs,
        out.display(),
        if out.join("coverage.json").exists() {
            " (and coverage.json)"
        } else {
            ""
        }
    );
    Ok(())
}

/// `litesim calibrate`.
pub fn calibrate_cmd(profile: &str, out: Option<PathBuf>) -> Result<()> {
    let c = calibrate::calibrate(profile)?;
    let path =
        out.unwrap_or_else(|| PathBuf::from("calibration").join(format!("{}.toml", c.profile)));
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d)?;
    }
    std::fs::write(&path, calibrate::to_toml(&c))?;
    print!(
        "profile {}: {} candidates (tuned on launch, speed steps, lane change; held out: stop, curve)\n{}",
        c.profile,
        c.trials,
        calibrate::report(&c)
    );
    println!("wrote {}", path.display());
    Ok(())
}

/// The MCAP file of `litesim run`, written on its own thread from the
/// moment the test has loaded and the run's stamp is on disk
/// ([`McapStreamer::map`] hands it the map):
/// header, schemas and the map's content, then the ticks — every 50 from the
/// run's observer, the rest when the run is over ([`McapStreamer::end`]). A
/// run that ends without a log (an error) leaves no file: dropping the
/// streamer stops the writer, which discards its temporary file, and waits
/// for it.
struct McapStreamer {
    state: std::sync::Arc<std::sync::Mutex<StreamState>>,
    job: Option<StreamJob>,
}

/// The writer thread and the outcome it reports once its file is in place
/// (or given up).
struct StreamJob {
    thread: std::thread::JoinHandle<()>,
    outcome: std::sync::mpsc::Receiver<Result<(), litesim_mcap::McapError>>,
}

impl StreamJob {
    /// Waits until the file is in place (or given up) and says how it went;
    /// the thread is left to wind down on its own.
    fn wait(self) -> Result<(), litesim_mcap::McapError> {
        self.outcome
            .recv()
            .unwrap_or_else(|_| Err(litesim_mcap::McapError::Stopped("it panicked".into())))
    }
}

/// What the writer thread is handed, in this order: pieces of ticks, the
/// end.
enum ToWriter {
    Piece(Box<litesim_log::SimulationLog>),
    Done,
}

struct StreamState {
    /// `None` once the writer was told the run is over (or stopped).
    tx: Option<std::sync::mpsc::Sender<ToWriter>>,
    /// Ticks handed over so far.
    sent: usize,
    /// Metadata the CLI adds to the run's log (test, run), in every piece.
    extra: Vec<(String, String)>,
}

impl StreamState {
    fn send(&mut self, log: &litesim_log::SimulationLog) {
        let mut piece = log.ticks_from(self.sent);
        piece.meta.extend(self.extra.iter().cloned());
        self.sent = log.tick.len();
        if let Some(tx) = &self.tx {
            // A writer that stopped has its error waiting at `join`.
            let _ = tx.send(ToWriter::Piece(Box::new(piece)));
        }
    }
}

/// Ticks per piece handed to the writer: often enough that it keeps up
/// with the run, seldom enough that the copies cost nothing.
const STREAM_PIECE: usize = 50;

impl McapStreamer {
    /// Starts the writer of `path` for a run on `net` (`None`: without a
    /// map) whose log carries `extra` in its metadata (test, run): every
    /// piece gets the same.
    fn start(
        path: &Path,
        net: Option<std::sync::Arc<litesim_map::RoadNetwork>>,
        extra: Vec<(String, String)>,
    ) -> Result<McapStreamer> {
        let (tx, rx) = std::sync::mpsc::channel::<ToWriter>();
        let (done, outcome) = std::sync::mpsc::channel();
        let path = path.to_path_buf();
        let write = move || -> Result<(), litesim_mcap::McapError> {
            let mut made = Ok(());
            let written = litesim_log::write_atomic_seekable(&path, |w| {
                made = stream_pieces(&mut *w, net, &rx);
                made.as_ref()
                    .map(|_| ())
                    .map_err(|e| std::io::Error::other(e.to_string()))
            });
            made?;
            written?;
            Ok(())
        };
        let thread = std::thread::Builder::new()
            .name("mcap".into())
            // The outcome goes out as soon as the file is in place (or its
            // temporary is gone): the run need not wait for the thread to
            // wind down (−0.1 ms a run; BENCHMARKS.md, seventeenth session).
            .spawn(move || {
                let _ = done.send(write());
            })
            .map_err(|e| anyhow!("starting the MCAP writer: {e}"))?;
        let _ = placement::keep_off_this_cpu(&placement::others());
        let state = StreamState {
            tx: Some(tx),
            sent: 0,
            extra,
        };
        Ok(McapStreamer {
            state: std::sync::Arc::new(std::sync::Mutex::new(state)),
            job: Some(StreamJob { thread, outcome }),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, StreamState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The run's observer: a piece every [`STREAM_PIECE`] ticks.
    fn observer(&self) -> litesim_scenario::TickObserver {
        let state = std::sync::Arc::clone(&self.state);
        litesim_scenario::TickObserver(std::sync::Arc::new(std::sync::Mutex::new(
            move |log: &litesim_log::SimulationLog| {
                let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
                if log.tick.len() >= s.sent + STREAM_PIECE {
                    s.send(log);
                }
            },
        )))
    }

    /// Hands over the ticks not yet sent from the finished log and says it
    /// is complete; the returned job finishes the file.
    fn end(mut self, log: &litesim_log::SimulationLog) -> Option<StreamJob> {
        {
            let mut s = self.lock();
            s.send(log);
            if let Some(tx) = s.tx.take() {
                let _ = tx.send(ToWriter::Done);
            }
        }
        self.job.take()
    }
}

impl Drop for McapStreamer {
    /// A run that failed: the writer sees its channel close, abandons the
    /// temporary file, and is waited for (a thread cut off at exit would
    /// leave it behind).
    fn drop(&mut self) {
        self.lock().tx = None;
        if let Some(job) = self.job.take() {
            let _ = job.thread.join();
        }
    }
}

/// Where the MCAP writer runs: on a CPU other than the run's.
///
/// Left to itself, the scheduler queues a new thread on the CPU of the
/// thread that made it, and wakes it there again each time the run hands
/// it a piece: on a two-CPU machine the writer then starts only when the
/// run first waits for the disk (delaying that very wait by its start-up)
/// and later preempts the run while the other CPU idles (traced with `perf
/// sched`: the run waited 0.3–2 ms a run with a CPU idle; BENCHMARKS.md,
/// seventeenth session). So the writer is kept off the CPU the run is on
/// when it starts; with one CPU allowed nothing changes.
#[cfg(target_os = "linux")]
mod placement {
    use rustix::thread::{Pid, gettid, sched_getaffinity, sched_getcpu, sched_setaffinity};

    /// This process's threads, from the kernel's list: std cannot say
    /// which system thread a `JoinHandle` is before that thread has run.
    pub(super) fn threads() -> Vec<Pid> {
        std::fs::read_dir("/proc/self/task")
            .map(|rd| {
                rd.flatten()
                    .filter_map(|e| e.file_name().to_str()?.parse().ok())
                    .filter_map(Pid::from_raw)
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Every thread of this process but the caller: as the MCAP writer
    /// starts, the writer alone (a SUT client's helper, were there one,
    /// is as well kept apart from the run).
    pub(super) fn others() -> Vec<Pid> {
        let me = gettid();
        threads().into_iter().filter(|&p| p != me).collect()
    }

    /// Keeps `others` off the calling thread's CPU, which it returns
    /// (`None`: the caller may use no other CPU; nothing changed). Best
    /// effort: a placement that cannot be set is left as it was.
    pub(super) fn keep_off_this_cpu(others: &[Pid]) -> Option<usize> {
        let mut set = sched_getaffinity(None).ok()?;
        let cpu = sched_getcpu();
        set.unset(cpu);
        if set.count() == 0 {
            return None;
        }
        for &p in others {
            let _ = sched_setaffinity(Some(p), &set);
        }
        Some(cpu)
    }
}

/// Elsewhere the scheduler places the writer.
#[cfg(not(target_os = "linux"))]
mod placement {
    pub(super) fn others() -> Vec<u32> {
        Vec::new()
    }

    pub(super) fn keep_off_this_cpu(_others: &[u32]) -> Option<usize> {
        None
    }
}

/// Writes the MCAP file of a run on `net` from what arrives on `rx`:
/// header, schemas and the map's content at once, the first piece's
/// actors, then each piece until the run is over.
fn stream_pieces<W: std::io::Write + std::io::Seek>(
    w: W,
    net: Option<std::sync::Arc<litesim_map::RoadNetwork>>,
    rx: &std::sync::mpsc::Receiver<ToWriter>,
) -> Result<(), litesim_mcap::McapError> {
    let stopped = || litesim_mcap::McapError::Stopped("the run ended without a log".into());
    let prelude = litesim_mcap::McapPrelude::new(w)?;
    let map = net.map(|n| litesim_mcap::McapMap::new(&n));
    let prelude = prelude.map(map.as_ref());
    let Ok(ToWriter::Piece(first)) = rx.recv() else {
        return Err(stopped());
    };
    let mut stream = prelude.start(&first)?;
    stream.push(&first)?;
    loop {
        match rx.recv() {
            Ok(ToWriter::Piece(piece)) => stream.push(&piece)?,
            Ok(ToWriter::Done) => return stream.finish().map(|_| ()),
            Err(_) => return Err(stopped()),
        }
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use rustix::thread::sched_getaffinity;

    #[test]
    fn a_thread_started_for_the_writer_keeps_off_the_cpu_it_was_started_from() {
        let mine = sched_getaffinity(None).unwrap();
        // The thread reports where it may run once it has been placed.
        let (go_tx, go_rx) = std::sync::mpsc::channel::<()>();
        let (tx, rx) = std::sync::mpsc::channel();
        let before = super::placement::threads();
        let worker = std::thread::spawn(move || {
            let _ = go_rx.recv();
            tx.send(sched_getaffinity(None).unwrap()).unwrap();
        });
        // Only the threads started since (other tests run beside this one).
        let new: Vec<_> = super::placement::threads()
            .into_iter()
            .filter(|p| !before.contains(p))
            .collect();
        let kept_off = super::placement::keep_off_this_cpu(&new);
        go_tx.send(()).unwrap();
        let theirs = rx.recv().unwrap();
        worker.join().unwrap();
        // The caller's own placement never changes.
        assert_eq!(sched_getaffinity(None).unwrap(), mine);
        match kept_off {
            // One CPU allowed: nothing moves.
            None => {
                assert_eq!(mine.count(), 1);
                assert_eq!(theirs, mine);
            }
            Some(cpu) => {
                assert!(mine.is_set(cpu) && mine.count() >= 2);
                assert!(
                    !theirs.is_set(cpu),
                    "the new thread may still run on CPU {cpu}"
                );
                assert_eq!(theirs.count(), mine.count() - 1);
            }
        }
    }
}
