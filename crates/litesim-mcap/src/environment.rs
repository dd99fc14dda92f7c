//! The environment's changes in an MCAP file: each one as a JSON message
//! on `/environment` (what the scenario asked, what the simulator applied),
//! and the state they add up to as OSI's `EnvironmentalConditions` in every
//! GroundTruth message from then on. A run without changes has neither (its
//! file is the bytes it was before environments were recorded).

use crate::osi3;
use crate::osi3::environmental_conditions as ec;
use litesim_log::EnvironmentChange;

/// The topic of the environment's changes.
pub const TOPIC_ENVIRONMENT: &str = "/environment";

/// The schema name of an environment change message.
pub const ENVIRONMENT_SCHEMA: &str = "litesim.EnvironmentChange";

/// The JSON Schema of an environment change message.
pub(super) fn environment_schema() -> String {
    let map = |d: &str| serde_json::json!({"type": "object", "additionalProperties": {"type": "number"}, "description": d});
    serde_json::json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": ENVIRONMENT_SCHEMA,
        "description": "A change of the environment during a litesim run (weather, sun, time of day)",
        "type": "object",
        "properties": {
            "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
            "tick": {"type": "integer"},
            "time": {"type": "number", "description": "s from the run's start"},
            "action": {"type": "string", "description": "rain, snow, fog, wind, clouds, air, assign_celestial_position, time_of_day"},
            "values": map("the action's arguments in SI units (m/s, m, rad, K, Pa; okta, percent)"),
            "applied": map("the simulator's weather or time of day after the change"),
            "note": {"type": "string", "description": "what the simulator could not take"}
        }
    })
    .to_string()
}

/// One change as its JSON message (time stamp `ns`).
pub(super) fn change_json(c: &EnvironmentChange, ns: u64) -> Vec<u8> {
    let mut v = serde_json::json!({
        "timestamp": {"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000},
    });
    if let (Some(o), Ok(serde_json::Value::Object(fields))) =
        (v.as_object_mut(), serde_json::to_value(c))
    {
        o.extend(fields);
    }
    serde_json::to_vec(&v).unwrap_or_default()
}

/// OSI's precipitation classes by their documented upper bounds in mm/h:
/// none below 0.1, very light below 0.5, light below 1.9, moderate below
/// 8.1, heavy below 34, very heavy below 149, extreme beyond.
const PRECIPITATION: [(f64, ec::Precipitation); 6] = [
    (0.1, ec::Precipitation::None),
    (0.5, ec::Precipitation::VeryLight),
    (1.9, ec::Precipitation::Light),
    (8.1, ec::Precipitation::Moderate),
    (34.0, ec::Precipitation::Heavy),
    (149.0, ec::Precipitation::VeryHeavy),
];

/// OSI's fog classes by their documented upper bounds of visual range in
/// m: dense below 50, thick below 200, light below 1 km, mist below 2 km,
/// poor below 4 km, moderate below 10 km, good below 40 km, excellent
/// beyond.
const FOG: [(f64, ec::Fog); 7] = [
    (50.0, ec::Fog::Dense),
    (200.0, ec::Fog::Thick),
    (1_000.0, ec::Fog::Light),
    (2_000.0, ec::Fog::Mist),
    (4_000.0, ec::Fog::PoorVisibility),
    (10_000.0, ec::Fog::ModerateVisibility),
    (40_000.0, ec::Fog::GoodVisibility),
];

/// The class of `x` in a table of upper bounds, `beyond` past the last.
fn class<C: Copy>(x: f64, table: &[(f64, C)], beyond: C) -> C {
    table
        .iter()
        .find(|(b, _)| x < *b)
        .map_or(beyond, |(_, c)| *c)
}

/// OSI's precipitation class of an intensity (m/s of water).
fn precipitation(intensity: f64) -> ec::Precipitation {
    class(
        intensity * 3.6e6,
        &PRECIPITATION,
        ec::Precipitation::Extreme,
    )
}

/// OSI's fog class of a visual range (m).
fn fog(range: f64) -> ec::Fog {
    class(range, &FOG, ec::Fog::ExcellentVisibility)
}

/// The conditions after `c`: the fields its action sets, the others as
/// they were.
pub(super) fn apply(state: &mut osi3::EnvironmentalConditions, c: &EnvironmentChange) {
    let v = |k: &str| c.values.get(k).copied();
    match c.action.as_str() {
        "rain" | "snow" => {
            if let Some(i) = v("intensity") {
                state.precipitation = Some(precipitation(i) as i32);
            }
        }
        "fog" => {
            if let Some(r) = v("visual_range") {
                state.fog = Some(fog(r) as i32);
            }
        }
        "clouds" => {
            if let Some(okta) = v("cloudiness") {
                // ZeroOktas is 2 in OSI's enum; 0–8 okta in order.
                let k = okta.round().clamp(0.0, 8.0) as i32;
                let layer = ec::CloudLayer {
                    fractional_cloud_cover: Some(
                        ec::cloud_layer::FractionalCloudCover::ZeroOktas as i32 + k,
                    ),
                };
                state.clouds = Some(layer);
            }
        }
        "wind" => {
            state.wind = Some(ec::Wind {
                origin_direction: v("direction"),
                speed: v("speed"),
            });
        }
        "air" => {
            state.temperature = v("temperature").or(state.temperature);
            state.atmospheric_pressure = v("atmospheric_pressure").or(state.atmospheric_pressure);
            state.relative_humidity = v("relative_humidity").or(state.relative_humidity);
        }
        // The sun's (litesim refuses the moon's).
        "assign_celestial_position" => {
            let sun = state.sun.get_or_insert_with(Default::default);
            sun.azimuth = v("azimuth").or(sun.azimuth);
            sun.elevation = v("elevation").or(sun.elevation);
        }
        "time_of_day" => {
            if let Some(t) = v("time") {
                state.time_of_day = Some(ec::TimeOfDay {
                    seconds_since_midnight: Some(t.rem_euclid(86_400.0) as u32),
                });
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_follow_osi_bounds() {
        let mm_h = |x: f64| x / 3.6e6;
        assert_eq!(precipitation(0.0), ec::Precipitation::None);
        assert_eq!(precipitation(mm_h(5.0)), ec::Precipitation::Moderate);
        assert_eq!(precipitation(mm_h(40.0)), ec::Precipitation::VeryHeavy);
        assert_eq!(precipitation(mm_h(200.0)), ec::Precipitation::Extreme);
        assert_eq!(fog(30.0), ec::Fog::Dense);
        assert_eq!(fog(150.0), ec::Fog::Thick);
        assert_eq!(fog(50_000.0), ec::Fog::ExcellentVisibility);
    }
}
