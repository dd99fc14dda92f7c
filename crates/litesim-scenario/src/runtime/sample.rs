//! Coverage sampling: the test's `cover`/`record` items read the simulated
//! state at their events (the start, a phase's end, the run's end).

use super::ExecConfig;
use crate::plan::Plan;
use crate::state::BodyState;
use litesim_map::RoadNetwork;

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
    states: &[BodyState],
    t: f64,
    end: bool,
    out: &mut [Option<crate::coverage::Sample>],
) {
    use crate::coverage::{Sample, evaluate};
    for (item, slot) in cfg.covers.iter().zip(out.iter_mut()) {
        if slot.is_some() || !(end || t >= item_due(item, plan) - 1e-9) {
            continue;
        }
        let actor = |id: &str| {
            let i = plan.actors.iter().position(|a| a.id == id)?;
            states.get(i).copied()
        };
        let lane = |a: &BodyState| {
            net.and_then(|n| n.to_road(litesim_core::Vec2::new(a.x, a.y)))
                .map(|p| p.lane)
        };
        *slot = Some(Sample {
            item: item.name.clone(),
            value: evaluate(item, &plan.ids, &cfg.values, &actor, &lane),
            t,
        });
    }
}
