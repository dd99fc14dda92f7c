//! Where each actor starts: along a road, in a lane, ahead of or behind
//! another actor, beside it.

use super::*;

/// What placing one actor reads: the map, every plan, the actor, where the
/// others start, and the places its modifiers are written.
struct Cx<'a> {
    net: &'a RoadNetwork,
    plans: &'a [ActorPlan],
    me: &'a ActorPlan,
    placed: &'a BTreeMap<String, Motion>,
    index: &'a BTreeMap<String, usize>,
    /// Where the phase is written.
    at: &'a str,
    /// Where each modifier is written.
    mod_at: &'a [String],
}

/// `lane(n)` or `lane(relation: o)` among the start modifiers.
type LaneMod = (Option<f64>, Option<(LaneRelation, String)>);

/// Where actor `i` starts, under its first phase's modifiers `mods`: on
/// its reference's place or a road (`along`, else a seeded choice), in a
/// lane, at a gap to another actor, beside one, at a speed. A start that
/// cannot be set up with this seed is named in `unplaced`.
#[allow(clippy::too_many_arguments)]
pub(super) fn place(
    net: &RoadNetwork,
    plans: &[ActorPlan],
    i: usize,
    mods: &[Intent],
    placed: &BTreeMap<String, Motion>,
    index: &BTreeMap<String, usize>,
    rng: &mut Rng,
    roads_ok: &[usize],
    (at, mod_at): (&str, &[String]),
    unplaced: &mut Vec<String>,
) -> Result<Motion, ScenarioError> {
    let me = &plans[i];
    check_start_combination(net, me, mods, mod_at, placed)?;
    let cx = Cx {
        net,
        plans,
        me,
        placed,
        index,
        at,
        mod_at,
    };
    // The modifiers that shape the start (`at: end` ones are goals).
    let starting = || mods.iter().filter(|m| m.at() != At::End);
    let mut mo = Motion {
        pos: LanePos {
            road: roads_ok[0],
            lane: 0,
            s: 0.0,
        },
        v: 0.0,
        lateral: 0.0,
        across: 0.0,
        change: None,
    };
    // Road: along(road) or the reference actor's, else a seeded choice.
    let along = starting().find_map(|m| match m {
        Intent::Along {
            road, start_offset, ..
        } => Some((road.clone(), *start_offset)),
        _ => None,
    });
    let reference: Option<String> = [
        RefKind::AheadOf,
        RefKind::Behind,
        RefKind::SameAs,
        RefKind::LeftOf,
        RefKind::RightOf,
        RefKind::SideOf,
    ]
    .into_iter()
    .find_map(|k| starting().find_map(|m| m.reference(k).map(String::from)));
    let lane_mod: Option<LaneMod> = starting().find_map(|m| match m {
        Intent::Lane {
            lane, reference, ..
        } => Some((*lane, reference.clone())),
        _ => None,
    });
    match reference
        .as_ref()
        .and_then(|o| placed.get(o).map(|om| (o, om)))
    {
        Some((o, om)) => on_reference(&cx, &mut mo, (o, om), lane_mod.as_ref())?,
        None => on_a_road(
            &cx,
            &mut mo,
            along,
            lane_mod.as_ref(),
            (rng, roads_ok),
            unplaced,
        )?,
    }
    if let Some((_, Some((rel, o)))) = &lane_mod
        && let Some(om) = placed.get(o)
    {
        lane_relative(&cx, &mut mo, *rel, (o, om))?;
    }
    at_a_gap(&cx, &mut mo, mods, unplaced);
    // Beside another actor (people, cyclists at the kerb).
    beside(&cx, &mut mo, starting());
    // Initial speed: a speed modifier of the first phase (at start/all), else
    // the reference actor's speed, else a seeded 30–50 km/h for vehicles.
    let v0 = starting().find_map(|m| match m {
        Intent::Speed {
            speed,
            change: false,
            relative: None,
            ..
        } => Some(*speed),
        // Relative to an actor placed already: its speed plus the offset
        // (the motion then follows that actor's plan).
        Intent::Speed {
            speed,
            change: false,
            relative: Some((sign, o)),
            ..
        } => placed.get(o).map(|p| (p.v + sign * speed).max(0.0)),
        _ => None,
    });
    mo.v = match (v0, me.kind) {
        (Some(v), _) => v,
        (None, ActorClass::Stationary) => 0.0,
        (None, ActorClass::Person | ActorClass::Animal) => WALK_SPEED,
        (None, _) => match &reference {
            Some(o) if placed.contains_key(o) => placed[o].v,
            _ => sample(30.0 / 3.6, 50.0 / 3.6, rng),
        },
    };
    Ok(mo)
}

/// The start on the reference actor `o`'s place (already placed at `om`);
/// with `lane(n)`, lane n of o's road in o's direction of travel.
fn on_reference(
    cx: &Cx<'_>,
    mo: &mut Motion,
    (o, om): (&String, &Motion),
    lane_mod: Option<&LaneMod>,
) -> Result<(), ScenarioError> {
    let (net, me, at) = (cx.net, cx.me, cx.at);
    mo.pos = om.pos;
    // `lane(n)` beside a position relative to `o`: lane n of o's road
    // in o's direction of travel (d along o's lane, below).
    if let Some((Some(n), None)) = lane_mod {
        let fwd = net.travels_forward(om.pos);
        let lanes = net.lanes_same_way(om.pos.road, om.pos.s, fwd);
        mo.pos.lane = *lanes.get(lane_index(lanes.len(), *n)).ok_or_else(|| {
            ScenarioError::Plan(format!(
                "{at}: lane {n} asked for {} beside {o}, but road {} has {} lane(s) that way",
                me.id,
                net.roads()[om.pos.road].id,
                lanes.len()
            ))
        })?;
    }
    Ok(())
}

/// The start on a road: `along`'s (with its offset) or a seeded choice
/// among `roads_ok`, in `lane(n)` or a seeded lane, at a free s (clear of
/// the actors placed on that lane).
fn on_a_road(
    cx: &Cx<'_>,
    mo: &mut Motion,
    along: Option<(Option<String>, Option<f64>)>,
    lane_mod: Option<&LaneMod>,
    (rng, roads_ok): (&mut Rng, &[usize]),
    unplaced: &mut Vec<String>,
) -> Result<(), ScenarioError> {
    let (net, me, at, placed, index, plans) = (cx.net, cx.me, cx.at, cx.placed, cx.index, cx.plans);
    let along_road = along.as_ref().and_then(|a| a.0.clone());
    let road = match &along_road {
        Some(id) => net
            .road_index(id)
            .ok_or_else(|| ScenarioError::Plan(format!("{at}: road '{id}' is not in the map")))?,
        None => roads_ok[(rng.next_u64() % roads_ok.len() as u64) as usize],
    };
    mo.pos.road = road;
    let r = &net.roads()[road];
    // Lanes going either way; prefer forward lanes, then any.
    let mut lanes = net.lanes_same_way(road, 0.01, true);
    if lanes.is_empty() {
        lanes = net.lanes_same_way(road, 0.01, false);
    }
    if lanes.is_empty() {
        return Err(ScenarioError::Plan(format!(
            "{at}: road {} has no driving lane",
            r.id
        )));
    }
    let lane = match lane_mod.and_then(|m| m.0) {
        Some(n) => *lanes.get(lane_index(lanes.len(), n)).ok_or_else(|| {
            ScenarioError::Plan(format!(
                "{at}: lane {} asked for {} but road {} has {} lane(s) that way",
                if n < 0.0 {
                    format!("{} from the left", -n)
                } else {
                    n.to_string()
                },
                me.id,
                r.id,
                lanes.len()
            ))
        })?,
        None => lanes[(rng.next_u64() % lanes.len() as u64) as usize],
    };
    mo.pos.lane = lane;
    let offset = along.as_ref().and_then(|a| a.1);
    // A free s: clear of every placed actor on this road by their lengths + 5 m.
    let margin = me.length / 2.0 + 5.0;
    let lo = margin.min(r.length / 2.0);
    let hi = (r.length * 0.5).max(lo);
    if let Some(o) = offset
        && !(0.0..=r.length).contains(&o)
    {
        unplaced.push(format!(
            "{at}: {} could not be placed {o:.1} m along road {}: the road is {:.1} m long",
            me.id, r.id, r.length
        ));
    }
    let mut s = offset.unwrap_or_else(|| sample(lo, hi, rng));
    let clear = |s: f64| {
        placed.iter().all(|(oid, om)| {
            let ol = index.get(oid).map_or(4.0, |k| plans[*k].length);
            om.pos.road != road
                || om.pos.lane != lane
                || (om.pos.s - s).abs() > (ol + me.length) / 2.0 + 5.0
        })
    };
    for _ in 0..50 {
        if clear(s) {
            break;
        }
        s += (me.length + 10.0).min(r.length / 8.0).max(1.0);
        if s > r.length - margin.min(r.length / 4.0) {
            s = lo;
        }
    }
    // An explicit offset is where the author put the actor (another
    // actor there is the author's choice); a free place that every try
    // found taken is a scenario that could not be set up.
    if offset.is_none() && !clear(s) {
        unplaced.push(format!(
            "{at}: {} could not be placed: no free place in road {} lane {lane} \
             ({:.0} m, {} actor(s) already there)",
            me.id,
            r.id,
            r.length,
            placed
                .values()
                .filter(|om| om.pos.road == road && om.pos.lane == lane)
                .count()
        ));
    }
    mo.pos.s = s.clamp(0.0, r.length);
    // Point the lane's s at its direction of travel: s runs backwards on backward lanes.
    if !net.travels_forward(mo.pos) {
        mo.pos.s = (r.length - mo.pos.s).clamp(0.0, r.length);
    }
    Ok(())
}

/// `lane(same_as/left_of/right_of: o)`: the lane relative to o's.
fn lane_relative(
    cx: &Cx<'_>,
    mo: &mut Motion,
    rel: LaneRelation,
    (o, om): (&String, &Motion),
) -> Result<(), ScenarioError> {
    let (net, me, at) = (cx.net, cx.me, cx.at);
    let base = LanePos {
        lane: om.pos.lane,
        ..mo.pos
    };
    mo.pos.lane = match rel {
        LaneRelation::SameAs => om.pos.lane,
        r => net.lane_beside(base, r.offset()).ok_or_else(|| {
            ScenarioError::Plan(format!(
                "{at}: no lane {} of {o} on road {} for {}",
                if r == LaneRelation::LeftOf {
                    "left"
                } else {
                    "right"
                },
                net.roads()[base.road].id,
                me.id
            ))
        })?,
    };
    Ok(())
}

/// `position(d or time, ahead_of/behind: o)` at the start: d along o's lane
/// from o's place, in the lane already chosen; a lane that ends short is
/// named in `unplaced`.
fn at_a_gap(cx: &Cx<'_>, mo: &mut Motion, mods: &[Intent], unplaced: &mut Vec<String>) {
    let (net, me, at, placed, index, plans, mod_at) = (
        cx.net, cx.me, cx.at, cx.placed, cx.index, cx.plans, cx.mod_at,
    );
    let Some((k, distance, time, order, o)) = mods
        .iter()
        .enumerate()
        .filter(|(_, m)| m.at() != At::End)
        .find_map(|(k, m)| match m {
            Intent::Position {
                distance,
                time,
                reference,
                ..
            } => Some((k, *distance, *time, reference.clone())),
            _ => None,
        })
        .and_then(|(k, d, t, r)| r.map(|(order, o)| (k, d, t, order, o)))
    else {
        return;
    };
    let Some(om) = placed.get(&o) else {
        return;
    };
    let ol = index.get(&o).map_or(4.6, |j| plans[*j].length);
    let d = match (distance, time) {
        (Some(d), _) => d,
        (None, Some(t)) => t * om.v,
        _ => 10.0,
    };
    let gap = d + (ol + me.length) / 2.0;
    let lane = mo.pos.lane;
    let base = LanePos {
        lane: om.pos.lane,
        ..om.pos
    };
    let (end, rest) = net.advance_rest(base, order.sign() * gap);
    if rest > 0.01 {
        let road = &net.roads()[end.road];
        unplaced.push(format!(
            "{}: {} could not be placed {d:.1} m {} {o}: {o}'s lane (road {} lane {}) \
             ends {:.1} m {} it, {rest:.1} m short",
            mod_at.get(k).map_or(at, String::as_str),
            me.id,
            order.word(),
            road.id,
            end.lane,
            (gap - rest - (ol + me.length) / 2.0).max(0.0),
            if order.sign() > 0.0 {
                "ahead of"
            } else {
                "behind"
            },
        ));
    }
    mo.pos = net.advance_path(base, order.sign() * gap, None);
    mo.pos.lane = lane;
}

/// Refuses start modifiers that cannot all hold, naming each: two that
/// both fix the lane, or `along(r)` with a position relative to an actor
/// on another road. (`lane(n)` with `position(…, ahead_of: x)` holds: the
/// actor stands in lane n, d along x's lane.)
pub(super) fn check_start_combination(
    net: &RoadNetwork,
    me: &ActorPlan,
    mods: &[Intent],
    mod_at: &[String],
    placed: &BTreeMap<String, Motion>,
) -> Result<(), ScenarioError> {
    let starting: Vec<(usize, &Intent)> = mods
        .iter()
        .enumerate()
        .filter(|(_, m)| m.at() != At::End)
        .collect();
    let where_ = |k: usize| mod_at.get(k).map_or("?", String::as_str);
    let lanes: Vec<usize> = starting
        .iter()
        .filter(|(_, m)| matches!(m, Intent::Lane { .. }))
        .map(|(k, _)| *k)
        .collect();
    if lanes.len() > 1 {
        return Err(ScenarioError::Plan(format!(
            "{}: lane(…) and {}: lane(…) both set {}'s lane at the start; only one can hold",
            where_(lanes[0]),
            where_(lanes[1]),
            me.id
        )));
    }
    let along = starting.iter().find_map(|(k, m)| match m {
        Intent::Along { road: Some(r), .. } => Some((*k, r.clone())),
        _ => None,
    });
    let position = starting.iter().find_map(|(k, m)| match m {
        Intent::Position {
            reference: Some((_, o)),
            ..
        } => Some((*k, o.clone())),
        _ => None,
    });
    if let (Some((ka, road)), Some((kp, o))) = (along, position)
        && let Some(om) = placed.get(&o)
        && net.road_index(&road).is_some_and(|r| r != om.pos.road)
    {
        return Err(ScenarioError::Plan(format!(
            "{}: along({road}) and {}: position(…, {o}) cannot both hold for {}: {o} starts on road {}",
            where_(ka),
            where_(kp),
            me.id,
            net.roads()[om.pos.road].id
        )));
    }
    Ok(())
}

/// The index in a right-to-left list of `len` lanes of lane number `n`
/// (1 = rightmost; negative counts from the left, −1 = leftmost; 0 reads
/// as 1, as it always has); out of range gives `len` (no such lane).
pub(super) fn lane_index(len: usize, n: f64) -> usize {
    let k = n.abs() as usize;
    if k == 0 {
        0
    } else if k > len {
        len
    } else if n < 0.0 {
        len - k
    } else {
        k - 1
    }
}

/// Every actor of the test with its size, category and model (from the
/// solution, else the kind's defaults), before placement.
pub(super) fn actor_plans(test: &Test, sol: &Solution) -> Vec<ActorPlan> {
    // Actor attributes from the solution.
    let attr = |a: &ActorDef, k: &str| sol.values.get(&format!("{}.{k}", a.path)).cloned();
    test.actors
        .iter()
        .map(|a| {
            let category = attr(a, "vehicle_category")
                .and_then(|v| v.text().map(String::from))
                .unwrap_or_else(|| {
                    match a.kind {
                        ActorClass::Vehicle => "car",
                        ActorClass::Person => "pedestrian",
                        ActorClass::Cyclist => "bicycle",
                        ActorClass::Animal => "animal",
                        ActorClass::Stationary => "static",
                    }
                    .into()
                });
            let (dl, dw) = match a.kind {
                ActorClass::Vehicle => match category.as_str() {
                    "truck" | "semitrailer" => (10.0, 2.5),
                    "bus" => (12.0, 2.55),
                    "van" => (5.2, 2.0),
                    "motorbike" => (2.2, 0.8),
                    _ => (4.6, 1.9),
                },
                ActorClass::Person => (0.5, 0.5),
                ActorClass::Cyclist => (1.8, 0.6),
                ActorClass::Animal => (1.2, 0.5),
                ActorClass::Stationary => (1.0, 1.0),
            };
            let length = attr(a, "bbox.length").and_then(|v| v.num()).unwrap_or(dl);
            let width = attr(a, "bbox.width").and_then(|v| v.num()).unwrap_or(dw);
            let mut p = ActorPlan::new(a.id.clone(), a.kind, a.ego, category, (length, width));
            p.model = attr(a, "model")
                .and_then(|v| v.text().map(String::from))
                .filter(|m| !m.is_empty());
            p
        })
        .collect()
}

/// Places the actors `order` (plan indexes), each after the actors its
/// start refers to: where each starts, and the actors that could not be
/// set up with this seed.
pub(super) fn place_all(
    net: &RoadNetwork,
    plans: &[ActorPlan],
    order: &[usize],
    rleaves: &[RLeaf],
    rng: &mut Rng,
) -> Result<(BTreeMap<String, Motion>, Vec<String>), ScenarioError> {
    let first_leaf = |id: &str| rleaves.iter().find(|l| l.actor == id);
    let mut placed: BTreeMap<String, Motion> = BTreeMap::new();
    let mut unplaced = Vec::new();
    let roads_ok: Vec<usize> = (0..net.roads().len())
        .filter(|i| {
            let r = &net.roads()[*i];
            r.junction.is_none()
                && r.sections
                    .iter()
                    .any(|s| s.left.iter().chain(s.right.iter()).any(|l| l.is_drivable()))
        })
        .collect();
    if roads_ok.is_empty() {
        return Err(ScenarioError::Plan(
            "the map has no drivable road outside junctions".into(),
        ));
    }
    let mut pending = order.to_vec();
    let mut guard = 0;
    // Placing does not change the plans: one index for every placement.
    let index = plans_index(plans);
    while !pending.is_empty() {
        guard += 1;
        if guard > plans.len() + 2 {
            let ids: Vec<&str> = pending.iter().map(|i| plans[*i].id.as_str()).collect();
            return Err(ScenarioError::Plan(format!(
                "placement depends on itself (position/lane relations form a cycle): {}",
                ids.join(", ")
            )));
        }
        let mut next = Vec::new();
        for &i in &pending {
            let id = plans[i].id.clone();
            let leaf = first_leaf(&id).expect("active actors have a leaf");
            let deps: Vec<&str> = leaf
                .mods
                .iter()
                .filter(|m| m.at() != At::End)
                .flat_map(Intent::references)
                .collect();
            if deps.iter().any(|d| *d != id && !placed.contains_key(*d)) {
                next.push(i);
                continue;
            }
            let m = place(
                net,
                plans,
                i,
                leaf.mods.as_slice(),
                &placed,
                &index,
                rng,
                &roads_ok,
                (&leaf.at, &leaf.mod_at),
                &mut unplaced,
            )?;
            placed.insert(id, m);
        }
        pending = next;
    }
    Ok((placed, unplaced))
}

/// `lateral(…)` at the start: the offset from the lane centre (beside a
/// reference, as its `measure_by` measures between the two outlines); a
/// person or an animal then walks towards and across the lane.
fn beside<'m>(cx: &Cx<'_>, mo: &mut Motion, mut starting: impl Iterator<Item = &'m Intent>) {
    let Some((d, side, o, measure)) = starting.find_map(|m| match m {
        Intent::Lateral {
            distance,
            side,
            side_of,
            measure,
            ..
        } => Some((*distance, *side, side_of, *measure)),
        _ => None,
    }) else {
        return;
    };
    let sgn = side.sign();
    // A reference's width (a lane centre has none).
    let w_ref = o
        .as_ref()
        .and_then(|o| cx.index.get(o))
        .map_or(0.0, |&j| cx.plans[j].width);
    mo.lateral = measure.centre_offset(d, side, (cx.me.width, w_ref));
    if cx.me.kind == ActorClass::Person || cx.me.kind == ActorClass::Animal {
        mo.across = -sgn; // walk towards and across the lane
    }
}
