//! Animated GIF of a run: the vehicle's pose, its MPC predicted horizon,
//! the occupancy grid and corridor on the left; speed and steering traces
//! growing over time on the right.
//!
//! Frame timing is true to simulation time: the delay of a frame is a whole
//! number `k` of simulation steps, with `k` the smallest value for which
//! `k·dt` is a whole number of GIF time units (10 ms), at least 20 ms (the
//! shortest delay viewers honour), and the frame count stays within the limit.

use crate::draw::{draw_track_vehicle, ego, map_chart, series_panel, world_bounds};
use crate::style::Style;
use crate::{VizError, check_size, draw_err, fonts};
use litesim_log::SimulationLog;
use plotters::prelude::*;
use std::path::Path;

/// Frame stride (simulation steps per frame) and delay (ms) for `n` steps of `dt` s.
pub fn frame_timing(dt: f64, n: usize, max_frames: usize) -> Result<(usize, u32), VizError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(VizError::Settings(format!(
            "the log's step dt = {dt} s cannot time frames"
        )));
    }
    let max_frames = max_frames.max(1);
    let mut k = 1usize;
    loop {
        let cs = k as f64 * dt * 100.0; // centiseconds
        let whole = (cs - cs.round()).abs() < 1e-6;
        if whole && cs.round() >= 2.0 && n.div_ceil(k) <= max_frames {
            return Ok((k, (cs.round() as u32) * 10));
        }
        k += 1;
        if k > 100_000 {
            return Err(VizError::Settings(format!(
                "no whole-centisecond frame delay for dt = {dt} s"
            )));
        }
    }
}

/// Writes the run's animation. `max_frames` bounds the file size.
pub fn write_gif(
    log: &SimulationLog,
    style: &Style,
    path: &Path,
    max_frames: usize,
) -> Result<usize, VizError> {
    fonts();
    let t = ego(log).ok_or_else(|| {
        VizError::Empty("the log has no actor samples: nothing to animate".into())
    })?;
    let [w, h] = style.frame_size;
    check_size(w, h)?;
    let n = t.len();
    let (stride, delay) = frame_timing(log.dt, n, max_frames)?;
    let bounds = world_bounds(log);
    let time_of = crate::draw::time_of(log);
    let times = crate::draw::times(&time_of, &t.tick, log.dt);
    let x_range = times.first().zip(times.last()).map(|(a, b)| (*a, *b));
    let mut frames = 0;
    {
        let mut out = crate::gif_out::GifOut::create(path, w, h, delay, style)?;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        let mut i = 0;
        while i < n {
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                root.fill(&style.c(&style.background)).map_err(draw_err)?;
                let (left, right) = root.split_horizontally((w as f64 * 0.64) as u32);
                let mut chart =
                    map_chart(&left, log, &format!("t = {:.2} s", times[i]), style, bounds)?;
                let trail: Vec<(f64, f64)> = t.state.x[..=i]
                    .iter()
                    .copied()
                    .zip(t.state.y[..=i].iter().copied())
                    .collect();
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        trail,
                        style.c(&style.trajectory).stroke_width(style.line_width),
                    )))
                    .map_err(draw_err)?;
                if let Some(tr) = &log.tracking {
                    // The latest MPC cycle at or before this frame.
                    let c = tr.tick.partition_point(|k| *k <= t.tick[i]);
                    if c > 0 {
                        let pred: Vec<(f64, f64)> =
                            tr.predictions[c - 1].iter().map(|z| (z[0], z[1])).collect();
                        let hc = style.c(&style.horizon);
                        chart
                            .draw_series(std::iter::once(PathElement::new(
                                pred.clone(),
                                hc.stroke_width(2),
                            )))
                            .map_err(draw_err)?;
                        chart
                            .draw_series(pred.into_iter().map(|p| Circle::new(p, 2, hc.filled())))
                            .map_err(draw_err)?;
                    }
                }
                for other in log.tracks.iter().filter(|o| o.id != t.id) {
                    if let Some(j) = other.tick.iter().position(|k| *k == t.tick[i]) {
                        draw_track_vehicle(&mut chart, other, j, 0.0, RGBColor(120, 120, 120))?;
                    }
                }
                let steer = t.control.steering_angle[i];
                draw_track_vehicle(&mut chart, t, i, steer, style.c(&style.vehicle))?;
                let (top, bottom) = right.split_vertically(h / 2);
                let upto = |v: &[f64]| {
                    times[..=i]
                        .iter()
                        .copied()
                        .zip(v[..=i].iter().copied())
                        .collect::<Vec<_>>()
                };
                series_panel(
                    &top,
                    "speed",
                    "v [m/s]",
                    &[("v".into(), style.series(0), upto(&t.state.speed))],
                    style,
                    x_range,
                )?;
                series_panel(
                    &bottom,
                    "steering",
                    "δ [rad]",
                    &[("δ".into(), style.series(1), upto(&t.control.steering_angle))],
                    style,
                    x_range,
                )?;
                root.present().map_err(draw_err)?;
            }
            out.push(&buf)?;
            frames += 1;
            i += stride;
        }
        out.finish()?;
    }
    Ok(frames)
}
