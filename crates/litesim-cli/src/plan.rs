//! `litesim plan CONFIG [-o DIR]`.

use anyhow::{Context, Result, anyhow};
use litesim_map::OccupancyGrid;
use litesim_plan::closed_loop::{ClosedLoopConfig, parse_config};
use std::path::{Path, PathBuf};

/// Builds the occupancy grid a configuration names (files relative to it).
pub fn load_grid(cfg: &ClosedLoopConfig, base: &Path) -> Result<OccupancyGrid> {
    litesim_plan::closed_loop::load_grid(cfg, base).map_err(|e| anyhow!("{e}"))
}

/// `litesim plan-matrix`: every example of `dir` with every preset (or the
/// given ones); prints the Markdown table, and fails when a run misses the
/// goal, collides or breaks the tracking bounds (when `check` is set).
pub fn matrix(dir: &Path, presets: &[String], tolerance: f64, check: bool) -> Result<()> {
    let known: Vec<&str> = litesim_plan::closed_loop::PRESETS
        .iter()
        .map(|(n, _)| *n)
        .collect();
    if let Some(bad) = presets.iter().find(|p| !known.contains(&p.as_str())) {
        return Err(anyhow!(
            "unknown vehicle preset '{bad}' in --presets; available: {}",
            known.join(", ")
        ));
    }
    let examples = litesim_plan::matrix::load_examples(dir).map_err(|e| anyhow!("{e}"))?;
    let presets: Vec<&str> = presets.iter().map(String::as_str).collect();
    let origin = std::time::Instant::now();
    let clock = move || origin.elapsed().as_secs_f64();
    let rows = litesim_plan::matrix::run_matrix(&examples, &presets, tolerance, &clock);
    print!("{}", litesim_plan::matrix::markdown(&rows));
    if check {
        let bad: Vec<String> = rows
            .iter()
            .filter(|r| {
                !litesim_plan::matrix::within_bounds(r)
                    && !litesim_plan::matrix::proven_impossible(r)
            })
            .map(|r| format!("{} × {}", r.example, r.preset))
            .collect();
        if !bad.is_empty() {
            return Err(anyhow!(
                "{} of {} runs outside the bounds (goal within {tolerance} m, max xte ≤ {} m, mean ≤ {} m, no collision, not refused unless proven impossible): {}",
                bad.len(),
                rows.len(),
                litesim_plan::matrix::MAX_XTE,
                litesim_plan::matrix::MEAN_XTE,
                bad.join(", ")
            ));
        }
    }
    Ok(())
}

/// Runs a closed loop from a configuration file.
pub fn run(
    config: &Path,
    out: Option<PathBuf>,
    style: Option<&Path>,
    pictures: bool,
) -> Result<()> {
    let style = crate::viz::load_style(style)?;
    let text = crate::read_text(config)?;
    let cfg = parse_config(&text).map_err(|e| anyhow!("{}: {e}", config.display()))?;
    let base = config.parent().unwrap_or(Path::new("."));
    let grid = load_grid(&cfg, base)?;
    let started = std::time::Instant::now();
    let r = litesim_plan::run_closed_loop(&cfg, grid)
        .map_err(|e| anyhow!("{}: {e}", config.display()))?;
    let wall = started.elapsed();
    let name = config
        .file_stem()
        .map_or("plan".into(), |s| s.to_string_lossy().to_string());
    let dir = out.unwrap_or_else(|| PathBuf::from("out/plan").join(&name));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    r.log.write_json(&dir.join("log.json"))?;
    r.log.write_csv(&dir.join("log.csv"))?;
    // The rule and where the run ended, so that a miss says why.
    let (tol, stop) = r.goal_rule;
    let why = if r.reached_goal {
        String::new()
    } else if r.goal_distance > tol {
        format!(" — {:.2} m away", r.goal_distance)
    } else {
        " — still moving".to_string()
    };
    println!(
        "{name}: {} (within {tol} m and below {stop} m/s: {:.2} m, {:.2} m/s{why})",
        if r.reached_goal {
            "reached the goal"
        } else {
            "did NOT reach the goal"
        },
        r.goal_distance,
        r.final_speed
    );
    println!(
        "  simulated time   {:8.2} s ({} steps, {:.0} ms wall)",
        r.time,
        r.steps,
        wall.as_secs_f64() * 1000.0
    );
    println!("  path length      {:8.2} m ({})", r.path_length, r.planner);
    if let Some(e) = &r.start_escape {
        println!("  start            {e}");
    }
    println!(
        "  cross-track      {:8.3} m max, {:.3} m mean{}",
        r.max_cross_track,
        r.mean_cross_track,
        if r.corridor.smoothed {
            ""
        } else {
            " (corridor not smoothed: smoothing cut a corner)"
        }
    );
    println!(
        "  min clearance    {:8.3} m{}",
        r.min_clearance,
        match r.collision {
            Some((t, [x, y])) => format!(
                " — COLLISION at t = {t:.2} s, rear axle at ({x:.2}, {y:.2}); the run ended there"
            ),
            None => String::new(),
        }
    );
    println!(
        "wrote {} and {}",
        dir.join("log.json").display(),
        dir.join("log.csv").display()
    );
    if pictures {
        let err = |e: litesim_viz::VizError| anyhow!("{e}");
        litesim_viz::dashboard::write_png(&r.log, &style, &dir.join("dashboard.png"))
            .map_err(err)?;
        litesim_viz::animation::write_gif(&r.log, &style, &dir.join("run.gif"), 150)
            .map_err(err)?;
        litesim_viz::planner::write_png(&r.log, &style, &dir.join("fmt.png")).map_err(err)?;
        litesim_viz::planner::write_exploration_gif(&r.log, &style, &dir.join("fmt.gif"), 40)
            .map_err(err)?;
        println!(
            "wrote dashboard.png, run.gif, fmt.png and fmt.gif in {}",
            dir.display()
        );
    }
    if !r.reached_goal || r.collided {
        return Err(anyhow!(
            "the run failed: {}",
            if r.collided {
                "collision"
            } else {
                "goal not reached"
            }
        ));
    }
    Ok(())
}
