//! A large map loads in memory proportional to its text (issue 18): the
//! document is read one top-level element at a time, so no whole-document
//! tree exists beside the model. One test per process (the peak resident
//! size is the process's).

use litesim_map::RoadNetwork;
use litesim_map::synth::{TownSpec, town};

/// Peak resident set size of this process (kB), from /proc.
fn peak_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

#[test]
fn a_large_town_loads_in_memory_proportional_to_its_text() {
    let spec = TownSpec::of_size(24_000_000);
    let text = town(&spec);
    assert!(text.len() > 20_000_000, "{} bytes", text.len());
    let Some(before) = peak_kb() else {
        eprintln!("no /proc/self/status: memory not measured");
        return;
    };
    let net = RoadNetwork::from_xodr(&text, "big.xodr").unwrap();
    assert_eq!(net.roads().len(), spec.road_count());
    let after = peak_kb().unwrap();
    let grown = (after.saturating_sub(before) * 1024) as f64;
    let ratio = grown / text.len() as f64;
    eprintln!(
        "{} bytes of text: peak grew by {:.1} MB ({ratio:.2}× the text)",
        text.len(),
        grown / 1e6
    );
    // A whole-document DOM alone took ~13× the text (3.5 GB for 200 MB with
    // the model); the model and the lane graph take ~2×.
    assert!(ratio < 3.0, "peak grew by {ratio:.2}× the text");
}
