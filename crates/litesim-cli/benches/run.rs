//! `litesim run` of the README example end to end, as a user runs it
//! (`cargo bench -p litesim --bench run`): default outputs (log, plan,
//! pictures, summary), and the same with `--mcap` — the issue asks MCAP
//! writing to add ≤ 10 % to a run.
#![allow(missing_docs)]

use criterion::Criterion;
use std::path::Path;
use std::process::Command;

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_litesim"))
            .current_dir(&root)
            .args(["run", "examples/scenarios/cut_in.osc", "-o"])
            .arg(dir.path().join("r"))
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{o:?}");
    };
    let mcap = dir.path().join("run.mcap");
    let mcap = mcap.to_str().unwrap();
    let mut g = c.benchmark_group("cli_run");
    g.sample_size(30);
    g.bench_function("cut_in", |b| b.iter(|| run(&[])));
    g.bench_function("cut_in_with_mcap", |b| b.iter(|| run(&["--mcap", mcap])));
    g.bench_function("cut_in_no_pictures", |b| b.iter(|| run(&["--no-pictures"])));
    g.bench_function("cut_in_no_pictures_with_mcap", |b| {
        b.iter(|| run(&["--no-pictures", "--mcap", mcap]))
    });
    g.finish();
    c.final_summary();
}
