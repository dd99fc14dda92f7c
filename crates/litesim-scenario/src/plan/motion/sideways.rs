//! A gap kept or changed sideways to another actor (`keep_space_gap(…,
//! direction: lateral)`, `change_space_gap(…, direction: left | right |
//! inside | outside)`): the actor moves across its lane, at a bounded
//! sideways speed, to stay (or get) that far beside the other one wherever
//! the other goes across the road.

use super::*;
use crate::intent::GapSide;

/// Sideways speed (m/s) at which a kept or changed lateral gap is pursued.
pub(super) const SIDE_GAP_RATE: f64 = 1.0;
/// A changed lateral gap is reached within this (m).
pub(super) const SIDE_GAP_REACHED_M: f64 = 0.1;

/// A lateral gap under way.
#[derive(Clone, Copy, Debug)]
pub(super) struct SideGap {
    /// The other actor's plan.
    j: usize,
    /// +1: the other is on this actor's left; −1: on its right.
    sign: f64,
    /// The free space between the two (m) asked for.
    gap: f64,
    /// Half of both widths (m): centre to centre is `gap` plus this.
    halves: f64,
}

impl Mover<'_> {
    /// Enters a lateral gap phase at `t` to `o`: the gap it has (kept) or
    /// `target` (changed, ending when reached); `side` is where `o` is,
    /// or, for a kept gap, wherever it is now.
    pub(super) fn start_side_gap(
        &mut self,
        l: &RLeaf,
        t: f64,
        (o, target, side): (&str, Option<f64>, Option<GapSide>),
        plans: &[ActorPlan],
    ) -> Result<(), ScenarioError> {
        let j = self.planned_before(l, o, "lateral gap", plans)?;
        let halves = (plans[j].width + plans[self.i].width) / 2.0;
        let across = self.across_to(j, t, plans);
        let sign = match side {
            Some(GapSide::Left) => 1.0,
            Some(GapSide::Right) => -1.0,
            Some(s @ (GapSide::Inside | GapSide::Outside)) => {
                self.inner_side(s == GapSide::Inside).sign()
            }
            None if across == 0.0 => {
                return Err(ScenarioError::Plan(format!(
                    "{}: {} keeps a lateral gap to {o}, which is right in line with it when the phase starts (no side to keep it on)",
                    l.at, self.id
                )));
            }
            None => across.signum(),
        };
        let gap = match target {
            Some(g) if g < 0.0 => {
                return Err(ScenarioError::Plan(format!(
                    "{}: {} changes its lateral gap to {o} to {g} m, which is negative",
                    l.at, self.id
                )));
            }
            Some(g) => g,
            None => across.abs() - halves,
        };
        if target.is_none() && gap < 0.0 {
            return Err(ScenarioError::Plan(format!(
                "{}: {} keeps a lateral gap to {o}, which overlaps it sideways when the phase starts ({gap:.2} m)",
                l.at, self.id
            )));
        }
        // It moves across for the gap, not back to its lane's centre.
        self.lane_offset = None;
        self.side_gap = Some(SideGap {
            j,
            sign,
            gap,
            halves,
        });
        if target.is_some() {
            self.reaching = Some((l.id, Reach::Side(gap), t));
        }
        self.exact(l, &format!("{}(direction: sideways)", l.action));
        Ok(())
    }

    /// How far the other actor's plan is across this one's lane at `t`
    /// from where this one is (m, left positive).
    fn across_to(&self, j: usize, t: f64, plans: &[ActorPlan]) -> f64 {
        let centre = self.cx.net.lane_pos_pose(self.mo.pos, 0.0);
        let r = plans[j].at(t, self.cx.dt);
        let (s, c) = math::sin_cos(centre.yaw);
        let lateral_of_other = -(r.x - centre.position.x) * s + (r.y - centre.position.y) * c;
        lateral_of_other - self.mo.lateral
    }

    /// Moves one plan step across towards the place beside the other
    /// actor that the gap asks for.
    pub(super) fn shift_to_side_gap(&mut self, t: f64, plans: &[ActorPlan]) {
        let Some(g) = self.side_gap else {
            return;
        };
        let across = self.across_to(g.j, t, plans);
        // Where it should be, from where it is: the other's offset less
        // the centre-to-centre distance on its side.
        let want = across - g.sign * (g.gap + g.halves);
        let step = SIDE_GAP_RATE * self.cx.dt;
        self.mo.lateral += want.clamp(-step, step);
    }

    /// A changed lateral gap within [`SIDE_GAP_REACHED_M`] of its target
    /// at `t`: it ends at `t`.
    pub(super) fn side_gap_reached(&mut self, t: f64, plans: &[ActorPlan]) {
        let (Some((id, Reach::Side(target), t0)), Some(g)) = (self.reaching, self.side_gap) else {
            return;
        };
        let free = self.across_to(g.j, t, plans).abs() - g.halves;
        if (free - target).abs() <= SIDE_GAP_REACHED_M && t > t0 + 1e-9 {
            self.out
                .reached
                .push((super::super::timer::reach_key(id), t - t0));
            self.reaching = None;
        }
    }
}
