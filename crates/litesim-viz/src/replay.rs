//! Scenario replays for multi-actor runs: every actor's track on the road
//! map (PNG), and a GIF of all actors' footprints over time.

use crate::animation::frame_timing;
use crate::draw::{draw_track_vehicle, equal_aspect, world_bounds};
use crate::style::Style;
use crate::{VizError, check_size, draw_err, encode_png, fonts, temp_sibling, write_atomic};
use litesim_log::SimulationLog;
use plotters::prelude::*;
use std::path::Path;

/// Background lines (lane borders and centres), in world metres.
pub type Lanes = [Vec<(f64, f64)>];

fn frame<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    log: &SimulationLog,
    lanes: &Lanes,
    style: &Style,
    tick: Option<u64>,
    title: &str,
) -> Result<(), VizError> {
    root.fill(&style.c(&style.background)).map_err(draw_err)?;
    let mut b = world_bounds(log)
        .ok_or_else(|| VizError::Empty("the log has no positions to replay".into()))?;
    for l in lanes {
        for p in l {
            b.0 = (b.0.0.min(p.0), b.0.1.max(p.0));
            b.1 = (b.1.0.min(p.1), b.1.1.max(p.1));
        }
    }
    let (w, h) = root.dim_in_pixel();
    let r = equal_aspect(b, w as f64 - 55.0, h as f64 - 60.0);
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", style.title_font))
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(45)
        .build_cartesian_2d(r.0.0..r.0.1, r.1.0..r.1.1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style(("sans-serif", style.tick_font))
        .draw()
        .map_err(draw_err)?;
    let lc = style.c(&style.lanes);
    chart
        .draw_series(
            lanes
                .iter()
                .map(|l| PathElement::new(l.clone(), lc.stroke_width(1))),
        )
        .map_err(draw_err)?;
    for (k, t) in log.tracks.iter().enumerate() {
        let c = style.series(k);
        let pts: Vec<(f64, f64)> = t
            .tick
            .iter()
            .zip(t.state.x.iter().zip(&t.state.y))
            .filter(|(tk, _)| tick.is_none_or(|now| **tk <= now))
            .map(|(_, (x, y))| (*x, *y))
            .collect();
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts,
                c.stroke_width(style.line_width),
            )))
            .map_err(draw_err)?
            .label(t.id.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
        let at = match tick {
            Some(now) => t.tick.iter().rposition(|tk| *tk <= now),
            None => t.len().checked_sub(1),
        };
        if let Some(i) = at {
            draw_track_vehicle(&mut chart, t, i, t.control.steering_angle[i], c)?;
        }
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", style.tick_font))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(draw_err)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Writes the replay overview (all tracks) as PNG.
pub fn write_png(
    log: &SimulationLog,
    lanes: &Lanes,
    style: &Style,
    path: &Path,
) -> Result<(), VizError> {
    fonts();
    let [w, h] = style.frame_size;
    check_size(w, h)?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        frame(
            &root,
            log,
            lanes,
            style,
            None,
            &format!("{} actors", log.tracks.len()),
        )?;
    }
    write_atomic(path, &encode_png(&buf, w, h)?)
}

/// Writes the replay GIF, timed like [`crate::animation`].
pub fn write_gif(
    log: &SimulationLog,
    lanes: &Lanes,
    style: &Style,
    path: &Path,
    max_frames: usize,
) -> Result<usize, VizError> {
    fonts();
    let [w, h] = style.frame_size;
    check_size(w, h)?;
    if log.tick.is_empty() {
        return Err(VizError::Empty(
            "the log has no time steps to replay".into(),
        ));
    }
    let (stride, delay) = frame_timing(log.dt, log.tick.len(), max_frames)?;
    let tmp = temp_sibling(path)?;
    let mut n = 0;
    {
        let mut out = crate::gif_out::GifOut::create(&tmp, w, h, delay, style)?;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        for (tick, time) in log.tick.iter().zip(&log.time).step_by(stride) {
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                frame(
                    &root,
                    log,
                    lanes,
                    style,
                    Some(*tick),
                    &format!("t = {time:.2} s"),
                )?;
            }
            out.push(&buf)?;
            n += 1;
        }
    }
    tmp.persist(path).map_err(|e| VizError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    Ok(n)
}
