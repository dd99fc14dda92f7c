//! Every example × every vehicle preset: the tracking table of
//! BENCHMARKS.md (`litesim plan-matrix`) and the test over the whole matrix.
//!
//! A row states what a user of the planner asks first: did the vehicle
//! arrive (and by the stated rule), how closely did it follow its path once
//! on it, how close did its footprint come to an obstacle, and what did the
//! planner and the controller cost. Timing comes from a clock the caller
//! passes in, so the crate itself stays clock-free and a run's results do
//! not depend on it.

use crate::closed_loop::{
    ClosedLoopConfig, PRESETS, PlanError, load_grid, parse_config, run_closed_loop_timed,
};
use litesim_map::OccupancyGrid;
use serde::Serialize;

/// One example × preset run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MatrixRow {
    /// Example name (configuration file stem).
    pub example: String,
    /// Vehicle preset.
    pub preset: String,
    /// The goal was reached (within the tolerance, below the stop speed).
    pub reached: bool,
    /// Distance to the goal at the end (m).
    pub final_distance: f64,
    /// Mean |cross-track error| once on the path (m).
    pub mean_xte: f64,
    /// Largest |cross-track error| once on the path (m).
    pub max_xte: f64,
    /// Smallest clearance of the footprint to an obstacle (m).
    pub min_clearance: f64,
    /// The planner's inflation radius (half width + margin, m).
    pub inflation: f64,
    /// The footprint touched an obstacle.
    pub collided: bool,
    /// Planning (distance field, FMT*, corridor) wall time (ms).
    pub plan_ms: f64,
    /// Median MPC solve wall time (µs).
    pub mpc_us: f64,
    /// Why the run could not be made (no feasible path, …).
    pub error: Option<String>,
}

/// Every `*.toml` configuration in `dir` (sorted by name) with its
/// occupancy grid: (file stem, configuration, grid). Errors name the file.
pub fn load_examples(
    dir: &std::path::Path,
) -> Result<Vec<(String, ClosedLoopConfig, OccupancyGrid)>, PlanError> {
    let entries = std::fs::read_dir(dir).map_err(|source| PlanError::Dir {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<std::path::PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(PlanError::Config(format!(
            "no .toml configurations in {}",
            dir.display()
        )));
    }
    files
        .iter()
        .map(|f| {
            let text = litesim_core::files::read_text(f, litesim_core::files::MAX_INPUT_BYTES)?;
            let cfg = parse_config(&text).map_err(|e| PlanError::InFile {
                path: f.clone(),
                source: Box::new(e),
            })?;
            let grid = load_grid(&cfg, f.parent().unwrap_or(std::path::Path::new(".")))?;
            let name = f
                .file_stem()
                .map_or(String::new(), |s| s.to_string_lossy().to_string());
            Ok((name, cfg, grid))
        })
        .collect()
}

/// Runs `examples` (name, configuration, occupancy) with each of
/// `presets` (all when empty); the goal tolerance is set to `tolerance`.
/// `clock` returns seconds from any fixed origin.
pub fn run_matrix(
    examples: &[(String, ClosedLoopConfig, OccupancyGrid)],
    presets: &[&str],
    tolerance: f64,
    clock: &dyn Fn() -> f64,
) -> Vec<MatrixRow> {
    let all: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
    let presets = if presets.is_empty() {
        &all[..]
    } else {
        presets
    };
    let mut rows = Vec::new();
    for (name, cfg, grid) in examples {
        for preset in presets {
            let mut cfg = cfg.clone();
            cfg.vehicle.preset = (*preset).to_string();
            cfg.goal.tolerance = tolerance;
            let row = match run_closed_loop_timed(&cfg, grid.clone(), clock) {
                Ok((r, t)) => MatrixRow {
                    example: name.clone(),
                    preset: (*preset).to_string(),
                    reached: r.reached_goal,
                    final_distance: r.goal_distance,
                    mean_xte: r.mean_cross_track,
                    max_xte: r.max_cross_track,
                    min_clearance: r.min_clearance,
                    inflation: r.grid.radius + r.grid.margin,
                    collided: r.collided,
                    plan_ms: t.plan_s * 1e3,
                    mpc_us: median(&t.mpc_s) * 1e6,
                    error: None,
                },
                Err(e) => MatrixRow {
                    example: name.clone(),
                    preset: (*preset).to_string(),
                    reached: false,
                    final_distance: f64::NAN,
                    mean_xte: f64::NAN,
                    max_xte: f64::NAN,
                    min_clearance: f64::NAN,
                    inflation: f64::NAN,
                    collided: false,
                    plan_ms: f64::NAN,
                    mpc_us: f64::NAN,
                    error: Some(e.to_string()),
                },
            };
            rows.push(row);
        }
    }
    rows
}

/// The tracking bound on the largest |cross-track error| (m).
pub const MAX_XTE: f64 = 0.03;
/// The tracking bound on the mean |cross-track error| (m).
pub const MEAN_XTE: f64 = 0.02;

/// A run that was made, arrived, never touched an obstacle or the map's
/// edge with its footprint, and tracked within [`MAX_XTE`] / [`MEAN_XTE`].
/// (The body's clearance is reported, not bounded here: the planner keeps
/// the covering circles a margin away, and every arrived run so far keeps
/// ≥ 0.47 m — see BENCHMARKS.md.)
pub fn within_bounds(r: &MatrixRow) -> bool {
    r.error.is_none() && r.reached && !r.collided && r.max_xte <= MAX_XTE && r.mean_xte <= MEAN_XTE
}

/// A row no run can exist for, proven ([`crate::PlanError::Impossible`]:
/// the body cannot stand at the start, or an exhaustive search found no
/// path): `--check` accepts it with its reason.
pub fn proven_impossible(r: &MatrixRow) -> bool {
    r.error
        .as_deref()
        .is_some_and(|e| e.starts_with("impossible for this vehicle: "))
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// The table as Markdown.
pub fn markdown(rows: &[MatrixRow]) -> String {
    let mut out = String::from(
        "| example | preset | goal | final distance (m) | mean xte (m) | max xte (m) | min clearance (m) | inflation (m) | plan (ms) | MPC (µs, median) |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        if let Some(e) = &r.error {
            out.push_str(&format!(
                "| {} | {} | {}: {} | | | | | | | |\n",
                r.example,
                r.preset,
                if proven_impossible(r) {
                    "**impossible**"
                } else {
                    "**no run**"
                },
                e.replace('|', "/")
            ));
            continue;
        }
        out.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.4} | {:.4} | {:.3} | {:.2} | {:.1} | {:.1} |\n",
            r.example,
            r.preset,
            if r.collided {
                "**collision**"
            } else if r.reached {
                "reached"
            } else {
                "**missed**"
            },
            r.final_distance,
            r.mean_xte,
            r.max_xte,
            r.min_clearance,
            r.inflation,
            r.plan_ms,
            r.mpc_us
        ));
    }
    out
}
