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

/// A call of the simulator-support API, as the phases allow or refuse
/// it: a value, not its name, so that asking costs a byte compare (the
/// session's per-step calls ask several times a step).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Call {
    /// `init`.
    Init,
    /// `launch_simulator`.
    LaunchSimulator,
    /// `terminate_simulator`.
    TerminateSimulator,
    /// `start_simulation`.
    StartSimulation,
    /// `wait_start_simulation`.
    WaitStartSimulation,
    /// `end_simulation`.
    EndSimulation,
    /// `start_step`.
    StartStep,
    /// `step`.
    Step,
    /// `wait_step`.
    WaitStep,
    /// `create_actor`.
    CreateActor,
    /// `destroy_actor`.
    DestroyActor,
    /// `set_actor_params`.
    SetActorParams,
    /// `set_xy_trajectory`.
    SetXyTrajectory,
    /// `set_dynamic_move`.
    SetDynamicMove,
    /// `set_external_controller`.
    SetExternalController,
    /// `get_actors_states`.
    GetActorsStates,
    /// `set_weather`.
    SetWeather,
    /// `set_time_of_day`.
    SetTimeOfDay,
    /// `sim_command`.
    SimCommand,
    /// `list_traffic_lights`.
    ListTrafficLights,
    /// `set_traffic_light_state`.
    SetTrafficLightState,
}

impl Call {
    /// The call's name, as errors and `allowed_calls` give it.
    pub(super) fn name(self) -> &'static str {
        match self {
            Call::Init => "init",
            Call::LaunchSimulator => "launch_simulator",
            Call::TerminateSimulator => "terminate_simulator",
            Call::StartSimulation => "start_simulation",
            Call::WaitStartSimulation => "wait_start_simulation",
            Call::EndSimulation => "end_simulation",
            Call::StartStep => "start_step",
            Call::Step => "step",
            Call::WaitStep => "wait_step",
            Call::CreateActor => "create_actor",
            Call::DestroyActor => "destroy_actor",
            Call::SetActorParams => "set_actor_params",
            Call::SetXyTrajectory => "set_xy_trajectory",
            Call::SetDynamicMove => "set_dynamic_move",
            Call::SetExternalController => "set_external_controller",
            Call::GetActorsStates => "get_actors_states",
            Call::SetWeather => "set_weather",
            Call::SetTimeOfDay => "set_time_of_day",
            Call::SimCommand => "sim_command",
            Call::ListTrafficLights => "list_traffic_lights",
            Call::SetTrafficLightState => "set_traffic_light_state",
        }
    }
}

pub(super) const ACTOR_CALLS: &[Call] = &[
    Call::CreateActor,
    Call::DestroyActor,
    Call::SetActorParams,
    Call::SetXyTrajectory,
    Call::SetDynamicMove,
    Call::SetExternalController,
    Call::GetActorsStates,
    Call::SetWeather,
    Call::SetTimeOfDay,
    Call::SimCommand,
    Call::ListTrafficLights,
    Call::SetTrafficLightState,
];

impl Phase {
    /// The calls of this phase's own (the actor calls come on top).
    pub(super) const fn own_calls(self) -> &'static [Call] {
        match self {
            Phase::Uninitialized => &[Call::Init],
            Phase::Initialized => &[
                Call::LaunchSimulator,
                Call::TerminateSimulator,
                Call::StartSimulation,
            ],
            Phase::Starting => &[Call::WaitStartSimulation, Call::EndSimulation],
            Phase::Running => &[
                Call::StartStep,
                Call::Step,
                Call::EndSimulation,
                Call::WaitStartSimulation,
            ],
            Phase::Stepping => &[Call::WaitStep, Call::EndSimulation],
            Phase::Ended => &[
                Call::GetActorsStates,
                Call::TerminateSimulator,
                Call::SimCommand,
            ],
        }
    }

    pub(super) const fn has_actor_calls(self) -> bool {
        !matches!(self, Phase::Uninitialized | Phase::Ended)
    }

    /// The calls this phase allows as bits (bit `c as u32` for call `c`),
    /// made from [`Phase::own_calls`] and [`ACTOR_CALLS`] at compile time.
    const fn mask(self) -> u32 {
        const fn bits(calls: &[Call]) -> u32 {
            let mut m = 0;
            let mut k = 0;
            while k < calls.len() {
                m |= 1 << calls[k] as u32;
                k += 1;
            }
            m
        }
        let own = bits(self.own_calls());
        if self.has_actor_calls() {
            own | bits(ACTOR_CALLS)
        } else {
            own
        }
    }

    /// Whether `call` is allowed in this phase: one bit test (every call
    /// of a step asks; scanning the lists cost ~45 instructions a call).
    #[inline]
    pub(super) fn allows(self, call: Call) -> bool {
        let mask = match self {
            Phase::Uninitialized => const { Phase::Uninitialized.mask() },
            Phase::Initialized => const { Phase::Initialized.mask() },
            Phase::Starting => const { Phase::Starting.mask() },
            Phase::Running => const { Phase::Running.mask() },
            Phase::Stepping => const { Phase::Stepping.mask() },
            Phase::Ended => const { Phase::Ended.mask() },
        };
        mask & (1 << call as u32) != 0
    }

    /// The calls allowed in this state.
    pub fn allowed_calls(self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = self.own_calls().iter().map(|c| c.name()).collect();
        if self.has_actor_calls() {
            v.extend(ACTOR_CALLS.iter().map(|c| c.name()));
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bit masks answer as the lists they are made from: every call
    /// in every phase.
    #[test]
    fn the_masks_answer_as_the_lists() {
        let phases = [
            Phase::Uninitialized,
            Phase::Initialized,
            Phase::Starting,
            Phase::Running,
            Phase::Stepping,
            Phase::Ended,
        ];
        let mut calls = Vec::new();
        for p in phases {
            calls.extend_from_slice(p.own_calls());
        }
        calls.extend_from_slice(ACTOR_CALLS);
        for p in phases {
            for &c in &calls {
                let listed =
                    p.own_calls().contains(&c) || (p.has_actor_calls() && ACTOR_CALLS.contains(&c));
                assert_eq!(p.allows(c), listed, "{p} {}", c.name());
            }
        }
    }
}
