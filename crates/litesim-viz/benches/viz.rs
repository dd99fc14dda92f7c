//! Rendering benchmarks (`cargo bench -p litesim-viz --bench viz`): the
//! 1600 × 1200 dashboard, and GIF frames of 800 × 600, from the closed-loop
//! log of `examples/plan/single_rect.toml`.

use criterion::Criterion;
use litesim_core::Vec2;
use litesim_map::OccupancyGrid;
use litesim_viz::{Style, animation, dashboard};

fn main() {
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
    let log = litesim_plan::run_closed_loop(&cfg, grid).unwrap().log;
    let style = Style::default();
    let mut c = Criterion::default().configure_from_args();
    let mut g = c.benchmark_group("viz");
    g.sample_size(20);
    g.bench_function("dashboard_1600x1200_rgb", |b| {
        b.iter(|| dashboard::render_rgb(&log, &style).unwrap())
    });
    g.bench_function("dashboard_1600x1200_png_encoded", |b| {
        b.iter(|| {
            let (buf, w, h) = dashboard::render_rgb(&log, &style).unwrap();
            litesim_viz::encode_png(&buf, w, h).unwrap()
        })
    });
    let dir = std::env::temp_dir();
    let path = dir.join(format!("litesim-bench-{}.gif", std::process::id()));
    // 20 frames per iteration: divide the time by 20 for a frame.
    g.bench_function("gif_800x600_20_frames", |b| {
        b.iter(|| animation::write_gif(&log, &style, &path, 20).unwrap())
    });
    g.finish();
    let _ = std::fs::remove_file(&path);
    c.final_summary();

    // The same dashboard in matplotlib, in the same session, when it is installed.
    let json = dir.join(format!("litesim-bench-{}.json", std::process::id()));
    log.write_json(&json).unwrap();
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/benches/matplotlib_dashboard.py"
    );
    let out = std::process::Command::new("python3")
        .arg(script)
        .arg(&json)
        .output();
    let _ = std::fs::remove_file(&json);
    let mpl = out.ok().filter(|o| o.status.success()).and_then(|o| {
        String::from_utf8_lossy(&o.stdout)
            .trim()
            .parse::<f64>()
            .ok()
    });
    let ours = std::time::Instant::now();
    for _ in 0..5 {
        let (buf, w, h) = dashboard::render_rgb(&log, &style).unwrap();
        litesim_viz::encode_png(&buf, w, h).unwrap();
    }
    let ours = ours.elapsed().as_secs_f64() / 5.0;
    match mpl {
        Some(m) => println!(
            "\n== dashboard 1600 x 1200: litesim {:.1} ms, matplotlib {:.1} ms, ratio {:.0}x ==",
            ours * 1e3,
            m * 1e3,
            m / ours
        ),
        None => println!(
            "\n== dashboard 1600 x 1200: litesim {:.1} ms (matplotlib not installed) ==",
            ours * 1e3
        ),
    }
}
