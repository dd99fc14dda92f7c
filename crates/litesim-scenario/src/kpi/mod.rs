//! Checkers and KPIs over the executed states: collisions between actors
//! (oriented boxes, separating axes), off-road vehicles, minimum distance
//! (box to box) and time to collision per pair (constant velocities, swept
//! boxes), and speed and path errors against the plan.

mod broad;
mod ego;
mod geometry;
pub use broad::*;
pub use ego::*;
pub use geometry::*;

use crate::state::BodyState;
use litesim_core::geometry::wrap_angle;
use litesim_core::math;
use serde::Serialize;
use std::collections::BTreeMap;

/// KPIs of one actor pair.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PairKpi {
    /// First actor id.
    pub a: String,
    /// Second actor id.
    pub b: String,
    /// Smallest box-to-box distance (m), to [`DISTANCE_RESOLUTION`].
    pub min_distance: f64,
    /// When it was smallest (s).
    pub min_distance_at: f64,
    /// Smallest time to collision (s): when the boxes would touch if both
    /// kept their velocities (within [`TTC_HORIZON`]); `null` when never.
    pub min_ttc: Option<f64>,
    /// When it was smallest (s).
    pub min_ttc_at: Option<f64>,
    /// First collision time (s).
    pub collision_at: Option<f64>,
    /// How the first collision happened, and who caused it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<Contact>,
}

/// Which part of a body was hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// The front.
    Front,
    /// The rear.
    Rear,
    /// The left side.
    Left,
    /// The right side.
    Right,
}

/// The kind of a collision, from the two headings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactKind {
    /// Same direction, a front into a rear (headings within 30°).
    RearEnd,
    /// Same direction, side to side.
    Sideswipe,
    /// Opposite directions (headings 150° or more apart).
    HeadOn,
    /// Crossing paths (between).
    Angle,
}

/// A collision's geometry at first contact and its attribution: who struck
/// whom, where, and who was not keeping its lane and speed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Contact {
    /// The kind.
    pub kind: ContactKind,
    /// Where the pair's first actor (`a`) was hit.
    pub part_a: Part,
    /// Where the second (`b`) was hit.
    pub part_b: Part,
    /// The actor that struck the other (its front, or the one that moved
    /// sideways into the other).
    pub striker: String,
    /// The actor responsible: the striker, unless the other cut into its
    /// path (it was moving sideways across the striker's heading faster
    /// than [`CUT_IN_SPEED`]); `None`: both (a head-on where neither
    /// swerved).
    pub responsible: Option<String>,
}

/// Sideways speed (m/s) across the other's heading above which an actor
/// counts as changing lanes at a contact (not keeping its lane).
pub const CUT_IN_SPEED: f64 = 0.3;

/// Where `other`'s centre lies seen from `me`: the part of `me` facing it
/// (its half extents set the diagonals that part the four sides).
fn part_facing(me: &BodyState, other: &BodyState) -> Part {
    let (s, c) = math::sin_cos(me.yaw);
    let (dx, dy) = (other.x - me.x, other.y - me.y);
    let along = (dx * c + dy * s) / (0.5 * me.length).max(1e-6);
    let across = (-dx * s + dy * c) / (0.5 * me.width).max(1e-6);
    if along.abs() >= across.abs() {
        if along >= 0.0 {
            Part::Front
        } else {
            Part::Rear
        }
    } else if across >= 0.0 {
        Part::Left
    } else {
        Part::Right
    }
}

/// `me`'s speed across `other`'s heading, towards `other` (m/s).
fn sideways_towards(me: &BodyState, other: &BodyState) -> f64 {
    let (s, c) = math::sin_cos(other.yaw);
    let lateral_v = -me.vx * s + me.vy * c;
    let lateral_p = -(other.x - me.x) * s + (other.y - me.y) * c;
    lateral_v * lateral_p.signum()
}

/// The geometry and attribution of a contact between `a` and `b` (ids
/// `ida`, `idb`).
pub fn contact(a: &BodyState, b: &BodyState, ida: &str, idb: &str) -> Contact {
    let (part_a, part_b) = (part_facing(a, b), part_facing(b, a));
    let alpha = wrap_angle(b.yaw - a.yaw).abs();
    let kind = if alpha >= 150f64.to_radians() {
        ContactKind::HeadOn
    } else if alpha > 30f64.to_radians() {
        ContactKind::Angle
    } else if matches!(part_a, Part::Front | Part::Rear)
        && matches!(part_b, Part::Front | Part::Rear)
    {
        ContactKind::RearEnd
    } else {
        ContactKind::Sideswipe
    };
    let (sa, sb) = (sideways_towards(a, b), sideways_towards(b, a));
    let name = |first: bool| if first { ida } else { idb }.to_string();
    let (striker, responsible) = match kind {
        ContactKind::RearEnd | ContactKind::Angle => {
            // The front that hit: a's front into b, or b's into a.
            let a_strikes = part_a == Part::Front && part_b != Part::Front;
            let struck_swerved = if a_strikes { sb } else { sa } > CUT_IN_SPEED;
            let striker = name(a_strikes);
            let responsible = if kind == ContactKind::RearEnd && struck_swerved {
                // It cut into the striker's path: the cut-in's fault.
                name(!a_strikes)
            } else {
                striker.clone()
            };
            (striker, Some(responsible))
        }
        ContactKind::Sideswipe | ContactKind::HeadOn => {
            // The one moving sideways into the other.
            let a_moves = sa >= sb;
            let striker = name(a_moves);
            let responsible = (sa.max(sb) > CUT_IN_SPEED).then(|| striker.clone());
            (striker, responsible)
        }
    };
    Contact {
        kind,
        part_a,
        part_b,
        striker,
        responsible,
    }
}

/// KPIs of one actor.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ActorKpi {
    /// Id.
    pub id: String,
    /// Largest |speed − planned speed| (m/s).
    pub max_speed_error: f64,
    /// Largest distance from the planned position (m).
    pub max_path_error: f64,
    /// RMS distance from the planned position (m), set by [`Kpis::finish`].
    pub rms_path_error: f64,
    /// RMS |speed − planned speed| (m/s); for calibration reports, not in
    /// run summaries.
    #[serde(skip)]
    pub rms_speed_error: f64,
    /// First time off every road (s), vehicles only.
    pub off_road_at: Option<f64>,
    /// Distance travelled (m).
    pub distance: f64,
    /// Top speed (m/s).
    pub max_speed: f64,
    /// The first red light run: (box id, time s).
    pub ran_red_light: Option<(String, f64)>,
}

/// Pairs closer than this (box bound to box bound, m) are tracked: their
/// distance, TTC and collisions are computed exactly.
pub const NEAR: f64 = 30.0;
/// Pairs whose boxes, swept along their velocities over this time, could
/// meet are tracked too (s); it bounds the TTCs reported.
pub const TTC_HORIZON: f64 = 5.0;

type PairHash = std::hash::BuildHasherDefault<PairHasher>;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn bx(x: f64, y: f64, yaw: f64, vx: f64, vy: f64) -> BodyState {
        BodyState {
            x,
            y,
            yaw,
            length: 4.0,
            width: 2.0,
            vx,
            vy,
            speed: math::hypot(vx, vy),
            acceleration: 0.0,
        }
    }

    #[test]
    fn time_headway_drac_and_jerk_over_a_second() {
        let mut k = EgoKpi::new("sut.car", 0.02);
        // sut.car at 20 m/s, a car 20 m ahead (16 m bumper gap) at 10 m/s,
        // one in the next lane, one behind.
        let boxes = [
            bx(0.0, 0.0, 0.0, 20.0, 0.0),
            bx(20.0, 0.0, 0.0, 10.0, 0.0),
            bx(10.0, 3.5, 0.0, 10.0, 0.0),
            bx(-20.0, 0.0, 0.0, 30.0, 0.0),
        ];
        let ids = ["sut.car", "lead", "beside", "behind"];
        k.follow(1.0, 0, &boxes, |j| ids[j]);
        k.finish(0.0, 0.0);
        assert_eq!(k.leads.len(), 1);
        let l = &k.leads[0];
        assert_eq!(l.id, "lead");
        assert!((l.min_thw - 0.8).abs() < 1e-12, "{l:?}");
        assert!((l.max_drac - 100.0 / 32.0).abs() < 1e-12, "{l:?}");
        // Braking ramped at 2 m/s³ for 2 s: 2 m/s³ over a second.
        let mut k = EgoKpi::new("sut.car", 0.02);
        let mut v = 20.0;
        for i in 0..200 {
            let a = -2.0 * (i as f64 * 0.02);
            v += a * 0.02;
            k.step(i as f64 * 0.02, v, 0.0, 0.0);
        }
        assert!((k.max_jerk_1s - 2.0).abs() < 1e-6, "{}", k.max_jerk_1s);
    }

    #[test]
    fn contacts_are_attributed_from_their_geometry() {
        // The ego keeps its lane at 10 m/s; a faster car runs into its rear.
        let ego = bx(0.0, 0.0, 0.0, 10.0, 0.0);
        let rear = bx(-3.9, 0.1, 0.0, 15.0, 0.0);
        let c = contact(&ego, &rear, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::RearEnd, Part::Rear, Part::Front)
        );
        assert_eq!(c.striker, "other");
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // A car cuts in just ahead, moving sideways: the ego's front hits
        // its rear, and the cut-in is responsible.
        let cut = bx(3.9, 0.3, 0.1, 10.0, -1.5);
        let c = contact(&ego, &cut, "sut.car", "other");
        assert_eq!(c.kind, ContactKind::RearEnd);
        assert_eq!(c.striker, "sut.car");
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // The same car ahead keeping its lane: the ego is responsible.
        let slow = bx(3.9, 0.3, 0.0, 5.0, 0.0);
        let c = contact(&ego, &slow, "sut.car", "other");
        assert_eq!(c.responsible.as_deref(), Some("sut.car"));
        // Side by side, the other drifting into the ego's side.
        let beside = bx(0.5, 1.9, 0.0, 10.0, -1.0);
        let c = contact(&ego, &beside, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::Sideswipe, Part::Left, Part::Right)
        );
        assert_eq!(c.responsible.as_deref(), Some("other"));
        // A crossing car's front into the ego's right side.
        let crossing = bx(0.0, -2.9, std::f64::consts::FRAC_PI_2, 0.0, 8.0);
        let c = contact(&ego, &crossing, "sut.car", "other");
        assert_eq!(
            (c.kind, c.part_a, c.part_b),
            (ContactKind::Angle, Part::Right, Part::Front)
        );
        assert_eq!(c.responsible.as_deref(), Some("other"));
    }

    /// Distance by brute force: every corner of each box to every edge of
    /// the other (0 when they overlap).
    fn brute(a: &BodyState, b: &BodyState) -> f64 {
        if overlap(a, b) {
            return 0.0;
        }
        let seg = |p: (f64, f64), s: (f64, f64), e: (f64, f64)| {
            let (dx, dy) = (e.0 - s.0, e.1 - s.1);
            let u = (((p.0 - s.0) * dx + (p.1 - s.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            ((s.0 + dx * u - p.0).powi(2) + (s.1 + dy * u - p.1).powi(2)).sqrt()
        };
        let (ca, cb) = (Shape::of(a).corners, Shape::of(b).corners);
        let mut d = f64::INFINITY;
        for (p, q) in [(&ca, &cb), (&cb, &ca)] {
            for c in p {
                for k in 0..4 {
                    d = d.min(seg(*c, q[k], q[(k + 1) % 4]));
                }
            }
        }
        d
    }

    proptest! {
        #[test]
        fn distance_matches_brute_force(
            x in -20.0f64..20.0, y in -20.0f64..20.0, ya in -3.2f64..3.2, yb in -3.2f64..3.2,
        ) {
            let (a, b) = (bx(0.0, 0.0, ya, 0.0, 0.0), bx(x, y, yb, 0.0, 0.0));
            let (d, r) = (distance(&a, &b), brute(&a, &b));
            prop_assert!((d - r).abs() < 1e-9, "{} vs {}", d, r);
            // The separating axes' gap never exceeds the distance.
            if let Some(g) = separation(&Shape::of(&a), &Shape::of(&b)) {
                prop_assert!(g <= r + 1e-9);
            }
        }
    }

    /// n vehicles in random traffic for `steps` steps: positions, headings
    /// and speeds from a seeded generator, each step a random acceleration
    /// and yaw rate (some vehicles keep a constant velocity, like traffic
    /// that moves together).
    fn random_traffic(seed: u64, n: usize, steps: usize) -> Vec<Vec<BodyState>> {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut rnd = move || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let dt = 0.05;
        // Some runs are mostly a platoon (one velocity), some mostly free;
        // in some the free ones now and then change velocity at once (a
        // pair's TTC can then drop long before its distance does).
        let rigid = if rnd() < 0.5 { 0.8 } else { 0.2 };
        let jumps = if rnd() < 0.5 { 0.02 } else { 0.0 };
        let mut st: Vec<(f64, f64, f64, f64, bool)> = (0..n)
            .map(|_| {
                // Platoon runs: the others drift slowly around the
                // platoon's velocity (small closing speeds, long TTCs).
                let (yaw, v) = if rigid > 0.5 {
                    ((rnd() - 0.5) * 0.2, 9.0 + rnd() * 2.0)
                } else {
                    ((rnd() - 0.5) * 6.3, rnd() * 15.0)
                };
                (rnd() * 240.0, rnd() * 24.0, yaw, v, rnd() < rigid)
            })
            .collect();
        let mut frames = Vec::new();
        for _ in 0..steps {
            frames.push(
                st.iter()
                    .map(|&(x, y, yaw, v, _)| BodyState {
                        x,
                        y,
                        yaw,
                        length: 4.5,
                        width: 1.9,
                        vx: v * yaw.cos(),
                        vy: v * yaw.sin(),
                        speed: v,
                        acceleration: 0.0,
                    })
                    .collect(),
            );
            for s in &mut st {
                if s.4 {
                    (s.2, s.3) = (0.0, 10.0);
                } else if rnd() < jumps {
                    (s.2, s.3) = ((rnd() - 0.5) * 6.3, rnd() * 20.0);
                } else {
                    s.3 = (s.3 + (rnd() - 0.5) * 8.0 * dt).max(0.0);
                    s.2 += (rnd() - 0.5) * 0.8 * dt;
                }
                s.0 += s.3 * s.2.cos() * dt;
                s.1 += s.3 * s.2.sin() * dt;
            }
        }
        frames
    }

    /// Every pair of `k` (stepped over `frames`, `dt` apart) against the
    /// exact distance, collision and TTC of every frame: the minimum of a
    /// pair that comes within 10 m (to DISTANCE_RESOLUTION), the first
    /// collision and the minimum TTC of every pair that has one. (A pair
    /// tracked only for its TTC keeps the distances it met.)
    fn agrees_with_exact(
        k: &Kpis,
        ids: &[String],
        frames: &[Vec<BodyState>],
        dt: f64,
    ) -> Result<(), TestCaseError> {
        let n = ids.len();
        for i in 0..n {
            for j in i + 1..n {
                let (mut dmin, mut hit, mut ttc) = (f64::INFINITY, None, None::<f64>);
                for (s, f) in frames.iter().enumerate() {
                    let d = distance(&f[i], &f[j]);
                    dmin = dmin.min(d);
                    if d == 0.0 && hit.is_none() {
                        hit = Some(s as f64 * dt);
                    }
                    if d > 0.0
                        && let Some(x) = time_to_collision(&f[i], &f[j])
                        && x <= TTC_HORIZON
                    {
                        ttc = Some(ttc.map_or(x, |m: f64| m.min(x)));
                    }
                }
                let got = k.pairs.iter().find(|p| p.a == ids[i] && p.b == ids[j]);
                if dmin < 10.0 || ttc.is_some() {
                    let p = got.expect("a close pair is reported");
                    if dmin < 10.0 {
                        prop_assert!(
                            p.min_distance >= dmin - 1e-12
                                && p.min_distance <= dmin + DISTANCE_RESOLUTION,
                            "{}-{}: {} vs {}",
                            i,
                            j,
                            p.min_distance,
                            dmin
                        );
                    }
                    prop_assert_eq!(p.collision_at, hit);
                    prop_assert_eq!(p.min_ttc, ttc, "{}-{}", i, j);
                }
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// The broad phase, the candidate list and every skipped pair lose
        /// nothing: each pair's minimum distance (to DISTANCE_RESOLUTION),
        /// first collision and minimum TTC equal what checking every pair
        /// exactly at every step gives.
        #[test]
        fn skipping_pairs_loses_nothing(seed in any::<u64>(), n in 2usize..24) {
            let frames = random_traffic(seed, n, 160);
            let ids: Vec<String> = (0..n).map(|i| format!("v{i:02}")).collect();
            let mut k = Kpis::new(&ids);
            for (s, f) in frames.iter().enumerate() {
                k.step(s as f64 * 0.05, f, &vec![(0.0, 0.0, 0.0); n], &vec![false; n]);
            }
            k.finish();
            agrees_with_exact(&k, &ids, &frames, 0.05)?;
        }
    }

    proptest! {
        /// Pairs asleep in a platoon that moves together wake in time: after
        /// `calm` steps one vehicle brakes (or swerves) into the others, and
        /// every pair's minimum distance, first collision and minimum TTC
        /// equal the exact ones.
        #[test]
        fn sleeping_pairs_wake_in_time(
            n in 3usize..16,
            calm in 20usize..200,
            who in 0usize..16,
            brake in 0.5f64..9.0,
            swerve in -0.3f64..0.3,
            gap in 5.0f64..30.0,
        ) {
            let who = who % n;
            // Two lanes, 3.5 m apart, everyone at 20 m/s along x.
            let mut cars: Vec<(f64, f64, f64, f64)> = (0..n)
                .map(|k| ((k / 2) as f64 * gap, (k % 2) as f64 * 3.5, 20.0, 0.0))
                .collect();
            let dt = 0.02;
            let mut frames = Vec::new();
            for s in 0..calm + 150 {
                frames.push(cars.iter().map(|&(x, y, v, yaw)| bx(x, y, yaw, v * yaw.cos(), v * yaw.sin())).collect::<Vec<_>>());
                for (k, c) in cars.iter_mut().enumerate() {
                    if k == who && s >= calm {
                        c.2 = (c.2 - brake * dt).max(0.0);
                        c.3 += swerve * dt;
                    }
                    c.0 += c.2 * c.3.cos() * dt;
                    c.1 += c.2 * c.3.sin() * dt;
                }
            }
            let ids: Vec<String> = (0..n).map(|i| format!("v{i:02}")).collect();
            let mut k = Kpis::new(&ids);
            for (s, f) in frames.iter().enumerate() {
                k.step(s as f64 * dt, f, &vec![(0.0, 0.0, 0.0); n], &vec![false; n]);
            }
            k.finish();
            agrees_with_exact(&k, &ids, &frames, dt)?;
        }
    }

    #[test]
    fn ttc_is_when_the_swept_boxes_touch() {
        // Head-on in one lane: 20 m between bumpers, closing at 10 m/s.
        let a = bx(0.0, 0.0, 0.0, 5.0, 0.0);
        let b = bx(24.0, 0.0, std::f64::consts::PI, -5.0, 0.0);
        let t = time_to_collision(&a, &b).unwrap();
        assert!((t - 2.0).abs() < 1e-9, "{t}");
        // Passing in the next lane: never.
        let c = bx(24.0, 3.5, std::f64::consts::PI, -5.0, 0.0);
        assert_eq!(time_to_collision(&a, &c), None);
        // Moving apart: never; overlapping: now.
        assert_eq!(time_to_collision(&a, &bx(24.0, 0.0, 0.0, 9.0, 0.0)), None);
        assert_eq!(
            time_to_collision(&a, &bx(1.0, 0.5, 0.3, 0.0, 0.0)),
            Some(0.0)
        );
    }

    #[test]
    fn far_pairs_are_not_tracked_and_close_ones_are() {
        let ids: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let mut k = Kpis::new(&ids);
        let boxes = [
            bx(0.0, 0.0, 0.0, 10.0, 0.0),
            bx(15.0, 0.0, 0.0, 10.0, 0.0),
            bx(500.0, 0.0, 0.0, 10.0, 0.0),
        ];
        k.step(0.0, &boxes, &[(0.0, 0.0, 10.0); 3], &[false; 3]);
        k.finish();
        assert_eq!(k.pairs.len(), 1);
        assert_eq!((k.pairs[0].a.as_str(), k.pairs[0].b.as_str()), ("a", "b"));
        assert!((k.pairs[0].min_distance - 11.0).abs() < 1e-9);
    }
}
