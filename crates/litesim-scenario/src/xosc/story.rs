//! The storyboard's elements and their states: standby, running, complete,
//! with the start, end, stop and skip transitions of the standard
//! (`StoryboardElementStateCondition` reads them), and triggers — condition
//! groups OR'ed, conditions AND'ed, each with its edge and delay.

use litesim_xosc::{Edge, ElementState, ElementType, Priority, Trigger};
use std::collections::VecDeque;

/// An element's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Waiting for its start trigger (or its parent).
    Standby,
    /// Running.
    Running,
    /// Done (ended, stopped or skipped for good).
    Complete,
}

/// A transition an element took.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transition {
    /// Standby → running.
    Start,
    /// Running → complete or standby, its goal reached.
    End,
    /// Stopped (a stop trigger, an overriding event).
    Stop,
    /// An event's start refused by `skip`.
    Skip,
}

/// One storyboard element, its place in the tree and its state.
#[derive(Clone, Debug)]
pub struct Elem {
    /// Its type.
    pub kind: ElementType,
    /// Its name.
    pub name: String,
    /// Its parent (none for a story).
    pub parent: Option<usize>,
    /// Its children, in order.
    pub children: Vec<usize>,
    /// Its state now.
    pub state: State,
    /// Executions so far (events and maneuver groups).
    pub count: u32,
    /// `maximumExecutionCount` (1 for others).
    pub max: u32,
    /// Start trigger (acts, events), as index into the triggers.
    pub start: Option<usize>,
    /// Stop trigger (acts).
    pub stop: Option<usize>,
    /// An event's priority.
    pub priority: Priority,
    /// An action's index in the flat action list.
    pub action: Option<usize>,
    /// Where it is written.
    pub at: String,
}

/// A condition's running history: what its edge saw last and when its
/// (edge-applied) value held, for the delay.
#[derive(Clone, Debug, Default)]
pub struct CondState {
    /// The logical value at the previous evaluation (none before the
    /// first: no edge on the first sample).
    pub last: Option<bool>,
    /// Times its edge value was true, oldest first (kept for the delay).
    pub held: VecDeque<f64>,
}

/// A trigger and its conditions' histories.
#[derive(Clone, Debug)]
pub struct TriggerRt {
    /// The trigger as written.
    pub trigger: Trigger,
    /// One history per condition, group by group.
    pub conds: Vec<Vec<CondState>>,
    /// Whether it is being evaluated (its element waits on it): histories
    /// start when evaluation does.
    pub armed: bool,
}

impl TriggerRt {
    /// A trigger not yet evaluated.
    pub fn new(trigger: Trigger) -> Self {
        let conds = trigger
            .groups
            .iter()
            .map(|g| vec![CondState::default(); g.len()])
            .collect();
        TriggerRt {
            trigger,
            conds,
            armed: false,
        }
    }

    /// Forgets the histories (an element armed again).
    pub fn rearm(&mut self) {
        for g in &mut self.conds {
            for c in g {
                *c = CondState::default();
            }
        }
        self.armed = true;
    }
}

/// One condition at time `t`: its logical value `l` through its edge and
/// its delay (the value `delay` seconds ago, on the step grid).
pub fn condition_value(
    st: &mut CondState,
    edge: Edge,
    delay: f64,
    l: bool,
    t: f64,
    dt: f64,
) -> bool {
    let e = match (edge, st.last) {
        (Edge::None, _) => l,
        (_, None) => false,
        (Edge::Rising, Some(prev)) => l && !prev,
        (Edge::Falling, Some(prev)) => !l && prev,
        (Edge::RisingOrFalling, Some(prev)) => l != prev,
    };
    st.last = Some(l);
    if delay <= 0.0 {
        return e;
    }
    if e {
        st.held.push_back(t);
    }
    // The value `delay` ago: held at a step whose time plus the delay is
    // now (within half a step: the delay on the step grid).
    let half = 0.5 * dt;
    while st.held.front().is_some_and(|&h| h + delay < t - half) {
        st.held.pop_front();
    }
    st.held
        .front()
        .is_some_and(|&h| (h + delay - t).abs() <= half)
}

/// Whether an element is in `state` (a state) or took it this step (a
/// transition), for `StoryboardElementStateCondition`.
pub fn in_state(e: &Elem, took: &[(usize, Transition)], ix: usize, state: ElementState) -> bool {
    let took_it = |tr: Transition| took.iter().any(|&(i, x)| i == ix && x == tr);
    match state {
        ElementState::Standby => e.state == State::Standby,
        ElementState::Running => e.state == State::Running,
        ElementState::Complete => e.state == State::Complete,
        ElementState::StartTransition => took_it(Transition::Start),
        ElementState::EndTransition => took_it(Transition::End),
        ElementState::StopTransition => took_it(Transition::Stop),
        ElementState::SkipTransition => took_it(Transition::Skip),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_see_no_change_on_the_first_sample() {
        let mut st = CondState::default();
        // Already true at the first evaluation: rising must see it fall
        // and rise again.
        assert!(!condition_value(&mut st, Edge::Rising, 0.0, true, 0.0, 0.1));
        assert!(!condition_value(&mut st, Edge::Rising, 0.0, true, 0.1, 0.1));
        assert!(!condition_value(
            &mut st,
            Edge::Rising,
            0.0,
            false,
            0.2,
            0.1
        ));
        assert!(condition_value(&mut st, Edge::Rising, 0.0, true, 0.3, 0.1));
        let mut st = CondState::default();
        assert!(!condition_value(
            &mut st,
            Edge::Falling,
            0.0,
            true,
            0.0,
            0.1
        ));
        assert!(condition_value(
            &mut st,
            Edge::Falling,
            0.0,
            false,
            0.1,
            0.1
        ));
        let mut st = CondState::default();
        assert!(condition_value(&mut st, Edge::None, 0.0, true, 0.0, 0.1));
        let mut st = CondState::default();
        assert!(!condition_value(
            &mut st,
            Edge::RisingOrFalling,
            0.0,
            true,
            0.0,
            0.1
        ));
        assert!(condition_value(
            &mut st,
            Edge::RisingOrFalling,
            0.0,
            false,
            0.1,
            0.1
        ));
        assert!(condition_value(
            &mut st,
            Edge::RisingOrFalling,
            0.0,
            true,
            0.2,
            0.1
        ));
    }

    #[test]
    fn a_delay_shifts_the_value_by_its_time() {
        let mut st = CondState::default();
        let dt = 0.1;
        let mut fired = Vec::new();
        for k in 0..40 {
            let t = k as f64 * dt;
            // True from 1.0 s on; rising fires once, at 1.0 s; delayed 1.5 s.
            if condition_value(&mut st, Edge::Rising, 1.5, t >= 1.0 - 1e-9, t, dt) {
                fired.push(k);
            }
        }
        assert_eq!(fired, vec![25]);
    }
}
