//! Scenario replays for multi-actor runs: every actor's track on the road
//! map (PNG), and a GIF of all actors' footprints over time.

use crate::animation::frame_timing;
use crate::draw::{Range2, draw_track_vehicle, equal_aspect, path_bounds, world_bounds};
use crate::style::Style;
use crate::{VizError, check_size, draw_err, encode_png, fonts, write_atomic};
use litesim_log::SimulationLog;
use plotters::prelude::*;
use std::path::Path;

/// What a replay draws under the actors: lane areas, lane lines and road
/// marks, in world metres (built from an OpenDRIVE map by the caller).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Background {
    /// Lane areas (outline polygons), drawn first.
    pub areas: Vec<Area>,
    /// Lines, drawn over the areas in order.
    pub lines: Vec<MapLine>,
}

/// A filled lane area.
#[derive(Clone, Debug, PartialEq)]
pub struct Area {
    /// Outline (closed implicitly).
    pub outline: Vec<(f64, f64)>,
    /// Drivable road (true) or sidewalk / other lane (false).
    pub drivable: bool,
}

/// A line of the map.
#[derive(Clone, Debug, PartialEq)]
pub struct MapLine {
    /// Points (m).
    pub points: Vec<(f64, f64)>,
    /// How to draw it.
    pub kind: LineKind,
}

/// How a map line is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// A lane border without a road mark: thin, in the `lanes` colour.
    Border,
    /// A lane centre line: thin, light.
    Centre,
    /// A road mark (OpenDRIVE `solid`, `broken`, `solid solid`, …).
    Mark {
        /// Dashed (`broken`, and the broken half of mixed types).
        broken: bool,
        /// Two lines (`solid solid`, `broken broken`, `solid broken`, …), drawn bold.
        double: bool,
        /// Yellow (`yellow`, `orange`) rather than white.
        yellow: bool,
    },
}

impl LineKind {
    /// The kind of an OpenDRIVE road mark, or `None` for marks that are not
    /// painted lines (`none`, `grass`, `curb`, `edge`, `botts dots`, …: the
    /// border is drawn plain then).
    pub fn of_mark(kind: &str, color: &str) -> Option<LineKind> {
        let kind = kind.trim().to_ascii_lowercase();
        let (broken, double) = match kind.as_str() {
            "solid" => (false, false),
            "broken" => (true, false),
            "solid solid" => (false, true),
            "broken broken" | "solid broken" | "broken solid" => (true, true),
            _ => return None,
        };
        let yellow = matches!(
            color.trim().to_ascii_lowercase().as_str(),
            "yellow" | "orange"
        );
        Some(LineKind::Mark {
            broken,
            double,
            yellow,
        })
    }
}

/// Dash pattern of broken marks (m): 3 m painted, 9 m gap, the pattern
/// OpenDRIVE's own examples use for `broken` when no `<type>` is given.
const DASH: (f64, f64) = (3.0, 9.0);

/// Splits a polyline into its dashes.
fn dashes(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    // Position within the pattern (m); painted while < DASH.0.
    let mut phase = 0.0;
    let period = DASH.0 + DASH.1;
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        if !(len.is_finite() && len > 0.0) {
            continue;
        }
        let mut done = 0.0;
        while done < len {
            let painted = phase < DASH.0;
            let room = if painted {
                DASH.0 - phase
            } else {
                period - phase
            };
            let step = room.min(len - done);
            let at = |d: f64| (a.0 + (b.0 - a.0) * d / len, a.1 + (b.1 - a.1) * d / len);
            if painted {
                if cur.is_empty() {
                    cur.push(at(done));
                }
                cur.push(at(done + step));
            }
            done += step;
            phase += step;
            if phase >= period - 1e-12 {
                phase = 0.0;
            }
            if phase >= DASH.0 && !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
        }
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

/// The parts of a polyline inside `view` (Liang–Barsky per segment; a part
/// ends where the line leaves the view).
fn clip_polyline(points: &[(f64, f64)], view: Range2) -> Vec<Vec<(f64, f64)>> {
    let ((x0, x1), (y0, y1)) = view;
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        // A segment with a non-finite end is not drawn.
        let mut inside = [a.0, a.1, b.0, b.1].iter().all(|v| v.is_finite());
        for (p, q) in [
            (-dx, a.0 - x0),
            (dx, x1 - a.0),
            (-dy, a.1 - y0),
            (dy, y1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    inside = false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        if !inside || t0 > t1 || t0.is_nan() || t1.is_nan() {
            if cur.len() >= 2 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        // The ends themselves where uncut, so that pieces join exactly.
        let p0 = if t0 == 0.0 {
            a
        } else {
            (a.0 + t0 * dx, a.1 + t0 * dy)
        };
        let p1 = if t1 == 1.0 {
            b
        } else {
            (a.0 + t1 * dx, a.1 + t1 * dy)
        };
        if cur.last() != Some(&p0) {
            if cur.len() >= 2 {
                out.push(std::mem::take(&mut cur));
            }
            cur = vec![p0];
        }
        cur.push(p1);
        if t1 < 1.0 {
            out.push(std::mem::take(&mut cur));
        }
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

/// A polygon cut to `view` (Sutherland–Hodgman against its four sides).
fn clip_polygon(outline: &[(f64, f64)], view: Range2) -> Vec<(f64, f64)> {
    let ((x0, x1), (y0, y1)) = view;
    // Each side: inside test and the crossing of segment a→b with it.
    type Side = (
        fn(f64, (f64, f64)) -> bool,
        fn(f64, (f64, f64), (f64, f64)) -> (f64, f64),
    );
    let at_x =
        |c: f64, a: (f64, f64), b: (f64, f64)| (c, a.1 + (b.1 - a.1) * (c - a.0) / (b.0 - a.0));
    let at_y =
        |c: f64, a: (f64, f64), b: (f64, f64)| (a.0 + (b.0 - a.0) * (c - a.1) / (b.1 - a.1), c);
    let sides: [(f64, Side); 4] = [
        (x0, (|c, p| p.0 >= c, at_x)),
        (x1, (|c, p| p.0 <= c, at_x)),
        (y0, (|c, p| p.1 >= c, at_y)),
        (y1, (|c, p| p.1 <= c, at_y)),
    ];
    // Non-finite vertices are dropped (the rest still outline the area).
    let mut poly: Vec<(f64, f64)> = outline
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    for (c, (inside, cross)) in sides {
        let Some(&last) = poly.last() else { break };
        let mut out = Vec::with_capacity(poly.len() + 4);
        let mut prev = last;
        for &p in &poly {
            match (inside(c, prev), inside(c, p)) {
                (true, true) => out.push(p),
                (true, false) => out.push(cross(c, prev, p)),
                (false, true) => {
                    out.push(cross(c, prev, p));
                    out.push(p);
                }
                (false, false) => {}
            }
            prev = p;
        }
        poly = out;
    }
    poly
}

/// Draws the background on a replay chart.
fn draw_background<DB: DrawingBackend>(
    chart: &mut ChartContext<
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    bg: &Background,
    style: &Style,
    view: Range2,
) -> Result<(), VizError> {
    let (road, walk) = (style.c(&style.road), style.c(&style.sidewalk));
    // plotters pins points outside the axes to their edge, which would draw
    // the map beyond the view along the frame: clip to the view first.
    chart
        .draw_series(bg.areas.iter().filter_map(|a| {
            let outline = clip_polygon(&a.outline, view);
            (outline.len() >= 3)
                .then(|| Polygon::new(outline, if a.drivable { road } else { walk }.filled()))
        }))
        .map_err(draw_err)?;
    let (lanes, white, yellow) = (
        style.c(&style.lanes),
        style.c(&style.mark_white),
        style.c(&style.mark_yellow),
    );
    for l in &bg.lines {
        let (colour, width, broken) = match l.kind {
            LineKind::Border => (lanes.to_rgba(), 1, false),
            LineKind::Centre => (lanes.mix(0.35), 1, false),
            LineKind::Mark {
                broken,
                double,
                yellow: y,
            } => (
                if y { yellow } else { white }.to_rgba(),
                if double { 3 } else { 2 },
                broken,
            ),
        };
        let parts = if broken {
            dashes(&l.points)
        } else {
            vec![l.points.clone()]
        };
        let parts = parts.iter().flat_map(|p| clip_polyline(p, view));
        chart
            .draw_series(parts.map(|p| PathElement::new(p, colour.stroke_width(width))))
            .map_err(draw_err)?;
    }
    Ok(())
}

fn frame<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    log: &SimulationLog,
    bg: &Background,
    style: &Style,
    tick: Option<u64>,
    title: &str,
) -> Result<Drawn, VizError> {
    let b = framed(log)?;
    let builder = || {
        let mut c = ChartBuilder::on(root);
        c.caption(title, ("sans-serif", style.title_font))
            .margin(6)
            .x_label_area_size(30)
            .y_label_area_size(45);
        c
    };
    // Equal axes exactly: the plot area's pixel size is measured on a
    // probe chart, then the ranges are widened to its shape.
    root.fill(&style.c(&style.background)).map_err(draw_err)?;
    let probe = builder()
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(draw_err)?;
    let (pw, ph) = probe.plotting_area().dim_in_pixel();
    root.fill(&style.c(&style.background)).map_err(draw_err)?;
    let r = equal_aspect(b, pw as f64, ph as f64);
    let mut chart = builder()
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
    draw_background(&mut chart, bg, style, r)?;
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
            // The id beside the box: legible without matching colours.
            let (x, y) = (t.state.x[i], t.state.y[i]);
            if x.is_finite() && y.is_finite() {
                chart
                    .draw_series(std::iter::once(Text::new(
                        t.id.clone(),
                        (x, y + t.width.max(1.0)),
                        ("sans-serif", style.tick_font).into_font().color(&BLACK),
                    )))
                    .map_err(draw_err)?;
            }
        }
    }
    crate::draw::legend(&mut chart, style, Some(SeriesLabelPosition::UpperRight))?;
    root.present().map_err(draw_err)?;
    Ok(Drawn {
        view: r,
        plot_px: (pw, ph),
    })
}

/// What [`frame`] drew: the world ranges and the plot area's pixel size
/// (what the tests check equal axes and framing on).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
struct Drawn {
    view: Range2,
    plot_px: (u32, u32),
}

/// The world area a replay shows: the actors' paths, not the whole map (a
/// 500 m road with two cars on 100 m of it would draw them as specks), with
/// a margin of 10 % of their extent and at least 8 m, where the map shows
/// around them.
fn framed(log: &SimulationLog) -> Result<Range2, VizError> {
    // A planner run frames its grid; a scenario run its actors' paths
    // (their bare extent: the margin is added once, here).
    let grid = log
        .plan
        .as_ref()
        .is_some_and(|p| p.grid.width > 0 && p.grid.height > 0);
    let b = if grid {
        world_bounds(log)
    } else {
        path_bounds(log)
    }
    .ok_or_else(|| VizError::Empty("the log has no positions to replay".into()))?;
    let m = ((b.0.1 - b.0.0).max(b.1.1 - b.1.0) * 0.10).max(8.0);
    Ok(((b.0.0 - m, b.0.1 + m), (b.1.0 - m, b.1.1 + m)))
}

/// Pixel size of the overview picture: metres are equal on both axes, so
/// the picture takes the shape of what it frames — a long straight run is
/// a wide, low picture (up to twice the stylesheet's width) rather than a
/// thin strip in a square; a compact one keeps the stylesheet's size.
pub fn overview_size(log: &SimulationLog, style: &Style) -> Result<(u32, u32), VizError> {
    let [w, h] = style.frame_size;
    let ((x0, x1), (y0, y1)) = framed(log)?;
    let ratio = (x1 - x0).max(1e-6) / (y1 - y0).max(1e-6);
    // Chrome around the plot area: title, axis labels (see `frame`).
    let (cw, ch) = (55.0, 60.0);
    let width = (w as f64 * (ratio / 1.33).clamp(1.0, 2.0)).round();
    let height = ((width - cw) / ratio + ch).clamp(300.0_f64.min(h as f64), h as f64);
    Ok((width as u32, height.round() as u32))
}

/// Writes the replay overview (all tracks) as PNG.
pub fn write_png(
    log: &SimulationLog,
    background: &Background,
    style: &Style,
    path: &Path,
) -> Result<(), VizError> {
    fonts();
    let (w, h) = overview_size(log, style)?;
    check_size(w, h)?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        frame(
            &root,
            log,
            background,
            style,
            None,
            &match log.tracks.len() {
                1 => "1 actor".to_string(),
                n => format!("{n} actors"),
            },
        )?;
    }
    write_atomic(path, &encode_png(&buf, w, h)?)
}

/// Writes the replay GIF, timed like [`crate::animation`].
pub fn write_gif(
    log: &SimulationLog,
    background: &Background,
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
    let mut n = 0;
    {
        let mut out = crate::gif_out::GifOut::create(path, w, h, delay, style)?;
        let mut buf = vec![0u8; (w * h * 3) as usize];
        for (tick, time) in log.tick.iter().zip(&log.time).step_by(stride) {
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                frame(
                    &root,
                    log,
                    background,
                    style,
                    Some(*tick),
                    &format!("t = {time:.2} s"),
                )?;
            }
            out.push(&buf)?;
            n += 1;
        }
        out.finish()?;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use litesim_log::{ActorSample, LogRecorder};

    /// Two cars on 200 m of straight road, 3.5 m apart.
    fn straight_run() -> SimulationLog {
        let mut rec = LogRecorder::new(0.1);
        rec.actor("sut.car", "vehicle/car", "car", 4.6, 1.9, 1500.0);
        rec.actor("other", "vehicle/car", "car", 4.6, 1.9, 1500.0);
        for k in 0..100u64 {
            rec.begin(k, k as f64 * 0.1);
            for (id, y, v) in [("sut.car", -8.75, 18.0), ("other", -5.25, 20.0)] {
                let s = ActorSample::from_kinematics(
                    litesim_core::geometry::Pose::planar(100.0 + v * k as f64 * 0.1, y, 0.0),
                    litesim_core::geometry::Vec3::new(v, 0.0, 0.0),
                    litesim_core::geometry::Vec3::new(0.0, 0.0, 0.0),
                    0.0,
                    v,
                    1500.0,
                );
                rec.sample(id, "trajectory", &s);
            }
        }
        rec.finish()
    }

    #[test]
    fn the_overview_has_equal_axes_and_frames_the_paths() {
        let log = straight_run();
        let style = Style::default();
        let (w, h) = overview_size(&log, &style).unwrap();
        // A long straight run makes a wide, low picture.
        assert!(w as f64 > 2.0 * h as f64, "{w}×{h}");
        fonts();
        let mut buf = vec![0u8; (w * h * 3) as usize];
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let d = frame(&root, &log, &Background::default(), &style, None, "t").unwrap();
        let ((x0, x1), (y0, y1)) = d.view;
        let (pw, ph) = d.plot_px;
        // Metres per pixel equal on both axes (to the pixel rounding).
        let (mx, my) = ((x1 - x0) / pw as f64, (y1 - y0) / ph as f64);
        assert!((mx / my - 1.0).abs() < 1e-9, "{mx} vs {my} m/px");
        // Every path inside, with at least 8 m around it; and tight: the
        // view is not more than the paths plus their margin on the long axis.
        for t in &log.tracks {
            for (x, y) in t.state.x.iter().zip(&t.state.y) {
                assert!(*x >= x0 + 8.0 && *x <= x1 - 8.0 && *y >= y0 + 8.0 && *y <= y1 - 8.0);
            }
        }
        assert!(x1 - x0 <= 198.0 * 1.2 + 1e-6 + 2.0 * 8.0, "{x0}..{x1}");
        // Cars are legible: at least 4 px per metre (a car ≥ 18 px long).
        assert!(1.0 / mx >= 4.0, "{} px/m", 1.0 / mx);
    }

    #[test]
    fn dashes_keep_their_pattern_across_vertices() {
        // 24 m in two pieces (10 m + 14 m): dashes at 0–3 m and 12–15 m.
        let d = dashes(&[(0.0, 0.0), (10.0, 0.0), (24.0, 0.0)]);
        assert_eq!(d.len(), 2, "{d:?}");
        assert_eq!(d[0], vec![(0.0, 0.0), (3.0, 0.0)]);
        assert_eq!(d[1].first(), Some(&(12.0, 0.0)));
        assert_eq!(d[1].last(), Some(&(15.0, 0.0)));
        // A dash across a vertex bends with the line.
        let d = dashes(&[(0.0, 0.0), (2.0, 0.0), (2.0, 5.0)]);
        assert_eq!(d[0], vec![(0.0, 0.0), (2.0, 0.0), (2.0, 1.0)]);
        assert!(dashes(&[(1.0, 1.0)]).is_empty());
        assert!(dashes(&[(0.0, 0.0), (f64::NAN, 0.0)]).is_empty());
    }

    #[test]
    fn clipping_to_the_view() {
        let view = ((0.0, 10.0), (0.0, 10.0));
        // In, out, back in: two pieces, cut at the edge.
        let pieces = clip_polyline(&[(5.0, 5.0), (15.0, 5.0), (15.0, 8.0), (5.0, 8.0)], view);
        assert_eq!(
            pieces,
            vec![vec![(5.0, 5.0), (10.0, 5.0)], vec![(10.0, 8.0), (5.0, 8.0)]]
        );
        // Wholly inside: unchanged; wholly outside: nothing.
        let inside = vec![(1.0, 1.0), (2.0, 3.0), (4.0, 4.0)];
        assert_eq!(clip_polyline(&inside, view), vec![inside.clone()]);
        assert!(clip_polyline(&[(20.0, 20.0), (30.0, 25.0)], view).is_empty());
        // A rectangle sticking out of the view's top is cut at y = 10.
        let poly = clip_polygon(&[(2.0, 5.0), (8.0, 5.0), (8.0, 20.0), (2.0, 20.0)], view);
        assert!(poly.iter().all(|p| p.1 <= 10.0 && p.1 >= 5.0), "{poly:?}");
        assert!(
            poly.contains(&(8.0, 10.0)) && poly.contains(&(2.0, 10.0)),
            "{poly:?}"
        );
        assert!(clip_polygon(&[(20.0, 20.0), (30.0, 20.0), (30.0, 30.0)], view).is_empty());
    }

    proptest::proptest! {
        /// Whatever the input (far away, degenerate, NaN), clipping never
        /// panics and every point it returns lies in the view.
        #[test]
        fn clipped_points_lie_in_the_view(
            pts in proptest::collection::vec((-50.0f64..60.0, -50.0f64..60.0), 0..12),
            nan in proptest::bool::ANY,
        ) {
            let view = ((0.0, 10.0), (0.0, 10.0));
            let mut pts = pts;
            if nan && !pts.is_empty() {
                pts[0].0 = f64::NAN;
            }
            let ok = |p: &(f64, f64)| {
                (-1e-9..=10.0 + 1e-9).contains(&p.0) && (-1e-9..=10.0 + 1e-9).contains(&p.1)
            };
            for piece in clip_polyline(&pts, view) {
                proptest::prop_assert!(piece.len() >= 2);
                proptest::prop_assert!(piece.iter().all(ok), "{piece:?}");
            }
            let poly = clip_polygon(&pts, view);
            proptest::prop_assert!(poly.iter().all(ok), "{poly:?}");
        }
    }

    #[test]
    fn mark_kinds() {
        let m = |k, c| LineKind::of_mark(k, c);
        assert_eq!(
            m("broken", "standard"),
            Some(LineKind::Mark {
                broken: true,
                double: false,
                yellow: false
            })
        );
        assert_eq!(
            m("solid solid", "yellow"),
            Some(LineKind::Mark {
                broken: false,
                double: true,
                yellow: true
            })
        );
        assert_eq!(m("none", "standard"), None);
        assert_eq!(m("curb", "standard"), None);
        assert_eq!(m("botts dots", "white"), None);
    }
}
