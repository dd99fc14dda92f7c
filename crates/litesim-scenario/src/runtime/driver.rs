//! The driver model of every vehicle litesim drives itself.
//!
//! Car-following is the ACC model of Kesting, Treiber and Helbing (2010):
//! the improved IDM (IIDM, Treiber & Kesting 2013, ch. 11) blended with the
//! constant-acceleration heuristic (CAH) by the coolness factor `c`, so a
//! car that cuts in ahead without braking draws a comfortable brake, not a
//! panic stop. Lane changes are MOBIL (Kesting, Treiber & Helbing 2007) in
//! its asymmetric, keep-right form. Equations: `docs/closed-loop.md` and
//! the project's traffic-model reference.
//!
//! Everything here is a pure function of (parameters, own state, leader):
//! MOBIL asks what another vehicle *would* do by calling the same function
//! with that vehicle's parameters and a different leader.

use litesim_core::math;
use serde::Serialize;

/// What a driver sees ahead of it in its lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leader {
    /// Bumper-to-bumper gap (m); ≤ 0 is contact.
    pub gap: f64,
    /// The leader's speed (m/s).
    pub speed: f64,
    /// The leader's acceleration (m/s²); a stop line or a standing
    /// obstacle has 0.
    pub accel: f64,
}

/// A driver's parameters (SI units). One set per vehicle category
/// ([`DriverParams::for_category`]); the desired speed is per vehicle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DriverParams {
    /// Desired speed on a free road, `v0` (m/s).
    pub desired_speed: f64,
    /// Desired time gap `T` (s).
    pub time_gap: f64,
    /// Jam (minimum) gap `s0` (m).
    pub min_gap: f64,
    /// Maximum acceleration `a` (m/s²).
    pub max_accel: f64,
    /// Comfortable deceleration `b` (m/s², positive).
    pub comfort_decel: f64,
    /// Emergency deceleration, the physical cap of any command (m/s², positive).
    pub emergency_decel: f64,
    /// Acceleration exponent `δ`.
    pub delta: f64,
    /// Coolness `c` of the ACC blend (0 = plain IIDM).
    pub coolness: f64,
    /// MOBIL politeness `p`.
    pub politeness: f64,
    /// MOBIL safe-braking limit `b_safe` imposed on the new follower (m/s², positive).
    pub safe_decel: f64,
    /// MOBIL change threshold `Δa_th` (m/s²).
    pub change_threshold: f64,
    /// MOBIL keep-right bias `a_bias` (m/s²).
    pub keep_right_bias: f64,
}

impl DriverParams {
    /// The parameters of a vehicle category (`car`, `truck`, `bus`, …;
    /// anything else drives as a car), at a desired speed.
    ///
    /// Cars: Kesting, Treiber & Helbing (2010), table of the ACC model
    /// (`a` 1.4, `b` 2.0, `T` 1.5 s, `s0` 2 m, `δ` 4, `c` 0.99); the cap is
    /// SUMO's passenger `emergencyDecel` (9 m/s²). Trucks and buses: SUMO's
    /// vType defaults for the class (`accel` 1.3 / 1.2, `minGap` 2.5 m,
    /// `emergencyDecel` 7), Treiber's 1.8 s time gap and a 2 m/s² comfort.
    /// MOBIL: Treiber's recommended `b_safe` 4; the paper's `Δa_th` 0.1 and
    /// `a_bias` 0.3 (Kesting et al. 2007; with a bias above the threshold
    /// a driver returns right once nothing holds it on the left);
    /// politeness 0.3 (between the selfish 0 and the realistic 0.5).
    pub fn for_category(category: &str, desired_speed: f64) -> Self {
        let car = DriverParams {
            desired_speed,
            time_gap: 1.5,
            min_gap: 2.0,
            max_accel: 1.4,
            comfort_decel: 2.0,
            emergency_decel: 9.0,
            delta: 4.0,
            coolness: 0.99,
            politeness: 0.3,
            safe_decel: 4.0,
            change_threshold: 0.1,
            keep_right_bias: 0.3,
        };
        match category {
            "truck" | "semi_trailer_truck" | "full_trailer_truck" => DriverParams {
                time_gap: 1.8,
                min_gap: 2.5,
                max_accel: 1.3,
                emergency_decel: 7.0,
                ..car
            },
            "bus" => DriverParams {
                time_gap: 1.8,
                min_gap: 2.5,
                max_accel: 1.2,
                emergency_decel: 7.0,
                ..car
            },
            _ => car,
        }
    }

    /// Checks every parameter against the range a driver can have; the
    /// error names the parameter, its value and the range.
    pub fn validate(&self) -> Result<(), DriverParamError> {
        let ranges: [(&'static str, f64, f64, f64); 12] = [
            ("desired_speed", self.desired_speed, 0.0, 100.0),
            ("time_gap", self.time_gap, 0.1, 10.0),
            ("min_gap", self.min_gap, 0.1, 50.0),
            ("max_accel", self.max_accel, 0.1, 10.0),
            ("comfort_decel", self.comfort_decel, 0.1, 10.0),
            ("emergency_decel", self.emergency_decel, 1.0, 15.0),
            ("delta", self.delta, 1.0, 10.0),
            ("coolness", self.coolness, 0.0, 1.0),
            ("politeness", self.politeness, -1.0, 2.0),
            ("safe_decel", self.safe_decel, 0.1, 15.0),
            ("change_threshold", self.change_threshold, 0.0, 5.0),
            ("keep_right_bias", self.keep_right_bias, -5.0, 5.0),
        ];
        for (name, v, lo, hi) in ranges {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(DriverParamError::OutOfRange {
                    name,
                    value: v,
                    lo,
                    hi,
                });
            }
        }
        if self.emergency_decel < self.comfort_decel {
            return Err(DriverParamError::CapBelowComfort {
                emergency_decel: self.emergency_decel,
                comfort_decel: self.comfort_decel,
            });
        }
        Ok(())
    }
}

/// A driver parameter a driver cannot have ([`DriverParams::validate`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DriverParamError {
    /// A parameter outside its range (or not a number).
    #[error("driver parameter {name} = {value} is out of range (expected {lo} ..= {hi})")]
    OutOfRange {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The range's ends.
        lo: f64,
        /// (inclusive)
        hi: f64,
    },
    /// The emergency cap below the comfortable deceleration.
    #[error(
        "driver parameter emergency_decel = {emergency_decel} is below comfort_decel = {comfort_decel} (the cap must allow the comfortable brake)"
    )]
    CapBelowComfort {
        /// The emergency cap (m/s²).
        emergency_decel: f64,
        /// The comfortable deceleration (m/s²).
        comfort_decel: f64,
    },
}

/// `x^δ`, multiplied out for the usual δ = 4 (the same bits every run;
/// `pow` only for other exponents).
fn pow_delta(x: f64, delta: f64) -> f64 {
    if delta == 4.0 {
        let x2 = x * x;
        x2 * x2
    } else {
        math::pow(x, delta)
    }
}

/// The IIDM's free-road acceleration at speed `v`.
fn free_accel(p: &DriverParams, v: f64) -> f64 {
    let (a, b, v0) = (p.max_accel, p.comfort_decel, p.desired_speed);
    if v0 <= 0.0 {
        // Asked to stand: brake comfortably to a stop, stay there.
        return if v > 0.0 { -b } else { 0.0 };
    }
    if v <= v0 {
        a * (1.0 - pow_delta(v / v0, p.delta))
    } else {
        -b * (1.0 - math::pow(v0 / v, a * p.delta / b))
    }
}

/// Improved IDM acceleration (Treiber & Kesting 2013) with `leader`, or
/// the free-road acceleration without one.
pub fn iidm(p: &DriverParams, v: f64, leader: Option<Leader>) -> f64 {
    let a_free = free_accel(p, v);
    let Some(l) = leader else {
        return a_free;
    };
    let a = p.max_accel;
    if l.gap <= 0.0 {
        return -p.emergency_decel;
    }
    let z = desired_gap(p, v, l) / l.gap;
    if v <= p.desired_speed {
        if z >= 1.0 {
            a * (1.0 - z * z)
        } else if a_free > 0.0 {
            // MovSim caps the exponent at 100 where a_free → 0 near v0.
            let e = (2.0 * a / a_free).min(100.0);
            // z^e as e^(e·ln z): z lies in (0, 1) here, where this is
            // within a few ulps of `pow` and costs one call less.
            let ze = if z > 0.0 {
                math::exp(e * math::ln(z))
            } else {
                0.0
            };
            a_free * (1.0 - ze)
        } else {
            0.0
        }
    } else if z >= 1.0 {
        a_free + a * (1.0 - z * z)
    } else {
        a_free
    }
}

/// The constant-acceleration heuristic: the constant acceleration that just
/// avoids contact if both keep their accelerations (Kesting et al. 2010).
pub fn cah(p: &DriverParams, v: f64, l: Leader) -> f64 {
    let al = l.accel.min(p.max_accel);
    let s = l.gap.max(1e-3);
    let vl = l.speed;
    if al < 0.0 && vl * (v - vl) <= -2.0 * s * al {
        // The leader stops before the gap would close: stop behind it.
        v * v * al / (vl * vl - 2.0 * s * al)
    } else {
        let closing = (v - vl).max(0.0);
        al - closing * closing / (2.0 * s)
    }
}

/// [`acceleration`] behind `leader` where it may be below `floor`; where
/// it is surely at least 0 and `floor` ≤ 0, 0 itself — a caller that takes
/// the minimum with `floor` gets the same bits without the IIDM's power
/// (`z^(2a/a_free)`, an `exp` and a `ln`). It is surely at least 0 with a
/// gap (`gap > 0`), at most the desired speed, a positive free-road
/// acceleration and the desired gap not yet reached (`z < 1`): the IIDM is
/// then in (0, a_free], and the CAH blend never goes below the IIDM when
/// the IIDM is the lower (b · tanh(x/b) ≥ x for x ≤ 0).
pub fn acceleration_above(p: &DriverParams, v: f64, leader: Leader, floor: f64) -> f64 {
    if floor <= 0.0
        && leader.gap > 0.0
        && v <= p.desired_speed
        && free_accel(p, v) > 0.0
        && desired_gap(p, v, leader) < leader.gap
    {
        return 0.0;
    }
    acceleration(p, v, Some(leader))
}

/// The IIDM's desired gap s* behind `l` at speed `v` (m).
fn desired_gap(p: &DriverParams, v: f64, l: Leader) -> f64 {
    let (a, b) = (p.max_accel, p.comfort_decel);
    let dv = v - l.speed;
    p.min_gap + (v * p.time_gap + v * dv / (2.0 * (a * b).sqrt())).max(0.0)
}

/// The ACC model's acceleration (IIDM blended with CAH), capped at the
/// maximum acceleration and the emergency deceleration.
pub fn acceleration(p: &DriverParams, v: f64, leader: Option<Leader>) -> f64 {
    let a_iidm = iidm(p, v, leader);
    let out = match leader {
        Some(l) if l.gap > 0.0 && p.coolness > 0.0 => {
            let a_cah = cah(p, v, l);
            if a_iidm >= a_cah {
                a_iidm
            } else {
                let b = p.comfort_decel;
                (1.0 - p.coolness) * a_iidm
                    + p.coolness * (a_cah + b * math::tanh((a_iidm - a_cah) / b))
            }
        }
        _ => a_iidm,
    };
    out.clamp(-p.emergency_decel, p.max_accel)
}

/// What MOBIL weighs for one candidate change, every term an acceleration
/// from [`acceleration`] (m/s²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneChangeCase {
    /// The changer now (`a_c`) and after the change (`ã_c`).
    pub me: (f64, f64),
    /// The new follower now and after (`a_n`, `ã_n`); `None`: nobody behind.
    pub new_follower: Option<(f64, f64)>,
    /// The old follower now and after (`a_o`, `ã_o`); `None`: nobody behind.
    pub old_follower: Option<(f64, f64)>,
    /// The change is towards the slow (keep-right) side.
    pub towards_slow_side: bool,
    /// Extra incentive the route gives (m/s²): a lane that ends ahead
    /// pushes its vehicles out of it.
    pub strategic: f64,
}

/// MOBIL's decision in the paper's asymmetric (keep-right) form: the
/// change is safe for the new follower, and the incentive beats the
/// threshold, lowered by the bias towards the slow side and raised away
/// from it. Moving to the fast side weighs only the new follower's
/// loss; moving back to the slow side only the old follower's gain (a
/// driver does not pull out to let someone pass: it is overtaken).
pub fn mobil(p: &DriverParams, c: &LaneChangeCase) -> bool {
    if let Some((_, after)) = c.new_follower
        && after < -p.safe_decel
    {
        return false;
    }
    let gain = |x: Option<(f64, f64)>| x.map_or(0.0, |(now, after)| after - now);
    let others = if c.towards_slow_side {
        gain(c.old_follower)
    } else {
        gain(c.new_follower)
    };
    let incentive = c.me.1 - c.me.0 + p.politeness * others + c.strategic;
    let bias = if c.towards_slow_side {
        -p.keep_right_bias
    } else {
        p.keep_right_bias
    };
    incentive > p.change_threshold + bias
}

#[cfg(test)]
mod tests {
    use super::*;

    fn car(v0: f64) -> DriverParams {
        DriverParams::for_category("car", v0)
    }

    #[test]
    fn a_cut_in_that_pulls_away_draws_a_comfortable_brake_not_a_panic_stop() {
        // The reference example (Kesting et al. 2010): a 1.4, b 2, T 1.5 s,
        // s0 2 m, v 25 m/s, Δv 0, s 10 m → IDM −20.9, ACC −2.2 m/s².
        let p = car(120.0 / 3.6);
        let l = Leader {
            gap: 10.0,
            speed: 25.0,
            accel: 0.0,
        };
        let plain = iidm(&p, 25.0, Some(l));
        assert!(plain < -19.0, "IIDM alone {plain}");
        let a = acceleration(&p, 25.0, Some(l));
        assert!((a - -2.18).abs() < 0.02, "ACC {a}");
    }

    #[test]
    fn free_road_reaches_and_keeps_the_desired_speed() {
        let p = car(30.0);
        assert!((acceleration(&p, 0.0, None) - 1.4).abs() < 1e-12);
        assert_eq!(acceleration(&p, 30.0, None), 0.0);
        // Above v0 the IIDM brakes by at most b.
        let over = acceleration(&p, 45.0, None);
        assert!((-2.0..0.0).contains(&over), "{over}");
    }

    #[test]
    fn equilibrium_gap_is_exactly_s0_plus_vt_below_v0() {
        let p = car(30.0);
        let v = 20.0;
        let l = Leader {
            gap: p.min_gap + v * p.time_gap,
            speed: v,
            accel: 0.0,
        };
        assert!(acceleration(&p, v, Some(l)).abs() < 1e-9);
    }

    #[test]
    fn a_standing_obstacle_is_stopped_for_within_the_cap() {
        let p = car(30.0);
        let l = Leader {
            gap: 30.0,
            speed: 0.0,
            accel: 0.0,
        };
        let a = acceleration(&p, 20.0, Some(l));
        // v²/(2s) = 6.7 m/s² is needed: more than comfort, within the cap.
        assert!((-9.0..=-6.0).contains(&a), "{a}");
        let touching = Leader { gap: 0.0, ..l };
        assert_eq!(acceleration(&p, 20.0, Some(touching)), -9.0);
    }

    #[test]
    fn mobil_needs_safety_and_an_incentive() {
        let p = car(30.0);
        let base = LaneChangeCase {
            me: (-1.0, 1.0),
            new_follower: Some((0.0, -1.0)),
            old_follower: Some((-0.5, 0.0)),
            towards_slow_side: false,
            strategic: 0.0,
        };
        assert!(mobil(&p, &base));
        let unsafe_case = LaneChangeCase {
            new_follower: Some((0.0, -5.0)),
            ..base
        };
        assert!(!mobil(&p, &unsafe_case));
        let marginal = LaneChangeCase {
            me: (0.0, 0.3),
            new_follower: None,
            old_follower: None,
            ..base
        };
        // 0.3 beats 0.1 − 0.3 to the right but not 0.1 + 0.3 to the left.
        assert!(!mobil(&p, &marginal));
        assert!(mobil(
            &p,
            &LaneChangeCase {
                towards_slow_side: true,
                ..marginal
            }
        ));
    }

    #[test]
    fn parameters_out_of_range_are_named() {
        let mut p = car(30.0);
        assert!(p.validate().is_ok());
        p.time_gap = -1.0;
        let e = p.validate().unwrap_err();
        assert!(e.to_string().contains("time_gap = -1"), "{e}");
        assert!(matches!(
            e,
            DriverParamError::OutOfRange {
                name: "time_gap",
                ..
            }
        ));
        p = car(f64::NAN);
        assert!(
            p.validate()
                .unwrap_err()
                .to_string()
                .contains("desired_speed")
        );
    }

    proptest::proptest! {
        /// Taking the minimum with a floor ≤ 0, the shortcut gives the same
        /// bits as the exact acceleration, for any category, speed, leader
        /// and floor.
        #[test]
        fn the_minimum_with_a_non_positive_floor_is_exact(
            cat in 0usize..4,
            v0 in 1.0f64..60.0,
            v in 0.0f64..70.0,
            gap in -1.0f64..200.0,
            speed in 0.0f64..70.0,
            accel in -9.0f64..3.0,
            floor in -9.0f64..0.0,
        ) {
            let p = DriverParams::for_category(["car", "truck", "bus", "motorcycle"][cat], v0);
            let l = Leader { gap, speed, accel };
            let exact = acceleration(&p, v, Some(l)).min(floor);
            let short = acceleration_above(&p, v, l, floor).min(floor);
            proptest::prop_assert_eq!(exact.to_bits(), short.to_bits());
        }
    }
}
