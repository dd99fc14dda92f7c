//! Shared drawing: the map panel (grid layers, corridors, trajectories),
//! vehicle footprints with steered wheels, time-series panels.

use crate::style::Style;
use crate::{VizError, draw_err};
use litesim_log::{ActorTrack, SimulationLog};
use plotters::coord::Shift;
use plotters::prelude::*;

pub type Range2 = ((f64, f64), (f64, f64));
/// A polyline in world metres.
pub type Points = Vec<(f64, f64)>;
/// A named, coloured time series.
pub type Series = (String, RGBColor, Points);
/// Body outline, four wheels, heading arrow.
pub type VehicleShapes = (Points, Vec<Points>, Points);

/// The track of the ego vehicle: "ego", else "sut.car", else the first track.
pub fn ego(log: &SimulationLog) -> Option<&ActorTrack> {
    log.track("ego")
        .or_else(|| log.track("sut.car"))
        .or_else(|| log.tracks.first())
        .filter(|t| !t.is_empty())
}

/// Simulation time of each recorded tick.
pub fn time_of(log: &SimulationLog) -> std::collections::BTreeMap<u64, f64> {
    log.tick
        .iter()
        .copied()
        .zip(log.time.iter().copied())
        .collect()
}

/// Times (s) of `ticks`; ticks the log's axis lacks fall back to `tick · dt`.
pub fn times(time_of: &std::collections::BTreeMap<u64, f64>, ticks: &[u64], dt: f64) -> Vec<f64> {
    ticks
        .iter()
        .map(|k| time_of.get(k).copied().unwrap_or(*k as f64 * dt))
        .collect()
}

/// World bounds of what a map view shows: the plan grid, else every track, with a margin.
pub fn world_bounds(log: &SimulationLog) -> Option<Range2> {
    if let Some(p) = &log.plan {
        let g = &p.grid;
        if g.width > 0 && g.height > 0 {
            let (x0, y0) = (g.origin[0], g.origin[1]);
            return Some((
                (x0, x0 + g.width as f64 * g.resolution),
                (y0, y0 + g.height as f64 * g.resolution),
            ));
        }
    }
    path_bounds(log).map(|((x0, x1), (y0, y1))| {
        let m = ((x1 - x0).max(y1 - y0) * 0.08).max(5.0);
        ((x0 - m, x1 + m), (y0 - m, y1 + m))
    })
}

/// The extent of every actor's finite positions (no margin).
pub fn path_bounds(log: &SimulationLog) -> Option<Range2> {
    let mut b: Option<Range2> = None;
    for t in &log.tracks {
        for (x, y) in t.state.x.iter().zip(&t.state.y) {
            if x.is_finite() && y.is_finite() {
                let r = b.get_or_insert(((*x, *x), (*y, *y)));
                r.0 = (r.0.0.min(*x), r.0.1.max(*x));
                r.1 = (r.1.0.min(*y), r.1.1.max(*y));
            }
        }
    }
    b
}

/// Widens a range so that metres have the same size on both axes for a plot area of `w × h` px.
pub fn equal_aspect(r: Range2, w: f64, h: f64) -> Range2 {
    let ((x0, x1), (y0, y1)) = r;
    let (dx, dy) = ((x1 - x0).max(1e-6), (y1 - y0).max(1e-6));
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    if dx / dy > w / h {
        let ny = dx * h / w;
        ((x0, x1), (cy - ny / 2.0, cy + ny / 2.0))
    } else {
        let nx = dy * w / h;
        ((cx - nx / 2.0, cx + nx / 2.0), (y0, y1))
    }
}

/// Footprint polygon and four wheels of a vehicle whose state point is its
/// rear axle (wheelbase ≈ 0.6 · length, rear overhang 0.2 · length).
pub fn vehicle_shapes(
    x: f64,
    y: f64,
    yaw: f64,
    length: f64,
    width: f64,
    steer: f64,
) -> VehicleShapes {
    let (s, c) = litesim_core::math::sin_cos(yaw);
    let at = |along: f64, across: f64| (x + along * c - across * s, y + along * s + across * c);
    let rear = 0.2 * length;
    let wb = litesim_core::seed_wheelbase(length);
    let body = vec![
        at(-rear, -width / 2.0),
        at(length - rear, -width / 2.0),
        at(length - rear, width / 2.0),
        at(-rear, width / 2.0),
    ];
    let (wl, ww) = (0.16 * length, 0.12 * width.max(0.5));
    let wheel = |ax: f64, ay: f64, ang: f64| {
        let (sa, ca) = litesim_core::math::sin_cos(ang);
        [(-wl, -ww), (wl, -ww), (wl, ww), (-wl, ww)]
            .iter()
            .map(|(u, v)| at(ax + u * ca - v * sa, ay + u * sa + v * ca))
            .collect::<Vec<_>>()
    };
    let st = if steer.is_finite() { steer } else { 0.0 };
    let wheels = vec![
        wheel(0.0, width / 2.0 - ww, 0.0),
        wheel(0.0, -width / 2.0 + ww, 0.0),
        wheel(wb, width / 2.0 - ww, st),
        wheel(wb, -width / 2.0 + ww, st),
    ];
    let arrow = vec![at(wb * 0.5, 0.0), at(length - rear + 0.6, 0.0)];
    (body, wheels, arrow)
}

/// Draws the map view: plan grid layers, corridor, raw path, trajectory.
pub fn map_chart<'a, DB: DrawingBackend + 'a>(
    area: &'a DrawingArea<DB, Shift>,
    log: &SimulationLog,
    title: &str,
    style: &Style,
    range: Option<Range2>,
) -> Result<
    ChartContext<
        'a,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    VizError,
> {
    let bounds = range
        .or_else(|| world_bounds(log))
        .ok_or_else(|| VizError::Empty("the log has no positions to draw".into()))?;
    let (w, h) = area.dim_in_pixel();
    let (lx, ly) = (45.0, 30.0);
    let r = equal_aspect(
        bounds,
        (w as f64 - lx - 10.0).max(10.0),
        (h as f64 - ly - 30.0).max(10.0),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", style.title_font))
        .margin(6)
        .x_label_area_size(ly as u32)
        .y_label_area_size(lx as u32)
        .build_cartesian_2d(r.0.0..r.0.1, r.1.0..r.1.1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style(("sans-serif", style.tick_font))
        .axis_desc_style(("sans-serif", style.label_font))
        .draw()
        .map_err(draw_err)?;
    if let Some(p) = &log.plan {
        let g = &p.grid;
        let colours = [
            style.c(&style.free),
            style.c(&style.inflated),
            style.c(&style.obstacle),
        ];
        // Run-length per row: one rectangle per run of equal cells.
        let mut rects = Vec::new();
        for j in 0..g.height {
            let mut i = 0;
            while i < g.width {
                let v = g.cells[j * g.width + i];
                let start = i;
                while i < g.width && g.cells[j * g.width + i] == v {
                    i += 1;
                }
                let x0 = g.origin[0] + start as f64 * g.resolution;
                let x1 = g.origin[0] + i as f64 * g.resolution;
                let y0 = g.origin[1] + j as f64 * g.resolution;
                rects.push(Rectangle::new(
                    [(x0, y0), (x1, y0 + g.resolution)],
                    colours[(v as usize).min(2)].filled(),
                ));
            }
        }
        chart.draw_series(rects).map_err(draw_err)?;
        let line = |pts: &[[f64; 2]]| pts.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>();
        // A scenario's plan has no raw planner path: no empty legend entry.
        if !p.raw_path.is_empty() {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    line(&p.raw_path),
                    style.c(&style.raw_path).stroke_width(1),
                )))
                .map_err(draw_err)?
                .label("raw path")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], RGBColor(148, 103, 189))
                });
        }
        let cc = style.c(&style.corridor);
        chart
            .draw_series(std::iter::once(PathElement::new(
                line(&p.corridor),
                cc.stroke_width(style.corridor_width),
            )))
            .map_err(draw_err)?
            .label(p.reference_label())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], cc));
    }
    Ok(chart)
}

/// Draws an actor of a log at its sample `i` (pose and size from the track).
pub fn draw_track_vehicle<DB: DrawingBackend>(
    chart: &mut ChartContext<
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    t: &ActorTrack,
    i: usize,
    steer: f64,
    colour: RGBColor,
) -> Result<(), VizError> {
    draw_vehicle(
        chart,
        t.state.x[i],
        t.state.y[i],
        t.state.yaw[i],
        t.length,
        t.width,
        steer,
        colour,
    )
}

/// Draws a vehicle on a chart (pose, size, steering and colour are all
/// needed; a parameter struct would only rename them).
#[allow(clippy::too_many_arguments)]
pub fn draw_vehicle<DB: DrawingBackend>(
    chart: &mut ChartContext<
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    x: f64,
    y: f64,
    yaw: f64,
    length: f64,
    width: f64,
    steer: f64,
    colour: RGBColor,
) -> Result<(), VizError> {
    let (length, width) = (
        if length > 0.0 { length } else { 4.5 },
        if width > 0.0 { width } else { 1.8 },
    );
    let (body, wheels, arrow) = vehicle_shapes(x, y, yaw, length, width, steer);
    chart
        .draw_series(std::iter::once(Polygon::new(
            body.clone(),
            colour.mix(0.55).filled(),
        )))
        .map_err(draw_err)?;
    let mut outline = body;
    outline.push(outline[0]);
    chart
        .draw_series(std::iter::once(PathElement::new(
            outline,
            colour.stroke_width(1),
        )))
        .map_err(draw_err)?;
    chart
        .draw_series(wheels.into_iter().map(|w| Polygon::new(w, BLACK.filled())))
        .map_err(draw_err)?;
    chart
        .draw_series(std::iter::once(PathElement::new(
            arrow,
            BLACK.stroke_width(2),
        )))
        .map_err(draw_err)?;
    Ok(())
}

/// One time-series panel; `series` are (name, colour, points). An empty
/// panel says what is missing.
pub fn series_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    y_desc: &str,
    series: &[Series],
    style: &Style,
    x_range: Option<(f64, f64)>,
) -> Result<(), VizError> {
    let pts: Vec<&(f64, f64)> = series
        .iter()
        .flat_map(|s| s.2.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    if pts.is_empty() {
        let (w, h) = area.dim_in_pixel();
        area.draw(&Text::new(
            format!("{title}: no data in this log"),
            (w as i32 / 8, h as i32 / 2),
            ("sans-serif", style.label_font),
        ))
        .map_err(draw_err)?;
        return Ok(());
    }
    let (mut x0, mut x1) = x_range.unwrap_or((f64::MAX, f64::MIN));
    if x_range.is_none() {
        for p in &pts {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
        }
    }
    let (mut y0, mut y1) = (f64::MAX, f64::MIN);
    for p in &pts {
        y0 = y0.min(p.1);
        y1 = y1.max(p.1);
    }
    if x1 - x0 < 1e-9 {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.08).max(1e-3);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", style.title_font))
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(y_desc)
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", style.tick_font))
        .axis_desc_style(("sans-serif", style.label_font))
        .draw()
        .map_err(draw_err)?;
    for (name, colour, s) in series {
        let c = *colour;
        chart
            .draw_series(LineSeries::new(
                s.iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite()),
                c.stroke_width(style.line_width),
            ))
            .map_err(draw_err)?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
    }
    if series.len() > 1 || !series[0].0.is_empty() {
        legend(&mut chart, style, None)?;
    }
    Ok(())
}

/// A chart's legend in the style's font on a pale box; at `at`, else
/// where plotters puts it.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    style: &Style,
    at: Option<SeriesLabelPosition>,
) -> Result<(), VizError> {
    let mut labels = chart.configure_series_labels();
    labels
        .label_font(("sans-serif", style.tick_font))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180));
    if let Some(at) = at {
        labels.position(at);
    }
    labels.draw().map_err(draw_err)
}
