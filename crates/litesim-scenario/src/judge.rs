//! The verdict: what the run's KPIs say about the system under test.
//!
//! Always: collisions (any pair; those with sut.car first), vehicles off
//! the road, red lights run, a SUT that failed to answer, strict gap and
//! lane goals missed by a planned actor (a driver's missed goal is the
//! scenario not realised: a note, not the SUT's failure). With `--sut planned` (the scenario player), every actor must
//! also follow its plan within the mode's tolerances. Thresholds the test
//! sets in `test_config` ([`Thresholds`]) judge sut.car: minimum TTC and
//! gap to any actor, maximum deceleration and jerk, reaching the goal.
//! Every failure names the time, the actors and the value.

use crate::elab::Thresholds;
use crate::runtime::Executed;
use crate::{DriveMode, Verdict, tolerances};

/// What one run came to, and why.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Judged {
    /// The verdict.
    pub verdict: Verdict,
    /// The SUT's failures (and the error that stopped the run).
    pub failures: Vec<String>,
    /// Why the scenario was not realised.
    pub invalid: Vec<String>,
    /// Remarks (best-effort goals missed).
    pub notes: Vec<String>,
}

/// The verdict of one run: error before fail before invalid before pass.
pub fn verdict(
    ex: &Executed,
    th: &Thresholds,
    mode: DriveMode,
    closed_loop: bool,
    ego_id: Option<&str>,
) -> Judged {
    let error = ex.realtime_failure.is_some() || ex.sut_error.is_some();
    let mut j = Judged::default();
    j.failures.extend(ex.realtime_failure.iter().cloned());
    j.failures.extend(ex.sut_error.iter().cloned());
    checks(ex, th, mode, closed_loop, ego_id, &mut j);
    j.verdict = if error {
        Verdict::Error
    } else if !j.failures.is_empty() {
        Verdict::Fail
    } else if !j.invalid.is_empty() {
        Verdict::Invalid
    } else {
        Verdict::Pass
    };
    j
}

/// A contact in words: who struck whom, where, and who caused it.
fn describe_contact(p: &crate::kpi::PairKpi, c: &crate::kpi::Contact) -> String {
    use crate::kpi::{ContactKind, Part};
    let part = |x: Part| match x {
        Part::Front => "front",
        Part::Rear => "rear",
        Part::Left => "left side",
        Part::Right => "right side",
    };
    let kind = match c.kind {
        ContactKind::RearEnd => "rear-end",
        ContactKind::Sideswipe => "sideswipe",
        ContactKind::HeadOn => "head-on",
        ContactKind::Angle => "angle",
    };
    let (struck, striker_part, struck_part) = if c.striker == p.a {
        (&p.b, c.part_a, c.part_b)
    } else {
        (&p.a, c.part_b, c.part_a)
    };
    let who = match &c.responsible {
        Some(r) if *r == c.striker => format!("{r} is responsible"),
        Some(r) => format!("{r} is responsible: it cut into {}'s path", c.striker),
        None => "both are responsible".to_string(),
    };
    format!(
        "{}'s {} struck {struck}'s {} ({kind}); {who}",
        c.striker,
        part(striker_part),
        part(struck_part)
    )
}

/// A driver's missed gap goal as the intent and why: what it ended at, how
/// the reference braked during the phase, what the driver would have
/// needed against its limit (`cut_in.osc:30:13: other ended 10.4 m ahead of
/// sut.car at 10.00 s, wanted 5 m ± 1 m: sut.car braked at up to 6.0 m/s²
/// from 7.02 s; other needed 7.3 m/s², its limit is 4 m/s²`).
fn missed_gap(g: &crate::reactive::GoalResult, msg: &str) -> String {
    let mut why = Vec::new();
    if let Some((decel, from)) = g.reference_braking {
        why.push(format!(
            "{} braked at up to {decel:.1} m/s² from {from:.2} s",
            g.reference
        ));
    }
    if let Some((asked, limit)) = g.needed {
        why.push(format!(
            "{} needed {asked:.1} m/s², its limit is {limit} m/s²",
            g.actor
        ));
    }
    if why.is_empty() {
        msg.to_string()
    } else {
        format!("{msg}: {}", why.join("; "))
    }
}

/// Every check of the run: failures, the scenario's missed intents, notes.
fn checks(
    ex: &Executed,
    th: &Thresholds,
    mode: DriveMode,
    closed_loop: bool,
    ego_id: Option<&str>,
    j: &mut Judged,
) {
    collisions(ex, ego_id, j);
    actors(ex, mode, closed_loop, j);
    goals(ex, j);
    if let Some(ego) = ego_id {
        thresholds(ex, th, ego, j);
    }
}

/// Collisions, sut.car's first (they are the verdict on the SUT); one
/// where sut.car was struck while keeping its lane and speed is a note.
fn collisions(ex: &Executed, ego_id: Option<&str>, j: &mut Judged) {
    let Judged {
        failures, notes, ..
    } = j;
    let involves = |a: &str, b: &str| ego_id.is_some_and(|e| a == e || b == e);
    // Collisions with the ego first: they are the verdict on the SUT.
    let mut pairs: Vec<_> = ex.kpis.pairs.iter().collect();
    pairs.sort_by_key(|p| !involves(&p.a, &p.b));
    for p in &pairs {
        let Some(t) = p.collision_at else {
            continue;
        };
        let head = format!("collision between {} and {} at {t:.2} s", p.a, p.b);
        let Some(c) = &p.contact else {
            failures.push(head);
            continue;
        };
        let msg = format!("{head}: {}", describe_contact(p, c));
        // sut.car struck while keeping its lane and speed: the other's
        // doing, not the SUT's failure (a collision between two others
        // still fails the run: the scenario drove them into each other).
        let ego_blameless = ego_id.is_some_and(|e| {
            (p.a == e || p.b == e) && c.responsible.as_deref().is_some_and(|r| r != e)
        });
        if ego_blameless {
            notes.push(format!("{msg} (not sut.car's failure)"));
        } else {
            failures.push(msg);
        }
    }
}

/// Each actor off the road, through a red light, or (a scenario player's
/// check) off its plan.
fn actors(ex: &Executed, mode: DriveMode, closed_loop: bool, j: &mut Judged) {
    let failures = &mut j.failures;
    let (tol_path, tol_speed) = tolerances(mode);
    for a in &ex.kpis.actors {
        if let Some(t) = a.off_road_at {
            failures.push(format!("{} off the road at {t:.2} s", a.id));
        }
        if let Some((light, t)) = &a.ran_red_light {
            failures.push(format!("{} ran the red light {light} at {t:.2} s", a.id));
        }
        // Following the plan is the check of a scenario player; in closed
        // loop the SUT decides and the others re-time their plans.
        if closed_loop {
            continue;
        }
        if a.max_path_error > tol_path {
            failures.push(format!(
                "{} strays {:.3} m from its plan (tolerance {tol_path} m)",
                a.id, a.max_path_error
            ));
        }
        if a.max_speed_error > tol_speed {
            failures.push(format!(
                "{} misses its planned speed by {:.3} m/s (tolerance {tol_speed} m/s)",
                a.id, a.max_speed_error
            ));
        }
    }
}

/// The scenario's intents: gap and lane goals missed, conditions that
/// never held (the scenario did not happen).
fn goals(ex: &Executed, j: &mut Judged) {
    let Judged {
        failures,
        invalid,
        notes,
        ..
    } = j;
    for g in &ex.goals {
        if g.met {
            continue;
        }
        let side = |o: crate::intent::Order| match o {
            crate::intent::Order::AheadOf => "ahead of",
            crate::intent::Order::Behind => "behind",
        };
        let other = match g.relation {
            crate::intent::Order::AheadOf => crate::intent::Order::Behind,
            crate::intent::Order::Behind => crate::intent::Order::AheadOf,
        };
        // A gap that ended on the other side is said so ("18.8 m behind",
        // not "-18.8 m ahead of"), with the side that was wanted.
        let (got, ended, wanted_side) = if g.got < 0.0 {
            (-g.got, side(other), format!(" {} it", side(g.relation)))
        } else {
            (g.got, side(g.relation), String::new())
        };
        let msg = format!(
            "{}: {} ended {:.1} m {} {} at {:.2} s, wanted {} m ± {} m{}",
            g.at,
            g.actor,
            got,
            ended,
            g.reference,
            g.t,
            g.wanted,
            crate::reactive::GAP_TOLERANCE,
            wanted_side
        );
        if ex.driven.contains(&g.actor) {
            // A driver pursues its goals within its limits and never by
            // force: a gap it could not reach (the SUT or the traffic
            // would not let it) means the scenario did not happen, which
            // is not the SUT's failure.
            invalid.push(format!("scenario not realised: {}", missed_gap(g, &msg)));
        } else if g.strict {
            failures.push(msg);
        } else {
            notes.push(format!("best effort: {msg}"));
        }
    }
    for c in &ex.never_held {
        invalid.push(format!("scenario not realised: {c}"));
    }
    for g in ex.lane_goals.iter().filter(|g| !g.met) {
        let lane = |l: Option<i32>| l.map_or("no lane".to_string(), |l| format!("lane {l}"));
        let msg = format!(
            "{}: {} ended in {} at {:.2} s, wanted {} ({} {})",
            g.at,
            g.actor,
            lane(g.got),
            g.t,
            lane(g.wanted),
            g.relation.name(),
            g.reference
        );
        if ex.driven.contains(&g.actor) {
            // A driver pursues its goals within its limits and never by
            // force: a gap it could not reach (the SUT or the traffic
            // would not let it) means the scenario did not happen, which
            // is not the SUT's failure.
            invalid.push(format!("scenario not realised: {msg}"));
        } else if g.strict {
            failures.push(msg);
        } else {
            notes.push(format!("best effort: {msg}"));
        }
    }
}

/// The test's thresholds on sut.car: TTC, gap, deceleration, jerk, time
/// headway, DRAC, PET, distance to its goal.
fn thresholds(ex: &Executed, th: &Thresholds, ego: &str, j: &mut Judged) {
    let failures = &mut j.failures;
    let ego_pairs = || ex.kpis.pairs.iter().filter(|p| p.a == ego || p.b == ego);
    let other = |p: &crate::kpi::PairKpi| if p.a == ego { p.b.clone() } else { p.a.clone() };
    if let Some(limit) = th.min_ttc
        && let Some(p) = ego_pairs().filter(|p| p.min_ttc.is_some()).min_by(|a, b| {
            a.min_ttc
                .unwrap_or(0.0)
                .total_cmp(&b.min_ttc.unwrap_or(0.0))
        })
        && let (Some(ttc), Some(t)) = (p.min_ttc, p.min_ttc_at)
        && ttc < limit
    {
        failures.push(format!(
            "time to collision between {ego} and {} is {ttc:.2} s at {t:.2} s, below the test's min_ttc {limit} s",
            other(p)
        ));
    }
    if let Some(limit) = th.min_gap
        && let Some(p) = ego_pairs()
            .filter(|p| p.min_distance.is_finite() && p.min_distance >= 0.0)
            .min_by(|a, b| a.min_distance.total_cmp(&b.min_distance))
        && p.min_distance < limit
    {
        failures.push(format!(
            "gap between {ego} and {} is {:.2} m at {:.2} s, below the test's min_gap {limit} m",
            other(p),
            p.min_distance,
            p.min_distance_at
        ));
    }
    if let Some(e) = &ex.ego {
        if let Some(limit) = th.max_decel
            && e.max_decel > limit
        {
            failures.push(format!(
                "{ego} decelerates at {:.2} m/s² at {:.2} s, above the test's max_decel {limit} m/s²",
                e.max_decel, e.max_decel_at
            ));
        }
        if let Some(limit) = th.max_jerk
            && e.max_jerk > limit
        {
            failures.push(format!(
                "{ego} jerk is {:.2} m/s³ at {:.2} s, above the test's max_jerk {limit} m/s³",
                e.max_jerk, e.max_jerk_at
            ));
        }
        if let Some(limit) = th.max_jerk_1s
            && e.max_jerk_1s > limit
        {
            failures.push(format!(
                "{ego} jerk over 1 s is {:.2} m/s³ at {:.2} s, above the test's max_jerk_1s {limit} m/s³",
                e.max_jerk_1s, e.max_jerk_1s_at
            ));
        }
        let thw = e
            .leads
            .iter()
            .filter(|l| l.min_thw >= 0.0)
            .min_by(|a, b| a.min_thw.total_cmp(&b.min_thw));
        if let (Some(limit), Some(l)) = (th.min_thw, thw)
            && l.min_thw < limit
        {
            failures.push(format!(
                "time headway of {ego} to {} is {:.2} s at {:.2} s, below the test's min_thw {limit} s",
                l.id, l.min_thw, l.min_thw_at
            ));
        }
        let drac = e
            .leads
            .iter()
            .max_by(|a, b| a.max_drac.total_cmp(&b.max_drac));
        if let (Some(limit), Some(l)) = (th.max_drac, drac)
            && l.max_drac > limit
        {
            failures.push(format!(
                "{ego} needed {:.2} m/s² to avoid {} at {:.2} s (DRAC), above the test's max_drac {limit} m/s²",
                l.max_drac, l.id, l.max_drac_at
            ));
        }
        let pet = e.pets.iter().min_by(|a, b| a.pet.total_cmp(&b.pet));
        if let (Some(limit), Some(p)) = (th.min_pet, pet)
            && p.pet < limit
        {
            failures.push(format!(
                "post-encroachment time of {ego} and {} at junction {} is {:.2} s at {:.2} s, below the test's min_pet {limit} s",
                p.id, p.junction, p.pet, p.at
            ));
        }
        if let Some(tol) = th.goal_tolerance
            && e.distance_to_goal > tol
            && ex.sut_error.is_none()
        {
            failures.push(format!(
                "{ego} ends {:.2} m from its goal (goal_tolerance {tol} m)",
                e.distance_to_goal
            ));
        }
    }
}
