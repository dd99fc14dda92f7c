//! Path → smoothed, time-parametrised reference corridor.
//!
//! 1. Greedy line-of-sight shortcutting of the planner's path (every kept
//!    segment is checked against the grid, with the vehicle's body swept
//!    along it), and a lead-in along the start heading when the path
//!    leaves at an angle to it.
//! 2. Centripetal Catmull–Rom (α = ½: no cusps or self-intersections,
//!    Yuksel et al. 2011) through the remaining vertices, leaving the
//!    start along the vehicle's heading; resampling by arc length at `ds`.
//! 3. Bending-energy relaxation (a fourth-order flow), moves kept only
//!    where the footprint stays free: three candidates — shaped at 2 m
//!    towards 80 % of the turning limit then refined, the Catmull–Rom
//!    curve refined, the polyline refined — the first free one within the
//!    turning limit wins (`smoothed = false` for the polyline).
//! 4. Speed profile: v ≤ v_max, v ≤ √(a_lat,max / |κ|), v ≤ κ̇_max / |dκ/ds|
//!    (steering rate), forward pass with a_max, backward pass with d_max to
//!    stop at the goal; then, with a jerk limit, the fastest profile under
//!    all of that and the jerk limit (a linear program in v², Clarabel).
//! 5. Lateral bounds: free distance to the left and right of each point.

use crate::grid::PlanningGrid;
use litesim_core::{Vec2, wrap_angle};
use serde::{Deserialize, Serialize};

/// Limits of the speed profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedLimits {
    /// Top speed (m/s).
    pub v_max: f64,
    /// Lateral acceleration limit (m/s²).
    pub a_lat_max: f64,
    /// Acceleration (m/s²).
    pub a_max: f64,
    /// Deceleration (m/s², positive).
    pub d_max: f64,
    /// Speed at the start (m/s).
    pub v_start: f64,
    /// Largest rate of change of curvature the steering can produce
    /// (1/(m·s)): v·|dκ/ds| must stay below it, or the vehicle cannot turn
    /// its wheels fast enough to follow the path. `f64::INFINITY` = none.
    pub kappa_rate_max: f64,
    /// Largest curvature the vehicle can drive (1/m, tan δ_max / L): the
    /// corridor is shaped towards 80 % of it. `f64::INFINITY` = none.
    pub kappa_max: f64,
    /// Largest jerk of the profile (m/s³); `f64::INFINITY` = none.
    pub jerk_max: f64,
    /// Heading the vehicle starts with (rad): the corridor leaves the start
    /// along it, so tracking has no start-up transient. `None` = the
    /// path's own direction.
    pub start_heading: Option<f64>,
}

/// A reference corridor.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Corridor {
    /// The planner's path.
    pub raw: Vec<Vec2>,
    /// The path after shortcutting.
    pub shortcut: Vec<Vec2>,
    /// Resampled reference points.
    pub points: Vec<Vec2>,
    /// Arc length (m).
    pub s: Vec<f64>,
    /// Heading (rad).
    pub heading: Vec<f64>,
    /// Curvature (1/m).
    pub curvature: Vec<f64>,
    /// Speed profile (m/s).
    pub speed: Vec<f64>,
    /// Time at each point along the profile (s).
    pub time: Vec<f64>,
    /// Free distance to the left (m).
    pub left_bound: Vec<f64>,
    /// Free distance to the right (m).
    pub right_bound: Vec<f64>,
    /// False when neither Catmull–Rom candidate was free and the relaxed
    /// (corner-rounded) polyline is used instead.
    pub smoothed: bool,
    /// True when the speed profile is jerk-limited (false: the limit was
    /// not asked for, or the linear program had no answer and the
    /// acceleration-limited profile is used).
    #[serde(default)]
    pub jerk_limited: bool,
}

/// A reference point at some time or arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefState {
    /// Position.
    pub p: Vec2,
    /// Heading (rad).
    pub heading: f64,
    /// Speed (m/s).
    pub speed: f64,
    /// Curvature (1/m).
    pub curvature: f64,
    /// Arc length (m).
    pub s: f64,
}

fn shortcut(path: &[Vec2], grid: &PlanningGrid) -> Vec<Vec2> {
    if path.len() <= 2 {
        return path.to_vec();
    }
    let mut out = vec![path[0]];
    let mut i = 0;
    while i < path.len() - 1 {
        let mut j = path.len() - 1;
        while j > i + 1 && !grid.segment_free(path[i], path[j]) {
            j -= 1;
        }
        out.push(path[j]);
        i = j;
    }
    out
}

fn catmull_rom(pts: &[Vec2], per_segment: usize, start_heading: Option<f64>) -> Vec<Vec2> {
    if pts.len() < 2 || (pts.len() < 3 && start_heading.is_none()) {
        return pts.to_vec();
    }
    // Mirror the ends so the curve passes through the first and last
    // points; at the start, a phantom point behind the vehicle makes the
    // curve leave along its heading.
    let first = match start_heading {
        Some(h) => pts[0] - Vec2::from_heading(h) * pts[0].distance(pts[1]),
        None => pts[0] + (pts[0] - pts[1]),
    };
    let last = pts[pts.len() - 1] + (pts[pts.len() - 1] - pts[pts.len() - 2]);
    let mut ext = vec![first];
    ext.extend_from_slice(pts);
    ext.push(last);
    let knot = |a: Vec2, b: Vec2| a.distance(b).sqrt().max(1e-9);
    let mut out = Vec::new();
    for k in 1..ext.len() - 2 {
        let (p0, p1, p2, p3) = (ext[k - 1], ext[k], ext[k + 1], ext[k + 2]);
        let t0 = 0.0;
        let t1 = t0 + knot(p0, p1);
        let t2 = t1 + knot(p1, p2);
        let t3 = t2 + knot(p2, p3);
        for m in 0..per_segment {
            let t = t1 + (t2 - t1) * m as f64 / per_segment as f64;
            let a1 = p0 * ((t1 - t) / (t1 - t0)) + p1 * ((t - t0) / (t1 - t0));
            let a2 = p1 * ((t2 - t) / (t2 - t1)) + p2 * ((t - t1) / (t2 - t1));
            let a3 = p2 * ((t3 - t) / (t3 - t2)) + p3 * ((t - t2) / (t3 - t2));
            let b1 = a1 * ((t2 - t) / (t2 - t0)) + a2 * ((t - t0) / (t2 - t0));
            let b2 = a2 * ((t3 - t) / (t3 - t1)) + a3 * ((t - t1) / (t3 - t1));
            out.push(b1 * ((t2 - t) / (t2 - t1)) + b2 * ((t - t1) / (t2 - t1)));
        }
    }
    out.push(*pts.last().unwrap_or(&Vec2::default()));
    out
}

fn resample(dense: &[Vec2], ds: f64) -> Vec<Vec2> {
    let mut cum = vec![0.0];
    for w in dense.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let total = *cum.last().unwrap_or(&0.0);
    if total <= 0.0 {
        return dense.to_vec();
    }
    let n = (total / ds).ceil().max(1.0) as usize;
    let mut out = Vec::with_capacity(n + 1);
    let mut j = 0;
    for k in 0..=n {
        let s = total * k as f64 / n as f64;
        while j + 1 < cum.len() - 1 && cum[j + 1] < s {
            j += 1;
        }
        let seg = cum[j + 1] - cum[j];
        let u = if seg > 0.0 {
            ((s - cum[j]) / seg).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(dense[j].lerp(dense[j + 1], u));
    }
    out
}

/// Relaxes the resampled curve towards continuous curvature with sweeps
/// of the bi-Laplacian flow p ← p − (1/16)·Δ²p — the gradient flow of the
/// bending energy ∫κ² — each move kept only where the whole footprint
/// stays free. Catmull–Rom is only C¹: its curvature jumps at every vertex,
/// and a jump in curvature is a jump in steering that no rate-limited
/// actuator follows, the main source of cross-track error. The first two
/// points are clamped along the start heading, so the start is a smooth
/// turn out of the vehicle's own direction. (A second-order flow — the heat
/// equation on positions — would leave a kink at the clamped second point
/// and shrink every turn; the fourth-order flow does neither.)
fn relax(pts: &mut [Vec2], grid: &PlanningGrid, start_heading: Option<f64>, ds: f64) {
    relax_sweeps(pts, grid, start_heading, None, relax_length(ds));
}

/// Sweeps of a full relaxation at spacing `ds`: the length scale is about
/// ds·sweeps^¼, 2.5 m at ds = 0.5 m.
fn relax_length(ds: f64) -> usize {
    (2.5 / ds).powi(4).round().clamp(16.0, 2000.0) as usize
}

/// [`relax`] with a given number of sweeps; with `end_heading` the curve
/// also arrives along that heading (its last two points fixed, as the
/// first two are with a start heading).
fn relax_sweeps(
    pts: &mut [Vec2],
    grid: &PlanningGrid,
    start_heading: Option<f64>,
    end_heading: Option<f64>,
    sweeps: usize,
) {
    let n = pts.len();
    if n < 6 {
        return;
    }
    let d = pts[0].distance(pts[1]);
    clamp_start(pts, grid, start_heading, d);
    let mut fixed_end = 1;
    if let Some(h) = end_heading {
        let d = pts[n - 2].distance(pts[n - 1]);
        let q = pts[n - 1] - Vec2::from_heading(h) * d;
        if grid.pose_free(q, h) {
            pts[n - 2] = q;
            fixed_end = 2;
        }
    }
    let mut next = pts.to_vec();
    let ok = |prev: Vec2, q: Vec2, nxt: Vec2| grid.pose_free(q, (nxt - prev).heading());
    biharmonic(pts, &mut next, sweeps, &ok, fixed_end);
}

/// Sweeps of the bi-Laplacian flow over `pts[2..n−fixed_end]`: the first
/// two points are clamped (start position and heading); the last is fixed
/// and its tangent free (a ghost point continues the curve straight), so
/// the end has no kink either — or with `fixed_end` = 2 the last two are
/// clamped too (end position and heading).
fn biharmonic(
    pts: &mut [Vec2],
    next: &mut [Vec2],
    sweeps: usize,
    ok: &dyn Fn(Vec2, Vec2, Vec2) -> bool,
    fixed_end: usize,
) {
    let n = pts.len();
    if n < 4 + fixed_end {
        return;
    }
    let end = n - fixed_end;
    for _ in 0..sweeps {
        for i in 2..end {
            let after = if i + 2 < n {
                pts[i + 2]
            } else {
                pts[n - 1] * 2.0 - pts[n - 2]
            };
            let b = pts[i - 2] + after - (pts[i - 1] + pts[i + 1]) * 4.0 + pts[i] * 6.0;
            let q = pts[i] - b * (1.0 / 16.0);
            next[i] = if ok(pts[i - 1], q, pts[i + 1]) {
                q
            } else {
                pts[i]
            };
        }
        pts[2..end].copy_from_slice(&next[2..end]);
    }
}

/// Signed curvature of the circle through three points (Menger); 0 for
/// coincident or collinear points.
fn curvature3(p0: Vec2, p1: Vec2, p2: Vec2) -> f64 {
    let (a, b) = (p1 - p0, p2 - p1);
    let den = a.norm() * b.norm() * (p2 - p0).norm();
    if den > 1e-12 {
        2.0 * a.cross(b) / den
    } else {
        0.0
    }
}

/// Largest |curvature| of a polyline (three-point formula).
pub(crate) fn max_curvature(pts: &[Vec2]) -> f64 {
    pts.windows(3)
        .map(|w| curvature3(w[0], w[1], w[2]).abs())
        .fold(0.0, f64::max)
}

/// Puts the second point `d` m ahead of the first along the start heading
/// (if the body fits there), which fixes the curve's initial tangent.
fn clamp_start(pts: &mut [Vec2], grid: &PlanningGrid, start_heading: Option<f64>, d: f64) {
    if let (Some(h), true) = (start_heading, pts.len() >= 2) {
        let q = pts[0] + Vec2::from_heading(h) * d;
        if grid.pose_free(q, h) {
            pts[1] = q;
        }
    }
}

/// Shapes the path at a coarse spacing (2 m) until its curvature is below
/// `kappa_target` or the free space stops it: at 2 m a sweep of the
/// bending flow reaches 4⁴ = 256 times further than at 0.5 m, so turns of
/// a vehicle's size (4–8 m radii) form in a few hundred sweeps. The fine
/// relaxation then only removes what resampling leaves.
fn shape_coarse(
    fine: &[Vec2],
    grid: &PlanningGrid,
    start_heading: Option<f64>,
    kappa_target: f64,
) -> Vec<Vec2> {
    let total: f64 = fine.windows(2).map(|w| w[0].distance(w[1])).sum();
    let n = (total / 2.0).ceil() as usize;
    if n < 5 {
        return fine.to_vec();
    }
    let mut pts = resample(fine, total / n as f64);
    let ds = total / n as f64;
    clamp_start(&mut pts, grid, start_heading, ds);
    let mut next = pts.clone();
    // At 2 m spacing the chords to the neighbours must be free too (the
    // fine curve runs within centimetres of them): checked every 0.5 m,
    // and the vertex with either chord's heading.
    // A quarter of a cell of extra room absorbs what the fine curve and
    // its headings differ from the chords.
    let extra = 0.25 * grid.grid.resolution;
    let ok = |prev: Vec2, q: Vec2, nxt: Vec2| {
        grid.pose_free_with(q, (nxt - prev).heading(), extra)
            && grid.pose_free_with(q, (q - prev).heading(), extra)
            && grid.pose_free_with(q, (nxt - q).heading(), extra)
            && [0.25, 0.5, 0.75].iter().all(|&u| {
                grid.pose_free_with(q.lerp(prev, u), (q - prev).heading(), extra)
                    && grid.pose_free_with(q.lerp(nxt, u), (nxt - q).heading(), extra)
            })
    };
    // At least a 6 m length scale (81 sweeps), more while too tight.
    biharmonic(&mut pts, &mut next, 81, &ok, 1);
    for _round in 0..20 {
        if max_curvature(&pts) <= kappa_target {
            break;
        }
        biharmonic(&mut pts, &mut next, 100, &ok, 1);
    }
    pts
}

/// The fastest speed profile under the caps, the acceleration limits and a
/// jerk limit, as a linear program in b = v² (Clarabel): acceleration
/// a = ½·db/ds is linear in b, and jerk j = v·da/ds is kept within J by
/// |aᵢ₊₁ − aᵢ| ≤ J·Δs / v̄ — linear once v̄ is the acceleration-limited
/// profile, which bounds the answer from above, so the limit is
/// conservative, never loose. The objective, Σ bᵢ·Δsᵢ, pushes speed up
/// everywhere (a proxy for the shortest time). The start speed and the
/// stop are equalities. `None` when no limit is asked for, or the program
/// has no answer (the caller keeps the acceleration-limited profile).
fn jerk_limited_profile(
    caps: &[f64],
    vbar: &[f64],
    s: &[f64],
    limits: &SpeedLimits,
) -> Option<Vec<f64>> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{
        DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, ZeroConeT,
    };
    let n = caps.len();
    let jerk = limits.jerk_max;
    if !(jerk.is_finite() && jerk > 0.0) || n < 4 {
        return None;
    }
    let ds: Vec<f64> = (0..n - 1).map(|i| (s[i + 1] - s[i]).max(1e-9)).collect();
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::with_capacity(6 * n);
    // Equalities: b₀ = v₀², b_{n−1} = 0.
    rows.push((vec![(0, 1.0)], caps[0] * caps[0]));
    rows.push((vec![(n - 1, 1.0)], 0.0));
    let n_eq = rows.len();
    for (i, c) in caps.iter().enumerate().take(n - 1).skip(1) {
        rows.push((vec![(i, 1.0)], c * c));
        rows.push((vec![(i, -1.0)], 0.0));
    }
    for (i, d) in ds.iter().enumerate() {
        rows.push((vec![(i, -1.0), (i + 1, 1.0)], 2.0 * limits.a_max * d));
        rows.push((vec![(i, 1.0), (i + 1, -1.0)], 2.0 * limits.d_max * d));
    }
    for i in 0..n.saturating_sub(3) {
        // a_{i+1} − a_i with a_k = (b_{k+1} − b_k) / (2 Δs_k).
        let (h0, h1) = (0.5 / ds[i], 0.5 / ds[i + 1]);
        let coef = [(i, h0), (i + 1, -h0 - h1), (i + 2, h1)];
        let lim = jerk * 0.5 * (ds[i] + ds[i + 1]) / vbar[i + 1].max(0.3);
        rows.push((coef.to_vec(), lim));
        rows.push((coef.iter().map(|&(j, c)| (j, -c)).collect(), lim));
    }
    let m = rows.len();
    let b: Vec<f64> = rows.iter().map(|r| r.1).collect();
    if b.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let a = crate::mpc::csc_from_rows(m, n, &rows);
    let p = CscMatrix::new(n, n, vec![0; n + 1], Vec::new(), Vec::new());
    let q: Vec<f64> = (0..n)
        .map(|i| {
            let w =
                0.5 * (if i > 0 { ds[i - 1] } else { 0.0 } + if i + 1 < n { ds[i] } else { 0.0 });
            -w
        })
        .collect();
    // Speeds to about 1e-4 m/s are plenty (b to 1e-6 m²/s² in relative
    // terms): looser than the solver's default 1e-8, and fewer iterations.
    let settings = DefaultSettings::<f64> {
        verbose: false,
        max_iter: 200,
        tol_gap_abs: 1e-6,
        tol_gap_rel: 1e-6,
        tol_feas: 1e-6,
        ..DefaultSettings::default()
    };
    let cones = [ZeroConeT(n_eq), NonnegativeConeT(m - n_eq)];
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings).ok()?;
    solver.solve();
    if !matches!(
        solver.solution.status,
        SolverStatus::Solved | SolverStatus::AlmostSolved
    ) {
        return None;
    }
    // Never above the caps (interior-point answers sit a hair inside or
    // outside their bounds).
    Some(
        solver
            .solution
            .x
            .iter()
            .zip(caps)
            .map(|(b, c)| b.max(0.0).sqrt().min(*c))
            .collect(),
    )
}

/// Every point's footprint is free, heading along the curve.
fn footprint_free(pts: &[Vec2], grid: &PlanningGrid) -> bool {
    let n = pts.len();
    (0..n).all(|i| {
        let (a, b) = (pts[i.saturating_sub(1)], pts[(i + 1).min(n - 1)]);
        if a == b {
            grid.is_free(pts[i])
        } else {
            grid.pose_free(pts[i], (b - a).heading())
        }
    })
}

/// Arc length and heading (as [`Corridor::from_points`] takes them) of
/// resampled points.
fn arc_and_heading(points: &[Vec2]) -> (Vec<f64>, Vec<f64>) {
    let n = points.len();
    let mut s = vec![0.0; n];
    for i in 1..n {
        s[i] = s[i - 1] + points[i - 1].distance(points[i]);
    }
    let heading = (0..n)
        .map(|i| {
            let (a, b) = (points[i.saturating_sub(1)], points[(i + 1).min(n - 1)]);
            (b - a).heading()
        })
        .collect();
    (s, heading)
}

/// [`Corridor::turn_curvature`] of points with arc length `s` and
/// headings `heading`.
fn turn_curvature(s: &[f64], heading: &[f64], half: f64) -> Vec<f64> {
    let n = s.len().min(heading.len());
    (0..n)
        .map(|i| {
            let lo = s.partition_point(|x| *x < s[i] - half).min(i);
            let hi = (s.partition_point(|x| *x <= s[i] + half)).clamp(i + 1, n) - 1;
            let ds = s[hi] - s[lo];
            if hi > lo && ds > 1e-9 {
                let mut turn = 0.0;
                for k in lo..hi {
                    turn += wrap_angle(heading[k + 1] - heading[k]);
                }
                turn / ds
            } else {
                0.0
            }
        })
        .collect()
}

/// Half the arc (m) over which a path's turn is measured as a vehicle
/// drives it ([`Corridor::turn_curvature`]) when its turning limit is
/// checked …
pub(crate) const TURN_HALF_ARC: f64 = 1.0;
/// … and the share of the limit allowed (2 % for rounding).
pub(crate) const TURN_SLACK: f64 = 1.02;

/// The points turn no tighter than `kappa_max` as a vehicle drives them
/// (the closed loop's own test of a path).
fn turns_within(points: &[Vec2], kappa_max: f64) -> bool {
    if !kappa_max.is_finite() {
        return true;
    }
    let (s, heading) = arc_and_heading(points);
    turn_curvature(&s, &heading, TURN_HALF_ARC)
        .iter()
        .all(|k| k.abs() <= kappa_max * TURN_SLACK)
}

fn free_distance(grid: &PlanningGrid, p: Vec2, dir: Vec2) -> f64 {
    let step = 0.5 * grid.grid.resolution;
    let mut d = 0.0;
    while d < 20.0 && grid.is_free(p + dir * (d + step)) {
        d += step;
    }
    d
}

impl Corridor {
    /// Builds a corridor from a planner path (at least 2 points).
    pub fn build(raw: &[Vec2], grid: &PlanningGrid, ds: f64, limits: &SpeedLimits) -> Self {
        let ds = if ds.is_finite() && ds > 0.0 { ds } else { 0.5 };
        let mut short = shortcut(raw, grid);
        let start_heading = limits.start_heading.filter(|h| h.is_finite());
        // Lead-in: when the path leaves at an angle to the vehicle's
        // heading, first drive straight on for about a turning radius (if
        // that is free), so the turn onto the path has room instead of
        // being squeezed into the first metre.
        if let (Some(h), true) = (start_heading, short.len() >= 2) {
            let dir = Vec2::from_heading(h);
            let leave = (short[1] - short[0]).heading();
            let off = wrap_angle(leave - h).abs();
            let r = if limits.kappa_max.is_finite() && limits.kappa_max > 0.0 {
                1.0 / limits.kappa_max
            } else {
                3.0
            };
            if off > 0.05 {
                let first = short[0];
                let seg = first.distance(short[1]);
                for d in [1.5 * r, r, 0.5 * r] {
                    let q = first + dir * d;
                    if d < seg && grid.segment_free(first, q) && grid.segment_free(q, short[1]) {
                        short.insert(1, q);
                        break;
                    }
                }
            }
        }
        // Candidates, best first; the first that is free and within the
        // turning limit wins, else the first free one, else the relaxed
        // polyline (which the caller's own check then refuses):
        // 1. the Catmull–Rom curve shaped at 2 m towards the turning limit,
        // 2. the Catmull–Rom curve,
        // 3. the checked polyline (free, and relaxation only makes moves
        //    that stay free, so its corners round off as far as the free
        //    space allows).
        let cr = resample(&catmull_rom(&short, 20, start_heading), ds);
        let kappa_target = 0.8 * limits.kappa_max;
        let finish = |mut pts: Vec<Vec2>| {
            relax(&mut pts, grid, start_heading, ds);
            resample(&pts, ds)
        };
        let polyline = || {
            let mut dense = Vec::new();
            for w in short.windows(2) {
                let n = (w[0].distance(w[1]) / (ds / 4.0)).ceil().max(1.0) as usize;
                dense.extend((0..n).map(|k| w[0].lerp(w[1], k as f64 / n as f64)));
            }
            dense.extend(short.last().copied());
            resample(&dense, ds)
        };
        let within =
            |pts: &[Vec2]| !limits.kappa_max.is_finite() || max_curvature(pts) <= limits.kappa_max;
        let mut first_free: Option<(Vec<Vec2>, bool)> = None;
        let mut chosen: Option<(Vec<Vec2>, bool)> = None;
        for k in 0..3 {
            let pts = match k {
                0 if limits.kappa_max.is_finite() => finish(resample(
                    &shape_coarse(&cr, grid, start_heading, kappa_target),
                    ds,
                )),
                0 => continue,
                1 => finish(cr.clone()),
                _ => finish(polyline()),
            };
            if !footprint_free(&pts, grid) {
                continue;
            }
            if within(&pts) {
                chosen = Some((pts, k < 2));
                break;
            }
            if first_free.is_none() {
                first_free = Some((pts, k < 2));
            }
        }
        let (points, smoothed) = chosen
            .or(first_free)
            .unwrap_or_else(|| (finish(polyline()), false));
        Self::from_points(raw.to_vec(), short, points, smoothed, grid, limits)
    }

    /// Builds a corridor along a path the vehicle can already drive (from
    /// [`crate::hybrid_astar`]: arcs within its turning limit, footprint
    /// free): resampled at `ds` and relaxed towards continuous curvature
    /// (the arcs' joints are curvature jumps), with no shortcut — a
    /// shortcut would cut the arcs back into corners.
    pub fn along(path: &[Vec2], grid: &PlanningGrid, ds: f64, limits: &SpeedLimits) -> Self {
        Self::along_to(path, grid, ds, limits, None)
    }

    /// [`Self::along`], arriving along `end_heading` (rad) when given: a leg
    /// that ends at a change of direction ends in the heading the next one
    /// leaves in, so the vehicle turns its wheels at standstill and no
    /// kink is left at the cusp.
    pub fn along_to(
        path: &[Vec2],
        grid: &PlanningGrid,
        ds: f64,
        limits: &SpeedLimits,
        end_heading: Option<f64>,
    ) -> Self {
        let ds = if ds.is_finite() && ds > 0.0 { ds } else { 0.5 };
        let start_heading = limits.start_heading.filter(|h| h.is_finite());
        let plain = resample(path, ds);
        // The most relaxed curve whose whole footprint stays free (moves
        // are checked one at a time, against headings that later moves
        // change, so a long relaxation can end against a wall): the full
        // length scale, then ½, ¼, … of it (a sixteenth of the sweeps
        // halves the scale); else the path as planned. With a heading at
        // both ends (a leg between cusps) the curve must also stay within
        // the turning limit: a short leg clamped at both ends can be bent
        // tighter than its arcs.
        let mut chosen = None;
        let mut sweeps = relax_length(ds);
        while sweeps >= 4 {
            let mut relaxed = plain.clone();
            relax_sweeps(&mut relaxed, grid, start_heading, end_heading, sweeps);
            let relaxed = resample(&relaxed, ds);
            let turns_ok = end_heading.is_none() || turns_within(&relaxed, limits.kappa_max);
            if turns_ok && footprint_free(&relaxed, grid) {
                chosen = Some(relaxed);
                break;
            }
            sweeps /= 16;
        }
        let (points, smoothed) = match chosen {
            Some(p) => (p, true),
            None => (plain, false),
        };
        Self::from_points(path.to_vec(), path.to_vec(), points, smoothed, grid, limits)
    }

    /// The reference (headings, curvatures, speed profile, bounds) along
    /// resampled `points`.
    fn from_points(
        raw: Vec<Vec2>,
        short: Vec<Vec2>,
        points: Vec<Vec2>,
        smoothed: bool,
        grid: &PlanningGrid,
        limits: &SpeedLimits,
    ) -> Self {
        let n = points.len();
        let (s, heading) = arc_and_heading(&points);
        let mut curvature: Vec<f64> = (0..n)
            .map(|i| {
                if i == 0 || i + 1 >= n {
                    return 0.0;
                }
                curvature3(points[i - 1], points[i], points[i + 1])
            })
            .collect();
        // The ends take their neighbours' curvature (a three-point formula
        // has none there), so the reference steering does not jump at the
        // first and last points.
        if n >= 3 {
            curvature[0] = curvature[1];
            curvature[n - 1] = curvature[n - 2];
        }
        let mut speed: Vec<f64> = (0..n)
            .map(|i| {
                let k = curvature[i];
                let lat = if k.abs() > 1e-9 {
                    (limits.a_lat_max / k.abs()).sqrt()
                } else {
                    f64::INFINITY
                };
                // Steering rate: v·|dκ/ds| ≤ κ̇_max.
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let dk = if b > a && s[b] > s[a] {
                    (curvature[b] - curvature[a]).abs() / (s[b] - s[a])
                } else {
                    0.0
                };
                let steer = if dk > 1e-12 {
                    limits.kappa_rate_max / dk
                } else {
                    f64::INFINITY
                };
                lat.min(steer).min(limits.v_max)
            })
            .collect();
        if n > 0 {
            speed[0] = speed[0].min(limits.v_start.max(0.0));
            speed[n - 1] = 0.0;
        }
        let caps = speed.clone();
        for i in 1..n {
            let d = s[i] - s[i - 1];
            speed[i] = speed[i].min((speed[i - 1].powi(2) + 2.0 * limits.a_max * d).sqrt());
        }
        for i in (0..n.saturating_sub(1)).rev() {
            let d = s[i + 1] - s[i];
            speed[i] = speed[i].min((speed[i + 1].powi(2) + 2.0 * limits.d_max * d).sqrt());
        }
        let jerk_limited = match jerk_limited_profile(&caps, &speed, &s, limits) {
            Some(v) => {
                speed = v;
                true
            }
            None => false,
        };
        let mut time = vec![0.0; n];
        for i in 1..n {
            let v = 0.5 * (speed[i] + speed[i - 1]);
            time[i] = time[i - 1] + if v > 1e-6 { (s[i] - s[i - 1]) / v } else { 0.0 };
        }
        let (left_bound, right_bound) = (0..n)
            .map(|i| {
                let nrm = Vec2::from_heading(heading[i] + std::f64::consts::FRAC_PI_2);
                (
                    free_distance(grid, points[i], nrm),
                    free_distance(grid, points[i], -nrm),
                )
            })
            .unzip();
        Self {
            raw,
            shortcut: short,
            points,
            s,
            heading,
            curvature,
            speed,
            time,
            left_bound,
            right_bound,
            smoothed,
            jerk_limited,
        }
    }

    /// Total length (m).
    pub fn length(&self) -> f64 {
        self.s.last().copied().unwrap_or(0.0)
    }

    /// Duration of the speed profile (s).
    pub fn duration(&self) -> f64 {
        self.time.last().copied().unwrap_or(0.0)
    }

    fn interp(&self, i: usize, u: f64) -> RefState {
        let j = (i + 1).min(self.points.len() - 1);
        RefState {
            p: self.points[i].lerp(self.points[j], u),
            heading: self.heading[i] + wrap_angle(self.heading[j] - self.heading[i]) * u,
            speed: self.speed[i] + (self.speed[j] - self.speed[i]) * u,
            curvature: self.curvature[i] + (self.curvature[j] - self.curvature[i]) * u,
            s: self.s[i] + (self.s[j] - self.s[i]) * u,
        }
    }

    /// The reference at time `t` along the speed profile (clamped).
    pub fn at_time(&self, t: f64) -> RefState {
        let i = self
            .time
            .partition_point(|x| *x <= t)
            .clamp(1, self.time.len().max(2) - 1)
            - 1;
        let j = (i + 1).min(self.time.len() - 1);
        let dt = self.time[j] - self.time[i];
        let u = if dt > 0.0 {
            ((t - self.time[i]) / dt).clamp(0.0, 1.0)
        } else {
            1.0
        };
        self.interp(i, u)
    }

    /// Projects a point: (arc length, signed lateral error, index of the segment).
    pub fn project(&self, p: Vec2, hint: usize) -> (f64, f64, usize) {
        let n = self.points.len();
        if n < 2 {
            return (0.0, 0.0, 0);
        }
        // Search a window around the previous projection; the vehicle moves
        // little per step, and a global search could jump between branches.
        let lo = hint.saturating_sub(20);
        let hi = (hint + 200).min(n - 1);
        let mut best = (f64::INFINITY, 0.0, 0.0, lo);
        for i in lo..hi {
            let (a, b) = (self.points[i], self.points[i + 1]);
            let d = b - a;
            let l2 = d.dot(d);
            let u = litesim_core::segment_fraction(p, a, d);
            let e = p - (a + d * u);
            let dist = e.dot(e);
            if dist < best.0 {
                let lat = if l2 > 0.0 {
                    d.cross(p - a) / l2.sqrt()
                } else {
                    0.0
                };
                best = (dist, self.s[i] + u * (self.s[i + 1] - self.s[i]), lat, i);
            }
        }
        (best.1, best.2, best.3)
    }

    /// The segment `[i, j]` around arc length `s` and the fraction `u` along it.
    fn locate_s(&self, s: f64) -> (usize, usize, f64) {
        let i = self
            .s
            .partition_point(|x| *x <= s)
            .clamp(1, self.s.len().max(2) - 1)
            - 1;
        let j = (i + 1).min(self.s.len() - 1);
        let ds = self.s[j] - self.s[i];
        let u = if ds > 0.0 {
            ((s - self.s[i]) / ds).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (i, j, u)
    }

    /// Time along the profile at arc length `s`.
    pub fn time_at_s(&self, s: f64) -> f64 {
        let (i, j, u) = self.locate_s(s);
        self.time[i] + (self.time[j] - self.time[i]) * u
    }

    /// Heading at arc length `s`.
    pub fn heading_at_s(&self, s: f64) -> f64 {
        let (i, j, u) = self.locate_s(s);
        self.heading[i] + wrap_angle(self.heading[j] - self.heading[i]) * u
    }

    /// Curvature as a vehicle experiences it: the heading change over
    /// ±`half` m of arc divided by that arc. A kink shorter than that (a
    /// point the smoothing could not move) changes the heading by little,
    /// and a body metres long drives over it; a real turn keeps its
    /// curvature.
    pub fn turn_curvature(&self, half: f64) -> Vec<f64> {
        turn_curvature(&self.s, &self.heading, half)
    }

    /// The first point whose footprint (heading along the corridor) is not
    /// free, if any.
    pub fn first_blocked(&self, grid: &PlanningGrid) -> Option<Vec2> {
        (0..self.points.len())
            .find(|&i| !grid.pose_free(self.points[i], self.heading[i]))
            .map(|i| self.points[i])
    }

    /// Smallest clearance along the corridor (m), from the grid.
    pub fn min_clearance(&self, grid: &PlanningGrid) -> f64 {
        self.points
            .iter()
            .map(|p| grid.clearance(*p))
            .fold(f64::INFINITY, f64::min)
    }
}
