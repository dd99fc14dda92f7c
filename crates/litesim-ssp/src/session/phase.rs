//! A session's life-cycle states and the calls each allows.

use super::*;

/// Life-cycle states of a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Phase {
    /// Before `init`.
    Uninitialized,
    /// After `init`.
    Initialized,
    /// After `start_simulation`.
    Starting,
    /// Ready to step.
    Running,
    /// Between `start_step` and `wait_step`.
    Stepping,
    /// After `end_simulation`.
    Ended,
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Phase::Uninitialized => "UNINITIALIZED",
            Phase::Initialized => "INITIALIZED",
            Phase::Starting => "STARTING",
            Phase::Running => "RUNNING",
            Phase::Stepping => "STEPPING",
            Phase::Ended => "ENDED",
        };
        f.write_str(s)
    }
}

pub(super) const ACTOR_CALLS: &[&str] = &[
    "create_actor",
    "destroy_actor",
    "set_actor_params",
    "set_xy_trajectory",
    "set_dynamic_move",
    "set_external_controller",
    "get_actors_states",
    "set_weather",
    "set_time_of_day",
    "sim_command",
    "list_traffic_lights",
    "set_traffic_light_state",
];

impl Phase {
    /// The calls of this phase's own (the actor calls come on top).
    pub(super) fn own_calls(self) -> &'static [&'static str] {
        match self {
            Phase::Uninitialized => &["init"],
            Phase::Initialized => &[
                "launch_simulator",
                "terminate_simulator",
                "start_simulation",
            ],
            Phase::Starting => &["wait_start_simulation", "end_simulation"],
            Phase::Running => &[
                "start_step",
                "step",
                "end_simulation",
                "wait_start_simulation",
            ],
            Phase::Stepping => &["wait_step", "end_simulation"],
            Phase::Ended => &["get_actors_states", "terminate_simulator", "sim_command"],
        }
    }

    pub(super) fn has_actor_calls(self) -> bool {
        !matches!(self, Phase::Uninitialized | Phase::Ended)
    }

    /// Whether `call` is allowed in this phase (every API call asks: no
    /// list is built).
    pub fn allows(self, call: &str) -> bool {
        // Callers pass the same literals as the lists hold: the address
        // usually decides, the text only when it does not (the session's
        // per-step calls ask this several times a step).
        let is = |c: &&str| (c.as_ptr() == call.as_ptr() && c.len() == call.len()) || *c == call;
        self.own_calls().iter().any(is) || (self.has_actor_calls() && ACTOR_CALLS.iter().any(is))
    }

    /// The calls allowed in this state.
    pub fn allowed_calls(self) -> Vec<&'static str> {
        let mut v = self.own_calls().to_vec();
        if self.has_actor_calls() {
            v.extend_from_slice(ACTOR_CALLS);
        }
        v
    }
}
