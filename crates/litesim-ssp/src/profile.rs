//! Simulator profiles: data files in `profiles/` (embedded at build time).
//!
//! A profile brings what litesim takes from a real simulator's configuration:
//! step size, actuator units, an actor catalogue with real dimensions, PID
//! calibration for the scenario engine's drivers, traffic-light API level and
//! post-plan limits. Profiles are plain TOML so users can add their own.

use crate::api::{CatalogEntry, PedalEncoding};
use crate::error::{SspError, SspResult};
use litesim_core::RangePolicy;
use serde::{Deserialize, Serialize};

/// PID gains of one actuator loop.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PidGains {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain (1/s).
    pub ki: f64,
    /// Derivative gain (s).
    pub kd: f64,
}

/// Driver calibration of a profile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Step size the gains were tuned for (ms).
    pub calibrated_step_ms: u32,
    /// Speed error (m/s) → throttle.
    pub throttle: PidGains,
    /// Speed error (m/s) → brake.
    pub brake: PidGains,
    /// Lateral/heading error → steering.
    pub steering: PidGains,
}

/// Traffic-light API level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrafficLightApi {
    /// Not supported.
    None,
    /// Logical lights only.
    Logical,
    /// Bulb level ("physical"), with logical grouping.
    #[default]
    Physical,
}

/// How much a profile's post-plan checks cover.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PostPlanLevel {
    /// The seed's "base implementation" (CarMaker, DriveSim): speed,
    /// acceleration and deceleration limits (and every planned position in
    /// a lane, which every profile checks).
    Base,
    /// The seed's dSPACE "implementation": the base checks plus the
    /// curvature limit.
    #[default]
    Full,
}

/// Limits a plan is checked against before it runs (post-plan checks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PostPlanChecks {
    /// Checks are enabled.
    pub enabled: bool,
    /// Which checks.
    #[serde(default)]
    pub level: PostPlanLevel,
    /// Maximum speed (m/s).
    pub max_speed: f64,
    /// Maximum acceleration (m/s²).
    pub max_acceleration: f64,
    /// Maximum deceleration (m/s², positive).
    pub max_deceleration: f64,
    /// Maximum curvature (1/m).
    pub max_curvature: f64,
}

/// A simulator profile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    /// Name, e.g. `carla-0.9.15`.
    pub name: String,
    /// What it emulates.
    pub simulator: String,
    /// One-line description.
    pub description: String,
    /// Where the step and its range come from (the simulator's
    /// documentation, or why litesim chose them).
    #[serde(default)]
    pub step_source: String,
    /// Default step (ms).
    pub step_ms: u32,
    /// Smallest allowed step (ms).
    pub min_step_ms: u32,
    /// Largest allowed step (ms).
    pub max_step_ms: u32,
    /// Native actuator encoding.
    pub pedal_encoding: PedalEncoding,
    /// What to do with out-of-range actuator values.
    pub range_policy: RangePolicy,
    /// Resolution of the engine's pedal and steering commands, as a
    /// fraction of full travel: each command is rounded to a multiple of
    /// it (a throttle reads 0.0312, not 2e-308).
    #[serde(default = "default_command_resolution")]
    pub command_resolution: f64,
    /// Steering torque at full lock (N·m) for torque commands.
    pub max_steering_torque_nm: f64,
    /// Mirror y at the boundary (CARLA's left-handed frame).
    #[serde(default)]
    pub mirror_y: bool,
    /// Traffic-light API level.
    pub traffic_light_api: TrafficLightApi,
    /// Weather can be set.
    pub weather: bool,
    /// Time of day can be set.
    pub time_of_day: bool,
    /// Blueprint used when a create request names none.
    pub default_vehicle: String,
    /// Driver calibration.
    pub calibration: Calibration,
    /// Post-plan checks.
    #[serde(default)]
    pub post_plan: PostPlanChecks,
    /// Actor catalogue.
    pub catalog: Vec<CatalogEntry>,
}

/// The command resolution of a profile that declares none.
pub const DEFAULT_COMMAND_RESOLUTION: f64 = 1e-4;

fn default_command_resolution() -> f64 {
    DEFAULT_COMMAND_RESOLUTION
}

/// The built-in profiles: (name, TOML text).
pub const BUILTIN: &[(&str, &str)] = &[
    ("dummy", include_str!("../../../profiles/dummy.toml")),
    (
        "carla-0.9.12",
        include_str!("../../../profiles/carla-0.9.12.toml"),
    ),
    (
        "carla-0.9.13",
        include_str!("../../../profiles/carla-0.9.13.toml"),
    ),
    (
        "carla-0.9.15",
        include_str!("../../../profiles/carla-0.9.15.toml"),
    ),
    ("sumo", include_str!("../../../profiles/sumo.toml")),
    ("dspace", include_str!("../../../profiles/dspace.toml")),
    ("carmaker", include_str!("../../../profiles/carmaker.toml")),
    ("drivesim", include_str!("../../../profiles/drivesim.toml")),
    ("simian", include_str!("../../../profiles/simian.toml")),
    ("aisim", include_str!("../../../profiles/aisim.toml")),
];

/// Names of the built-in profiles.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}

impl Profile {
    /// Parses and validates a profile from TOML text.
    pub fn from_toml(text: &str) -> SspResult<Self> {
        let p: Profile =
            toml::from_str(text).map_err(|e| SspError::invalid(format!("profile: {e}")))?;
        p.validate()?;
        Ok(p)
    }

    /// A built-in profile by name; an unknown name is an error listing what exists.
    ///
    /// Each built-in is parsed once per process (sessions start by the
    /// thousand in bulk runs) and cloned from then on — only the ones
    /// asked for: parsing all ten cost a single run's process ~1 ms.
    pub fn builtin(name: &str) -> SspResult<Self> {
        use std::sync::OnceLock;
        static PARSED: [OnceLock<SspResult<Profile>>; BUILTIN.len()] =
            [const { OnceLock::new() }; BUILTIN.len()];
        let name = if name.is_empty() { "dummy" } else { name };
        match BUILTIN.iter().position(|(n, _)| *n == name) {
            Some(i) => PARSED[i]
                .get_or_init(|| Self::from_toml(BUILTIN[i].1))
                .clone(),
            None => Err(SspError::not_found(format!(
                "unknown profile '{name}'; available: {}",
                builtin_names().join(", ")
            ))),
        }
    }

    fn validate(&self) -> SspResult<()> {
        if !(self.command_resolution > 0.0 && self.command_resolution <= 0.1) {
            return Err(SspError::invalid(format!(
                "profile {}: command_resolution = {} must be in (0, 0.1]",
                self.name, self.command_resolution
            )));
        }
        if self.min_step_ms == 0 || self.min_step_ms > self.max_step_ms {
            return Err(SspError::invalid(format!(
                "profile {}: step range [{}, {}] ms is empty or starts at 0",
                self.name, self.min_step_ms, self.max_step_ms
            )));
        }
        if !(self.min_step_ms..=self.max_step_ms).contains(&self.step_ms) {
            return Err(SspError::invalid(format!(
                "profile {}: default step {} ms is outside [{}, {}]",
                self.name, self.step_ms, self.min_step_ms, self.max_step_ms
            )));
        }
        if self.catalog.is_empty() {
            return Err(SspError::invalid(format!(
                "profile {}: empty catalog",
                self.name
            )));
        }
        for e in &self.catalog {
            let dims = [
                e.length,
                e.width,
                e.height,
                e.mass,
                e.max_speed,
                e.max_accel,
                e.max_decel,
            ];
            if dims.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                return Err(SspError::invalid(format!(
                    "profile {}: catalog entry {} needs positive dimensions, mass and limits",
                    self.name, e.model_id
                )));
            }
        }
        if self.entry(&self.default_vehicle).is_err() {
            return Err(SspError::invalid(format!(
                "profile {}: default_vehicle '{}' is not in the catalog",
                self.name, self.default_vehicle
            )));
        }
        Ok(())
    }

    /// A catalog entry by model id; unknown ids are an error listing what exists.
    pub fn entry(&self, model_id: &str) -> SspResult<&CatalogEntry> {
        let id = if model_id.is_empty() {
            self.default_vehicle.as_str()
        } else {
            model_id
        };
        self.catalog
            .iter()
            .find(|e| e.model_id == id)
            .ok_or_else(|| {
                SspError::not_found(format!(
                    "unknown blueprint '{id}' in profile {}; available: {}",
                    self.name,
                    self.catalog
                        .iter()
                        .map(|e| e.model_id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_ten_builtin_profiles_load() {
        assert_eq!(BUILTIN.len(), 10);
        for name in builtin_names() {
            let p = Profile::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(p.name, name);
        }
    }

    #[test]
    fn unknown_names_list_what_exists() {
        let e = Profile::builtin("carla-0.8").unwrap_err();
        assert!(
            e.message.contains("carla-0.9.15") && e.message.contains("aisim"),
            "{}",
            e.message
        );
        let p = Profile::builtin("carla-0.9.15").unwrap();
        let e = p.entry("vehicle.flux.capacitor").unwrap_err();
        assert!(e.message.contains("vehicle.tesla.model3"), "{}", e.message);
    }
}
