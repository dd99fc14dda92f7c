//! Timed xy trajectories, the SSP's kinematic control.
//!
//! A scenario engine sends a trajectory about every 200 ms covering the
//! coming steps. [`Trajectory::replace_from`] replaces the remainder of the
//! old one from the new start time; [`Trajectory::sample`] places the actor at
//! any time by linear interpolation (yaw by the shorter arc) and derives what
//! the points do not say: heading from the direction of travel, speed from
//! distance over time. Before the first point the actor holds the first
//! point; after the last it holds the last and reports
//! [`TrajectoryStatus::Exhausted`].

use crate::actor::TrajectoryStatus;
use crate::geometry::{Vec3, wrap_angle};
use crate::math;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// One trajectory point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimedPoint {
    /// Simulation time (s).
    pub t: f64,
    /// Position (m).
    pub position: Vec3,
    /// Heading (rad), if the sender knows it.
    pub yaw: Option<f64>,
    /// Speed (m/s), if the sender knows it.
    pub speed: Option<f64>,
}

/// A bad trajectory.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TrajectoryError {
    /// No points.
    #[error("trajectory has no points")]
    Empty,
    /// A NaN or infinite field.
    #[error("trajectory point {index}: {field} is not finite")]
    NotFinite {
        /// Point index.
        index: usize,
        /// Field name.
        field: &'static str,
    },
    /// Times not strictly increasing.
    #[error("trajectory point {index}: time {t} s is not after the previous point's {previous} s")]
    NotIncreasing {
        /// Point index.
        index: usize,
        /// Its time.
        t: f64,
        /// The previous time.
        previous: f64,
    },
    /// A negative speed.
    #[error("trajectory point {index}: speed {speed} m/s is negative")]
    NegativeSpeed {
        /// Point index.
        index: usize,
        /// The speed.
        speed: f64,
    },
}

/// Where the trajectory puts an actor at some time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectorySample {
    /// Position (m).
    pub position: Vec3,
    /// Heading (rad); `None` when neither the points nor the motion tell.
    pub yaw: Option<f64>,
    /// Speed (m/s).
    pub speed: f64,
    /// Where on the trajectory the time falls.
    pub status: TrajectoryStatus,
}

/// A timed trajectory (times strictly increasing).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    points: VecDeque<TimedPoint>,
}

/// The first field of `p` that is NaN or infinite (an absent yaw or
/// speed is none), in the order t, x, y, z, yaw, speed. Plain tests in a
/// row: every step of a closed loop checks every actor's points.
fn not_finite(p: &TimedPoint) -> Option<&'static str> {
    let finite = |v: Option<f64>| v.is_none_or(f64::is_finite);
    if !p.t.is_finite() {
        Some("t")
    } else if !p.position.x.is_finite() {
        Some("x")
    } else if !p.position.y.is_finite() {
        Some("y")
    } else if !p.position.z.is_finite() {
        Some("z")
    } else if !finite(p.yaw) {
        Some("yaw")
    } else if !finite(p.speed) {
        Some("speed")
    } else {
        None
    }
}

impl Trajectory {
    /// Validates and builds a trajectory.
    pub fn new(points: Vec<TimedPoint>) -> Result<Self, TrajectoryError> {
        Self::check(&points)?;
        Ok(Self {
            points: points.into(),
        })
    }

    /// What [`Trajectory::new`] checks: at least one point, every field
    /// finite, speeds not negative, times strictly increasing. A caller
    /// that replaces a trajectory in place ([`Trajectory::replace_from_slice`])
    /// checks its points with it first.
    pub fn check(points: &[TimedPoint]) -> Result<(), TrajectoryError> {
        if points.is_empty() {
            return Err(TrajectoryError::Empty);
        }
        for (index, p) in points.iter().enumerate() {
            if let Some(field) = not_finite(p) {
                return Err(TrajectoryError::NotFinite { index, field });
            }
            if let Some(speed) = p.speed.filter(|s| *s < 0.0) {
                return Err(TrajectoryError::NegativeSpeed { index, speed });
            }
            if index > 0 && p.t <= points[index - 1].t {
                return Err(TrajectoryError::NotIncreasing {
                    index,
                    t: p.t,
                    previous: points[index - 1].t,
                });
            }
        }
        Ok(())
    }

    /// The points.
    pub fn points(&self) -> impl Iterator<Item = &TimedPoint> {
        self.points.iter()
    }

    /// Number of points held.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when no point is held.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Replaces everything from `new`'s first time on with `new`.
    pub fn replace_from(&mut self, new: Trajectory) {
        if let Some(start) = new.points.front().map(|p| p.t) {
            while self.points.back().is_some_and(|p| p.t >= start) {
                self.points.pop_back();
            }
        }
        self.points.extend(new.points);
    }

    /// [`Trajectory::replace_from`] with points already checked
    /// ([`Trajectory::check`]), copied in: the trajectory's memory is
    /// reused (a closed loop sends every actor a new one each step).
    pub fn replace_from_slice(&mut self, new: &[TimedPoint]) {
        if let Some(start) = new.first().map(|p| p.t) {
            while self.points.back().is_some_and(|p| p.t >= start) {
                self.points.pop_back();
            }
        }
        self.points.extend(new.iter().copied());
    }

    /// Drops points no longer needed at time `t` (keeps the one before `t`
    /// for interpolation), so memory stays flat however long a run lasts.
    pub fn prune_before(&mut self, t: f64) {
        while self.points.len() >= 2 && self.points[1].t <= t {
            self.points.pop_front();
        }
    }

    /// Samples the trajectory at time `t` (s); `None` when empty or `t` is NaN.
    pub fn sample(&self, t: f64) -> Option<TrajectorySample> {
        if t.is_nan() {
            return None;
        }
        let first = self.points.front()?;
        let last = self.points.back()?;
        if t < first.t {
            return Some(TrajectorySample {
                position: first.position,
                yaw: first.yaw.or_else(|| self.segment_heading(0)),
                speed: 0.0,
                status: TrajectoryStatus::NotStarted,
            });
        }
        if t >= last.t {
            let n = self.points.len();
            let status = if t > last.t {
                TrajectoryStatus::Exhausted
            } else {
                TrajectoryStatus::Following
            };
            let yaw = last
                .yaw
                .or_else(|| n.checked_sub(2).and_then(|i| self.segment_heading(i)));
            let speed = if status == TrajectoryStatus::Exhausted {
                0.0
            } else {
                last.speed
                    .unwrap_or_else(|| n.checked_sub(2).map_or(0.0, |i| self.segment_speed(i)))
            };
            return Some(TrajectorySample {
                position: last.position,
                yaw,
                speed,
                status,
            });
        }
        // t in [p_i.t, p_{i+1}.t). A stepping world prunes the points it
        // has passed, so the first few segments hold t almost always: look
        // there before searching the whole (possibly long) queue.
        let i = (0..self.points.len().min(4) - 1)
            .find(|&k| self.points[k + 1].t > t)
            .unwrap_or_else(|| self.points.partition_point(|p| p.t <= t) - 1);
        let (a, b) = (&self.points[i], &self.points[i + 1]);
        let u = (t - a.t) / (b.t - a.t);
        let position = Vec3::new(
            a.position.x + (b.position.x - a.position.x) * u,
            a.position.y + (b.position.y - a.position.y) * u,
            a.position.z + (b.position.z - a.position.z) * u,
        );
        let yaw = match (a.yaw, b.yaw) {
            (Some(ya), Some(yb)) => Some(wrap_angle(ya + wrap_angle(yb - ya) * u)),
            _ => self.segment_heading(i).or(a.yaw),
        };
        let speed = match (a.speed, b.speed) {
            (Some(va), Some(vb)) => va + (vb - va) * u,
            _ => self.segment_speed(i),
        };
        Some(TrajectorySample {
            position,
            yaw,
            speed,
            status: TrajectoryStatus::Following,
        })
    }

    fn segment_heading(&self, i: usize) -> Option<f64> {
        let (a, b) = (self.points.get(i)?, self.points.get(i + 1)?);
        let (dx, dy) = (b.position.x - a.position.x, b.position.y - a.position.y);
        // Below a millimetre the direction is noise: let the caller keep its heading.
        (dx * dx + dy * dy > 1e-6).then(|| math::atan2(dy, dx))
    }

    fn segment_speed(&self, i: usize) -> f64 {
        match (self.points.get(i), self.points.get(i + 1)) {
            (Some(a), Some(b)) => {
                let (dx, dy) = (b.position.x - a.position.x, b.position.y - a.position.y);
                let d = math::hypot(dx, dy);
                // x² overflows beyond ~1e154 m: rescale only then, so
                // ordinary values keep their bits.
                let d = if d.is_finite() {
                    d
                } else {
                    libm::hypot(dx, dy)
                };
                // Absurd inputs (1e300 m in a nanosecond) saturate instead of
                // becoming infinite.
                (d / (b.t - a.t)).min(f64::MAX)
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(t: f64, x: f64, y: f64) -> TimedPoint {
        TimedPoint {
            t,
            position: Vec3::new(x, y, 0.0),
            yaw: None,
            speed: None,
        }
    }

    #[test]
    fn interpolates_and_derives() {
        let tr = Trajectory::new(vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 10.0, 0.0),
            p(2.0, 10.0, 10.0),
        ])
        .unwrap();
        let s = tr.sample(0.5).unwrap();
        assert_eq!(s.position.x, 5.0);
        assert_eq!(s.speed, 10.0);
        assert_eq!(s.yaw, Some(0.0));
        assert_eq!(s.status, TrajectoryStatus::Following);
        let s = tr.sample(1.5).unwrap();
        assert_eq!((s.position.x, s.position.y), (10.0, 5.0));
        assert!((s.yaw.unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let s = tr.sample(3.0).unwrap();
        assert_eq!(s.status, TrajectoryStatus::Exhausted);
        assert_eq!((s.position.y, s.speed), (10.0, 0.0));
        assert_eq!(
            tr.sample(-1.0).unwrap().status,
            TrajectoryStatus::NotStarted
        );
    }

    #[test]
    fn replace_and_prune() {
        let mut tr =
            Trajectory::new(vec![p(0.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(2.0, 2.0, 0.0)]).unwrap();
        tr.replace_from(Trajectory::new(vec![p(1.0, 5.0, 0.0), p(3.0, 7.0, 0.0)]).unwrap());
        let ts: Vec<f64> = tr.points().map(|q| q.t).collect();
        assert_eq!(ts, vec![0.0, 1.0, 3.0]);
        assert_eq!(tr.sample(1.0).unwrap().position.x, 5.0);
        tr.prune_before(1.5);
        assert_eq!(tr.len(), 2);
    }

    #[test]
    fn rejects_bad_points() {
        assert_eq!(Trajectory::new(vec![]), Err(TrajectoryError::Empty));
        assert!(matches!(
            Trajectory::new(vec![p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0)]),
            Err(TrajectoryError::NotIncreasing { index: 1, .. })
        ));
        assert!(matches!(
            Trajectory::new(vec![p(0.0, f64::NAN, 0.0)]),
            Err(TrajectoryError::NotFinite {
                index: 0,
                field: "x"
            })
        ));
    }
}
