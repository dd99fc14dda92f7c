//! The SUT seam: the system under test (built in, a Python object or a
//! process over gRPC) drives sut.car. It is told the vehicle and route once
//! ([`SutSeam::reset`]), then sent the step's observation and its command
//! goes to the SSP as a dynamic move.

use super::pid::{Limits, pedals};
use super::{Act, Controller, Flow, See, ssp_err};
use crate::error::ScenarioError;
use crate::sut::{Sut, SutCommand, SutInfo};
use litesim_core::math;
use litesim_log::ControlSample;
use litesim_ssp::api::{DynamicMove, Ssp};

/// Where the SUT's commands come from.
pub enum SutSlot<'s> {
    /// A SUT the caller keeps.
    Borrowed(&'s mut dyn Sut),
    /// A SUT the run keeps.
    Owned(Box<dyn Sut>),
    /// The caller of a stepped run: it reads the observation and gives the
    /// command before each step ([`crate::Stepped`]).
    Outside,
}

/// The system under test behind the controller trait.
pub(crate) struct SutSeam<'s> {
    sut: SutSlot<'s>,
    /// An outside SUT's command for the step to come.
    given: Option<SutCommand>,
    /// sut.car's plan index.
    pub ego: usize,
    /// sut.car's limits from the catalogue.
    pub lim: Limits,
    /// The simulator's model (its steering geometry).
    model: String,
    mirror: bool,
    /// sut.car's mass (kg): a force command's acceleration.
    mass: f64,
    /// The last command as the SUT sent it, as (acceleration, road-wheel
    /// angle): what the log's command columns show.
    pub last: Option<(f64, f64)>,
    /// sut.car's gear: backwards (the SUT's last `Accel` asked for reverse
    /// and the vehicle has stopped to change).
    reverse: bool,
}

impl<'s> SutSeam<'s> {
    /// The SUT driving actor `ego`.
    pub fn new(
        sut: SutSlot<'s>,
        ego: usize,
        lim: Limits,
        (model, mass): (&str, f64),
        mirror: bool,
    ) -> Self {
        SutSeam {
            sut,
            given: None,
            ego,
            lim,
            model: model.to_string(),
            mirror,
            mass,
            last: None,
            reverse: false,
        }
    }

    /// The road-wheel angle that gives `curvature` in the model: the seed's
    /// Model SSP turns at sin δ / L, the bicycle at tan δ / L.
    fn wheel_angle(&self, curvature: f64) -> f64 {
        let lk = self.lim.wheelbase * curvature;
        if self.model == "dummy" || self.model.is_empty() {
            math::asin(lk.clamp(-1.0, 1.0))
        } else {
            math::atan(lk)
        }
    }

    /// A command as (acceleration, road-wheel angle): an acceleration
    /// command as sent; pedals at the vehicle's limits (full throttle its
    /// largest acceleration, full brake its largest deceleration); forces
    /// over its mass (the steering wheel's angle is not a road-wheel angle
    /// without the steering ratio: NaN).
    fn as_accel(&self, c: &SutCommand) -> (f64, f64) {
        match *c {
            // The signed speed's rate: backwards, the travel's negated.
            SutCommand::Accel {
                acceleration,
                curvature,
                reverse,
            } => (
                if reverse { -acceleration } else { acceleration },
                self.wheel_angle(curvature),
            ),
            SutCommand::Pedals {
                throttle,
                brake,
                steering,
            } => (
                throttle * self.lim.max_accel - brake * self.lim.max_decel,
                steering * self.lim.max_steer,
            ),
            SutCommand::Physical {
                drive_force_n,
                brake_force_n,
                ..
            } => (
                (drive_force_n - brake_force_n) / self.mass.max(1.0),
                f64::NAN,
            ),
        }
    }

    /// Tells the SUT its vehicle and route; its failure as the run's stop
    /// message.
    pub fn reset(&mut self, info: &SutInfo) -> Option<String> {
        self.inside()?
            .reset(info)
            .err()
            .map(|err| format!("sut error at t=0.00 s (reset): {err}"))
    }

    /// The SUT the run calls (none when it is driven from outside).
    fn inside(&mut self) -> Option<&mut dyn Sut> {
        match &mut self.sut {
            SutSlot::Borrowed(s) => Some(&mut **s),
            SutSlot::Owned(s) => Some(&mut **s),
            SutSlot::Outside => None,
        }
    }

    /// An outside SUT's command for the step to come.
    pub fn give(&mut self, cmd: SutCommand) {
        self.given = Some(cmd);
    }

    /// What the SUT has to report.
    pub fn notes(&mut self) -> Vec<String> {
        self.inside().map(|s| s.notes()).unwrap_or_default()
    }
}

impl Controller for SutSeam<'_> {
    fn command(&mut self, see: &See<'_>, act: &mut Act<'_>) -> Result<Flow, ScenarioError> {
        // The SUT sees every actor but itself: the observation's layout.
        let answer = match self.inside() {
            Some(s) => s.step_shared(&see.world.obs),
            None => self
                .given
                .take()
                .ok_or_else(|| crate::sut::SutError("no command was given for this step".into())),
        };
        let cmd = answer.map_err(|err| err.0).and_then(|c| {
            c.validate()
                .map(|()| c)
                .map_err(|m| format!("it returned a bad command: {m}"))
        });
        match cmd {
            Ok(c) => {
                self.last = Some(self.as_accel(&c));
                let id = &see.plan.actors[self.ego].id;
                let c = self.geared(act.ssp, id, c, see.world.obs.ego.speed)?;
                let control = &mut act.controls[self.ego];
                send_sut(act.ssp, id, c, self, control)?;
                Ok(Flow::Go)
            }
            Err(m) => Ok(Flow::Stop(format!("sut error at t={:.2} s: {m}", see.t()))),
        }
    }
}

impl SutSeam<'_> {
    /// The gear an `Accel` command asks for. Where it is not the one
    /// engaged, the vehicle is braked to rest first (at the command's
    /// rate, at least 1 m/s², at most its brakes'), then the gear changes
    /// (`controls.gear` R or D) and the command drives. Returns the
    /// command to send this step, as the signed speed's rate.
    fn geared(
        &mut self,
        ssp: &mut dyn Ssp,
        id: &str,
        c: SutCommand,
        speed: f64,
    ) -> Result<SutCommand, ScenarioError> {
        let SutCommand::Accel {
            acceleration,
            curvature,
            reverse,
        } = c
        else {
            return Ok(c);
        };
        if reverse != self.reverse {
            if speed.abs() > 1e-3 {
                let brake = acceleration.abs().clamp(1.0, self.lim.max_decel.max(1.0));
                return Ok(SutCommand::Accel {
                    acceleration: -brake * speed.signum(),
                    curvature,
                    reverse: false,
                });
            }
            let controls = litesim_ssp::api::ActorControls {
                gear: if reverse { "R" } else { "D" }.into(),
                ..Default::default()
            };
            ssp.set_actor_params(id, Default::default(), Some(controls))
                .map_err(ssp_err)?;
            self.reverse = reverse;
        }
        Ok(SutCommand::Accel {
            acceleration: if reverse { -acceleration } else { acceleration },
            curvature,
            reverse: false,
        })
    }
}

/// Sends the SUT's command to `sut.car` as a dynamic move (an `Accel`
/// already as the signed speed's rate: [`SutSeam::geared`]).
fn send_sut(
    ssp: &mut dyn Ssp,
    id: &str,
    c: SutCommand,
    seam: &SutSeam<'_>,
    control: &mut ControlSample,
) -> Result<(), ScenarioError> {
    let (caps, mirror) = (&seam.lim, seam.mirror);
    let m = if mirror { -1.0 } else { 1.0 };
    let mv = match c {
        SutCommand::Pedals {
            throttle,
            brake,
            steering,
        } => pedals(throttle, brake, steering, caps, mirror, control),
        SutCommand::Physical {
            drive_force_n,
            brake_force_n,
            steering_wheel_angle_rad,
        } => DynamicMove::Physical {
            drive_force_n,
            brake_force_n,
            steer: litesim_ssp::api::PhysicalSteer::SteeringWheelAngleRad(
                m * steering_wheel_angle_rad,
            ),
        },
        SutCommand::Accel {
            acceleration,
            curvature,
            ..
        } => {
            let delta = seam.wheel_angle(curvature);
            *control = ControlSample {
                acceleration,
                steering_angle: delta,
                ..ControlSample::default()
            };
            DynamicMove::Direct {
                acceleration,
                steering_angle_rad: m * delta,
            }
        }
    };
    ssp.set_dynamic_move(id, mv, 0).map_err(ssp_err)
}
