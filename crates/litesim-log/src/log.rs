//! The columnar log and its recorder.

use litesim_core::{Derived, Pose, Vec3, VehicleInput, World, math};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// JSON has no NaN: writers emit `null` for "no value"; read it back as NaN.
/// Straight into the column (no intermediate `Vec<Option<f64>>` of twice
/// the size, copied once more): a long log's columns are most of what
/// reading it allocates.
fn nan_vec<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    struct Column;
    impl<'de> serde::de::Visitor<'de> for Column {
        type Value = Vec<f64>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a sequence of numbers or nulls")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<f64>, A::Error> {
            // A hint from the format, bounded: a hostile length is not
            // allocated up front.
            let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 16));
            while let Some(x) = seq.next_element::<Option<f64>>()? {
                out.push(x.unwrap_or(f64::NAN));
            }
            Ok(out)
        }
    }
    d.deserialize_seq(Column)
}

/// State columns of one actor (SI units, world frame).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateColumns {
    /// x (m).
    #[serde(deserialize_with = "nan_vec")]
    pub x: Vec<f64>,
    /// y (m).
    #[serde(deserialize_with = "nan_vec")]
    pub y: Vec<f64>,
    /// z (m).
    #[serde(deserialize_with = "nan_vec")]
    pub z: Vec<f64>,
    /// Heading (rad).
    #[serde(deserialize_with = "nan_vec")]
    pub yaw: Vec<f64>,
    /// Velocity x (m/s).
    #[serde(deserialize_with = "nan_vec")]
    pub vx: Vec<f64>,
    /// Velocity y (m/s).
    #[serde(deserialize_with = "nan_vec")]
    pub vy: Vec<f64>,
    /// Longitudinal speed (m/s).
    #[serde(deserialize_with = "nan_vec")]
    pub speed: Vec<f64>,
    /// Yaw rate (rad/s).
    #[serde(deserialize_with = "nan_vec")]
    pub yaw_rate: Vec<f64>,
}

/// Control columns: what the actor was told in the step (NaN = not applicable).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ControlColumns {
    /// Throttle 0..1.
    #[serde(deserialize_with = "nan_vec")]
    pub throttle: Vec<f64>,
    /// Brake 0..1.
    #[serde(deserialize_with = "nan_vec")]
    pub brake: Vec<f64>,
    /// Steering −1..1 of full lock.
    #[serde(deserialize_with = "nan_vec")]
    pub steering: Vec<f64>,
    /// Commanded acceleration (m/s²) for direct control.
    #[serde(deserialize_with = "nan_vec")]
    pub acceleration: Vec<f64>,
    /// Road-wheel angle applied (rad).
    #[serde(deserialize_with = "nan_vec")]
    pub steering_angle: Vec<f64>,
}

/// Derived columns (seed 001 §1.3; see [`litesim_core::Derived`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DerivedColumns {
    /// Curvature (1/m).
    #[serde(deserialize_with = "nan_vec")]
    pub curvature: Vec<f64>,
    /// Lateral acceleration (m/s²).
    #[serde(deserialize_with = "nan_vec")]
    pub lateral_acceleration: Vec<f64>,
    /// Longitudinal acceleration (m/s²).
    #[serde(deserialize_with = "nan_vec")]
    pub longitudinal_acceleration: Vec<f64>,
    /// Side-slip angle (rad).
    #[serde(deserialize_with = "nan_vec")]
    pub slip_angle: Vec<f64>,
    /// m·a_x (N).
    #[serde(deserialize_with = "nan_vec")]
    pub force_longitudinal_n: Vec<f64>,
    /// m·a_y (N).
    #[serde(deserialize_with = "nan_vec")]
    pub force_lateral_n: Vec<f64>,
    /// √(a_x²+a_y²)/(μg).
    #[serde(deserialize_with = "nan_vec")]
    pub friction_use: Vec<f64>,
}

/// One actor's record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActorTrack {
    /// Actor id.
    pub id: String,
    /// Kind ("vehicle/car", "person", …).
    pub kind: String,
    /// Blueprint.
    pub model: String,
    /// Length (m).
    pub length: f64,
    /// Width (m).
    pub width: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Ticks at which the actor was recorded.
    pub tick: Vec<u64>,
    /// Control mode per tick ("stored", "trajectory", "dynamic", "direct", "external").
    pub mode: Vec<String>,
    /// State.
    pub state: StateColumns,
    /// Control.
    pub control: ControlColumns,
    /// Derived.
    pub derived: DerivedColumns,
}

impl ActorTrack {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.tick.len()
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.tick.is_empty()
    }
    /// Every numeric column with its name: the one list that slicing and
    /// validation walk, so a new column cannot be forgotten by one of them.
    fn columns(&self) -> [(&'static str, &Vec<f64>); 20] {
        let (s, c, d) = (&self.state, &self.control, &self.derived);
        [
            ("state.x", &s.x),
            ("state.y", &s.y),
            ("state.z", &s.z),
            ("state.yaw", &s.yaw),
            ("state.vx", &s.vx),
            ("state.vy", &s.vy),
            ("state.speed", &s.speed),
            ("state.yaw_rate", &s.yaw_rate),
            ("control.throttle", &c.throttle),
            ("control.brake", &c.brake),
            ("control.steering", &c.steering),
            ("control.acceleration", &c.acceleration),
            ("control.steering_angle", &c.steering_angle),
            ("derived.curvature", &d.curvature),
            ("derived.lateral_acceleration", &d.lateral_acceleration),
            (
                "derived.longitudinal_acceleration",
                &d.longitudinal_acceleration,
            ),
            ("derived.slip_angle", &d.slip_angle),
            ("derived.force_longitudinal_n", &d.force_longitudinal_n),
            ("derived.force_lateral_n", &d.force_lateral_n),
            ("derived.friction_use", &d.friction_use),
        ]
    }
    /// [`ActorTrack::columns`], writable, in the same order.
    fn columns_mut(&mut self) -> [&mut Vec<f64>; 20] {
        let (s, c, d) = (&mut self.state, &mut self.control, &mut self.derived);
        [
            &mut s.x,
            &mut s.y,
            &mut s.z,
            &mut s.yaw,
            &mut s.vx,
            &mut s.vy,
            &mut s.speed,
            &mut s.yaw_rate,
            &mut c.throttle,
            &mut c.brake,
            &mut c.steering,
            &mut c.acceleration,
            &mut c.steering_angle,
            &mut d.curvature,
            &mut d.lateral_acceleration,
            &mut d.longitudinal_acceleration,
            &mut d.slip_angle,
            &mut d.force_longitudinal_n,
            &mut d.force_lateral_n,
            &mut d.friction_use,
        ]
    }
    /// The track's samples `i..j` (clamped; metadata kept).
    pub fn samples_between(&self, i: usize, j: usize) -> ActorTrack {
        let j = j.min(self.tick.len());
        let i = i.min(j);
        // Columns of the wrong length (a hand-made log) are cut where they
        // can be: a writer reports them as it would for the whole log.
        let mut out = ActorTrack {
            id: self.id.clone(),
            kind: self.kind.clone(),
            model: self.model.clone(),
            length: self.length,
            width: self.width,
            mass: self.mass,
            tick: self.tick[i..j].to_vec(),
            mode: self.mode[i.min(self.mode.len())..j.min(self.mode.len())].to_vec(),
            ..ActorTrack::default()
        };
        for ((_, from), to) in self.columns().into_iter().zip(out.columns_mut()) {
            *to = from[i.min(from.len())..j.min(from.len())].to_vec();
        }
        out
    }
    /// Column lengths that disagree with `tick` (name, length).
    pub fn bad_columns(&self) -> Vec<(&'static str, usize)> {
        let n = self.tick.len();
        std::iter::once(("mode", self.mode.len()))
            .chain(self.columns().into_iter().map(|(name, v)| (name, v.len())))
            .filter(|(_, l)| *l != n)
            .collect()
    }
}

/// A whole run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimulationLog {
    /// Format version (1).
    pub format_version: u32,
    /// Step (s).
    pub dt: f64,
    /// Free metadata (profile, model, seed, scenario…), sorted.
    pub meta: BTreeMap<String, String>,
    /// Recorded ticks.
    pub tick: Vec<u64>,
    /// Times of the recorded ticks (s).
    #[serde(deserialize_with = "nan_vec")]
    pub time: Vec<f64>,
    /// Actor tracks, in first-appearance order.
    pub tracks: Vec<ActorTrack>,
    /// The plan, for runs that planned (samples, tree, corridors, grid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan: Option<PlanRecord>,
    /// Tracking metrics and MPC predictions, for runs that tracked a corridor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking: Option<TrackingColumns>,
    /// The environment's changes (weather, sun, time of day), in tick
    /// order: what the scenario asked and what the simulator applied.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub environment: Vec<EnvironmentChange>,
}

/// One change of the environment during a run (`environment.rain(…)`,
/// `environment.fog(…)`, …).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnvironmentChange {
    /// The tick from which it holds.
    pub tick: u64,
    /// Its time (s).
    pub time: f64,
    /// The action (`rain`, `fog`, `assign_celestial_position`, …).
    pub action: String,
    /// Its arguments in SI units (m/s, m, rad, K, Pa; okta and fractions
    /// as they are), by parameter name.
    pub values: BTreeMap<String, f64>,
    /// The simulator's whole weather or time of day after the change, as
    /// the simulator answered it (by field); empty when it has none.
    pub applied: BTreeMap<String, f64>,
    /// What the simulator could not take (a profile without weather, a
    /// value it has no field for), if anything.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// The occupancy grid a plan was made on: 0 free, 1 inflated margin, 2 hard obstacle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GridRecord {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Cell size (m).
    pub resolution: f64,
    /// Lower-left corner (m).
    pub origin: [f64; 2],
    /// Layer per cell, row-major from the bottom row.
    pub cells: Vec<u8>,
}

/// What the planner produced.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlanRecord {
    /// Start, goal, then the samples (m).
    pub samples: Vec<[f64; 2]>,
    /// Tree edges (parent, child) in acceptance order.
    pub edges: Vec<[usize; 2]>,
    /// Connection radius (m).
    pub radius: f64,
    /// The planner's path (m).
    pub raw_path: Vec<[f64; 2]>,
    /// The smoothed, resampled corridor (m).
    pub corridor: Vec<[f64; 2]>,
    /// Speed profile along the corridor (m/s).
    pub corridor_speed: Vec<f64>,
    /// Free distance left of the corridor (m).
    pub left_bound: Vec<f64>,
    /// Free distance right of the corridor (m).
    pub right_bound: Vec<f64>,
    /// Whether smoothing was kept (false: raw polyline used).
    pub smoothed: bool,
    /// The grid.
    pub grid: GridRecord,
    /// What `corridor` is, for labels: empty = the planner's corridor; a
    /// scenario run stores the ego's planned path as "planned path".
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub reference_name: String,
}

impl PlanRecord {
    /// The label of `corridor` in pictures: "corridor" unless named.
    pub fn reference_label(&self) -> &str {
        named_or(&self.reference_name, "corridor")
    }
}

/// `name`, or `default` when it is empty (labels older logs lack).
fn named_or<'a>(name: &'a str, default: &'a str) -> &'a str {
    if name.is_empty() { default } else { name }
}

/// Per control cycle: errors against the corridor, progress, command, prediction.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackingColumns {
    /// Tick of the cycle.
    pub tick: Vec<u64>,
    /// Lateral (cross-track) error (m, left positive).
    pub lateral_error: Vec<f64>,
    /// Heading error (rad).
    pub heading_error: Vec<f64>,
    /// Progress along the corridor (m).
    pub progress: Vec<f64>,
    /// Commanded acceleration (m/s²).
    pub cmd_acceleration: Vec<f64>,
    /// Commanded steering angle (rad).
    pub cmd_steering: Vec<f64>,
    /// MPC predicted states (x, y, ψ, v) per cycle.
    pub predictions: Vec<Vec<[f64; 4]>>,
    /// The legend of the command series: empty = "MPC command"; a scenario
    /// run says "planned" (the plan's acceleration and the steering angle
    /// its curvature implies).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub command_source: String,
    /// Cycles whose QP had no answer (tick, reason): the command there is
    /// the best admissible one, not an optimum.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fallback: Vec<(u64, String)>,
}

impl TrackingColumns {
    /// The legend of the command series in pictures.
    pub fn command_label(&self) -> &str {
        named_or(&self.command_source, "MPC command")
    }
}

impl SimulationLog {
    /// A track by actor id.
    pub fn track(&self, id: &str) -> Option<&ActorTrack> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// The ticks from index `from` on: [`SimulationLog::ticks_between`]
    /// to the end.
    pub fn ticks_from(&self, from: usize) -> SimulationLog {
        self.ticks_between(from, self.tick.len())
    }

    /// The ticks with index in `from..to` (clamped to the log), every track
    /// cut to its samples at those ticks; metadata and step kept, the plan
    /// and tracking left out. For streaming writers that take the log in
    /// pieces while it is still recorded.
    pub fn ticks_between(&self, from: usize, to: usize) -> SimulationLog {
        let to = to.min(self.tick.len());
        let from = from.min(to);
        let first = self.tick.get(from).copied().unwrap_or(u64::MAX);
        let end = self.tick.get(to).copied().unwrap_or(u64::MAX);
        let times = from.min(self.time.len())..to.min(self.time.len());
        let env_end = match self.tick.get(to) {
            Some(&k) => k,
            None => self.tick.last().map_or(0, |&k| k + 1),
        };
        SimulationLog {
            format_version: self.format_version,
            dt: self.dt,
            meta: self.meta.clone(),
            tick: self.tick[from..to].to_vec(),
            time: self.time[times].to_vec(),
            tracks: self
                .tracks
                .iter()
                .map(|t| {
                    t.samples_between(
                        t.tick.partition_point(|&k| k < first),
                        t.tick.partition_point(|&k| k < end),
                    )
                })
                .collect(),
            // A change belongs to the piece that holds its tick: one made
            // for a tick not recorded yet goes with the next piece, one
            // made before the first recorded tick with the first piece.
            environment: self
                .environment
                .iter()
                .filter(|e| (from == 0 || e.tick >= first) && e.tick < env_end)
                .cloned()
                .collect(),
            ..SimulationLog::default()
        }
    }

    /// For each of the log's ticks, the index of `track`'s sample at that
    /// tick, `None` where the track has none (a track's ticks increase).
    /// For readers that walk the log tick by tick over every actor.
    pub fn sample_indices(&self, track: &ActorTrack) -> Vec<Option<u32>> {
        let mut out = Vec::with_capacity(self.tick.len());
        let mut c = 0usize;
        for &tick in &self.tick {
            while c < track.tick.len() && track.tick[c] < tick {
                c += 1;
            }
            out.push((c < track.tick.len() && track.tick[c] == tick).then_some(c as u32));
        }
        out
    }
}

/// Control applied in a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlSample {
    /// Throttle (NaN when not pedal-driven).
    pub throttle: f64,
    /// Brake.
    pub brake: f64,
    /// Steering fraction.
    pub steering: f64,
    /// Commanded acceleration (NaN when pedal-driven).
    pub acceleration: f64,
    /// Road-wheel angle applied (rad).
    pub steering_angle: f64,
}

impl Default for ControlSample {
    fn default() -> Self {
        Self {
            throttle: f64::NAN,
            brake: f64::NAN,
            steering: f64::NAN,
            acceleration: f64::NAN,
            steering_angle: f64::NAN,
        }
    }
}

/// One actor at one tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ActorSample {
    /// Pose.
    pub pose: Pose,
    /// Velocity (world frame).
    pub velocity: Vec3,
    /// Longitudinal speed.
    pub speed: f64,
    /// Yaw rate.
    pub yaw_rate: f64,
    /// Control.
    pub control: ControlSample,
    /// Derived quantities.
    pub derived: Derived,
}

impl ActorSample {
    /// A sample from kinematics alone (e.g. states read over the SSP API):
    /// curvature = ω/v, a_y = v·ω, a_x = a·heading; force proxies from `mass`.
    pub fn from_kinematics(
        pose: Pose,
        velocity: Vec3,
        acceleration: Vec3,
        yaw_rate: f64,
        speed: f64,
        mass: f64,
    ) -> Self {
        let (s, c) = math::sin_cos(pose.yaw);
        let a_x = acceleration.x * c + acceleration.y * s;
        let a_y = speed * yaw_rate;
        let g = 9.806_65;
        Self {
            pose,
            velocity,
            speed,
            yaw_rate,
            control: ControlSample::default(),
            derived: Derived {
                curvature: if speed.abs() > 1e-6 {
                    yaw_rate / speed
                } else {
                    0.0
                },
                lateral_acceleration: a_y,
                longitudinal_acceleration: a_x,
                slip_angle: 0.0,
                force_longitudinal_n: mass * a_x,
                force_lateral_n: mass * a_y,
                friction_use: (a_x * a_x + a_y * a_y).sqrt() / g,
            },
        }
    }
}

/// Builds a [`SimulationLog`] step by step.
#[derive(Clone, Debug, Default)]
pub struct LogRecorder {
    log: SimulationLog,
    index: BTreeMap<String, usize>,
}

impl LogRecorder {
    /// A recorder for steps of `dt` seconds.
    pub fn new(dt: f64) -> Self {
        Self {
            log: SimulationLog {
                format_version: 1,
                dt,
                ..SimulationLog::default()
            },
            index: BTreeMap::new(),
        }
    }

    /// Adds a metadata entry.
    pub fn meta(&mut self, key: &str, value: impl ToString) {
        self.log.meta.insert(key.into(), value.to_string());
    }

    /// Opens a tick; follow with [`LogRecorder::sample`] per actor.
    pub fn begin(&mut self, tick: u64, time: f64) {
        self.log.tick.push(tick);
        self.log.time.push(time);
    }

    /// Declares an actor (first call wins) so that samples can be recorded.
    pub fn actor(&mut self, id: &str, kind: &str, model: &str, length: f64, width: f64, mass: f64) {
        if !self.index.contains_key(id) {
            self.index.insert(id.to_string(), self.log.tracks.len());
            self.log.tracks.push(ActorTrack {
                id: id.into(),
                kind: kind.into(),
                model: model.into(),
                length,
                width,
                mass,
                ..ActorTrack::default()
            });
        }
    }

    /// Records one actor at the current tick. Unknown actors are declared
    /// with empty metadata.
    pub fn sample(&mut self, id: &str, mode: &str, s: &ActorSample) {
        if !self.index.contains_key(id) {
            self.actor(id, "", "", 0.0, 0.0, 0.0);
        }
        let tick = self.log.tick.last().copied().unwrap_or(0);
        let t = &mut self.log.tracks[self.index[id]];
        t.tick.push(tick);
        t.mode.push(mode.into());
        let st = &mut t.state;
        st.x.push(s.pose.position.x);
        st.y.push(s.pose.position.y);
        st.z.push(s.pose.position.z);
        st.yaw.push(s.pose.yaw);
        st.vx.push(s.velocity.x);
        st.vy.push(s.velocity.y);
        st.speed.push(s.speed);
        st.yaw_rate.push(s.yaw_rate);
        let c = &mut t.control;
        c.throttle.push(s.control.throttle);
        c.brake.push(s.control.brake);
        c.steering.push(s.control.steering);
        c.acceleration.push(s.control.acceleration);
        c.steering_angle.push(s.control.steering_angle);
        let d = &mut t.derived;
        d.curvature.push(s.derived.curvature);
        d.lateral_acceleration.push(s.derived.lateral_acceleration);
        d.longitudinal_acceleration
            .push(s.derived.longitudinal_acceleration);
        d.slip_angle.push(s.derived.slip_angle);
        d.force_longitudinal_n.push(s.derived.force_longitudinal_n);
        d.force_lateral_n.push(s.derived.force_lateral_n);
        d.friction_use.push(s.derived.friction_use);
    }

    /// Records every actor of a world at its current tick.
    pub fn record_world(&mut self, world: &World) {
        self.begin(world.tick(), world.time());
        for a in world.actors() {
            let desc = a.description();
            let kind = match desc.kind {
                litesim_core::ActorKind::Vehicle(c) => {
                    format!("vehicle/{}", format!("{c:?}").to_lowercase())
                }
                k => format!("{k:?}").to_lowercase(),
            };
            self.actor(
                a.id(),
                &kind,
                &desc.model,
                desc.length,
                desc.width,
                desc.mass,
            );
            let vs = a.vehicle_state();
            let control = match (a.mode().name(), a.last_input()) {
                ("dynamic", VehicleInput::Pedals(p)) => ControlSample {
                    throttle: p.throttle,
                    brake: p.brake,
                    steering: p.steering,
                    acceleration: f64::NAN,
                    steering_angle: vs.steering_angle,
                },
                ("direct" | "external", VehicleInput::Direct { acceleration, .. }) => {
                    ControlSample {
                        acceleration,
                        steering_angle: vs.steering_angle,
                        ..ControlSample::default()
                    }
                }
                _ => ControlSample::default(),
            };
            let st = a.state();
            let s = ActorSample {
                pose: st.pose,
                velocity: st.velocity,
                speed: st.speed,
                yaw_rate: st.yaw_rate,
                control,
                derived: a.derived(),
            };
            self.sample(a.id(), a.mode().name(), &s);
        }
    }

    /// Records a change of the environment (kept in tick order: a change
    /// comes at the step it is made, before that step's tick is opened).
    pub fn environment(&mut self, change: EnvironmentChange) {
        self.log.environment.push(change);
    }

    /// The log so far.
    pub fn log(&self) -> &SimulationLog {
        &self.log
    }

    /// Finishes recording.
    pub fn finish(self) -> SimulationLog {
        self.log
    }
}
