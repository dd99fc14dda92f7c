//! `ParameterValueDistribution` files (1.1+): a scenario and the parameter
//! values of its variations — deterministic (value sets, single-parameter
//! sets and ranges, all combinations) or stochastic (a number of runs,
//! each parameter drawn from its distribution with the file's seed).
//! `litesim batch` runs every variation.

use crate::error::XoscError;
use crate::read::{Cx, list, next, open, read_text};
use litesim_core::math;
use litesim_core::rng::Rng;
use litesim_map::xml::{Node, Tree};
use std::path::{Path, PathBuf};

/// Most variations one distribution may expand into.
pub const MAX_VARIATIONS: usize = 100_000;

/// A distribution's scenario and its variations, each a list of
/// (parameter, value) overrides.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution {
    /// `ScenarioFile filepath`, resolved against the distribution's folder.
    pub scenario: PathBuf,
    /// The variations, in order.
    pub variations: Vec<Vec<(String, String)>>,
}

type R<T> = Result<T, XoscError>;

/// Whether a file's root holds a `ParameterValueDistribution` (read up to
/// its second top-level element only).
pub fn is_distribution(path: &Path) -> bool {
    let Ok(text) = read_text(path, "file") else {
        return false;
    };
    let cx = Cx::new(&text, path);
    let Ok((mut s, _)) = open(&cx) else {
        return false;
    };
    let mut tree = Tree::new(&text);
    for _ in 0..2 {
        match next(&cx, &mut s, &mut tree) {
            Ok(true) if tree.root().name() == "ParameterValueDistribution" => return true,
            Ok(true) => {}
            _ => return false,
        }
    }
    false
}

/// Reads a distribution file.
pub fn read_distribution(path: &Path) -> R<Distribution> {
    let text = read_text(path, "distribution")?;
    let mut cx = Cx::new(&text, path);
    let (mut stream, _) = open(&cx)?;
    let mut tree = Tree::new(&text);
    while next(&cx, &mut stream, &mut tree)? {
        let n = tree.root();
        match n.name() {
            "FileHeader" => {
                if let Some(m) = cx.opt_int(n, "revMinor")? {
                    cx.version = (1, m.clamp(0, 3) as u32);
                }
            }
            "ParameterValueDistribution" => {
                cx.since(n, "ParameterValueDistribution", 1)?;
                return cx.within(n, |cx| distribution(cx, n));
            }
            other => {
                return Err(cx.err(n, format!("unexpected element <{other}> in a distribution file (expected FileHeader and ParameterValueDistribution)")));
            }
        }
    }
    Err(XoscError::file(
        &path.display().to_string(),
        "no ParameterValueDistribution in the file",
    ))
}

fn distribution(cx: &mut Cx<'_>, n: Node<'_, '_>) -> R<Distribution> {
    cx.attrs(n, &[])?;
    cx.children(n, &["ScenarioFile", "Deterministic", "Stochastic"])?;
    let f = cx.child(n, "ScenarioFile")?;
    cx.attrs(f, &["filepath"])?;
    let scenario = cx.dir.join(cx.req(f, "filepath")?);
    if !scenario.is_file() {
        return Err(cx.err(
            f,
            format!("the scenario {} is not there", scenario.display()),
        ));
    }
    let kinds: Vec<Node<'_, '_>> = n
        .elements()
        .filter(|c| c.name() != "ScenarioFile")
        .collect();
    let [kind] = kinds.as_slice() else {
        return Err(cx.err(
            n,
            "a ParameterValueDistribution holds one of Deterministic or Stochastic",
        ));
    };
    let variations = if kind.name() == "Deterministic" {
        cx.within(*kind, |cx| deterministic(cx, *kind))?
    } else {
        cx.within(*kind, |cx| stochastic(cx, *kind))?
    };
    Ok(Distribution {
        scenario,
        variations,
    })
}

fn deterministic(cx: &mut Cx<'_>, d: Node<'_, '_>) -> R<Vec<Vec<(String, String)>>> {
    cx.attrs(d, &[])?;
    cx.children(
        d,
        &[
            "DeterministicMultiParameterDistribution",
            "DeterministicSingleParameterDistribution",
        ],
    )?;
    // Each distribution is a list of alternatives; all combine.
    let mut axes: Vec<Vec<Vec<(String, String)>>> = Vec::new();
    for c in d.elements() {
        if c.name() == "DeterministicMultiParameterDistribution" {
            let v = cx.child(c, "ValueSetDistribution")?;
            cx.children(v, &["ParameterValueSet"])?;
            let mut sets = Vec::new();
            for s in v.elements() {
                cx.children(s, &["ParameterAssignment"])?;
                let mut set = Vec::new();
                for a in s.elements() {
                    cx.attrs(a, &["parameterRef", "value"])?;
                    set.push((cx.req(a, "parameterRef")?, cx.req(a, "value")?));
                }
                sets.push(set);
            }
            axes.push(sets);
            continue;
        }
        cx.attrs(c, &["parameterName"])?;
        let name = cx.req(c, "parameterName")?;
        let k = cx.choice(
            c,
            &[
                "DistributionSet",
                "DistributionRange",
                "UserDefinedDistribution",
            ],
        )?;
        let values: Vec<String> = match k.name() {
            "DistributionSet" => {
                cx.children(k, &["Element"])?;
                k.elements().map(|e| cx.req(e, "value")).collect::<R<_>>()?
            }
            "DistributionRange" => {
                cx.attrs(k, &["stepWidth"])?;
                let step = cx.num(k, "stepWidth")?;
                let r = cx.child(k, "Range")?;
                let (lo, hi) = (cx.num(r, "lowerLimit")?, cx.num(r, "upperLimit")?);
                if step <= 0.0 || hi < lo {
                    return Err(cx.err(k, format!("a range from {lo} to {hi} by {step}: the step must be above 0 and the upper limit at least the lower")));
                }
                let n = ((hi - lo) / step + 1e-9).floor() as usize + 1;
                if n > MAX_VARIATIONS {
                    return Err(cx.err(k, format!("{n} values: at most {MAX_VARIATIONS}")));
                }
                (0..n).map(|i| fmt(lo + step * i as f64)).collect()
            }
            _ => return Err(cx.err(k, "a UserDefinedDistribution is not supported (DistributionSet and DistributionRange are)")),
        };
        axes.push(
            values
                .into_iter()
                .map(|v| vec![(name.clone(), v)])
                .collect(),
        );
    }
    combine(cx, d, axes)
}

/// All combinations of the axes' alternatives, in order.
fn combine(
    cx: &Cx<'_>,
    at: Node<'_, '_>,
    axes: Vec<Vec<Vec<(String, String)>>>,
) -> R<Vec<Vec<(String, String)>>> {
    let total = axes
        .iter()
        .try_fold(1usize, |n, a| n.checked_mul(a.len().max(1)));
    if total.is_none_or(|t| t > MAX_VARIATIONS) {
        return Err(cx.err(
            at,
            format!("the distribution has more than {MAX_VARIATIONS} variations"),
        ));
    }
    let mut out: Vec<Vec<(String, String)>> = vec![Vec::new()];
    for axis in axes.into_iter().filter(|a| !a.is_empty()) {
        out = out
            .iter()
            .flat_map(|prefix| {
                axis.iter().map(move |alt| {
                    let mut v = prefix.clone();
                    v.extend(alt.iter().cloned());
                    v
                })
            })
            .collect();
    }
    Ok(out)
}

fn stochastic(cx: &mut Cx<'_>, s: Node<'_, '_>) -> R<Vec<Vec<(String, String)>>> {
    cx.attrs(s, &["numberOfTestRuns", "randomSeed"])?;
    cx.children(s, &["StochasticDistribution"])?;
    let runs = cx
        .opt_int(s, "numberOfTestRuns")?
        .ok_or_else(|| cx.err(s, "<Stochastic> needs the attribute 'numberOfTestRuns'"))?;
    if !(1..=MAX_VARIATIONS as i64).contains(&runs) {
        return Err(cx.err(s, format!("numberOfTestRuns {runs}: 1 to {MAX_VARIATIONS}")));
    }
    // The file's seed (1 without one): the same values on every machine.
    let seed = cx.opt_num(s, "randomSeed")?.map_or(1, |x| x.abs() as u64);
    let mut rng = Rng::new(seed);
    let mut dists = Vec::new();
    for d in s.elements() {
        cx.attrs(d, &["parameterName"])?;
        let name = cx.req(d, "parameterName")?;
        let k = cx.choice(
            d,
            &[
                "ProbabilityDistributionSet",
                "NormalDistribution",
                "LogNormalDistribution",
                "UniformDistribution",
                "PoissonDistribution",
                "Histogram",
                "UserDefinedDistribution",
            ],
        )?;
        dists.push((name, cx.within(k, |cx| sampler(cx, k))?));
    }
    Ok((0..runs)
        .map(|_| {
            dists
                .iter()
                .map(|(n, d)| (n.clone(), d.draw(&mut rng)))
                .collect()
        })
        .collect())
}

/// One parameter's distribution.
enum Sampler {
    /// (value, weight)
    Set(Vec<(String, f64)>),
    Normal {
        mean: f64,
        sd: f64,
        range: Option<(f64, f64)>,
        log: bool,
    },
    Uniform(f64, f64),
    Poisson {
        mean: f64,
        range: Option<(f64, f64)>,
    },
    /// (weight, lower, upper)
    Histogram(Vec<(f64, f64, f64)>),
}

fn range(cx: &Cx<'_>, n: Node<'_, '_>) -> R<Option<(f64, f64)>> {
    match cx.opt_child(n, "Range")? {
        None => Ok(None),
        Some(r) => {
            let (lo, hi) = (cx.num(r, "lowerLimit")?, cx.num(r, "upperLimit")?);
            if hi < lo {
                return Err(cx.err(
                    r,
                    format!("a range from {lo} to {hi}: the upper limit is below the lower"),
                ));
            }
            Ok(Some((lo, hi)))
        }
    }
}

fn sampler(cx: &mut Cx<'_>, k: Node<'_, '_>) -> R<Sampler> {
    Ok(match k.name() {
        "ProbabilityDistributionSet" => {
            let mut v = Vec::new();
            for e in k.elements() {
                let w = cx.num(e, "weight")?;
                if w < 0.0 {
                    return Err(cx.err(e, "a weight is at least 0"));
                }
                v.push((cx.req(e, "value")?, w));
            }
            if v.iter().map(|x| x.1).sum::<f64>() <= 0.0 {
                return Err(cx.err(k, "the weights add up to 0"));
            }
            Sampler::Set(v)
        }
        "NormalDistribution" | "LogNormalDistribution" => {
            let log = k.name() == "LogNormalDistribution";
            let (mean, var) = if log {
                cx.since(k, "LogNormalDistribution", 3)?;
                (cx.num(k, "expectedValue")?, cx.num(k, "variance")?)
            } else {
                (cx.num(k, "expectedValue")?, cx.num(k, "variance")?)
            };
            if var < 0.0 {
                return Err(cx.err(k, "a variance is at least 0"));
            }
            Sampler::Normal {
                mean,
                sd: var.sqrt(),
                range: range(cx, k)?,
                log,
            }
        }
        "UniformDistribution" => {
            let (lo, hi) =
                range(cx, k)?.ok_or_else(|| cx.err(k, "<UniformDistribution> needs a Range"))?;
            Sampler::Uniform(lo, hi)
        }
        "PoissonDistribution" => Sampler::Poisson {
            mean: cx.num(k, "expectedValue")?,
            range: range(cx, k)?,
        },
        "Histogram" => {
            let mut bins = Vec::new();
            for b in k.elements() {
                let (lo, hi) = range(cx, b)?.ok_or_else(|| cx.err(b, "a Bin needs a Range"))?;
                bins.push((cx.num(b, "weight")?, lo, hi));
            }
            if bins.is_empty() {
                return Err(cx.err(k, "a Histogram needs at least one Bin"));
            }
            Sampler::Histogram(bins)
        }
        other => {
            return Err(cx.err(
                k,
                format!(
                    "{other} is not supported (supported: {})",
                    list(&[
                        "ProbabilityDistributionSet",
                        "NormalDistribution",
                        "LogNormalDistribution",
                        "UniformDistribution",
                        "PoissonDistribution",
                        "Histogram"
                    ])
                ),
            ));
        }
    })
}

impl Sampler {
    fn draw(&self, rng: &mut Rng) -> String {
        match self {
            Sampler::Set(v) => {
                let total: f64 = v.iter().map(|x| x.1).sum();
                let mut u = rng.unit() * total;
                for (value, w) in v {
                    if u < *w {
                        return value.clone();
                    }
                    u -= w;
                }
                v.last().map(|x| x.0.clone()).unwrap_or_default()
            }
            Sampler::Normal {
                mean,
                sd,
                range,
                log,
            } => {
                // Truncated by rejection (at most 1,000 tries, then the
                // nearest limit).
                for _ in 0..1000 {
                    let z = gauss(rng);
                    let x = if *log {
                        math::exp(math::ln(*mean) + sd * z)
                    } else {
                        mean + sd * z
                    };
                    if range.is_none_or(|(lo, hi)| (lo..=hi).contains(&x)) {
                        return fmt(x);
                    }
                }
                fmt(range.map_or(*mean, |(lo, hi)| mean.clamp(lo, hi)))
            }
            Sampler::Uniform(lo, hi) => fmt(lo + (hi - lo) * rng.unit()),
            Sampler::Poisson { mean, range } => {
                for _ in 0..1000 {
                    // Knuth's method.
                    let l = math::exp(-mean);
                    let (mut k, mut p) = (0u64, 1.0);
                    loop {
                        p *= rng.unit();
                        if p <= l || k > 10_000 {
                            break;
                        }
                        k += 1;
                    }
                    let x = k as f64;
                    if range.is_none_or(|(lo, hi)| (lo..=hi).contains(&x)) {
                        return fmt(x);
                    }
                }
                fmt(mean.round())
            }
            Sampler::Histogram(bins) => {
                let total: f64 = bins.iter().map(|b| b.0).sum();
                let mut u = rng.unit() * total;
                for (w, lo, hi) in bins {
                    if u < *w {
                        return fmt(lo + (hi - lo) * rng.unit());
                    }
                    u -= w;
                }
                let (_, lo, hi) = bins[bins.len() - 1];
                fmt(lo + (hi - lo) * rng.unit())
            }
        }
    }
}

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut Rng) -> f64 {
    let u1 = rng.unit().max(1e-300);
    let u2 = rng.unit();
    (-2.0 * math::ln(u1)).sqrt() * math::cos(2.0 * std::f64::consts::PI * u2)
}

fn fmt(v: f64) -> String {
    let r = (v * 1e9).round() / 1e9;
    if r.fract() == 0.0 && r.abs() < 9e15 {
        format!("{}", r as i64)
    } else {
        format!("{r}")
    }
}
