//! Planner debug views: FMT* samples, accepted edges, raw and smoothed
//! corridor (PNG), and an exploration GIF that adds the edges in the order
//! FMT* accepted them, batched into a bounded number of frames. A path
//! from the curvature-bounded search (hybrid A*) shows that search's tree
//! instead: its first expanded poses and their parents, in expansion order.

use crate::draw::map_chart;
use crate::style::Style;
use crate::{VizError, check_size, draw_err, encode_png, fonts, write_atomic};
use litesim_log::{PlanRecord, SimulationLog};
use plotters::prelude::*;
use std::path::Path;

fn plan(log: &SimulationLog) -> Result<&PlanRecord, VizError> {
    log.plan.as_ref().ok_or_else(|| {
        VizError::Empty("the log has no planner data (it was not made by `litesim plan`)".into())
    })
}

/// The log's `planner` meta when the run's path came from the
/// curvature-bounded search rather than FMT*.
fn hybrid_planner(log: &SimulationLog) -> Option<&str> {
    log.meta
        .get("planner")
        .map(String::as_str)
        .filter(|m| m.starts_with("hybrid A*"))
}

fn draw_plan<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    log: &SimulationLog,
    style: &Style,
    edges_upto: usize,
    title: &str,
) -> Result<(), VizError> {
    let p = plan(log)?;
    root.fill(&style.c(&style.background)).map_err(draw_err)?;
    let mut chart = map_chart(root, log, title, style, None)?;
    let ec = style.c(&style.edges);
    chart
        .draw_series(
            p.edges[..edges_upto.min(p.edges.len())]
                .iter()
                .filter_map(|e| {
                    let (a, b) = (p.samples.get(e[0])?, p.samples.get(e[1])?);
                    Some(PathElement::new(
                        vec![(a[0], a[1]), (b[0], b[1])],
                        ec.stroke_width(1),
                    ))
                }),
        )
        .map_err(draw_err)?;
    let sc = style.c(&style.samples);
    chart
        .draw_series(
            p.samples
                .iter()
                .skip(2)
                .map(|s| Circle::new((s[0], s[1]), style.marker_size, sc.filled())),
        )
        .map_err(draw_err)?;
    if edges_upto >= p.edges.len() {
        let line = |v: &[[f64; 2]]| v.iter().map(|q| (q[0], q[1])).collect::<Vec<_>>();
        chart
            .draw_series(std::iter::once(PathElement::new(
                line(&p.raw_path),
                style.c(&style.raw_path).stroke_width(2),
            )))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                line(&p.corridor),
                style
                    .c(&style.corridor)
                    .stroke_width(style.corridor_width + 1),
            )))
            .map_err(draw_err)?;
    }
    if let (Some(s), Some(g)) = (p.samples.first(), p.samples.get(1)) {
        chart
            .draw_series(std::iter::once(Circle::new(
                (s[0], s[1]),
                6,
                GREEN.filled(),
            )))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(Circle::new((g[0], g[1]), 6, RED.filled())))
            .map_err(draw_err)?;
    }
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Renders the planner view to RGB pixels.
pub fn render_rgb(log: &SimulationLog, style: &Style) -> Result<(Vec<u8>, u32, u32), VizError> {
    fonts();
    let p = plan(log)?;
    let [w, h] = style.frame_size;
    check_size(w, h)?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let unsmoothed = if p.smoothed {
            ""
        } else {
            " (corridor not smoothed)"
        };
        // A path from the curvature-bounded search: the title names that
        // planner (the log's `planner` meta, up to its reason — FMT*'s
        // path was not drivable); the tree drawn is its first expanded
        // poses, said when that is not all of them (the title must fit
        // the picture's width).
        let title = match hybrid_planner(log) {
            Some(m) => {
                let short = m.split(';').next().unwrap_or(m);
                let shown = p.samples.len().saturating_sub(2);
                let all = short.contains(&format!(", {shown} poses"));
                let tree = if all {
                    String::new()
                } else {
                    format!(" ({shown} shown)")
                };
                format!("{short}{tree}{unsmoothed}")
            }
            _ => format!(
                "FMT*: {} samples, {} edges, r = {:.2} m{unsmoothed}",
                p.samples.len().saturating_sub(2),
                p.edges.len(),
                p.radius,
            ),
        };
        // A start inside the margin (the log's `start` meta): how far, up
        // to how it was left (the summary has the rest).
        let title = match log.meta.get("start") {
            Some(m) => format!("{title}; start {}", m.split(':').next().unwrap_or(m)),
            None => title,
        };
        draw_plan(&root, log, style, usize::MAX, &title)?;
    }
    Ok((buf, w, h))
}

/// Writes the planner view as PNG.
pub fn write_png(log: &SimulationLog, style: &Style, path: &Path) -> Result<(), VizError> {
    let (buf, w, h) = render_rgb(log, style)?;
    write_atomic(path, &encode_png(&buf, w, h)?)
}

/// Writes the exploration GIF: edges in acceptance order over at most
/// `max_frames` frames (200 ms each), then the corridor.
pub fn write_exploration_gif(
    log: &SimulationLog,
    style: &Style,
    path: &Path,
    max_frames: usize,
) -> Result<usize, VizError> {
    fonts();
    let p = plan(log)?;
    let [w, h] = style.frame_size;
    check_size(w, h)?;
    let frames = max_frames.clamp(2, 1000);
    let per = p.edges.len().div_ceil(frames - 1).max(1);
    let mut n = 0;
    {
        let mut out = crate::gif_out::GifOut::create(path, w, h, 200, style)?;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        let mut upto = 0;
        loop {
            upto = (upto + per).min(p.edges.len());
            let done = upto >= p.edges.len();
            let title = if hybrid_planner(log).is_some() {
                format!(
                    "hybrid A* search: {upto} / {} expansions shown",
                    p.edges.len()
                )
            } else {
                format!("FMT* exploration: {upto} / {} edges", p.edges.len())
            };
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                draw_plan(
                    &root,
                    log,
                    style,
                    if done { usize::MAX } else { upto },
                    &title,
                )?;
            }
            out.push(&buf)?;
            n += 1;
            if done {
                break;
            }
        }
        out.finish()?;
    }
    Ok(n)
}
