//! Map loading and point queries.
//!
//! `cargo bench -p litesim-map --bench map`: builds (in memory) an OpenDRIVE
//! file of 200 roads × 500 m = 100 km, each a line, spiral, arc, spiral chain
//! with two lane sections of 3 + 3 lanes, then measures loading (parse,
//! lane geometry, spatial index, lane graph) and point → (road, lane, s, t).

use criterion::{Criterion, Throughput};

// The allocator the `litesim` binary (CLI and gRPC server) uses
// (crates/litesim-cli/src/main.rs): what loading a map costs a user.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;
use litesim_core::Vec2;
use litesim_map::RoadNetwork;
use std::fmt::Write;
use std::hint::black_box;

fn lane(id: i32) -> String {
    format!(
        r#"<lane id="{id}" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/><roadMark sOffset="0" type="broken"/></lane>"#
    )
}

/// 200 parallel roads 60 m apart, each 500 m.
fn hundred_km() -> String {
    let mut x = String::from("<OpenDRIVE><header revMajor=\"1\" revMinor=\"6\"/>");
    let lanes_l: String = (1..=3).map(lane).collect();
    let lanes_r: String = (1..=3).map(|i| lane(-i)).collect();
    for r in 0..200 {
        let y0 = r as f64 * 60.0;
        // line 200 m, spiral 0→0.01 over 50 m, spiral 0.01→0 over 50 m, line 200 m.
        // (Start points of later pieces are approximate: a gap warning is fine here.)
        let _ = write!(
            x,
            r#"<road id="{r}" length="500" junction="-1"><planView>
<geometry s="0" x="0" y="{y0}" hdg="0" length="200"><line/></geometry>
<geometry s="200" x="200" y="{y0}" hdg="0" length="50"><spiral curvStart="0" curvEnd="0.01"/></geometry>
<geometry s="250" x="249.98" y="{y1}" hdg="0.25" length="50"><spiral curvStart="0.01" curvEnd="0"/></geometry>
<geometry s="300" x="298.9" y="{y2}" hdg="0.5" length="200"><line/></geometry>
</planView><lanes><laneSection s="0"><left>{lanes_l}</left><center><lane id="0" type="none"/></center><right>{lanes_r}</right></laneSection>
<laneSection s="250"><left>{lanes_l}</left><center><lane id="0" type="none"/></center><right>{lanes_r}</right></laneSection></lanes></road>"#,
            y1 = y0 + 4.16,
            y2 = y0 + 16.5,
        );
    }
    x.push_str("</OpenDRIVE>");
    x
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let text = hundred_km();
    let mut g = c.benchmark_group("map");
    g.sample_size(20);
    g.bench_function("load_100km", |b| {
        b.iter(|| RoadNetwork::from_xodr(black_box(&text), "bench.xodr").unwrap())
    });
    // A town map as published ones are written (1.8 MB, 234 roads, 16
    // junctions with 192 connecting roads, lane offsets, four lane sections
    // per street): issue 18's city map.
    let town = litesim_map::synth::town(&litesim_map::synth::TownSpec::city());
    g.bench_function("load_town_234_roads", |b| {
        b.iter(|| RoadNetwork::from_xodr(black_box(&town), "town.xodr").unwrap())
    });
    g.bench_function("parse_town_234_roads", |b| {
        b.iter(|| litesim_map::parse(black_box(&town), "town.xodr").unwrap())
    });
    // The XML tree alone: the floor any DOM-based loader pays.
    g.bench_function("xml_tree_town_234_roads", |b| {
        b.iter(|| {
            roxmltree::Document::parse(black_box(&town))
                .unwrap()
                .root()
                .range()
        })
    });
    let net = RoadNetwork::from_xodr(&text, "bench.xodr").unwrap();
    assert!((net.total_length() - 100_000.0).abs() < 1e-6);
    // Query points: on lanes of many roads, spread along the straight part.
    let points: Vec<Vec2> = (0..1000)
        .map(|i| {
            Vec2::new(
                5.0 + (i % 190) as f64,
                (i % 200) as f64 * 60.0 - 1.75 - (i % 3) as f64 * 3.5,
            )
        })
        .collect();
    assert!(points.iter().all(|p| net.to_road(*p).is_some()));
    g.sample_size(100);
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("point_to_lane_x1000", |b| {
        b.iter(|| {
            for p in &points {
                black_box(net.to_road(*p));
            }
        })
    });
    g.finish();
    c.final_summary();
}
