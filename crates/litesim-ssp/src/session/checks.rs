//! What a call's arguments must be: finite, positive sizes, coordinates
//! within bounds, known kinds; and the conversions between the API's and
//! the world's descriptions of an actor.

use super::*;

pub(super) fn kind_of(category: &str) -> Option<ActorKind> {
    Some(match category {
        "car" => ActorKind::Vehicle(VehicleCategory::Car),
        "van" => ActorKind::Vehicle(VehicleCategory::Van),
        "bus" => ActorKind::Vehicle(VehicleCategory::Bus),
        "truck" => ActorKind::Vehicle(VehicleCategory::Truck),
        "semitrailer" => ActorKind::Vehicle(VehicleCategory::Semitrailer),
        "motorbike" => ActorKind::Vehicle(VehicleCategory::Motorbike),
        "emergency" => ActorKind::Vehicle(VehicleCategory::Emergency),
        "bicycle" => ActorKind::Cyclist,
        "pedestrian" => ActorKind::Person,
        "animal" => ActorKind::Animal,
        "static" => ActorKind::StationaryObject,
        _ => return None,
    })
}

pub(super) fn wire_category(kind: ActorKind) -> ActorCategory {
    match kind {
        ActorKind::Vehicle(VehicleCategory::Motorbike) => ActorCategory::Motorcycle,
        ActorKind::Vehicle(_) => ActorCategory::Vehicle,
        ActorKind::Person => ActorCategory::Pedestrian,
        ActorKind::Cyclist => ActorCategory::Cyclist,
        ActorKind::Animal => ActorCategory::Animal,
        ActorKind::StationaryObject => ActorCategory::StaticObject,
    }
}

pub(super) fn opt_finite(field: &str, v: Option<f64>) -> SspResult<Option<f64>> {
    v.map(|x| finite(field, x)).transpose()
}

pub(super) fn positive_dim(field: &str, v: Option<f64>) -> SspResult<Option<f64>> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(SspError::invalid(format!(
            "{field} must be a positive number of metres, got {x}"
        ))),
        other => Ok(other),
    }
}

/// Largest coordinate magnitude accepted (m, m/s, m/s², rad): 10⁹ is far
/// beyond any map (the Earth's circumference is 4·10⁷ m) yet keeps every
/// interpolation and integration finite.
pub(super) const MAX_COORD: f64 = 1e9;

/// Checks the six coordinates; `field` names the place in messages and is
/// only built on error (this runs for every trajectory point).
#[inline]
pub(super) fn check_coord(field: &dyn Fn() -> String, c: &Coord6) -> SspResult<()> {
    // Every given value finite and within MAX_COORD (NaN and ±inf fail the
    // comparison) is the common case, answered in one pass inline; else
    // `coord_error` says which value and why.
    let fine = |v: Option<f64>| v.is_none_or(|v| v.abs() <= MAX_COORD);
    if fine(c.x) && fine(c.y) && fine(c.z) && fine(c.roll) && fine(c.pitch) && fine(c.yaw) {
        return Ok(());
    }
    coord_error(field, c)
}

/// The refusal of a coordinate that [`check_coord`] found out of bounds.
#[cold]
pub(super) fn coord_error(field: &dyn Fn() -> String, c: &Coord6) -> SspResult<()> {
    for (name, v) in [
        ("x", c.x),
        ("y", c.y),
        ("z", c.z),
        ("roll", c.roll),
        ("pitch", c.pitch),
        ("yaw", c.yaw),
    ] {
        let Some(x) = v else { continue };
        if !x.is_finite() {
            opt_finite(&format!("{}.{name}", field()), v)?;
        }
        if x.abs() > MAX_COORD {
            return Err(SspError::invalid(format!(
                "{}.{name} = {x} is beyond ±{MAX_COORD:e}",
                field()
            )));
        }
    }
    Ok(())
}

pub(super) fn world_err(e: WorldError) -> SspError {
    match e {
        WorldError::UnknownActor(id) => SspError::not_found(format!("no actor with id '{id}'")),
        WorldError::DuplicateActor(id) => SspError::new(
            ErrorCode::AlreadyExists,
            format!("an actor with id '{id}' already exists"),
        ),
        WorldError::NoVehicleModel(id) => SspError::precondition(format!(
            "actor '{id}' is not a vehicle and cannot be driven dynamically or by a controller"
        )),
        WorldError::NotFinite(f) => SspError::invalid(format!("{f} must be finite")),
        WorldError::BadTimeStep(dt) => SspError::invalid(format!("step size {dt} s is invalid")),
    }
}

/// An actor's state at creation from the request's position, speed and
/// acceleration (in the session's frame); its longitudinal speed is the
/// velocity's component along the heading.
pub(super) fn initial_state(pos: &Coord6, spd: &Coord6, acc: &Coord6) -> ActorState {
    let yaw = pos.yaw.unwrap_or(0.0);
    let velocity = Vec3::new(
        spd.x.unwrap_or(0.0),
        spd.y.unwrap_or(0.0),
        spd.z.unwrap_or(0.0),
    );
    // Longitudinal speed: the velocity's component along the heading.
    let (sy, cy) = litesim_core::math::sin_cos(yaw);
    let speed = velocity.x * cy + velocity.y * sy;
    ActorState {
        pose: Pose {
            position: Vec3::new(
                pos.x.unwrap_or(0.0),
                pos.y.unwrap_or(0.0),
                pos.z.unwrap_or(0.0),
            ),
            roll: pos.roll.unwrap_or(0.0),
            pitch: pos.pitch.unwrap_or(0.0),
            yaw,
        },
        velocity,
        acceleration: Vec3::new(
            acc.x.unwrap_or(0.0),
            acc.y.unwrap_or(0.0),
            acc.z.unwrap_or(0.0),
        ),
        yaw_rate: spd.yaw.unwrap_or(0.0),
        speed,
        ..ActorState::default()
    }
}

/// The catalogue entry a created actor gets: the model it names, a vehicle
/// by default, else the profile's first blueprint of its category.
pub(super) fn catalog_entry(profile: &Profile, spec: &ActorSpec) -> SspResult<CatalogEntry> {
    Ok(
        if !spec.model_id.is_empty()
            || matches!(
                spec.category,
                ActorCategory::Unspecified | ActorCategory::Vehicle
            )
        {
            profile.entry(&spec.model_id)?.clone()
        } else {
            profile
                .catalog
                .iter()
                .find(|e| kind_of(&e.category).map(wire_category) == Some(spec.category))
                .cloned()
                .ok_or_else(|| {
                    SspError::not_found(format!(
                        "profile {} has no blueprint of category {:?}",
                        profile.name, spec.category
                    ))
                })?
        },
    )
}
