//! `litesim plot` and `litesim animate`.

use anyhow::{Result, anyhow, bail};
use litesim_log::SimulationLog;
use litesim_viz::replay::{Area, Background, LineKind, MapLine};
use litesim_viz::{Style, VizError};
use std::path::Path;

/// The stylesheet at `path`, or the built-in default.
pub fn load_style(path: Option<&Path>) -> Result<Style> {
    match path {
        None => Ok(Style::default()),
        Some(p) => {
            let text = crate::read_text(p)?;
            Style::from_toml(&text).map_err(|e| anyhow!("{}: {e}", p.display()))
        }
    }
}

fn read(log: &Path) -> Result<SimulationLog> {
    SimulationLog::read_json(log).map_err(|e| anyhow!("{e}"))
}

/// What a replay draws of a road network: lane areas (drivable road and
/// sidewalks), lane borders, lane centres (when asked) and the painted road
/// marks (solid, broken, double; white or yellow) on top.
pub fn background(net: &litesim_map::RoadNetwork, centres: bool) -> Background {
    const TOLERANCE: f64 = 0.1;
    let xy = |pts: &[litesim_core::Vec2]| pts.iter().map(|v| (v.x, v.y)).collect::<Vec<_>>();
    // One pass over the map: lanes for areas and borders, and every lane's
    // marks including the centre lanes' (id 0, no area).
    let all = net.all_lane_polylines(TOLERANCE);
    let lanes: Vec<_> = all.iter().filter(|l| l.lane != 0).collect();
    let mut bg = Background::default();
    for l in &lanes {
        let mut outline = xy(&l.inner);
        outline.extend(l.outer.iter().rev().map(|v| (v.x, v.y)));
        bg.areas.push(Area {
            outline,
            drivable: litesim_map::model::is_drivable_kind(&l.kind),
        });
    }
    for l in &lanes {
        for border in [&l.inner, &l.outer] {
            bg.lines.push(MapLine {
                points: xy(border),
                kind: LineKind::Border,
            });
        }
        if centres {
            bg.lines.push(MapLine {
                points: xy(&l.center),
                kind: LineKind::Centre,
            });
        }
    }
    for m in all.iter().flat_map(|l| &l.marks) {
        if let Some(kind) = LineKind::of_mark(&m.kind, &m.color) {
            bg.lines.push(MapLine {
                points: xy(&m.points),
                kind,
            });
        }
    }
    bg
}

/// The background of an OpenDRIVE map, for replays.
fn lanes(map: Option<&Path>) -> Result<Background> {
    let Some(p) = map else {
        return Ok(Background::default());
    };
    let net = litesim_map::RoadNetwork::load(p).map_err(|e| anyhow!("{e}"))?;
    Ok(background(&net, true))
}

fn err(e: VizError) -> anyhow::Error {
    anyhow!("{e}")
}

/// Draws a dashboard, planner view or replay overview.
pub fn plot(
    log: &Path,
    out: &Path,
    planner: bool,
    replay: bool,
    map: Option<&Path>,
    style: Option<&Path>,
) -> Result<()> {
    let style = load_style(style)?;
    let log = read(log)?;
    let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("");
    match (planner, replay, ext) {
        (true, true, _) => bail!("--planner and --replay are different views; pick one"),
        (true, false, "png") => litesim_viz::planner::write_png(&log, &style, out).map_err(err)?,
        (false, true, "png") => {
            litesim_viz::replay::write_png(&log, &lanes(map)?, &style, out).map_err(err)?
        }
        (false, false, "png") => {
            litesim_viz::dashboard::write_png(&log, &style, out).map_err(err)?
        }
        (false, false, "svg") => {
            litesim_viz::dashboard::write_svg(&log, &style, out).map_err(err)?
        }
        _ => bail!(
            "cannot write '{}': the dashboard is .png or .svg, the planner and replay views .png",
            out.display()
        ),
    }
    println!("wrote {}", out.display());
    Ok(())
}

/// Animates a run, the FMT* exploration, or a replay.
pub fn animate(
    log: &Path,
    out: &Path,
    max_frames: usize,
    planner: bool,
    replay: bool,
    map: Option<&Path>,
    style: Option<&Path>,
) -> Result<()> {
    if out.extension().and_then(|e| e.to_str()) != Some("gif") {
        bail!(
            "animations are GIF: give an output ending in .gif (got '{}')",
            out.display()
        );
    }
    if max_frames == 0 {
        bail!("--max-frames must be at least 1");
    }
    let style = load_style(style)?;
    let log = read(log)?;
    let frames = match (planner, replay) {
        (true, true) => bail!("--planner and --replay are different views; pick one"),
        (true, false) => litesim_viz::planner::write_exploration_gif(&log, &style, out, max_frames)
            .map_err(err)?,
        (false, true) => {
            litesim_viz::replay::write_gif(&log, &lanes(map)?, &style, out, max_frames)
                .map_err(err)?
        }
        (false, false) => {
            litesim_viz::animation::write_gif(&log, &style, out, max_frames).map_err(err)?
        }
    };
    println!("wrote {} ({frames} frames)", out.display());
    Ok(())
}
