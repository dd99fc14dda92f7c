//! Conversions between the wire types ([`crate::pb`]) and `litesim-ssp`'s API types.
//!
//! Wire → API conversions validate enums (an unknown value is
//! `INVALID_ARGUMENT` naming the field); API → wire conversions cannot fail.

use crate::pb;
use litesim_ssp as api;
use litesim_ssp::{SspError, SspResult};

fn enum_err(field: &str, v: i32) -> SspError {
    SspError::invalid(format!("{field} = {v} is not a known enum value"))
}

/// Wire coordinates → API coordinates.
pub fn coord(c: Option<pb::Coord6Dof>) -> api::Coord6 {
    let c = c.unwrap_or_default();
    api::Coord6 {
        x: c.x,
        y: c.y,
        z: c.z,
        roll: c.roll,
        pitch: c.pitch,
        yaw: c.yaw,
    }
}

/// API coordinates → wire coordinates.
pub fn coord_pb(c: &api::Coord6) -> pb::Coord6Dof {
    pb::Coord6Dof {
        x: c.x,
        y: c.y,
        z: c.z,
        roll: c.roll,
        pitch: c.pitch,
        yaw: c.yaw,
    }
}

/// Wire category → API category.
pub fn category(v: i32, field: &str) -> SspResult<api::ActorCategory> {
    use api::ActorCategory as C;
    Ok(
        match pb::ActorCategory::try_from(v).map_err(|_| enum_err(field, v))? {
            pb::ActorCategory::Unspecified => C::Unspecified,
            pb::ActorCategory::Vehicle => C::Vehicle,
            pb::ActorCategory::Pedestrian => C::Pedestrian,
            pb::ActorCategory::Cyclist => C::Cyclist,
            pb::ActorCategory::Motorcycle => C::Motorcycle,
            pb::ActorCategory::StaticObject => C::StaticObject,
            pb::ActorCategory::Animal => C::Animal,
        },
    )
}

/// API category → wire category.
pub fn category_pb(c: api::ActorCategory) -> i32 {
    use api::ActorCategory as C;
    (match c {
        C::Unspecified => pb::ActorCategory::Unspecified,
        C::Vehicle => pb::ActorCategory::Vehicle,
        C::Pedestrian => pb::ActorCategory::Pedestrian,
        C::Cyclist => pb::ActorCategory::Cyclist,
        C::Motorcycle => pb::ActorCategory::Motorcycle,
        C::StaticObject => pb::ActorCategory::StaticObject,
        C::Animal => pb::ActorCategory::Animal,
    }) as i32
}

/// Wire move mode → API move mode.
pub fn move_mode(v: i32, field: &str) -> SspResult<api::MoveMode> {
    Ok(
        match pb::MoveMode::try_from(v).map_err(|_| enum_err(field, v))? {
            pb::MoveMode::Unspecified => api::MoveMode::Unspecified,
            pb::MoveMode::Kinematic => api::MoveMode::Kinematic,
            pb::MoveMode::Dynamic => api::MoveMode::Dynamic,
            pb::MoveMode::External => api::MoveMode::External,
        },
    )
}

/// API move mode → wire move mode.
pub fn move_mode_pb(m: api::MoveMode) -> i32 {
    (match m {
        api::MoveMode::Unspecified => pb::MoveMode::Unspecified,
        api::MoveMode::Kinematic => pb::MoveMode::Kinematic,
        api::MoveMode::Dynamic => pb::MoveMode::Dynamic,
        api::MoveMode::External => pb::MoveMode::External,
    }) as i32
}

fn indicator(v: i32) -> SspResult<api::IndicatorState> {
    use api::IndicatorState as I;
    Ok(
        match pb::IndicatorState::try_from(v).map_err(|_| enum_err("controls.indicators", v))? {
            pb::IndicatorState::Unspecified => I::Unspecified,
            pb::IndicatorState::Off => I::Off,
            pb::IndicatorState::Left => I::Left,
            pb::IndicatorState::Right => I::Right,
            pb::IndicatorState::Hazard => I::Hazard,
        },
    )
}

fn indicator_pb(i: api::IndicatorState) -> i32 {
    use api::IndicatorState as I;
    (match i {
        I::Unspecified => pb::IndicatorState::Unspecified,
        I::Off => pb::IndicatorState::Off,
        I::Left => pb::IndicatorState::Left,
        I::Right => pb::IndicatorState::Right,
        I::Hazard => pb::IndicatorState::Hazard,
    }) as i32
}

/// Wire controls → API controls.
pub fn controls(c: pb::ActorControls) -> SspResult<api::ActorControls> {
    Ok(api::ActorControls {
        gear: c.gear,
        hand_brake: c.hand_brake,
        hazard_lights: c.hazard_lights,
        indicators: indicator(c.indicators)?,
        brake_pedal_pos: c.brake_pedal_pos,
        throttle_pedal_pos: c.throttle_pedal_pos,
        steering_wheel_angle: c.steering_wheel_angle_rad,
        siren: c.siren,
        emergency_lights: c.emergency_lights,
    })
}

/// API controls → wire controls.
pub fn controls_pb(c: &api::ActorControls) -> pb::ActorControls {
    pb::ActorControls {
        gear: c.gear.clone(),
        hand_brake: c.hand_brake,
        hazard_lights: c.hazard_lights,
        indicators: indicator_pb(c.indicators),
        brake_pedal_pos: c.brake_pedal_pos,
        throttle_pedal_pos: c.throttle_pedal_pos,
        steering_wheel_angle_rad: c.steering_wheel_angle,
        siren: c.siren,
        emergency_lights: c.emergency_lights,
    }
}

/// API state → wire state (position fully set; speed.yaw = yaw rate).
pub fn state_pb(s: &api::ReportedState) -> pb::ActorState {
    use litesim_core::TrajectoryStatus as T;
    let p = &s.pose;
    pb::ActorState {
        actor_id: s.actor_id.to_string(),
        position: Some(pb::Coord6Dof {
            x: Some(p.position.x),
            y: Some(p.position.y),
            z: Some(p.position.z),
            roll: Some(p.roll),
            pitch: Some(p.pitch),
            yaw: Some(p.yaw),
        }),
        speed: Some(pb::Coord6Dof {
            x: Some(s.velocity.x),
            y: Some(s.velocity.y),
            z: Some(s.velocity.z),
            yaw: Some(s.yaw_rate),
            ..Default::default()
        }),
        acceleration: Some(pb::Coord6Dof {
            x: Some(s.acceleration.x),
            y: Some(s.acceleration.y),
            z: Some(s.acceleration.z),
            ..Default::default()
        }),
        controls: Some(controls_pb(&s.controls)),
        active_mode: move_mode_pb(s.mode),
        speed_mps: s.speed,
        trajectory: (match s.trajectory {
            T::None => pb::TrajectoryStatus::None,
            T::Following => pb::TrajectoryStatus::Following,
            T::NotStarted => pb::TrajectoryStatus::NotStarted,
            T::Exhausted => pb::TrajectoryStatus::Exhausted,
        }) as i32,
    }
}

/// Wire state → API state (for the client).
pub fn state(s: pb::ActorState) -> SspResult<api::ReportedState> {
    use litesim_core::{Pose, TrajectoryStatus as T, Vec3};
    let p = coord(s.position);
    let v = coord(s.speed);
    let a = coord(s.acceleration);
    let z = |o: Option<f64>| o.unwrap_or(0.0);
    Ok(api::ReportedState {
        actor_id: s.actor_id.into(),
        pose: Pose {
            position: Vec3::new(z(p.x), z(p.y), z(p.z)),
            roll: z(p.roll),
            pitch: z(p.pitch),
            yaw: z(p.yaw),
        },
        velocity: Vec3::new(z(v.x), z(v.y), z(v.z)),
        acceleration: Vec3::new(z(a.x), z(a.y), z(a.z)),
        yaw_rate: z(v.yaw),
        speed: s.speed_mps,
        controls: controls(s.controls.unwrap_or_default())?,
        mode: move_mode(s.active_mode, "active_mode")?,
        trajectory: match pb::TrajectoryStatus::try_from(s.trajectory)
            .map_err(|_| enum_err("trajectory", s.trajectory))?
        {
            pb::TrajectoryStatus::None => T::None,
            pb::TrajectoryStatus::Following => T::Following,
            pb::TrajectoryStatus::NotStarted => T::NotStarted,
            pb::TrajectoryStatus::Exhausted => T::Exhausted,
        },
    })
}

/// Wire filter → API filter.
pub fn filter(f: Option<pb::ActorFilter>) -> SspResult<api::ActorFilter> {
    let f = f.unwrap_or_default();
    Ok(api::ActorFilter {
        actor_ids: f.actor_ids,
        categories: f
            .categories
            .iter()
            .map(|&c| category(c, "filter.categories"))
            .collect::<SspResult<_>>()?,
    })
}

/// API filter → wire filter.
pub fn filter_pb(f: &api::ActorFilter) -> pb::ActorFilter {
    pb::ActorFilter {
        actor_ids: f.actor_ids.clone(),
        categories: f.categories.iter().map(|&c| category_pb(c)).collect(),
    }
}

/// Wire catalog entry → API.
pub fn catalog(e: pb::CatalogEntry) -> api::CatalogEntry {
    api::CatalogEntry {
        model_id: e.model_id,
        category: e.category,
        length: e.length_m,
        width: e.width_m,
        height: e.height_m,
        wheelbase: e.wheelbase_m,
        mass: e.mass_kg,
        max_steer_angle_deg: e.max_steer_angle_deg,
        steering_ratio: e.steering_ratio,
        max_speed: e.max_speed_mps,
        max_accel: e.max_accel_mps2,
        max_decel: e.max_decel_mps2,
    }
}

/// API catalog entry → wire.
pub fn catalog_pb(e: &api::CatalogEntry) -> pb::CatalogEntry {
    pb::CatalogEntry {
        model_id: e.model_id.clone(),
        category: e.category.clone(),
        length_m: e.length,
        width_m: e.width,
        height_m: e.height,
        wheelbase_m: e.wheelbase,
        mass_kg: e.mass,
        max_steer_angle_deg: e.max_steer_angle_deg,
        steering_ratio: e.steering_ratio,
        max_speed_mps: e.max_speed,
        max_accel_mps2: e.max_accel,
        max_decel_mps2: e.max_decel,
    }
}

/// API capabilities → wire.
pub fn capabilities_pb(c: &api::Capabilities) -> pb::Capabilities {
    pb::Capabilities {
        profile: c.profile.clone(),
        move_modes: c.move_modes.iter().map(|&m| move_mode_pb(m)).collect(),
        pedal_encoding: (match c.pedal_encoding {
            api::PedalEncoding::Normalized => pb::PedalEncoding::Normalized,
            api::PedalEncoding::Physical => pb::PedalEncoding::Physical,
        }) as i32,
        min_step_ms: c.min_step_ms,
        max_step_ms: c.max_step_ms,
        traffic_lights: c.traffic_lights,
        weather: c.weather,
        time_of_day: c.time_of_day,
        catalog: c.catalog.iter().map(catalog_pb).collect(),
        sim_commands: c.sim_commands.clone(),
        model: c.model.clone(),
        step_size_ms: c.step_size_ms,
    }
}

/// Wire capabilities → API.
pub fn capabilities(c: pb::Capabilities) -> SspResult<api::Capabilities> {
    Ok(api::Capabilities {
        profile: c.profile,
        model: c.model,
        step_size_ms: c.step_size_ms,
        move_modes: c
            .move_modes
            .iter()
            .map(|&m| move_mode(m, "move_modes"))
            .collect::<SspResult<_>>()?,
        pedal_encoding: match pb::PedalEncoding::try_from(c.pedal_encoding) {
            Ok(pb::PedalEncoding::Physical) => api::PedalEncoding::Physical,
            _ => api::PedalEncoding::Normalized,
        },
        min_step_ms: c.min_step_ms,
        max_step_ms: c.max_step_ms,
        traffic_lights: c.traffic_lights,
        weather: c.weather,
        time_of_day: c.time_of_day,
        catalog: c.catalog.into_iter().map(catalog).collect(),
        sim_commands: c.sim_commands,
    })
}

/// Wire description → API spec.
pub fn spec(d: Option<pb::ActorDescription>) -> SspResult<api::ActorSpec> {
    let d = d.unwrap_or_default();
    Ok(api::ActorSpec {
        actor_type: d.actor_type,
        category: category(d.category, "description.category")?,
        model_id: d.model_id,
        length: d.length_m,
        width: d.width_m,
        height: d.height_m,
        properties: d.properties,
    })
}

/// API spec → wire description.
pub fn spec_pb(s: &api::ActorSpec) -> pb::ActorDescription {
    pb::ActorDescription {
        actor_type: s.actor_type.clone(),
        category: category_pb(s.category),
        model_id: s.model_id.clone(),
        length_m: s.length,
        width_m: s.width,
        height_m: s.height,
        properties: s.properties.clone(),
    }
}

/// API actual description → wire.
pub fn actual_pb(a: &api::ActualDescription) -> pb::ActorDescription {
    pb::ActorDescription {
        actor_type: a.actor_type.clone(),
        category: category_pb(a.category),
        model_id: a.model_id.clone(),
        length_m: Some(a.length),
        width_m: Some(a.width),
        height_m: Some(a.height),
        properties: a.properties.clone(),
    }
}

/// Wire description → API actual description.
pub fn actual(d: pb::ActorDescription) -> SspResult<api::ActualDescription> {
    Ok(api::ActualDescription {
        actor_type: d.actor_type,
        category: category(d.category, "category")?,
        model_id: d.model_id,
        length: d.length_m.unwrap_or(0.0),
        width: d.width_m.unwrap_or(0.0),
        height: d.height_m.unwrap_or(0.0),
        properties: d.properties,
    })
}

/// Wire trajectory → API trajectory.
pub fn xy(r: &pb::SetXyTrajectoryRequest) -> api::XyTrajectory {
    api::XyTrajectory {
        start_time_ms: r.start_time_ms,
        end_time_ms: r.end_time_ms,
        points: r.polyline.iter().map(|c| coord(Some(*c))).collect(),
        point_times_ms: r.point_times_ms.clone(),
        speeds: r.speeds_mps.clone(),
    }
}

/// API trajectory → wire request.
pub fn xy_pb(
    session_id: &str,
    actor_id: &str,
    t: &api::XyTrajectory,
) -> pb::SetXyTrajectoryRequest {
    pb::SetXyTrajectoryRequest {
        session_id: session_id.into(),
        actor_id: actor_id.into(),
        start_time_ms: t.start_time_ms,
        end_time_ms: t.end_time_ms,
        polyline: t.points.iter().map(coord_pb).collect(),
        point_times_ms: t.point_times_ms.clone(),
        speeds_mps: t.speeds.clone(),
    }
}

/// Wire dynamic command → API.
pub fn dynamic(r: &pb::SetDynamicMoveRequest) -> SspResult<api::DynamicMove> {
    use pb::physical_controls::Steer;
    use pb::set_dynamic_move_request::Command;
    match &r.command {
        None => Err(SspError::invalid(
            "command is missing: give normalized, physical or direct",
        )),
        Some(Command::Normalized(n)) => Ok(api::DynamicMove::Normalized {
            throttle: n.throttle,
            brake: n.brake,
            steering: n.steering,
        }),
        Some(Command::Physical(p)) => Ok(api::DynamicMove::Physical {
            drive_force_n: p.drive_force_n,
            brake_force_n: p.brake_force_n,
            steer: match p.steer {
                Some(Steer::SteeringTorqueNm(v)) => api::PhysicalSteer::TorqueNm(v),
                Some(Steer::SteeringWheelAngleRad(v)) => {
                    api::PhysicalSteer::SteeringWheelAngleRad(v)
                }
                None => {
                    return Err(SspError::invalid(
                        "physical.steer is missing: give steering_torque_nm or steering_wheel_angle_rad",
                    ));
                }
            },
        }),
        Some(Command::Direct(d)) => Ok(api::DynamicMove::Direct {
            acceleration: d.acceleration_mps2,
            steering_angle_rad: d.steering_angle_rad,
        }),
    }
}

/// API dynamic command → wire request.
pub fn dynamic_pb(
    session_id: &str,
    actor_id: &str,
    cmd: &api::DynamicMove,
    valid_until_ms: u64,
) -> pb::SetDynamicMoveRequest {
    use pb::physical_controls::Steer;
    use pb::set_dynamic_move_request::Command;
    let command = match *cmd {
        api::DynamicMove::Normalized {
            throttle,
            brake,
            steering,
        } => Command::Normalized(pb::NormalizedControls {
            throttle,
            brake,
            steering,
            ..Default::default()
        }),
        api::DynamicMove::Physical {
            drive_force_n,
            brake_force_n,
            steer,
        } => Command::Physical(pb::PhysicalControls {
            drive_force_n,
            brake_force_n,
            steer: Some(match steer {
                api::PhysicalSteer::TorqueNm(v) => Steer::SteeringTorqueNm(v),
                api::PhysicalSteer::SteeringWheelAngleRad(v) => Steer::SteeringWheelAngleRad(v),
            }),
        }),
        api::DynamicMove::Direct {
            acceleration,
            steering_angle_rad,
        } => Command::Direct(pb::DirectControls {
            acceleration_mps2: acceleration,
            steering_angle_rad,
        }),
    };
    pb::SetDynamicMoveRequest {
        session_id: session_id.into(),
        actor_id: actor_id.into(),
        command: Some(command),
        valid_until_ms,
    }
}

/// Wire external controller → API.
pub fn external(r: &pb::SetExternalControllerRequest) -> api::ExternalMove {
    api::ExternalMove {
        controller: r.controller.clone(),
        params: r.params.clone(),
        desired_speed: r.desired_speed,
    }
}

/// Wire weather → API.
pub fn weather(w: Option<pb::Weather>) -> api::Weather {
    let w = w.unwrap_or_default();
    api::Weather {
        preset: w.preset,
        cloudiness: w.cloudiness,
        precipitation: w.precipitation,
        wetness: w.wetness,
        fog_density: w.fog_density,
        fog_distance_m: w.fog_distance_m,
        wind_intensity: w.wind_intensity,
        sun_azimuth_deg: w.sun_azimuth_deg,
        sun_altitude_deg: w.sun_altitude_deg,
    }
}

/// API weather → wire.
pub fn weather_pb(w: &api::Weather) -> pb::Weather {
    pb::Weather {
        preset: w.preset.clone(),
        cloudiness: w.cloudiness,
        precipitation: w.precipitation,
        wetness: w.wetness,
        fog_density: w.fog_density,
        fog_distance_m: w.fog_distance_m,
        wind_intensity: w.wind_intensity,
        sun_azimuth_deg: w.sun_azimuth_deg,
        sun_altitude_deg: w.sun_altitude_deg,
    }
}

macro_rules! enum_map {
    ($from:ident, $to:ident, $pbty:ty, $apity:ty, $field:literal, [$($v:ident),*]) => {
        /// Wire → API.
        pub fn $from(v: i32) -> SspResult<$apity> {
            let p = <$pbty>::try_from(v).map_err(|_| enum_err($field, v))?;
            Ok(match p { $(<$pbty>::$v => <$apity>::$v,)* })
        }
        /// API → wire.
        pub fn $to(v: $apity) -> i32 {
            (match v { $(<$apity>::$v => <$pbty>::$v,)* }) as i32
        }
    };
}

enum_map!(
    bulb_icon,
    bulb_icon_pb,
    pb::BulbIcon,
    api::BulbIcon,
    "icon",
    [
        Unspecified,
        None,
        ArrowStraight,
        ArrowLeft,
        ArrowSlightLeft,
        ArrowRight,
        ArrowSlightRight,
        ArrowUturn,
        Pedestrian,
        Walk,
        DontWalk,
        Bicycle,
        Countdown,
        Tram,
        Bus
    ]
);
enum_map!(
    bulb_color,
    bulb_color_pb,
    pb::BulbColor,
    api::BulbColor,
    "color",
    [Unspecified, Red, Yellow, Green, Blue, White]
);
enum_map!(
    bulb_mode,
    bulb_mode_pb,
    pb::BulbMode,
    api::BulbMode,
    "mode",
    [Unspecified, Off, On, Flashing, Counting]
);

/// Wire box → API.
pub fn light_box(b: pb::TrafficLightBox) -> SspResult<api::TrafficLightBox> {
    Ok(api::TrafficLightBox {
        id: b.id,
        road_id: b.road_id,
        s: b.s,
        t: b.t,
        pose: coord(b.pose),
        bulbs: b
            .bulbs
            .into_iter()
            .map(|x| {
                Ok(api::Bulb {
                    map_id: x.map_id,
                    icon: bulb_icon(x.icon)?,
                    color: bulb_color(x.color)?,
                    mode: bulb_mode(x.mode)?,
                    counter: x.counter,
                })
            })
            .collect::<SspResult<_>>()?,
        valid_lanes: b.valid_lanes,
    })
}

/// API box → wire.
pub fn light_box_pb(b: &api::TrafficLightBox) -> pb::TrafficLightBox {
    pb::TrafficLightBox {
        id: b.id.clone(),
        road_id: b.road_id.clone(),
        s: b.s,
        t: b.t,
        pose: Some(coord_pb(&b.pose)),
        bulbs: b
            .bulbs
            .iter()
            .map(|x| pb::Bulb {
                map_id: x.map_id.clone(),
                icon: bulb_icon_pb(x.icon),
                color: bulb_color_pb(x.color),
                mode: bulb_mode_pb(x.mode),
                counter: x.counter,
            })
            .collect(),
        valid_lanes: b.valid_lanes.clone(),
    }
}

/// Wire logical light → API.
pub fn logical(l: pb::LogicalTrafficLight) -> api::LogicalTrafficLight {
    api::LogicalTrafficLight {
        id: l.id,
        box_ids: l.box_ids,
        controller_id: l.controller_id,
    }
}

/// API logical light → wire.
pub fn logical_pb(l: &api::LogicalTrafficLight) -> pb::LogicalTrafficLight {
    pb::LogicalTrafficLight {
        id: l.id.clone(),
        box_ids: l.box_ids.clone(),
        controller_id: l.controller_id.clone(),
    }
}

/// Wire light-state request → API target and states.
pub fn light_request(
    r: &pb::SetTrafficLightStateRequest,
) -> SspResult<(api::LightTarget, Vec<api::BulbState>)> {
    use pb::set_traffic_light_state_request::Target;
    let target = match &r.target {
        Some(Target::LogicalId(id)) => api::LightTarget::Logical(id.clone()),
        Some(Target::BoxId(id)) => api::LightTarget::Box(id.clone()),
        None => {
            return Err(SspError::invalid(
                "target is missing: give logical_id or box_id",
            ));
        }
    };
    let states = r
        .states
        .iter()
        .map(|s| {
            Ok(api::BulbState {
                icon: bulb_icon(s.icon)?,
                color: bulb_color(s.color)?,
                mode: bulb_mode(s.mode)?,
            })
        })
        .collect::<SspResult<_>>()?;
    Ok((target, states))
}

/// API light-state request → wire.
pub fn light_request_pb(
    session_id: &str,
    target: &api::LightTarget,
    states: &[api::BulbState],
) -> pb::SetTrafficLightStateRequest {
    use pb::set_traffic_light_state_request::Target;
    pb::SetTrafficLightStateRequest {
        session_id: session_id.into(),
        target: Some(match target {
            api::LightTarget::Logical(id) => Target::LogicalId(id.clone()),
            api::LightTarget::Box(id) => Target::BoxId(id.clone()),
        }),
        states: states
            .iter()
            .map(|s| pb::BulbState {
                icon: bulb_icon_pb(s.icon),
                color: bulb_color_pb(s.color),
                mode: bulb_mode_pb(s.mode),
            })
            .collect(),
    }
}

/// SSP error → gRPC status.
pub fn status(e: SspError) -> tonic::Status {
    use litesim_ssp::ErrorCode as E;
    let code = match e.code {
        E::InvalidArgument => tonic::Code::InvalidArgument,
        E::NotFound => tonic::Code::NotFound,
        E::AlreadyExists => tonic::Code::AlreadyExists,
        E::FailedPrecondition => tonic::Code::FailedPrecondition,
        E::DeadlineExceeded => tonic::Code::DeadlineExceeded,
        E::Unimplemented => tonic::Code::Unimplemented,
        E::ResourceExhausted => tonic::Code::ResourceExhausted,
        E::Aborted => tonic::Code::Aborted,
        E::Unavailable => tonic::Code::Unavailable,
        E::Internal => tonic::Code::Internal,
        E::PermissionDenied => tonic::Code::PermissionDenied,
        E::Unauthenticated => tonic::Code::Unauthenticated,
    };
    tonic::Status::new(code, e.message)
}

/// gRPC status → SSP error (the client side of [`status`]).
pub fn error(s: tonic::Status) -> SspError {
    use litesim_ssp::ErrorCode as E;
    let code = match s.code() {
        tonic::Code::InvalidArgument | tonic::Code::OutOfRange => E::InvalidArgument,
        tonic::Code::NotFound => E::NotFound,
        tonic::Code::AlreadyExists => E::AlreadyExists,
        tonic::Code::FailedPrecondition => E::FailedPrecondition,
        tonic::Code::DeadlineExceeded => E::DeadlineExceeded,
        tonic::Code::Unimplemented => E::Unimplemented,
        tonic::Code::ResourceExhausted => E::ResourceExhausted,
        tonic::Code::Aborted | tonic::Code::Cancelled => E::Aborted,
        tonic::Code::Unavailable => E::Unavailable,
        tonic::Code::PermissionDenied => E::PermissionDenied,
        tonic::Code::Unauthenticated => E::Unauthenticated,
        _ => E::Internal,
    };
    SspError::new(code, s.message().to_string())
}
