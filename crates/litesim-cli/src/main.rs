//! `litesim`: the command line. It only wires the libraries together and
//! owns argument parsing, printing and exit codes.

mod check;
mod demo;
mod map;
mod plan;
mod report;
mod scenario;
mod view;
mod viz;

use anyhow::{Context, Result};

/// mimalloc instead of the system allocator: the front end, the log and
/// MCAP writers and batch runs allocate many small objects (trees,
/// strings, messages); on this project's benchmarks it is ~20 % faster
/// than glibc's malloc for `litesim check` (BENCHMARKS.md).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;
use clap::{Parser, Subcommand};
use std::io::Write;
use std::path::PathBuf;

/// Exit code of a command line litesim cannot parse (sysexits' EX_USAGE).
const EXIT_USAGE: u8 = 64;

#[derive(Parser)]
#[command(
    name = "litesim",
    version,
    about = "A lightweight, deterministic vehicle and scenario simulator",
    after_help = "Exit codes (every command): 0 done and every check passed; 2 a check failed (a test failed, or some run of a batch failed); 1 could not run (bad input, unreadable test or map, SUT error, I/O); 64 the command line is not valid (an unknown flag, or a value such as --seeds abc or an unknown --sut)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Serve the SSP API over gRPC (with health and reflection services).
    Serve(ServeArgs),
    /// Start a server, drive it with the bundled demo client over gRPC, write the log.
    Demo {
        #[command(flatten)]
        opts: demo::DemoOptions,
        /// Drive the model in-process instead of over gRPC (same results).
        #[arg(long)]
        in_process: bool,
    },
    /// Run the demo client against a running server.
    Client {
        /// Server address.
        #[arg(long, default_value = "127.0.0.1:50051")]
        addr: String,
        #[command(flatten)]
        opts: demo::DemoOptions,
    },
    /// List the simulator profiles, or show one.
    Profiles {
        /// Profile to show.
        name: Option<String>,
    },
    /// List the models.
    Models,
    /// Read an RPC trace (`run --trace-rpc`, `serve --trace-rpc`).
    Trace {
        #[command(subcommand)]
        command: TraceCommand,
    },
    /// Plan (FMT*), smooth and track (MPC) a vehicle on a map; write the log and pictures.
    Plan {
        /// The TOML configuration (see examples/plan/).
        config: PathBuf,
        /// Output folder (default: out/plan/<config name>).
        #[arg(short = 'o', long)]
        out: Option<PathBuf>,
        /// Stylesheet for the pictures (TOML).
        #[arg(long)]
        style: Option<PathBuf>,
        /// Skip the pictures (dashboard, animation, planner views).
        #[arg(long)]
        no_pictures: bool,
    },
    /// Run every planning example with every vehicle preset and print the
    /// tracking table (goal, final distance, cross-track error, clearance,
    /// plan and MPC time) as Markdown.
    PlanMatrix {
        /// Folder of closed-loop configurations.
        #[arg(default_value = "examples/plan")]
        dir: PathBuf,
        /// Presets to run (default: all).
        #[arg(long, value_delimiter = ',')]
        presets: Vec<String>,
        /// Goal tolerance (m) for every run.
        #[arg(long, default_value_t = 0.5)]
        tolerance: f64,
        /// Exit with an error when a run misses the goal, collides or
        /// breaks the tracking bounds.
        #[arg(long)]
        check: bool,
    },
    /// Draw a log: the nine-panel dashboard (PNG or SVG by extension), or the planner view.
    Plot {
        /// A log.json written by litesim.
        log: PathBuf,
        /// Output file (.png or .svg).
        #[arg(short = 'o', long)]
        out: PathBuf,
        /// Draw the planner debug view (FMT* samples, edges, corridors) instead.
        #[arg(long)]
        planner: bool,
        /// Draw every actor's track (scenario replay overview) instead.
        #[arg(long)]
        replay: bool,
        /// OpenDRIVE map whose lanes are drawn under a replay.
        #[arg(long)]
        map: Option<PathBuf>,
        /// Stylesheet (TOML).
        #[arg(long)]
        style: Option<PathBuf>,
    },
    /// Animate a log as GIF: the vehicle with its MPC horizon, or a multi-actor replay.
    Animate {
        /// A log.json written by litesim.
        log: PathBuf,
        /// Output .gif.
        #[arg(short = 'o', long)]
        out: PathBuf,
        /// Most frames (steps are subsampled to stay within it).
        #[arg(long, default_value_t = 150)]
        max_frames: usize,
        /// The FMT* exploration instead of the run.
        #[arg(long)]
        planner: bool,
        /// A multi-actor replay instead of the ego view.
        #[arg(long)]
        replay: bool,
        /// OpenDRIVE map whose lanes are drawn under a replay.
        #[arg(long)]
        map: Option<PathBuf>,
        /// Stylesheet (TOML).
        #[arg(long)]
        style: Option<PathBuf>,
    },
    /// Check an OpenSCENARIO DSL file and its imports: all diagnostics, exit 1 on errors.
    Check {
        /// The .osc file.
        file: PathBuf,
        /// Import search paths (after the importing file's folder).
        #[arg(short = 'I', value_name = "DIR")]
        include: Vec<PathBuf>,
        /// Diagnostics as JSON lines in litesim's flat form (file, line, column, code, message, hint, related).
        #[arg(long, conflicts_with = "format")]
        json: bool,
        /// Output format: human (default), or json — rustc's JSON
        /// diagnostics (message, code, level, spans with text and
        /// highlights, children, rendered), one per line, for editors and CI.
        #[arg(long, value_parser = ["human", "json"], default_value = "human")]
        format: String,
        /// Print the syntax tree of the entry file (JSON).
        #[arg(long)]
        dump_ast: bool,
        /// OSC dialect: auto (default: CARLA's when the file imports its
        /// `basic.osc` or declares `actor Path`), litesim or carla.
        #[arg(long, default_value = "auto", value_parser = ["auto", "litesim", "carla"])]
        dialect: String,
    },
    /// Run an OpenSCENARIO DSL test: solve, plan, drive the SSP, check; write log, summary, pictures.
    Run(RunArgs),
    /// Run tests × seeds in parallel; JSON lines and CSV; resumable; shardable (i/N).
    Batch(BatchArgs),
    /// Watch a run in the browser: map, actors, time slider, play, zoom,
    /// follow, actor state on click, speed/gap/TTC plots, failures on the
    /// timeline. Serves on 127.0.0.1 (no network needed); `--export`
    /// writes the same viewer as one self-contained HTML file instead.
    View(ViewArgs),
    /// One self-contained HTML report of a batch folder: runs table,
    /// failure reasons, coverage and its holes, KPI histograms, replays.
    Report {
        /// The batch (or merged) folder.
        dir: PathBuf,
        /// Output file (default DIR/report.html).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Merge batch folders (shards) into one sorted result.
    Merge {
        /// Shard folders.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output folder.
        #[arg(short, long)]
        out: PathBuf,
        /// Merge even when shards or runs are missing (they are listed).
        #[arg(long)]
        allow_partial: bool,
    },
    /// Tune the dynamic drivers' gains for a profile; write its calibration file.
    Calibrate {
        /// Profile.
        #[arg(long, default_value = "dummy")]
        profile: String,
        /// Output file (default calibration/PROFILE.toml).
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
    /// Inspect and export OpenDRIVE maps.
    Map {
        #[command(subcommand)]
        command: map::MapCommand,
    },
}

/// `litesim view`'s options.
#[derive(clap::Args)]
struct ViewArgs {
    /// A run folder (from `litesim run`) or a log.json.
    run: PathBuf,
    /// Port (0: any free port; the URL is printed).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Address to listen on (the viewer is for this machine unless you say otherwise).
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// OpenDRIVE map to draw (default: the one the run's summary names).
    #[arg(long)]
    map: Option<PathBuf>,
    /// Write the viewer with the whole run inside to FILE (works from file://) and exit.
    #[arg(long, value_name = "FILE")]
    export: Option<PathBuf>,
}

/// `litesim batch`'s options.
#[derive(clap::Args)]
struct BatchArgs {
    /// Tests (.osc).
    #[arg(required = true)]
    tests: Vec<PathBuf>,
    #[command(flatten)]
    common: scenario::Common,
    /// Seeds, inclusive: A..B or one seed.
    #[arg(long, default_value = "1..10")]
    seeds: String,
    /// Shard i/N of the job list (Kubernetes Indexed Job, Slurm array).
    #[arg(long, default_value = "0/1")]
    shard: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Output folder.
    #[arg(short, long, default_value = "batch")]
    out: PathBuf,
    /// Continue the batch in OUT: run only its missing jobs (refused
    /// when OUT was made with other options or tests).
    #[arg(long, conflicts_with = "force_new")]
    resume: bool,
    /// Start over in OUT even though it holds results.
    #[arg(long)]
    force_new: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Keep the logs of failed runs in OUT/failed/.
    #[arg(long)]
    save_failed: bool,
    /// With --save-failed: also write each failed run as MCAP
    /// (OUT/failed/TEST-seedN.mcap; Foxglove schemas and OSI GroundTruth).
    #[arg(long, requires = "save_failed")]
    mcap: bool,
    /// Also write the results as JUnit XML (one testcase per test × seed).
    #[arg(long, value_name = "FILE")]
    junit: Option<PathBuf>,
    /// Fail (exit 2) when a `cover` item has buckets no run hit.
    #[arg(long)]
    fail_on_holes: bool,
    /// Exit 3 when a run's scenario was not realised (verdict
    /// `invalid`) and nothing failed; without it such runs are listed
    /// but do not fail the batch.
    #[arg(long)]
    fail_on_invalid: bool,
    /// Run on a Ray cluster (auto, HOST:PORT, ray://HOST:PORT, or local
    /// to start one here) through the Python package (`pip install
    /// ./python[ray]`); the folder written is the same as without.
    #[arg(long, value_name = "ADDRESS", conflicts_with_all = ["resume", "save_failed", "junit", "threads", "fail_on_holes", "fail_on_invalid"])]
    ray: Option<String>,
}

/// `litesim run`'s options.
#[derive(clap::Args)]
struct RunArgs {
    /// The test (.osc).
    test: PathBuf,
    #[command(flatten)]
    common: scenario::Common,
    /// Seed (default: the test's, else 1).
    #[arg(long)]
    seed: Option<u64>,
    /// Simulator: in-process (default) or grpc://HOST:PORT.
    #[arg(long)]
    sim: Option<String>,
    /// Output folder (default runs/TEST-seedN).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Print (and draw) the plan; run nothing.
    #[arg(long)]
    plan_only: bool,
    /// Skip the pictures.
    #[arg(long)]
    no_pictures: bool,
    /// Also write an animated replay (GIF).
    #[arg(long)]
    gif: bool,
    /// Also write the run as MCAP (Foxglove scene, transforms and actor
    /// states; ASAM OSI GroundTruth) to FILE.
    #[arg(long, value_name = "FILE")]
    mcap: Option<PathBuf>,
    /// Driver gains from `litesim calibrate` (TOML).
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Stylesheet for the pictures (TOML; colours, sizes, fonts).
    #[arg(long)]
    style: Option<PathBuf>,
    /// Write every SSP call the run makes (method, arguments, result,
    /// duration) to FILE as JSON lines, in-process or over gRPC.
    #[arg(long, value_name = "FILE")]
    trace_rpc: Option<PathBuf>,
    /// Pace the steps to the wall clock (hardware in the loop); on by
    /// default under the dspace profile. The summary reports lateness.
    #[arg(long, conflicts_with = "no_realtime")]
    realtime: bool,
    /// Run as fast as possible even under the dspace profile.
    #[arg(long)]
    no_realtime: bool,
    /// What a late step does: catch-up (run late steps back to back),
    /// skip (restart the schedule) or fail (stop with a verdict).
    #[arg(long, default_value = "catch-up", value_name = "POLICY")]
    realtime_policy: String,
}

/// `litesim serve`'s options.
#[derive(clap::Args)]
struct ServeArgs {
    /// Address to bind; loopback by default.
    #[arg(long, default_value = "127.0.0.1:50051")]
    addr: String,
    /// Model for sessions that name none (dummy, bicycle, lag).
    #[arg(long, default_value = "dummy")]
    model: String,
    /// Profile for sessions that name none.
    #[arg(long, default_value = "dummy")]
    profile: String,
    /// Write every call with arguments and result as JSON lines.
    #[arg(long, value_name = "FILE")]
    trace_rpc: Option<PathBuf>,
    /// Sessions alive at once.
    #[arg(long, default_value_t = 64)]
    max_sessions: usize,
    /// Actors per session.
    #[arg(long, default_value_t = 10_000)]
    max_actors: usize,
    /// Largest request (bytes).
    #[arg(long, default_value_t = 16 * 1024 * 1024)]
    max_message_bytes: usize,
    /// End a session unused this long (s), whatever its connection
    /// does; every call, or an explicit KeepAlive, renews it. Off by
    /// default: a session lives as long as the connection that made it.
    #[arg(long, value_name = "SECONDS", alias = "idle-timeout-s")]
    idle_timeout: Option<f64>,
    /// HTTP/2 keepalive (s): the server pings each connection this
    /// often and closes one that does not answer within it — its
    /// sessions are then detached, as when the client closes.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    keepalive: f64,
    /// How long a session outlives its closed connection (s): a client
    /// that reconnects takes it back with Attach within this time.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    attach_grace: f64,
    /// A folder Init's map_path may read from (repeatable); by default
    /// the folder the server is started in. Other paths are refused.
    #[arg(long, value_name = "DIR")]
    map_root: Vec<PathBuf>,
    /// Every call (but health's) must carry `authorization: Bearer
    /// <token>`, the token being this file's content.
    #[arg(long, value_name = "FILE")]
    auth_token_file: Option<PathBuf>,
    /// Serve Prometheus metrics (`GET /metrics`: sessions open,
    /// created, freed by cause, steps, call latencies) on this address.
    #[arg(long, value_name = "ADDR")]
    metrics: Option<std::net::SocketAddr>,
    /// Serve over TLS with this certificate chain (PEM; with --tls-key).
    #[arg(long, value_name = "FILE", requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The TLS private key (PEM; with --tls-cert).
    #[arg(long, value_name = "FILE", requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Serve in plain text on an address that is not loopback (without
    /// TLS anyone who can reach the port sees the traffic).
    #[arg(long)]
    insecure: bool,
    /// Server worker threads; 0 = one per CPU. For lock-step latency run
    /// one worker and put server and client on one CPU (`taskset -c 0`
    /// for both): a wake-up on another CPU costs tens of µs on a VM.
    #[arg(long, default_value_t = 0)]
    workers: usize,
}

#[derive(Subcommand)]
enum TraceCommand {
    /// Calls, errors and latency (p50, p99, max, total) per method.
    Summarize {
        /// The trace (JSON lines).
        file: PathBuf,
    },
}

fn main() -> std::process::ExitCode {
    // `litesim … | head` closes our stdout early: that is the reader's
    // choice, not a crash, so leave quietly instead of panicking.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.contains("Broken pipe") {
            std::process::exit(0);
        }
        default_hook(info);
    }));
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are answers, not errors; a usage error
            // gets its own code (64, EX_USAGE) so that scripts can tell it
            // from a failed check (2).
            let _ = e.print();
            return if e.use_stderr() {
                std::process::ExitCode::from(EXIT_USAGE)
            } else {
                std::process::ExitCode::SUCCESS
            };
        }
    };
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.chain().any(|c| c.is::<scenario::UsageError>()) {
                std::process::ExitCode::from(EXIT_USAGE)
            } else {
                std::process::ExitCode::FAILURE
            }
        }
    }
}

/// Reads a text file through litesim's one guarded reader (a regular file
/// of at most [`litesim_core::files::MAX_INPUT_BYTES`]).
pub(crate) fn read_text(p: &std::path::Path) -> Result<String> {
    Ok(litesim_core::files::read_text(
        p,
        litesim_core::files::MAX_INPUT_BYTES,
    )?)
}

/// Reads a file's bytes through the guarded reader ([`read_text`]).
pub(crate) fn read_bytes(p: &std::path::Path) -> Result<Vec<u8>> {
    Ok(litesim_core::files::read_bytes(
        p,
        litesim_core::files::MAX_INPUT_BYTES,
    )?)
}

/// `litesim run`: one test, its run folder, its exit code.
fn run_test(args: RunArgs) -> Result<()> {
    let RunArgs {
        test,
        common,
        seed,
        sim,
        out,
        plan_only,
        no_pictures,
        gif,
        mcap,
        calibration,
        style,
        trace_rpc,
        realtime,
        no_realtime,
        realtime_policy,
    } = args;
    let pacing = scenario::Pacing {
        on: realtime,
        off: no_realtime,
        policy: realtime_policy.parse().map_err(
            |e: litesim_scenario::realtime::UnknownPolicy| {
                anyhow::Error::new(e).context("--realtime-policy")
            },
        )?,
    };
    let outcome = scenario::run(
        &test,
        &common,
        seed,
        sim.as_deref(),
        out,
        plan_only,
        no_pictures,
        gif,
        mcap.as_deref(),
        calibration.as_deref(),
        style.as_deref(),
        trace_rpc.as_deref(),
        pacing,
    )?;
    exit_with(outcome)
}

/// `litesim batch`: tests × seeds, its folder, its exit code.
fn run_batch_cmd(args: BatchArgs) -> Result<()> {
    let BatchArgs {
        tests,
        common,
        seeds,
        shard,
        threads,
        out,
        resume,
        force_new,
        quiet,
        save_failed,
        mcap,
        junit,
        fail_on_holes,
        fail_on_invalid,
        ray,
    } = args;
    exit_with(scenario::batch(
        tests,
        &common,
        &seeds,
        &shard,
        threads,
        out,
        resume,
        force_new,
        quiet,
        save_failed,
        mcap,
        junit,
        fail_on_holes,
        fail_on_invalid,
        ray.as_deref(),
    )?)
}

/// `litesim view`: the run viewer, served or exported.
fn view_cmd(args: ViewArgs) -> Result<()> {
    let ViewArgs {
        run,
        port,
        host,
        map,
        export,
    } = args;
    // Everything is read and checked before a port is opened: a
    // bad log starts no server.
    let data = view::ViewData::new(view::Run::load(&run, map.as_deref())?);
    if let Some(out) = export {
        view::export(&data, &out)?;
        println!("wrote {}", out.display());
        return Ok(());
    }
    let listener = view::bind(&host, port)?;
    let addr = listener.local_addr()?;
    println!("litesim viewer: http://{addr}/  (Ctrl-C to stop)");
    std::io::stdout().flush()?;
    view::serve(data, listener)
}

/// The exit code of a run's or a batch's outcome: 0 pass; 2 a failed
/// check (an outcome, not a crash); 3 the scenario did not happen (a run
/// invalid, or a batch of only invalid runs under --fail-on-invalid); 1
/// the system under test broke down or a test could not run (the summary
/// is written).
fn exit_with(outcome: scenario::Outcome) -> Result<()> {
    match outcome {
        scenario::Outcome::Pass => Ok(()),
        scenario::Outcome::Fail => std::process::exit(2),
        scenario::Outcome::Invalid => std::process::exit(3),
        scenario::Outcome::SutError | scenario::Outcome::CouldNotRun => std::process::exit(1),
    }
}

/// `litesim profiles`: the built-in simulator profiles, one a line.
fn list_profiles() -> Result<()> {
    for n in litesim_ssp::profile::builtin_names() {
        let p = litesim_ssp::Profile::builtin(n).map_err(|e| anyhow::anyhow!(e.message))?;
        println!(
            "{:<14} {:>4} ms  {:<10?}  {}",
            p.name, p.step_ms, p.pedal_encoding, p.simulator
        );
    }
    Ok(())
}

/// `litesim profiles NAME`: one profile in full, with its catalogue.
fn show_profile(n: &str) -> Result<()> {
    let p = litesim_ssp::Profile::builtin(n).map_err(|e| anyhow::anyhow!(e.message))?;
    println!("{} — {}\n{}\n", p.name, p.simulator, p.description);
    println!(
        "step {} ms (allowed {}..={}), actuators {:?}, traffic lights {:?}",
        p.step_ms, p.min_step_ms, p.max_step_ms, p.pedal_encoding, p.traffic_light_api
    );
    if !p.step_source.is_empty() {
        println!("step source: {}", p.step_source);
    }
    if p.post_plan.enabled {
        println!(
            "post-plan checks: {:?} (speed ≤ {} m/s, acceleration ≤ {} m/s², deceleration ≤ {} m/s²{})",
            p.post_plan.level,
            p.post_plan.max_speed,
            p.post_plan.max_acceleration,
            p.post_plan.max_deceleration,
            if p.post_plan.level == litesim_ssp::profile::PostPlanLevel::Full {
                format!(", curvature ≤ {} 1/m", p.post_plan.max_curvature)
            } else {
                String::new()
            }
        );
    }
    println!(
        "\n{:<36} {:<12} {:>7} {:>6} {:>6} {:>8}",
        "blueprint", "category", "length", "width", "height", "mass"
    );
    for e in &p.catalog {
        println!(
            "{:<36} {:<12} {:>7.2} {:>6.2} {:>6.2} {:>8.0}",
            e.model_id, e.category, e.length, e.width, e.height, e.mass
        );
    }
    Ok(())
}

/// `litesim trace summarize FILE`: calls, errors and latencies per method.
fn trace_summary(file: &std::path::Path) -> Result<()> {
    let text = read_text(file)?;
    let (stats, skipped) = litesim_ssp::trace::summarize(&text);
    println!(
        "{:<26} {:>8} {:>7} {:>10} {:>10} {:>10} {:>12}",
        "method", "calls", "errors", "p50 µs", "p99 µs", "max µs", "total ms"
    );
    for m in &stats {
        println!(
            "{:<26} {:>8} {:>7} {:>10.1} {:>10.1} {:>10.1} {:>12.3}",
            m.method,
            m.calls,
            m.errors,
            m.p50_us,
            m.p99_us,
            m.max_us,
            m.total_us / 1000.0
        );
    }
    if skipped > 0 {
        println!("({skipped} lines were not trace records)");
    }
    Ok(())
}

/// `litesim serve`: the SSP API over gRPC until Ctrl-C.
fn serve(args: ServeArgs) -> Result<()> {
    let ServeArgs {
        addr,
        model,
        profile,
        trace_rpc,
        max_sessions,
        max_actors,
        max_message_bytes,
        idle_timeout,
        keepalive,
        attach_grace,
        map_root,
        auth_token_file,
        metrics,
        tls_cert,
        tls_key,
        insecure,
        workers,
    } = args;
    let tls = match (tls_cert, tls_key) {
        (Some(c), Some(k)) => {
            let read = |f: &PathBuf, what: &str| read_bytes(f).with_context(|| format!("--{what}"));
            Some(litesim_grpc::TlsPem {
                cert: read(&c, "tls-cert")?,
                key: read(&k, "tls-key")?,
            })
        }
        _ => None,
    };
    let plain = tls.is_none();
    let auth_token = auth_token_file.map(|f| read_token(&f)).transpose()?;
    let secs = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 && v <= 86_400.0 {
            Ok(std::time::Duration::from_secs_f64(v))
        } else {
            Err(anyhow::anyhow!(
                "--{name} {v}: expected seconds in (0, 86400]"
            ))
        }
    };
    let idle_timeout = idle_timeout.map(|v| secs("idle-timeout", v)).transpose()?;
    let keepalive = secs("keepalive", keepalive)?;
    let attach_grace = secs("attach-grace", attach_grace)?;
    // Fail early, before binding, on names that cannot work.
    litesim_ssp::model_by_name(&model).map_err(|e| anyhow::anyhow!(e.message))?;
    litesim_ssp::Profile::builtin(&profile).map_err(|e| anyhow::anyhow!(e.message))?;
    let cfg = litesim_grpc::ServerConfig {
        default_profile: profile,
        default_model: model,
        max_sessions,
        limits: litesim_ssp::SessionLimits {
            max_actors,
            ..litesim_ssp::SessionLimits::default()
        },
        idle_timeout,
        keepalive,
        attach_grace,
        map_roots: map_root,
        auth_token,
        metrics,
        tls,
        max_message_bytes,
        trace_rpc,
    };
    let cfg_has_token = cfg.auth_token.is_some();
    let mut rt = tokio::runtime::Builder::new_multi_thread();
    if workers > 0 {
        rt.worker_threads(workers);
    }
    let rt = rt.enable_all().build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(&addr)
            .await
            .with_context(|| format!("cannot bind {addr}"))?;
        let local = listener.local_addr()?;
        if !local.ip().is_loopback() && plain {
            if !insecure {
                anyhow::bail!(
                    "refusing to serve on {local} in plain text: it is not loopback, so anyone who can reach the port could read and drive the sessions; give --tls-cert and --tls-key, bind 127.0.0.1, or pass --insecure to serve in plain text anyway"
                );
            }
            eprintln!(
                "litesim: --insecure: serving in plain text on {local}; calls and maps cross the network unencrypted{}",
                if cfg_has_token { "" } else { ", and without --auth-token-file anyone who reaches the port can drive it" }
            );
        }
        println!("litesim: serving the SSP API on {local} (health, reflection on)");
        std::io::stdout().flush()?;
        litesim_grpc::serve(listener, cfg, async {
            let _ = tokio::signal::ctrl_c().await;
        })
        .await
        .map_err(|e| anyhow::anyhow!(e))
    })
}

/// A bearer token from a file (its content, trimmed); empty is an error.
fn read_token(f: &std::path::Path) -> Result<String> {
    let t = read_text(f).context("--auth-token-file")?;
    let t = t.trim().to_string();
    if t.is_empty() || !t.chars().all(|c| c.is_ascii_graphic()) {
        anyhow::bail!(
            "--auth-token-file {}: expected one token of printable ASCII characters",
            f.display()
        );
    }
    Ok(t)
}

/// The token this command sends to a litesim server
/// (`LITESIM_TOKEN_FILE`), if any.
pub(crate) fn client_token() -> Result<Option<String>> {
    std::env::var_os("LITESIM_TOKEN_FILE")
        .map(|f| read_token(std::path::Path::new(&f)))
        .transpose()
}

/// Connects to a litesim server at `addr` as this command does: with the
/// token of `LITESIM_TOKEN_FILE` and, when `LITESIM_CA_FILE` names a CA
/// (PEM), over TLS.
pub(crate) fn connect_server(addr: &str) -> Result<litesim_grpc::RemoteSsp> {
    let ca = std::env::var_os("LITESIM_CA_FILE")
        .map(|f| read_bytes(f.as_ref()).context("LITESIM_CA_FILE"))
        .transpose()?;
    litesim_grpc::RemoteSsp::connect_with(addr, client_token()?.as_deref(), ca.as_deref())
        .map_err(|e| anyhow::anyhow!("{e}"))
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Serve(args) => serve(args),
        Command::Demo { opts, in_process } => {
            if in_process {
                let mut s = litesim_ssp::Session::default();
                demo::run(&mut s, &opts, "in-process")
            } else {
                demo::run_with_local_server(&opts)
            }
        }
        Command::Client { addr, opts } => {
            let mut c = connect_server(&addr)?;
            demo::run(&mut c, &opts, &format!("gRPC {addr}"))
        }
        Command::Profiles { name: None } => list_profiles(),
        Command::Profiles { name: Some(n) } => show_profile(&n),
        Command::Map { command } => map::run(command),
        Command::Check {
            file,
            include,
            json,
            format,
            dump_ast,
            dialect,
        } => check::run(
            &file,
            &include,
            json,
            format == "json",
            dump_ast,
            scenario::dialect_choice(&dialect),
        ),
        Command::PlanMatrix {
            dir,
            presets,
            tolerance,
            check,
        } => plan::matrix(&dir, &presets, tolerance, check),
        Command::Plan {
            config,
            out,
            style,
            no_pictures,
        } => plan::run(&config, out, style.as_deref(), !no_pictures),
        Command::Plot {
            log,
            out,
            planner,
            replay,
            map,
            style,
        } => viz::plot(
            &log,
            &out,
            planner,
            replay,
            map.as_deref(),
            style.as_deref(),
        ),
        Command::Animate {
            log,
            out,
            max_frames,
            planner,
            replay,
            map,
            style,
        } => viz::animate(
            &log,
            &out,
            max_frames,
            planner,
            replay,
            map.as_deref(),
            style.as_deref(),
        ),
        Command::Run(args) => run_test(args),
        Command::Batch(args) => run_batch_cmd(args),
        Command::View(args) => view_cmd(args),
        Command::Report { dir, out, quiet } => {
            let p = report::write(&dir, out, quiet)?;
            println!("wrote {}", p.display());
            Ok(())
        }
        Command::Merge {
            dirs,
            out,
            allow_partial,
        } => scenario::merge(&dirs, &out, allow_partial),
        Command::Calibrate { profile, out } => scenario::calibrate_cmd(&profile, out),
        Command::Trace {
            command: TraceCommand::Summarize { file },
        } => trace_summary(&file),
        Command::Models => {
            for m in litesim_ssp::models() {
                println!("{:<8} {}", m.name(), m.summary());
            }
            Ok(())
        }
    }
}
