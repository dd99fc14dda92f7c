//! Bulk runs: tests × seeds in parallel (rayon), each run on its own
//! in-process SSP session. Results are JSON lines (appended as runs finish,
//! so an interrupted batch can `--resume`) and, at the end, rewritten in
//! (test, seed) order together with a CSV table — so the merged result is
//! byte-identical whatever the thread count and the shard count.
//!
//! Sharding: job j (in test-major, seed-minor order) belongs to shard
//! `j mod N`; `--shard i/N` runs shard i only. The same command therefore
//! runs as a Kubernetes Indexed Job (`i = $JOB_COMPLETION_INDEX`) or a
//! Slurm array (`i = $SLURM_ARRAY_TASK_ID`); [`merge`] joins the shards'
//! folders.

use crate::{DriveMode, LoadOptions, Prepared, RunOptions, ScenarioError};
use litesim_core::files::{MAX_INPUT_BYTES, ReadError, open_regular, read_text};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

mod lines;
mod manifest;
mod merge;
mod run;
mod sorted;
pub use lines::*;
pub use manifest::*;
pub use merge::*;
pub use run::*;
pub use sorted::*;

/// Most seeds one batch runs per test: a typo such as `--seeds
/// 1..18446744073709551615` is refused at once instead of filling memory
/// with jobs.
pub const MAX_SEEDS: u64 = 1_000_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cleaning_removes_litesims_temporaries_only() {
        let d = tempfile::tempdir().unwrap();
        let names = [
            ".summary.json.tmp",
            ".tmpAb12Cd.gif",
            "results.tmp",
            "notes.tmp",
            "mine.tmp.txt",
            "summary.json",
        ];
        for n in names {
            std::fs::write(d.path().join(n), "x").unwrap();
        }
        clean_temporaries(d.path());
        let mut left: Vec<String> = std::fs::read_dir(d.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["mine.tmp.txt", "notes.tmp", "summary.json"]);
        // An atomic write leaves only its target.
        atomic(&d.path().join("a.json"), "{}").unwrap();
        assert!(!d.path().join(".a.json.tmp").exists());
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.json")).unwrap(),
            "{}"
        );
    }
}
