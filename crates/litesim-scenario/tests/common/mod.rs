//! Helpers shared by the scenario engine's test binaries.
#![allow(dead_code)]

use litesim_scenario::{LoadOptions, Prepared, RunResult, prepare};
use std::path::PathBuf;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// An example test (`examples/scenarios/NAME.osc`), prepared.
pub fn example(name: &str) -> Prepared {
    let p = root().join(format!("examples/scenarios/{name}.osc"));
    prepare(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The seed's smoke test (`dummy_smoke.osc`, its imports found through
/// `$FTX` = litesim's `osc/`), prepared.
pub fn smoke() -> Prepared {
    let env = std::collections::BTreeMap::from([(
        "FTX".to_string(),
        root().join("osc").display().to_string(),
    )]);
    prepare(
        &root().join("osc/env/basic/exe_platforms/model_ssp/test/dummy_smoke.osc"),
        &LoadOptions {
            env: Some(env),
            ..LoadOptions::default()
        },
    )
    .unwrap()
}

/// Writes `text` as a test in `examples/scenarios` (so that relative
/// imports and map paths resolve like the examples'); removed when dropped.
pub fn example_file(text: &str) -> tempfile::NamedTempFile {
    let f = tempfile::Builder::new()
        .suffix(".osc")
        .tempfile_in(root().join("examples/scenarios"))
        .unwrap();
    std::fs::write(f.path(), text).unwrap();
    f
}

/// A 10 s test of `n` vehicles (sut.car included) in three lanes, 8 m
/// apart, at 30 kph; with `fast_every: Some(m)` every m-th one drives at
/// 38 kph, so that pairs close in, come near and collide (the checks have
/// something to find). Written to run beside the examples (`example_file`).
pub fn traffic(n: usize, fast_every: Option<usize>) -> String {
    let mut t = String::from(
        "import \"../../osc/domain/config.osc\"\nextend test_config:\n    set map = \"../maps/straight.xodr\"\nextend top.main:\n    do sut.traffic()\nscenario sut.traffic:\n    r: two_way_road\n",
    );
    for k in 1..n {
        t += &format!("    v{k}: vehicle\n");
    }
    t += "    do parallel(overlap: equal):\n        sut.car.drive() with:\n            speed(30kph)\n            along(r, at: start)\n            lane(1, at: start)\n";
    for k in 1..n {
        let lane = match k % 3 {
            0 => "same_as: sut.car".to_string(),
            1 => "left_of: sut.car".to_string(),
            _ => format!("left_of: v{}", k - 1),
        };
        let speed = if fast_every.is_some_and(|m| k % m == 0) {
            38
        } else {
            30
        };
        t += &format!(
            "        v{k}.drive() with:\n            speed({speed}kph)\n            lane({lane}, at: start)\n            position({}m, ahead_of: sut.car, at: start)\n",
            (k / 3) * 8 + 1
        );
    }
    t + "    with: duration(10s)\n"
}

/// A phase of the plan by label: (t0, t1).
pub fn phase(r: &RunResult, label: &str) -> (f64, f64) {
    let p = r
        .plan
        .phases
        .iter()
        .find(|p| p.label.as_deref() == Some(label))
        .unwrap_or_else(|| panic!("no phase {label}"));
    (p.t0, p.t1)
}
