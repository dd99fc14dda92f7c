//! The batch's manifest: what produced a results folder, checked by
//! `--resume` and by [`merge`](super::merge); and the jobs it runs.

use super::*;

/// What produced a results folder: written first (`manifest.json`), checked
/// by `--resume` (the same options and tests, or a refusal naming the
/// difference) and by [`merge`] (the same everything but the shard).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// litesim version.
    pub litesim: String,
    /// The tests, in job order.
    pub tests: Vec<ManifestTest>,
    /// `kinematic`, `dynamic` or `as configured` (each test's
    /// `sim_info.dynamic`).
    pub mode: String,
    /// What drove sut.car.
    pub sut: String,
    /// What drove the other vehicles (`driver`, `planned`).
    #[serde(default)]
    pub npc: String,
    /// The SUT's timeout option (s), if given.
    pub sut_timeout: Option<f64>,
    /// The step option (ms), if given (`--step-ms`); absent from the
    /// manifests of batches written before it was honoured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_ms: Option<u32>,
    /// Seeds, `A..B`.
    pub seeds: String,
    /// Shard, `i/N`.
    pub shard: String,
}

/// One test of a [`Manifest`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestTest {
    /// Path as given.
    pub path: String,
    /// SHA-256 of its sources (the file and its imports); `None` when it
    /// could not be read.
    pub sources: Option<String>,
    /// SHA-256 of its map's text, if it has one.
    pub map: Option<String>,
    /// The profile its runs use.
    pub profile: Option<String>,
    /// The driver calibration its runs use (`built-in`, `given`, or path
    /// and hash).
    pub calibration: Option<String>,
}

impl Manifest {
    /// What differs from `other` (`other` is the folder's, `self` this
    /// command's), ignoring the seeds and, with `shard_too == false`, the
    /// shard.
    pub fn differences(&self, other: &Manifest, shard_too: bool) -> Vec<String> {
        let mut d = Vec::new();
        let mut cmp = |what: &str, now: String, was: String| {
            if now != was {
                d.push(format!("{what}: {was} there, {now} now"));
            }
        };
        cmp("litesim", self.litesim.clone(), other.litesim.clone());
        cmp("mode", self.mode.clone(), other.mode.clone());
        cmp("sut", self.sut.clone(), other.sut.clone());
        cmp("npc", self.npc.clone(), other.npc.clone());
        cmp(
            "sut timeout",
            format!("{:?}", self.sut_timeout),
            format!("{:?}", other.sut_timeout),
        );
        let step = |m: &Manifest| {
            m.step_ms
                .map_or("as configured".to_string(), |v| format!("{v} ms"))
        };
        cmp("step", step(self), step(other));
        if shard_too {
            cmp("shard", self.shard.clone(), other.shard.clone());
        }
        let paths = |m: &Manifest| m.tests.iter().map(|t| t.path.clone()).collect::<Vec<_>>();
        if paths(self) != paths(other) {
            d.push(format!(
                "tests: [{}] there, [{}] now",
                paths(other).join(", "),
                paths(self).join(", ")
            ));
        } else {
            for (a, b) in self.tests.iter().zip(&other.tests) {
                if a != b {
                    let what = if a.sources != b.sources {
                        "its sources changed"
                    } else if a.map != b.map {
                        "its map changed"
                    } else if a.profile != b.profile {
                        "its profile changed"
                    } else {
                        "its calibration changed"
                    };
                    d.push(format!("test {}: {what}", a.path));
                }
            }
        }
        d
    }

    /// Reads `dir/manifest.json` (`Ok(None)` when there is none).
    pub fn read(dir: &Path) -> Result<Option<Manifest>, ScenarioError> {
        let p = dir.join("manifest.json");
        match read_text(&p, MAX_INPUT_BYTES) {
            Ok(t) => serde_json::from_str(&t)
                .map(Some)
                .map_err(|e| ScenarioError::format(p.display(), e)),
            Err(ReadError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Writes `dir/manifest.json` atomically; returns its text's SHA-256
    /// (what the folder's failed-run logs name).
    pub fn write(&self, dir: &Path) -> Result<String, ScenarioError> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| ScenarioError::format("manifest.json", e))?
            + "\n";
        atomic(&dir.join("manifest.json"), &text)?;
        Ok(crate::sha256_hex(text.as_bytes()))
    }

    /// The seed range.
    pub fn seed_range(&self) -> Option<(u64, u64)> {
        let (a, b) = self.seeds.split_once("..")?;
        Some((a.parse().ok()?, b.parse().ok()?))
    }

    /// The shard `(i, N)`.
    pub fn shard_pair(&self) -> Option<(u64, u64)> {
        let (i, n) = self.shard.split_once('/')?;
        Some((i.parse().ok()?, n.parse().ok()?))
    }

    /// Every job `(test path, seed)` of this manifest's shard.
    pub fn jobs(&self) -> Vec<(String, u64)> {
        let (Some((a, b)), Some((si, sn))) = (self.seed_range(), self.shard_pair()) else {
            return Vec::new();
        };
        jobs_of(self.tests.iter().map(|t| t.path.as_str()), a, b, (si, sn))
    }
}

/// Jobs `(test, seed)` of shard `(i, N)`: job j in test-major, seed-minor
/// order belongs to shard `j mod N`.
pub(super) fn jobs_of<'a>(
    tests: impl Iterator<Item = &'a str>,
    from: u64,
    to: u64,
    (si, sn): (u64, u64),
) -> Vec<(String, u64)> {
    let seeds = to - from + 1;
    let mut out = Vec::new();
    for (ti, name) in tests.enumerate() {
        for k in 0..seeds {
            if (ti as u64 * seeds + k) % sn.max(1) == si {
                out.push((name.to_string(), from + k));
            }
        }
    }
    out
}
