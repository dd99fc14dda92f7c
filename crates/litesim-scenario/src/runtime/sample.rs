//! Coverage sampling: the test's `cover`/`record` items read the simulated
//! state at their events (the start, a phase's end, the run's end).

use super::ExecConfig;
use crate::kpi::BoxState;
use crate::plan::Plan;
use litesim_map::RoadNetwork;

/// The step's state as coverage items read it (lanes are looked up only
/// by items that read one).
pub(crate) fn live_state(
    boxes: &[BoxState],
    speeds: &[f64],
    accels: &[f64],
    live: &mut Vec<crate::coverage::LiveActor>,
) {
    live.clear();
    for (i, b) in boxes.iter().enumerate() {
        live.push(crate::coverage::LiveActor {
            speed: speeds[i],
            acceleration: accels.get(i).copied().unwrap_or(0.0),
            x: b.x,
            y: b.y,
            yaw: b.yaw,
            lane: None,
            length: b.length,
            width: b.width,
            vx: b.vx,
            vy: b.vy,
        });
    }
}

/// When the next item not sampled yet is due (s; infinite: at the end).
pub(crate) fn due_time(
    cfg: &ExecConfig,
    plan: &Plan,
    samples: &[Option<crate::coverage::Sample>],
) -> f64 {
    cfg.covers
        .iter()
        .zip(samples)
        .filter(|(_, s)| s.is_none())
        .map(|(item, _)| item_due(item, plan))
        .fold(f64::INFINITY, f64::min)
}

/// When an item is due by the plan (s; infinite: at the end).
fn item_due(item: &crate::coverage::CoverItem, plan: &Plan) -> f64 {
    use crate::coverage::SampleAt;
    match &item.event {
        SampleAt::Start => 0.0,
        SampleAt::End => f64::INFINITY,
        // The plan keys label times by the label as written (`a.end`);
        // the item knows its path (`c.a`).
        SampleAt::PhaseEnd(label) => plan
            .events
            .get(&format!("{label}.end"))
            .or_else(|| {
                let own = label.rsplit('.').next().unwrap_or(label);
                plan.events.get(&format!("{own}.end"))
            })
            .copied()
            .unwrap_or(f64::INFINITY),
    }
}

/// Samples the items due at `t` (`end`: the run is over, every item not
/// sampled yet is due — a phase that never ended is sampled at the end).
pub(crate) fn sample_items(
    cfg: &ExecConfig,
    plan: &Plan,
    net: Option<&RoadNetwork>,
    live: &[crate::coverage::LiveActor],
    t: f64,
    end: bool,
    out: &mut [Option<crate::coverage::Sample>],
) {
    use crate::coverage::{Sample, evaluate};
    for (item, slot) in cfg.covers.iter().zip(out.iter_mut()) {
        if slot.is_some() || !(end || t >= item_due(item, plan) - 1e-9) {
            continue;
        }
        // The map lookup only for items that read a lane.
        let lane = item.reads_lane();
        let actor = |id: &str| {
            let i = plan.actors.iter().position(|a| a.id == id)?;
            let mut a = *live.get(i)?;
            if lane {
                a.lane = net
                    .and_then(|n| n.to_road(litesim_core::Vec2::new(a.x, a.y)))
                    .map(|p| p.lane);
            }
            Some(a)
        };
        *slot = Some(Sample {
            item: item.name.clone(),
            value: evaluate(item, &plan.ids, &cfg.values, &actor),
            t,
        });
    }
}
