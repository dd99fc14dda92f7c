//! `litesim run`: one test, one seed; its run folder, log, pictures,
//! MCAP and summary.

use super::*;

/// The test map's road, borders and marks (no lane centre lines: a
/// scenario replay shows several actors and stays readable).
pub(super) fn lanes(net: Option<&litesim_map::RoadNetwork>) -> litesim_viz::replay::Background {
    net.map(|n| crate::viz::background(n, false))
        .unwrap_or_default()
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
pub(super) fn run_options(
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
        step_ms: common.step_ms,
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
pub(super) fn write_plan(
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
pub(super) fn write_stamp(
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
pub(super) fn simulate(
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
pub(super) fn print_plan(result: &litesim_scenario::RunResult) {
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
pub(super) fn write_log(
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
pub(super) fn finish_mcap(
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
pub(super) fn print_summary(s: &litesim_scenario::Summary) {
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
pub(super) fn mcap_file_to_write(path: &Path) -> Result<()> {
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
