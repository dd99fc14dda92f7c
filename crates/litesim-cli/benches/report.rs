//! `litesim report` over 100,000 runs (`cargo bench -p litesim --bench
//! report`): a batch folder of the coverage example, its rows repeated
//! with new seeds up to 100k lines (with coverage.json), reported by the
//! binary — reading, grouping, charts and the HTML file.
#![allow(missing_docs)]

use criterion::Criterion;
use std::path::Path;
use std::process::Command;

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let o = Command::new(env!("CARGO_BIN_EXE_litesim"))
        .current_dir(&root)
        .args([
            "batch",
            "examples/scenarios/cut_in_coverage.osc",
            "--seeds",
            "1..200",
            "-q",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(out.join("coverage.json").exists(), "{o:?}");
    let rows: Vec<serde_json::Value> = std::fs::read_to_string(out.join("results.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let mut big = String::new();
    for k in 0..100_000u64 {
        let mut r = rows[(k % rows.len() as u64) as usize].clone();
        r["seed"] = serde_json::json!(k + 1);
        big += &r.to_string();
        big.push('\n');
    }
    std::fs::write(out.join("results.jsonl"), big).unwrap();
    let mut g = c.benchmark_group("report");
    g.sample_size(10);
    g.bench_function("100k_runs", |b| {
        b.iter(|| {
            let o = Command::new(env!("CARGO_BIN_EXE_litesim"))
                .arg("report")
                .arg(&out)
                .arg("-q")
                .output()
                .unwrap();
            assert!(o.status.success());
        })
    });
    g.finish();
    c.final_summary();
}
