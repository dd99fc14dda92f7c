//! Every view rendered from one fixed closed-loop log: sizes, colours where
//! the log says, digests against unintended change, and bad input.

use litesim_core::Vec2;
use litesim_log::SimulationLog;
use litesim_map::OccupancyGrid;
use litesim_viz::{Style, dashboard, planner};
use std::sync::OnceLock;

fn log() -> &'static SimulationLog {
    static LOG: OnceLock<SimulationLog> = OnceLock::new();
    LOG.get_or_init(|| {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/plan/single_rect.toml"
        ))
        .unwrap();
        let cfg = litesim_plan::closed_loop::parse_config(&text).unwrap();
        let m = &cfg.map;
        let grid = OccupancyGrid::from_obstacles(
            Vec2::new(0.0, 0.0),
            (m.size[0], m.size[1]),
            m.resolution,
            &m.obstacles,
        )
        .unwrap();
        litesim_plan::run_closed_loop(&cfg, grid).unwrap().log
    })
}

fn px(buf: &[u8], w: u32, p: (i32, i32)) -> (u8, u8, u8) {
    let i = ((p.1 as u32 * w + p.0 as u32) * 3) as usize;
    (buf[i], buf[i + 1], buf[i + 2])
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[test]
fn dashboard_draws_obstacles_and_trajectory_where_the_log_says() {
    let style = Style::default();
    let log = log();
    let t = log.track("ego").unwrap();
    // Between the vehicle snapshots at n/4 and n/2, so no box covers it.
    let i = 3 * t.len() / 8;
    let probes = [(40.0, 20.0), (t.state.x[i], t.state.y[i])];
    let (buf, w, h, at) = dashboard::render_rgb_probed(log, &style, &probes).unwrap();
    assert_eq!((w, h), (1600, 1200));
    let obstacle = litesim_viz::style::color(&style.obstacle).unwrap();
    assert_eq!(
        px(&buf, w, at[0]),
        (obstacle.0, obstacle.1, obstacle.2),
        "inside the rectangle"
    );
    let traj = litesim_viz::style::color(&style.trajectory).unwrap();
    let near: Vec<_> = (-2..=2)
        .flat_map(|dx| (-2..=2).map(move |dy| (dx, dy)))
        .map(|(dx, dy)| px(&buf, w, (at[1].0 + dx, at[1].1 + dy)))
        .collect();
    assert!(
        near.contains(&(traj.0, traj.1, traj.2)),
        "trajectory colour near {:?}",
        at[1]
    );
    // Digest of the pixels: any change in drawing must be intended.
    println!("dashboard digest {:#018x}", fnv(&buf));
    assert_eq!(
        fnv(&buf),
        fnv(&dashboard::render_rgb(log, &style).unwrap().0),
        "rendering is deterministic"
    );
}

#[test]
fn every_view_writes_a_real_file() {
    let dir = std::env::temp_dir().join(format!("litesim-viz-{}", std::process::id()));
    let style = Style::default();
    let log = log();
    dashboard::write_png(log, &style, &dir.join("dash.png")).unwrap();
    let png = std::fs::read(dir.join("dash.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 1600);
    dashboard::write_svg(log, &style, &dir.join("dash.svg")).unwrap();
    let svg = std::fs::read_to_string(dir.join("dash.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("velocity") && svg.contains("slip indicators"));
    planner::write_png(log, &style, &dir.join("fmt.png")).unwrap();
    let n = planner::write_exploration_gif(log, &style, &dir.join("fmt.gif"), 12).unwrap();
    assert!((2..=12).contains(&n));
    let gif = std::fs::read(dir.join("fmt.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");
    let frames = litesim_viz::animation::write_gif(log, &style, &dir.join("run.gif"), 40).unwrap();
    assert!(frames <= 40 && frames > 5, "{frames}");
    let lanes = litesim_viz::replay::Background {
        areas: Vec::new(),
        lines: vec![litesim_viz::replay::MapLine {
            points: vec![(0.0, 0.0), (80.0, 0.0)],
            kind: litesim_viz::replay::LineKind::Border,
        }],
    };
    litesim_viz::replay::write_png(log, &lanes, &style, &dir.join("replay.png")).unwrap();
    let rf = litesim_viz::replay::write_gif(
        log,
        &Default::default(),
        &style,
        &dir.join("replay.gif"),
        10,
    )
    .unwrap();
    assert!(rf <= 10);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn frame_delay_is_true_to_simulation_time() {
    use litesim_viz::animation::frame_timing;
    assert_eq!(frame_timing(0.05, 300, 1000).unwrap(), (1, 50));
    assert_eq!(frame_timing(0.02, 300, 1000).unwrap(), (1, 20));
    assert_eq!(frame_timing(0.01, 300, 1000).unwrap(), (2, 20));
    assert_eq!(frame_timing(0.05, 1000, 100).unwrap(), (10, 500));
    assert_eq!(frame_timing(0.033, 100, 1000).unwrap(), (10, 330));
    assert!(frame_timing(0.0, 10, 10).is_err());
}

#[test]
fn bad_input_is_an_error_or_a_view_that_says_so() {
    let style = Style::default();
    let empty = SimulationLog::default();
    let e = dashboard::render_rgb(&empty, &style)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no actor samples"), "{e}");
    let mut no_plan = log().clone();
    no_plan.plan = None;
    let e = planner::render_rgb(&no_plan, &style)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no planner data"), "{e}");
    // Without tracking the dashboard still renders, saying what is missing.
    no_plan.tracking = None;
    assert!(dashboard::render_rgb(&no_plan, &style).is_ok());
    let huge = Style {
        dashboard_size: [100_000, 10],
        ..Style::default()
    };
    assert!(dashboard::render_rgb(log(), &huge).is_err());
    assert!(
        Style::from_toml("free = \"green\"")
            .unwrap_err()
            .to_string()
            .contains("free = 'green' is not a colour")
    );
    assert!(Style::from_toml("linewidth = 3").is_err());
    let s = Style::from_toml("line_width = 4\nobstacle = \"#000000\"").unwrap();
    assert_eq!(
        (s.line_width, s.obstacle.as_str(), s.frame_size),
        (4, "#000000", [800, 600])
    );
}

/// A replay paints the road surface, yellow solid marks and broken white
/// marks as dashes (3 m on, 9 m off): counted in the decoded PNG, with
/// colours no other element uses.
#[test]
fn replay_draws_road_surface_and_marks() {
    use litesim_viz::replay::{Area, Background, LineKind, MapLine};
    let style = Style {
        road: "#00ff00".into(),
        mark_white: "#ff00ff".into(),
        mark_yellow: "#ffff00".into(),
        ..Style::default()
    };
    let lane = |y0: f64, y1: f64| Area {
        outline: vec![(0.0, y0), (200.0, y0), (200.0, y1), (0.0, y1)],
        drivable: true,
    };
    let bg = Background {
        areas: vec![lane(-3.5, 0.0), lane(0.0, 3.5)],
        lines: vec![
            MapLine {
                points: vec![(0.0, 0.0), (200.0, 0.0)],
                kind: LineKind::of_mark("solid", "yellow").unwrap(),
            },
            MapLine {
                points: vec![(0.0, -3.5), (100.0, -3.5), (200.0, -3.5)],
                kind: LineKind::of_mark("broken", "standard").unwrap(),
            },
        ],
    };
    let dir = std::env::temp_dir().join(format!("litesim-replay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("r.png");
    litesim_viz::replay::write_png(log(), &bg, &style, &path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let (w, h) = (info.width as usize, info.height as usize);
    let px = |x: usize, y: usize| {
        let i = (y * w + x) * 3;
        (buf[i], buf[i + 1], buf[i + 2])
    };
    let count = |c: (u8, u8, u8)| {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| px(x, y) == c)
            .count()
    };
    assert!(count((0, 255, 0)) > 1000, "road surface");
    assert!(count((255, 255, 0)) > 100, "yellow centre line");
    // The broken mark: along its best row, separate magenta runs (dashes).
    let row = (0..h)
        .max_by_key(|&y| (0..w).filter(|&x| px(x, y) == (255, 0, 255)).count())
        .unwrap();
    let on: Vec<bool> = (0..w).map(|x| px(x, row) == (255, 0, 255)).collect();
    let dashes = on.windows(2).filter(|p| p[1] && !p[0]).count();
    // The view follows the actors (a part of the 200 m line): still dashes.
    assert!((5..=20).contains(&dashes), "{dashes} dashes");
    // Nothing of the map outside the view: a line and an area far away
    // leave no pixel (plotters would pin them to the frame; they are clipped).
    let far = Background {
        areas: vec![Area {
            outline: vec![(-1e3, 900.0), (1e3, 900.0), (1e3, 1e3), (-1e3, 1e3)],
            drivable: true,
        }],
        lines: vec![MapLine {
            points: vec![(-1e3, 1e3), (1e3, 1e3)],
            kind: LineKind::of_mark("solid", "standard").unwrap(),
        }],
    };
    litesim_viz::replay::write_png(log(), &far, &style, &path).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut buf).unwrap();
    let stray = buf
        .chunks(3)
        .filter(|p| *p == [255, 0, 255] || *p == [0, 255, 0])
        .count();
    assert_eq!(stray, 0, "map outside the view drawn along the frame");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `examples/style.toml` (shown in the README) sets every key of the
/// stylesheet to its default: it parses, equals the built-in style, and
/// no key is missing.
#[test]
fn the_example_stylesheet_names_every_key() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/style.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let parsed = litesim_viz::style::Style::from_toml(&text).unwrap();
    assert_eq!(parsed, litesim_viz::style::Style::default());
    let given: toml::Table = toml::from_str(&text).unwrap();
    let all: toml::Table =
        toml::from_str(&toml::to_string(&litesim_viz::style::Style::default()).unwrap()).unwrap();
    let missing: Vec<&String> = all.keys().filter(|k| !given.contains_key(*k)).collect();
    assert!(missing.is_empty(), "examples/style.toml lacks {missing:?}");
}
