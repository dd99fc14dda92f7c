//! Per-tick content: an actor's sample, its scene entity and OSI object
//! templates, the `litesim.ActorState` JSON and its schema.

use super::*;

/// Height of an actor's box (the log has length and width only): cars 1.5 m,
/// people 1.8 m, anything else 1.5 m.
pub(super) fn height_of(kind: &str) -> f64 {
    if is_pedestrian(kind) { 1.8 } else { 1.5 }
}

/// A person by litesim's actor kinds (`person`, `pedestrian…`).
pub(super) fn is_pedestrian(kind: &str) -> bool {
    kind.starts_with("person") || kind.starts_with("pedestrian")
}

/// Nanoseconds of simulated time `t` (s): rounded, never negative.
pub(super) fn nanos(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 {
        (t * 1e9).round() as u64
    } else {
        0
    }
}

pub(super) fn stamp(ns: u64) -> fg::Timestamp {
    fg::Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

pub(super) fn quat_yaw(yaw: f64) -> fg::Quaternion {
    let (s, c) = litesim_core::math::sin_cos(yaw / 2.0);
    fg::Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    }
}

/// The colour of actor `k` (the ego first): a fixed, readable palette.
pub(super) fn colour(k: usize, a: f64) -> fg::Color {
    const P: [(f64, f64, f64); 8] = [
        (0.12, 0.47, 0.71),
        (0.84, 0.15, 0.16),
        (0.17, 0.63, 0.17),
        (1.0, 0.5, 0.05),
        (0.58, 0.4, 0.74),
        (0.55, 0.34, 0.29),
        (0.89, 0.47, 0.76),
        (0.09, 0.75, 0.81),
    ];
    let (r, g, b) = P[k % P.len()];
    fg::Color { r, g, b, a }
}

/// One actor's pose at one tick (box centre, heading) and motion.
#[derive(Clone, Copy, Debug)]
pub(super) struct Sample {
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) z: f64,
    pub(super) yaw: f64,
    pub(super) vx: f64,
    pub(super) vy: f64,
    pub(super) ax: f64,
    pub(super) ay: f64,
    pub(super) yaw_rate: f64,
}

impl Sample {
    pub(super) fn of(t: &ActorTrack, i: usize) -> Option<Sample> {
        let s = &t.state;
        let (x, y, yaw) = (s.x[i], s.y[i], s.yaw[i]);
        if !(x.is_finite() && y.is_finite() && yaw.is_finite()) {
            return None;
        }
        let f = |v: f64| if v.is_finite() { v } else { 0.0 };
        // World acceleration from the derived body-frame accelerations.
        let (along, across) = (
            f(t.derived.longitudinal_acceleration[i]),
            f(t.derived.lateral_acceleration[i]),
        );
        let (sy, cy) = litesim_core::math::sin_cos(yaw);
        Some(Sample {
            x,
            y,
            z: f(s.z[i]),
            yaw,
            vx: f(s.vx[i]),
            vy: f(s.vy[i]),
            ax: along * cy - across * sy,
            ay: along * sy + across * cy,
            yaw_rate: f(s.yaw_rate[i]),
        })
    }
}

/// OSI's vehicle class of a litesim actor (kind and blueprint words).
pub(super) fn vehicle_type(
    kind: &str,
    model: &str,
) -> osi3::moving_object::vehicle_classification::Type {
    use osi3::moving_object::vehicle_classification::Type;
    let words = format!("{kind} {model}").to_ascii_lowercase();
    let has = |w: &str| words.contains(w);
    if has("truck") {
        Type::HeavyTruck
    } else if has("bus") {
        Type::Bus
    } else if has("van") {
        Type::DeliveryVan
    } else if has("motor") {
        Type::Motorbike
    } else if has("bicycle") || has("cyclist") || has("bike") {
        Type::Bicycle
    } else {
        Type::Car
    }
}

/// The JSON Schema of the per-actor state messages.
pub(super) fn actor_state_schema() -> String {
    let num = |d: &str| serde_json::json!({"type": "number", "description": d});
    serde_json::json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": ACTOR_STATE_SCHEMA,
        "description": "One actor's state and command at one tick of a litesim run (SI units, world frame; NaN as null)",
        "type": "object",
        "properties": {
            "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
            "tick": {"type": "integer"},
            "id": {"type": "string"},
            "mode": {"type": "string", "description": "control mode: stored, trajectory, dynamic, direct, external"},
            "x": num("box centre x (m)"),
            "y": num("box centre y (m)"),
            "yaw": num("heading (rad)"),
            "speed": num("longitudinal speed (m/s)"),
            "vx": num("velocity x (m/s)"),
            "vy": num("velocity y (m/s)"),
            "yaw_rate": num("yaw rate (rad/s)"),
            "acceleration": num("longitudinal acceleration (m/s²)"),
            "lateral_acceleration": num("lateral acceleration (m/s²)"),
            "throttle": num("throttle 0..1"),
            "brake": num("brake 0..1"),
            "steering": num("steering −1..1 of full lock")
        }
    })
    .to_string()
}

/// The parts of actor `a`'s scene entity that never change: id, kind,
/// box size and colour, label (poses are filled in per tick).
pub(super) fn entity_template(a: usize, t: &ActorTrack, h: f64) -> fg::SceneEntity {
    fg::SceneEntity {
        frame_id: WORLD_FRAME.into(),
        id: t.id.clone(),
        metadata: vec![fg::KeyValuePair {
            key: "kind".into(),
            value: t.kind.clone(),
        }],
        cubes: vec![fg::CubePrimitive {
            pose: None,
            size: Some(fg::Vector3 {
                x: t.length,
                y: t.width,
                z: h,
            }),
            color: Some(colour(a, 0.85)),
        }],
        texts: vec![fg::TextPrimitive {
            pose: None,
            billboard: true,
            font_size: 14.0,
            scale_invariant: true,
            color: Some(colour(a, 1.0)),
            text: t.id.clone(),
        }],
        ..Default::default()
    }
}

/// The parts of actor `a`'s OSI moving object that never change: id,
/// dimension, type and classification, model (motion is filled in per tick).
pub(super) fn object_template(a: usize, t: &ActorTrack, h: f64) -> osi3::MovingObject {
    let pedestrian = is_pedestrian(&t.kind);
    osi3::MovingObject {
        id: Some(id(a as u64 + 1)),
        base: Some(osi3::BaseMoving {
            dimension: Some(osi3::Dimension3d {
                length: Some(t.length),
                width: Some(t.width),
                height: Some(h),
            }),
            ..Default::default()
        }),
        r#type: Some(if pedestrian {
            osi3::moving_object::Type::Pedestrian
        } else {
            osi3::moving_object::Type::Vehicle
        } as i32),
        vehicle_classification: (!pedestrian).then(|| osi3::moving_object::VehicleClassification {
            r#type: Some(vehicle_type(&t.kind, &t.model) as i32),
            ..Default::default()
        }),
        model_reference: (!t.model.is_empty()).then(|| t.model.clone()),
        ..Default::default()
    }
}

/// Appends actor `t`'s state at its sample `i` as a `litesim.ActorState`
/// JSON object (see [`actor_state_schema`]; NaN and infinities as null).
/// Written by hand: serde's derived path escapes every key on every call,
/// and these are the file's most numerous messages.
pub(super) fn actor_state_json(
    out: &mut Vec<u8>,
    ns: u64,
    tick: u64,
    quoted_id: &str,
    t: &ActorTrack,
    i: usize,
) {
    use serde_json::ser::{CompactFormatter, Formatter};
    let mut f = CompactFormatter;
    // Writing into a Vec cannot fail.
    let mut num = |out: &mut Vec<u8>, key: &str, v: f64| {
        out.extend_from_slice(key.as_bytes());
        if v.is_finite() {
            let _ = f.write_f64(out, v);
        } else {
            out.extend_from_slice(b"null");
        }
    };
    out.extend_from_slice(b"{\"timestamp\":{\"sec\":");
    let _ = CompactFormatter.write_u64(out, ns / 1_000_000_000);
    out.extend_from_slice(b",\"nsec\":");
    let _ = CompactFormatter.write_u64(out, ns % 1_000_000_000);
    out.extend_from_slice(b"},\"tick\":");
    let _ = CompactFormatter.write_u64(out, tick);
    out.extend_from_slice(b",\"id\":");
    out.extend_from_slice(quoted_id.as_bytes());
    out.extend_from_slice(b",\"mode\":");
    let _ = serde_json::to_writer(&mut *out, &t.mode[i]);
    let (st, d, c) = (&t.state, &t.derived, &t.control);
    num(out, ",\"x\":", st.x[i]);
    num(out, ",\"y\":", st.y[i]);
    num(out, ",\"yaw\":", st.yaw[i]);
    num(out, ",\"speed\":", st.speed[i]);
    num(out, ",\"vx\":", st.vx[i]);
    num(out, ",\"vy\":", st.vy[i]);
    num(out, ",\"yaw_rate\":", st.yaw_rate[i]);
    num(out, ",\"acceleration\":", d.longitudinal_acceleration[i]);
    num(out, ",\"lateral_acceleration\":", d.lateral_acceleration[i]);
    num(out, ",\"throttle\":", c.throttle[i]);
    num(out, ",\"brake\":", c.brake[i]);
    num(out, ",\"steering\":", c.steering[i]);
    out.push(b'}');
}
