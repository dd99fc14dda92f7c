//! The nine-panel dashboard (seed 001 §2.2): (1) map with trajectory and
//! vehicle snapshots, (2) velocity, (3) acceleration, (4) steering angle,
//! (5) combined control magnitude, (6) lateral and heading errors,
//! (7) progress along the corridor (or a scenario's planned path), (8) lateral force estimate, (9) slip indicator.

use crate::draw::{draw_track_vehicle, ego, map_chart, series_panel};
use crate::style::Style;
use crate::{VizError, check_size, draw_err, encode_png, fonts, write_atomic};
use litesim_log::SimulationLog;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Draws the panels; returns the pixel positions of `probes` (world points)
/// in the map panel, so that tests can check what was drawn where.
fn panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    log: &SimulationLog,
    style: &Style,
    probes: &[(f64, f64)],
) -> Result<Vec<(i32, i32)>, VizError> {
    let t = ego(log)
        .ok_or_else(|| VizError::Empty("the log has no actor samples: nothing to plot".into()))?;
    root.fill(&style.c(&style.background)).map_err(draw_err)?;
    let areas = root.split_evenly((3, 3));
    let time_of = crate::draw::time_of(log);
    let times = crate::draw::times(&time_of, &t.tick, log.dt);
    let x_range = times.first().zip(times.last()).map(|(a, b)| (*a, *b));
    let s = |i: usize| style.series(i);
    let zip = |v: &[f64]| {
        times
            .iter()
            .copied()
            .zip(v.iter().copied())
            .collect::<Vec<_>>()
    };

    // (1) Map.
    let probed = map_panel(&areas[0], log, t, style, probes)?;
    // (2) Velocity.
    series_panel(
        &areas[1],
        "velocity",
        "v [m/s]",
        &[("speed".into(), s(0), zip(&t.state.speed))],
        style,
        x_range,
    )?;
    // (3) Acceleration: applied and commanded.
    let tr = log.tracking.as_ref();
    let cz = |v: &[f64], ticks: &[u64]| {
        crate::draw::times(&time_of, ticks, log.dt)
            .into_iter()
            .zip(v.iter().copied())
            .collect::<Vec<_>>()
    };
    let mut acc = vec![(
        "applied a_x".to_string(),
        s(0),
        zip(&t.derived.longitudinal_acceleration),
    )];
    if let Some(tr) = tr {
        acc.push((
            tr.command_label().to_string(),
            s(1),
            cz(&tr.cmd_acceleration, &tr.tick),
        ));
    }
    series_panel(&areas[2], "acceleration", "a [m/s²]", &acc, style, x_range)?;
    // (4) Steering.
    let mut steer = vec![(
        "applied δ".to_string(),
        s(0),
        zip(&t.control.steering_angle),
    )];
    if let Some(tr) = tr {
        steer.push((
            tr.command_label().to_string(),
            s(1),
            cz(&tr.cmd_steering, &tr.tick),
        ));
    }
    series_panel(
        &areas[3],
        "steering angle",
        "δ [rad]",
        &steer,
        style,
        x_range,
    )?;
    // (5) Combined control magnitude: |(a / max|a|, δ / max|δ|)| of the run.
    let mag = control_magnitude(t);
    series_panel(
        &areas[4],
        "combined control magnitude",
        "|u| (normalised)",
        &[("|u|".into(), s(3), zip(&mag))],
        style,
        x_range,
    )?;
    // (6) Errors, (7) progress.
    tracking_panels((&areas[5], &areas[6]), log, &cz, style, x_range)?;
    // (8) Lateral force, (9) slip indicators.
    series_panel(
        &areas[7],
        "lateral force estimate",
        "m·a_y [N]",
        &[("F_y".into(), s(4), zip(&t.derived.force_lateral_n))],
        style,
        x_range,
    )?;
    series_panel(
        &areas[8],
        "slip indicators",
        "β [rad] / μ use",
        &[
            ("side-slip β".into(), s(0), zip(&t.derived.slip_angle)),
            ("friction use".into(), s(1), zip(&t.derived.friction_use)),
        ],
        style,
        x_range,
    )?;
    root.present().map_err(draw_err)?;
    Ok(probed)
}

/// Panel (5)'s series: |(a / max|a|, δ / max|δ|)| at each sample of the run.
fn control_magnitude(t: &litesim_log::ActorTrack) -> Vec<f64> {
    let (amax, dmax) = (
        t.derived
            .longitudinal_acceleration
            .iter()
            .fold(
                1e-9,
                |m: f64, v| if v.is_finite() { m.max(v.abs()) } else { m },
            ),
        t.control.steering_angle.iter().fold(
            1e-9,
            |m: f64, v| if v.is_finite() { m.max(v.abs()) } else { m },
        ),
    );
    t.derived
        .longitudinal_acceleration
        .iter()
        .zip(&t.control.steering_angle)
        .map(|(a, d)| {
            ((a / amax).powi(2) + (if d.is_finite() { d / dmax } else { 0.0 }).powi(2)).sqrt()
        })
        .collect()
}

/// Panel (1): the map with the ego's trajectory, five snapshots of it and
/// the other actors' paths; the pixel positions of `probes`.
fn map_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    log: &SimulationLog,
    t: &litesim_log::ActorTrack,
    style: &Style,
    probes: &[(f64, f64)],
) -> Result<Vec<(i32, i32)>, VizError> {
    let mut chart = map_chart(area, log, &format!("trajectory — {}", t.id), style, None)?;
    let path: Vec<(f64, f64)> = t
        .state
        .x
        .iter()
        .copied()
        .zip(t.state.y.iter().copied())
        .collect();
    let tc = style.c(&style.trajectory);
    chart
        .draw_series(std::iter::once(PathElement::new(
            path,
            tc.stroke_width(style.line_width),
        )))
        .map_err(draw_err)?
        .label("driven")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], tc));
    let n = t.len();
    for k in 0..5 {
        let i = if n > 1 { k * (n - 1) / 4 } else { 0 };
        let steer = t.control.steering_angle.get(i).copied().unwrap_or(0.0);
        draw_track_vehicle(&mut chart, t, i, steer, style.c(&style.vehicle))?;
    }
    for other in log.tracks.iter().filter(|o| o.id != t.id && !o.is_empty()) {
        let p: Vec<(f64, f64)> = other
            .state
            .x
            .iter()
            .copied()
            .zip(other.state.y.iter().copied())
            .collect();
        chart
            .draw_series(std::iter::once(PathElement::new(
                p,
                RGBColor(120, 120, 120).stroke_width(1),
            )))
            .map_err(draw_err)?;
    }
    crate::draw::legend(&mut chart, style, Some(SeriesLabelPosition::LowerRight))?;
    Ok(probes.iter().map(|p| chart.backend_coord(p)).collect())
}

/// Puts a column sampled at `ticks` on the time axis.
type OnTimeAxis<'a> = dyn Fn(&[f64], &[u64]) -> Vec<(f64, f64)> + 'a;

/// Panels (6) and (7): tracking errors and progress along the reference
/// (`cz` puts a tracking column on the time axis), or empty panels saying
/// nothing was tracked.
fn tracking_panels<DB: DrawingBackend>(
    areas: (&DrawingArea<DB, Shift>, &DrawingArea<DB, Shift>),
    log: &SimulationLog,
    cz: &OnTimeAxis<'_>,
    style: &Style,
    x_range: Option<(f64, f64)>,
) -> Result<(), VizError> {
    let s = |i: usize| style.series(i);
    let tr = log.tracking.as_ref();
    let reference = log
        .plan
        .as_ref()
        .map_or("corridor", |p| p.reference_label());
    match tr {
        Some(tr) => {
            series_panel(
                areas.0,
                "tracking errors",
                "error [m] / [rad]",
                &[
                    ("lateral [m]".into(), s(0), cz(&tr.lateral_error, &tr.tick)),
                    (
                        "heading [rad]".into(),
                        s(1),
                        cz(&tr.heading_error, &tr.tick),
                    ),
                ],
                style,
                x_range,
            )?;
            series_panel(
                areas.1,
                &format!("progress along the {reference}"),
                "s [m]",
                &[("progress".into(), s(2), cz(&tr.progress, &tr.tick))],
                style,
                x_range,
            )?;
        }
        None => {
            series_panel(
                areas.0,
                &format!("tracking errors (no {reference} tracked)"),
                "",
                &[],
                style,
                x_range,
            )?;
            series_panel(
                areas.1,
                &format!("progress (no {reference} tracked)"),
                "",
                &[],
                style,
                x_range,
            )?;
        }
    }
    Ok(())
}

/// Renders the dashboard to RGB pixels (width, height from the style).
pub fn render_rgb(log: &SimulationLog, style: &Style) -> Result<(Vec<u8>, u32, u32), VizError> {
    render_rgb_probed(log, style, &[]).map(|(b, w, h, _)| (b, w, h))
}

/// Pixels, width, height and the probes' pixel positions.
pub type Probed = (Vec<u8>, u32, u32, Vec<(i32, i32)>);

/// Like [`render_rgb`], also returning where the world points `probes`
/// land in the map panel (pixels).
pub fn render_rgb_probed(
    log: &SimulationLog,
    style: &Style,
    probes: &[(f64, f64)],
) -> Result<Probed, VizError> {
    fonts();
    let [w, h] = style.dashboard_size;
    check_size(w, h)?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    let probed = {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        panels(&root, log, style, probes)?
    };
    Ok((buf, w, h, probed))
}

/// Writes the dashboard as PNG.
pub fn write_png(log: &SimulationLog, style: &Style, path: &Path) -> Result<(), VizError> {
    let (buf, w, h) = render_rgb(log, style)?;
    write_atomic(path, &encode_png(&buf, w, h)?)
}

/// Renders the dashboard as SVG text.
pub fn render_svg(log: &SimulationLog, style: &Style) -> Result<String, VizError> {
    fonts();
    let [w, h] = style.dashboard_size;
    check_size(w, h)?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, (w, h)).into_drawing_area();
        panels(&root, log, style, &[])?;
    }
    Ok(s)
}

/// Writes the dashboard as SVG.
pub fn write_svg(log: &SimulationLog, style: &Style, path: &Path) -> Result<(), VizError> {
    write_atomic(path, render_svg(log, style)?.as_bytes())
}
