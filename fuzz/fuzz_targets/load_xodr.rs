//! The OpenDRIVE loader must answer any input with a map or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(net) = litesim_map::RoadNetwork::from_xodr(&text, "fuzz.xodr") {
        // Exercise the queries on whatever loaded.
        let _ = net.lane_polylines(0.5);
        let _ = net.road_summaries();
        let _ = net.to_road(litesim_core::Vec2::new(1.0, -1.0));
        let _ = net.rasterise(1.0, 1.0);
    }
});
