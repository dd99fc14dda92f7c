//! Traffic lights at bulb ("physical") level with logical grouping.
//!
//! A *box* is one housing with bulbs; a *logical light* groups boxes whose
//! common bulbs (same icon and colour) always share a state (Foretify's OSC
//! traffic-light model). Setting a state names (icon, colour, mode) triples;
//! bulbs of the target that match none of them are switched off.

use crate::api::Coord6;
use crate::error::{SspError, SspResult};
use serde::{Deserialize, Serialize};

/// Bulb icons (OSC `bulb_icon_kind`, plus tram and bus from OSI).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum BulbIcon {
    /// Unknown.
    #[default]
    Unspecified,
    /// Plain disc.
    None,
    /// Arrow straight.
    ArrowStraight,
    /// Arrow left.
    ArrowLeft,
    /// Arrow slight left.
    ArrowSlightLeft,
    /// Arrow right.
    ArrowRight,
    /// Arrow slight right.
    ArrowSlightRight,
    /// U-turn arrow.
    ArrowUturn,
    /// Pedestrian.
    Pedestrian,
    /// Walk.
    Walk,
    /// Don't walk.
    DontWalk,
    /// Bicycle.
    Bicycle,
    /// Countdown.
    Countdown,
    /// Tram.
    Tram,
    /// Bus.
    Bus,
}

/// Bulb colours.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum BulbColor {
    /// Unknown.
    #[default]
    Unspecified,
    /// Red.
    Red,
    /// Yellow.
    Yellow,
    /// Green.
    Green,
    /// Blue.
    Blue,
    /// White.
    White,
}

/// Bulb modes.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum BulbMode {
    /// Unknown.
    #[default]
    Unspecified,
    /// Off.
    Off,
    /// Constantly on.
    On,
    /// Flashing.
    Flashing,
    /// Counting down.
    Counting,
}

/// One bulb.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Bulb {
    /// Id in the map.
    pub map_id: String,
    /// Icon.
    pub icon: BulbIcon,
    /// Colour.
    pub color: BulbColor,
    /// Mode.
    pub mode: BulbMode,
    /// Counter value (s) for countdown bulbs.
    pub counter: Option<f64>,
}

/// A box (housing) of bulbs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrafficLightBox {
    /// Id (OpenDRIVE signal id when from a map).
    pub id: String,
    /// Road id.
    pub road_id: String,
    /// s along the road (m).
    pub s: f64,
    /// t across the road (m).
    pub t: f64,
    /// World pose of the housing.
    pub pose: Coord6,
    /// Bulbs.
    pub bulbs: Vec<Bulb>,
    /// Lanes it controls.
    pub valid_lanes: Vec<i32>,
}

/// A logical traffic light: boxes whose common bulbs share a state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LogicalTrafficLight {
    /// Id.
    pub id: String,
    /// Member boxes.
    pub box_ids: Vec<String>,
    /// OpenDRIVE controller id.
    pub controller_id: String,
}

/// Everything known about traffic lights.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrafficLights {
    /// Boxes, in definition order.
    pub boxes: Vec<TrafficLightBox>,
    /// Logical lights, in definition order.
    pub logical: Vec<LogicalTrafficLight>,
}

/// A bulb state to set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BulbState {
    /// Icon to match.
    pub icon: BulbIcon,
    /// Colour to match.
    pub color: BulbColor,
    /// Mode to set.
    pub mode: BulbMode,
}

/// What a state change targets.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightTarget {
    /// A logical light (all its boxes).
    Logical(String),
    /// One box.
    Box(String),
}

impl TrafficLights {
    /// Checks ids: boxes unique, logical lights unique and naming existing boxes.
    pub fn new(boxes: Vec<TrafficLightBox>, logical: Vec<LogicalTrafficLight>) -> SspResult<Self> {
        let mut seen = std::collections::BTreeSet::new();
        for (k, b) in boxes.iter().enumerate() {
            if b.id.is_empty() {
                return Err(SspError::invalid("traffic_lights: a box has an empty id"));
            }
            // Every number a client gives is checked, naming the field.
            let field = |f: &str| format!("traffic_lights[{k}] (box '{}').{f}", b.id);
            crate::error::finite(&field("s"), b.s)?;
            crate::error::finite(&field("t"), b.t)?;
            for (name, v) in [
                ("pose.x", b.pose.x),
                ("pose.y", b.pose.y),
                ("pose.z", b.pose.z),
                ("pose.roll", b.pose.roll),
                ("pose.pitch", b.pose.pitch),
                ("pose.yaw", b.pose.yaw),
            ] {
                if let Some(v) = v {
                    crate::error::finite(&field(name), v)?;
                }
            }
            for (j, bulb) in b.bulbs.iter().enumerate() {
                if let Some(c) = bulb.counter {
                    crate::error::finite(&field(&format!("bulbs[{j}].counter")), c)?;
                }
            }
            if !seen.insert(b.id.as_str()) {
                return Err(SspError::new(
                    crate::error::ErrorCode::AlreadyExists,
                    format!("traffic_lights: box id '{}' is used twice", b.id),
                ));
            }
        }
        let mut seen_l = std::collections::BTreeSet::new();
        for l in &logical {
            if !seen_l.insert(l.id.as_str()) {
                return Err(SspError::new(
                    crate::error::ErrorCode::AlreadyExists,
                    format!("logical_lights: id '{}' is used twice", l.id),
                ));
            }
            if let Some(missing) = l.box_ids.iter().find(|id| !seen.contains(id.as_str())) {
                return Err(SspError::not_found(format!(
                    "logical light '{}' names box '{missing}', which does not exist",
                    l.id
                )));
            }
        }
        Ok(Self { boxes, logical })
    }

    /// Applies `states` to the target; returns the affected boxes.
    pub fn set(
        &mut self,
        target: &LightTarget,
        states: &[BulbState],
    ) -> SspResult<Vec<TrafficLightBox>> {
        if let Some(bad) = states.iter().position(|s| s.mode == BulbMode::Unspecified) {
            return Err(SspError::invalid(format!(
                "states[{bad}].mode must be given (off, on, flashing, counting)"
            )));
        }
        let ids: Vec<String> = match target {
            LightTarget::Box(id) => {
                if !self.boxes.iter().any(|b| &b.id == id) {
                    return Err(SspError::not_found(format!(
                        "no traffic-light box '{id}'; known boxes: {}",
                        self.boxes
                            .iter()
                            .map(|b| b.id.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )));
                }
                vec![id.clone()]
            }
            LightTarget::Logical(id) => match self.logical.iter().find(|l| &l.id == id) {
                Some(l) => l.box_ids.clone(),
                None => {
                    return Err(SspError::not_found(format!(
                        "no logical traffic light '{id}'; known: {}",
                        self.logical
                            .iter()
                            .map(|l| l.id.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )));
                }
            },
        };
        let mut affected = Vec::new();
        for b in self.boxes.iter_mut().filter(|b| ids.contains(&b.id)) {
            for bulb in &mut b.bulbs {
                bulb.mode = states
                    .iter()
                    .find(|s| s.icon == bulb.icon && s.color == bulb.color)
                    .map_or(BulbMode::Off, |s| s.mode);
            }
            affected.push(b.clone());
        }
        Ok(affected)
    }
}

/// Bulbs of an OpenDRIVE traffic-light signal by its type code (German
/// numbering as used with `country="OpenDRIVE"`; lamps top to bottom).
fn bulbs_for(kind: &str, subtype: &str, id: &str) -> Vec<Bulb> {
    use BulbColor::*;
    use BulbIcon as I;
    let arrow = match subtype {
        "10" => I::ArrowLeft,
        "20" => I::ArrowRight,
        "30" => I::ArrowStraight,
        _ => I::None,
    };
    let lamps: Vec<(BulbIcon, BulbColor)> = match kind {
        "1000002" => vec![(I::DontWalk, Red), (I::Walk, Green)],
        "1000011" => vec![(arrow, Red), (arrow, Yellow), (arrow, Green)],
        "1000013" => vec![(I::Bicycle, Red), (I::Bicycle, Green)],
        "1000014" => vec![(I::Tram, Yellow)],
        "1000020" => vec![(arrow, Red)],
        "1000008" => vec![(arrow, Yellow)],
        "1000012" => vec![(arrow, Green)],
        _ => vec![(I::None, Red), (I::None, Yellow), (I::None, Green)],
    };
    lamps
        .into_iter()
        .enumerate()
        .map(|(k, (icon, color))| Bulb {
            map_id: format!("{id}/{k}"),
            icon,
            color,
            mode: BulbMode::Off,
            counter: None,
        })
        .collect()
}

/// Traffic lights of a map: one box per dynamic signal, one logical light per controller.
pub fn from_map(
    net: &litesim_map::RoadNetwork,
) -> (Vec<TrafficLightBox>, Vec<LogicalTrafficLight>) {
    let mut count: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
    for r in net.roads() {
        for s in r.signals.iter().filter(|s| s.dynamic) {
            *count.entry(s.id.as_str()).or_default() += 1;
        }
    }
    // Signal ids repeat across roads in real maps; make box ids unique then.
    let box_id = |road: &str, sig: &str| {
        if count.get(sig).copied().unwrap_or(0) > 1 {
            format!("{road}:{sig}")
        } else {
            sig.to_string()
        }
    };
    let mut boxes = Vec::new();
    for r in net.roads() {
        for s in r.signals.iter().filter(|s| s.dynamic) {
            let (x, y, z) = r.st_to_xyz(s.s, s.t);
            let mut yaw = r.reference(s.s).hdg;
            if s.orientation == "-" {
                yaw += std::f64::consts::PI;
            }
            let id = box_id(&r.id, &s.id);
            boxes.push(TrafficLightBox {
                bulbs: bulbs_for(&s.kind, &s.subtype, &id),
                id,
                road_id: r.id.clone(),
                s: s.s,
                t: s.t,
                pose: Coord6 {
                    x: Some(x),
                    y: Some(y),
                    z: Some(z),
                    yaw: Some(litesim_core::wrap_angle(yaw)),
                    ..Coord6::default()
                },
                valid_lanes: s
                    .validity
                    .map(|(a, b)| (a.min(b)..=a.max(b)).filter(|l| *l != 0).collect())
                    .unwrap_or_default(),
            });
        }
    }
    let logical = net
        .od
        .controllers
        .iter()
        .map(|c| LogicalTrafficLight {
            id: c.id.clone(),
            box_ids: c
                .signals
                .iter()
                .filter_map(|sid| {
                    boxes
                        .iter()
                        .find(|b| b.id == *sid || b.id.ends_with(&format!(":{sid}")))
                        .map(|b| b.id.clone())
                })
                .collect(),
            controller_id: c.id.clone(),
        })
        .collect();
    (boxes, logical)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bx(id: &str) -> TrafficLightBox {
        TrafficLightBox {
            id: id.into(),
            bulbs: [BulbColor::Red, BulbColor::Yellow, BulbColor::Green]
                .into_iter()
                .map(|color| Bulb {
                    map_id: format!("{id}-{color:?}"),
                    icon: BulbIcon::None,
                    color,
                    mode: BulbMode::Off,
                    counter: None,
                })
                .collect(),
            ..TrafficLightBox::default()
        }
    }

    #[test]
    fn logical_group_switches_common_bulbs() {
        let mut tl = TrafficLights::new(
            vec![bx("a"), bx("b"), bx("c")],
            vec![LogicalTrafficLight {
                id: "north".into(),
                box_ids: vec!["a".into(), "b".into()],
                controller_id: String::new(),
            }],
        )
        .unwrap();
        let green = BulbState {
            icon: BulbIcon::None,
            color: BulbColor::Green,
            mode: BulbMode::On,
        };
        let affected = tl
            .set(&LightTarget::Logical("north".into()), &[green])
            .unwrap();
        assert_eq!(affected.len(), 2);
        for b in &tl.boxes[..2] {
            let modes: Vec<_> = b.bulbs.iter().map(|x| x.mode).collect();
            assert_eq!(modes, vec![BulbMode::Off, BulbMode::Off, BulbMode::On]);
        }
        assert!(tl.boxes[2].bulbs.iter().all(|x| x.mode == BulbMode::Off));
        assert!(tl.set(&LightTarget::Box("zz".into()), &[green]).is_err());
    }

    #[test]
    fn bad_definitions() {
        assert!(TrafficLights::new(vec![bx("a"), bx("a")], vec![]).is_err());
        let l = LogicalTrafficLight {
            id: "x".into(),
            box_ids: vec!["nope".into()],
            controller_id: String::new(),
        };
        assert!(TrafficLights::new(vec![bx("a")], vec![l]).is_err());
    }
}
