//! Coverage and recording (OSC 2.0 §3.11): `cover(...)` items sample a
//! scalar at an event into buckets, `record(...)` items just log it.
//!
//! A run samples each item on the simulated (closed-loop) state and writes
//! its [`Sample`]s to summary.json and to its results line; a batch folds
//! the samples of all runs into [`ItemCoverage`] (bucket counts and holes).
//! Folding is a sum of counts, so coverage computed from any split of the
//! runs (shards, `--resume`) and merged equals coverage of the whole — and
//! since it is computed from the sorted results, it is byte-identical
//! whatever the threads or shards.

use crate::elab::CExpr;
use crate::expr::{Field, Pair, Scope, Val};
use crate::state::BodyState;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// When an item is sampled.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleAt {
    /// The first step.
    Start,
    /// The end of the run (the end of `top.main` and of what it invokes).
    End,
    /// The end of the phase with this label path.
    PhaseEnd(String),
}

/// A `cover`/`record` item as elaborated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CoverItem {
    /// Full name: the enclosing scenario and the item's name (`sut.cut_in.speed`).
    pub name: String,
    /// `record` (no buckets) rather than `cover`.
    pub record: bool,
    /// What is sampled.
    pub expr: CExpr,
    /// Unit of samples and buckets, for physical items.
    pub unit: Option<String>,
    /// SI value of one `unit`.
    pub factor: f64,
    /// Bucket range in `unit` (numeric items).
    pub range: Option<(f64, f64)>,
    /// Bucket width in `unit` (numeric items).
    pub every: Option<f64>,
    /// Values of an enum or bool item (its buckets).
    pub values: Vec<String>,
    /// When it is sampled.
    pub event: SampleAt,
    /// `text:`.
    pub text: Option<String>,
    /// Where it is written (`file:line:col`).
    pub at: String,
}

/// The definition a batch needs to bucket an item's samples (also kept in
/// coverage.json, so that merging shards needs no test files).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ItemDef {
    /// Full name.
    pub name: String,
    /// `cover` or `record`.
    pub kind: String,
    /// Unit, for physical items.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub unit: Option<String>,
    /// Bucket range (in `unit`).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub range: Option<(f64, f64)>,
    /// Bucket width (in `unit`).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub every: Option<f64>,
    /// Enum/bool values.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub values: Vec<String>,
    /// `text:`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub text: Option<String>,
}

impl CoverItem {
    /// Its batch-level definition.
    pub fn def(&self) -> ItemDef {
        ItemDef {
            name: self.name.clone(),
            kind: if self.record { "record" } else { "cover" }.into(),
            unit: self.unit.clone(),
            range: self.range,
            every: self.every,
            values: self.values.clone(),
            text: self.text.clone(),
        }
    }
}

/// A sampled value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SampleValue {
    /// A number, in the item's unit.
    Num(f64),
    /// An enum member or `true`/`false`.
    Word(String),
}

/// One item sampled in one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Item (full name).
    pub item: String,
    /// Value (`null`: the expression could not be evaluated on the state).
    pub value: Option<SampleValue>,
    /// When (s).
    pub t: f64,
}

/// Evaluates an item's expression: scenario parameters from `values`,
/// actor fields (`speed`, `acceleration`, `position.x`/`.y`, `yaw`,
/// `lane`) and `a.gap_to(b)` (box to box, m) / `a.ttc_to(b)` (s; none
/// when they never meet within [`crate::kpi::TTC_HORIZON`]) from
/// `actor(id)`, lanes from `lane_of` (asked only by items that read one);
/// numbers come back in the item's unit, truth values as the words
/// `true`/`false`.
pub fn evaluate(
    item: &CoverItem,
    ids: &BTreeMap<String, String>,
    values: &BTreeMap<String, crate::elab::Value>,
    actor: &dyn Fn(&str) -> Option<BodyState>,
    lane_of: &dyn Fn(&BodyState) -> Option<i32>,
) -> Option<SampleValue> {
    let scope = CoverScope {
        values,
        actor,
        lane_of,
    };
    match crate::expr::value(&item.expr, ids, &scope)? {
        Val::Num(x) => Some(SampleValue::Num(x / item.factor)),
        Val::Bool(b) => Some(SampleValue::Word(b.to_string())),
        Val::Word(w) => Some(SampleValue::Word(w)),
    }
}

/// The live actors and the scenario's parameters, as coverage reads them.
struct CoverScope<'a> {
    values: &'a BTreeMap<String, crate::elab::Value>,
    actor: &'a dyn Fn(&str) -> Option<BodyState>,
    lane_of: &'a dyn Fn(&BodyState) -> Option<i32>,
}

impl Scope for CoverScope<'_> {
    fn field(&self, id: &str, field: Field) -> Option<f64> {
        let s = (self.actor)(id)?;
        Some(match field {
            Field::Speed => s.speed,
            Field::Acceleration => s.acceleration,
            Field::X => s.x,
            Field::Y => s.y,
            Field::Yaw => s.yaw,
            Field::Lane => f64::from((self.lane_of)(&s)?),
        })
    }

    fn pair(&self, pair: Pair, a: &str, b: &str) -> Option<f64> {
        let (a, b) = ((self.actor)(a)?, (self.actor)(b)?);
        match pair {
            Pair::Gap => Some(crate::kpi::distance(&a, &b)),
            Pair::Ttc => {
                crate::kpi::time_to_collision(&a, &b).filter(|t| *t <= crate::kpi::TTC_HORIZON)
            }
        }
    }

    fn param(&self, path: &str) -> Option<&crate::elab::Value> {
        self.values.get(path)
    }
}

/// How many buckets a numeric item may have (range / every); beyond, the
/// range is one bucket per 1/1000 of it (a typo like `every: 0.0001` must
/// not allocate gigabytes).
pub const MAX_BUCKETS: usize = 1000;

/// An item's bucket edges: `(lo, width, count)`, when it has a range.
pub fn buckets(def: &ItemDef) -> Option<(f64, f64, usize)> {
    let (lo, hi) = def.range?;
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater)
        || !lo.is_finite()
        || !hi.is_finite()
    {
        return None;
    }
    let w = def.every.filter(|w| *w > 0.0).unwrap_or((hi - lo) / 10.0);
    let n = ((hi - lo) / w - 1e-9).ceil().max(1.0);
    if n as usize > MAX_BUCKETS {
        return Some((lo, (hi - lo) / MAX_BUCKETS as f64, MAX_BUCKETS));
    }
    Some((lo, w, n as usize))
}

/// Which bucket a value falls in (`None`: outside the range).
pub fn bucket_of(v: f64, (lo, w, n): (f64, f64, usize)) -> Option<usize> {
    if !v.is_finite() || v < lo {
        return None;
    }
    let k = ((v - lo) / w).floor() as usize;
    // The range's upper bound belongs to the last bucket.
    if k < n {
        Some(k)
    } else if v <= lo + w * n as f64 + 1e-9 * w {
        Some(n - 1)
    } else {
        None
    }
}

/// One bucket of an item's coverage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bucket {
    /// Label: `[lo..hi)` in the unit, or the value.
    pub label: String,
    /// Samples that fell in it.
    pub count: u64,
}

/// An item's coverage across runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ItemCoverage {
    /// The test file.
    pub test: String,
    /// The item.
    #[serde(flatten)]
    pub def: ItemDef,
    /// Samples.
    pub samples: u64,
    /// Samples that could not be evaluated.
    pub missing: u64,
    /// Samples outside the range.
    pub outside: u64,
    /// Buckets in order (cover items with a range, enum and bool items).
    pub buckets: Vec<Bucket>,
    /// Buckets nobody hit.
    pub holes: Vec<String>,
    /// Smallest and largest numeric sample.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub min: Option<f64>,
    /// Largest numeric sample.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub max: Option<f64>,
    /// Mean of the numeric samples.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub mean: Option<f64>,
}

/// The batch's coverage file (`coverage.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CoverageFile {
    /// Items by test, in (test, item) order.
    pub items: Vec<ItemCoverage>,
    /// Total holes over all cover items.
    pub holes: u64,
}

/// An item's definition and the values seen so far.
type Seen = (ItemDef, Vec<Option<SampleValue>>);

/// Folds runs' samples into coverage. Feed runs in any order and any
/// split: the result depends only on the multiset of samples (counts are
/// sums; the mean is the sum over the count, summed in a fixed order by
/// [`Fold::finish`]).
#[derive(Clone, Debug, Default)]
pub struct Fold {
    /// (test, item) → definition and the values seen.
    items: BTreeMap<(String, String), Seen>,
}

impl Fold {
    /// Declares an item of a test (so that an item nobody sampled still
    /// shows, all holes).
    pub fn declare(&mut self, test: &str, def: &ItemDef) {
        self.items
            .entry((test.to_string(), def.name.clone()))
            .or_insert_with(|| (def.clone(), Vec::new()));
    }

    /// Adds one run's samples.
    pub fn add(&mut self, test: &str, samples: &[Sample]) {
        for s in samples {
            if let Some((_, v)) = self.items.get_mut(&(test.to_string(), s.item.clone())) {
                v.push(s.value.clone());
            }
        }
    }

    /// The coverage of everything added.
    pub fn finish(&self) -> CoverageFile {
        let mut out = CoverageFile::default();
        for ((test, _), (def, values)) in &self.items {
            let mut c = ItemCoverage {
                test: test.clone(),
                def: def.clone(),
                samples: values.len() as u64,
                missing: values.iter().filter(|v| v.is_none()).count() as u64,
                outside: 0,
                buckets: Vec::new(),
                holes: Vec::new(),
                min: None,
                max: None,
                mean: None,
            };
            // Numbers sorted first: the sum (and so the mean) does not
            // depend on the order the runs came in.
            let mut nums: Vec<f64> = values
                .iter()
                .filter_map(|v| match v {
                    Some(SampleValue::Num(x)) => Some(*x),
                    _ => None,
                })
                .collect();
            nums.sort_by(f64::total_cmp);
            if !nums.is_empty() {
                c.min = nums.first().copied();
                c.max = nums.last().copied();
                c.mean = Some(nums.iter().sum::<f64>() / nums.len() as f64);
            }
            if def.kind == "cover" {
                if !def.values.is_empty() {
                    let mut counts: BTreeMap<&str, u64> =
                        def.values.iter().map(|v| (v.as_str(), 0)).collect();
                    for v in values.iter().flatten() {
                        match v {
                            SampleValue::Word(w) if counts.contains_key(w.as_str()) => {
                                *counts.get_mut(w.as_str()).expect("known") += 1
                            }
                            _ => c.outside += 1,
                        }
                    }
                    // In declaration order.
                    c.buckets = def
                        .values
                        .iter()
                        .map(|v| Bucket {
                            label: v.clone(),
                            count: counts[v.as_str()],
                        })
                        .collect();
                } else if let Some(b) = buckets(def) {
                    let mut counts = vec![0u64; b.2];
                    for x in &nums {
                        match bucket_of(*x, b) {
                            Some(k) => counts[k] += 1,
                            None => c.outside += 1,
                        }
                    }
                    c.buckets = counts
                        .iter()
                        .enumerate()
                        .map(|(k, n)| Bucket {
                            label: format!(
                                "[{}..{})",
                                trim(b.0 + b.1 * k as f64),
                                trim(b.0 + b.1 * (k + 1) as f64)
                            ),
                            count: *n,
                        })
                        .collect();
                }
                c.holes = c
                    .buckets
                    .iter()
                    .filter(|b| b.count == 0)
                    .map(|b| b.label.clone())
                    .collect();
                out.holes += c.holes.len() as u64;
            }
            out.items.push(c);
        }
        out
    }
}

/// A bucket edge as short text (no float noise: 6 significant decimals).
fn trim(x: f64) -> String {
    let s = format!("{:.6}", x);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn def() -> ItemDef {
        ItemDef {
            name: "s.v".into(),
            kind: "cover".into(),
            unit: Some("kph".into()),
            range: Some((20.0, 60.0)),
            every: Some(10.0),
            values: Vec::new(),
            text: None,
        }
    }

    #[test]
    fn buckets_cover_the_range_and_its_upper_bound() {
        let b = buckets(&def()).unwrap();
        assert_eq!(b, (20.0, 10.0, 4));
        assert_eq!(bucket_of(20.0, b), Some(0));
        assert_eq!(bucket_of(29.999, b), Some(0));
        assert_eq!(bucket_of(30.0, b), Some(1));
        assert_eq!(bucket_of(60.0, b), Some(3));
        assert_eq!(bucket_of(60.1, b), None);
        assert_eq!(bucket_of(19.9, b), None);
        assert_eq!(bucket_of(f64::NAN, b), None);
        // A tiny `every` is capped.
        let mut d = def();
        d.every = Some(1e-9);
        assert_eq!(buckets(&d).unwrap().2, MAX_BUCKETS);
    }

    #[test]
    fn holes_are_the_empty_buckets() {
        let mut f = Fold::default();
        f.declare("t.osc", &def());
        let s = |v: f64| Sample {
            item: "s.v".into(),
            value: Some(SampleValue::Num(v)),
            t: 1.0,
        };
        f.add("t.osc", &[s(25.0), s(45.0), s(47.0), s(99.0)]);
        let c = f.finish();
        let it = &c.items[0];
        let counts: Vec<u64> = it.buckets.iter().map(|b| b.count).collect();
        assert_eq!(counts, [1, 0, 2, 0]);
        assert_eq!(it.holes, ["[30..40)", "[50..60)"]);
        assert_eq!((it.outside, c.holes), (1, 2));
    }

    proptest! {
        /// Merging any split of the runs equals the whole: coverage from
        /// the runs folded in one go equals coverage from the runs folded
        /// in another order after being cut anywhere (what shards and
        /// --resume do), byte for byte.
        #[test]
        fn any_split_merges_to_the_whole(
            runs in proptest::collection::vec(proptest::collection::vec(-10.0f64..80.0, 0..4), 0..40),
            cut in 0usize..40,
            words in proptest::collection::vec(0usize..4, 0..40),
        ) {
            let mut e = def();
            e.name = "s.side".into();
            e.unit = None;
            e.range = None;
            e.every = None;
            e.values = vec!["left".into(), "right".into(), "centre".into()];
            let sample_runs: Vec<Vec<Sample>> = runs
                .iter()
                .enumerate()
                .map(|(k, vs)| {
                    let mut s: Vec<Sample> = vs
                        .iter()
                        .map(|v| Sample { item: "s.v".into(), value: Some(SampleValue::Num(*v)), t: 0.0 })
                        .collect();
                    let w = ["left", "right", "centre", "up"][words.get(k).copied().unwrap_or(0)];
                    s.push(Sample { item: "s.side".into(), value: Some(SampleValue::Word(w.into())), t: 0.0 });
                    s
                })
                .collect();
            let whole = {
                let mut f = Fold::default();
                f.declare("t", &def());
                f.declare("t", &e);
                sample_runs.iter().for_each(|r| f.add("t", r));
                serde_json::to_string(&f.finish()).unwrap()
            };
            let cut = cut.min(sample_runs.len());
            let split = {
                let mut f = Fold::default();
                f.declare("t", &e);
                f.declare("t", &def());
                sample_runs[cut..].iter().rev().for_each(|r| f.add("t", r));
                sample_runs[..cut].iter().for_each(|r| f.add("t", r));
                serde_json::to_string(&f.finish()).unwrap()
            };
            prop_assert_eq!(whole, split);
        }
    }
}
