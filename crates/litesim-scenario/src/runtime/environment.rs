//! The environment's changes, made when their step comes: the weather
//! (SSP `set_weather`) and the time of day (`set_time_of_day`), each
//! recorded in the log with what the simulator applied (and from there in
//! the MCAP file). What a simulator cannot take is said, never dropped: a
//! profile without weather gets a run note, a value the SSP's weather has
//! no field for (air, a wind's direction) a note in the log's record.

use super::schedule::Schedule;
use crate::error::ScenarioError;
use crate::plan::{EnvChange, Plan};
use litesim_log::{EnvironmentChange, LogRecorder};
use litesim_ssp::ErrorCode;
use litesim_ssp::api::{Ssp, TimeOfDay, Weather};
use std::collections::BTreeMap;

/// Precipitation intensity (m/s of water) the simulator's precipitation
/// reaches 1 at: 50 mm/h, violent rain.
const FULL_PRECIPITATION: f64 = 50.0 / 3.6e6;
/// Wind speed (m/s) the simulator's wind intensity reaches 1 at (storm).
const FULL_WIND: f64 = 30.0;
/// Visual range (m) from which there is no fog (the meteorological
/// definition of fog: under 1 km).
const NO_FOG: f64 = 1_000.0;

/// The run's environment: the weather as set so far, and the plan's next
/// change not made yet.
#[derive(Debug, Default)]
pub struct Environment {
    weather: Weather,
    next: Schedule,
    /// What the simulator could not take, for the run's notes.
    pub notes: Vec<String>,
}

impl Environment {
    /// Makes every change due by step `k`, recording each in `rec`.
    pub fn apply_due(
        &mut self,
        ssp: &mut dyn Ssp,
        plan: &Plan,
        (k, step_ms): (u64, u64),
        mut rec: Option<&mut LogRecorder>,
    ) -> Result<(), ScenarioError> {
        while let Some(c) = self.next.due(&plan.environment, k, step_ms) {
            let record = self.apply(ssp, c, k, step_ms)?;
            if let Some(r) = rec.as_deref_mut() {
                r.environment(record);
            }
            self.next.made();
        }
        Ok(())
    }

    /// The step of the next change not made yet.
    pub fn next_tick(&self, plan: &Plan, step_ms: u64) -> Option<u64> {
        self.next.next_tick(&plan.environment, step_ms)
    }

    /// The step of the first change after step `k`.
    pub fn next_after(&self, plan: &Plan, k: u64, step_ms: u64) -> Option<u64> {
        self.next.next_after(&plan.environment, k, step_ms)
    }

    /// A new plan's changes: those due before step `k` belong to the past.
    pub fn replanned(&mut self, plan: &Plan, k: u64, step_ms: u64) {
        self.next.replanned(&plan.environment, k, step_ms);
    }

    /// One change: the simulator's weather or time of day set, and its
    /// record.
    fn apply(
        &mut self,
        ssp: &mut dyn Ssp,
        c: &EnvChange,
        k: u64,
        step_ms: u64,
    ) -> Result<EnvironmentChange, ScenarioError> {
        let mut record = EnvironmentChange {
            tick: k,
            time: (k * step_ms) as f64 / 1000.0,
            action: c.action.clone(),
            values: c.values.clone(),
            ..EnvironmentChange::default()
        };
        let v = |key: &str| c.values.get(key).copied();
        let refused = |e: litesim_ssp::SspError| {
            ScenarioError::Plan(format!(
                "{}: environment.{}: the simulator refused it: {e}",
                c.at, c.action
            ))
        };
        if c.action == "time_of_day" {
            let tod = TimeOfDay {
                seconds_since_midnight: v("time").unwrap_or(0.0).rem_euclid(86_400.0) as u32,
                day_of_year: v("day_of_year").map(|d| d as u32),
                advance_with_sim: true,
            };
            match ssp.set_time_of_day(tod) {
                Ok(()) => {
                    record.applied.insert(
                        "seconds_since_midnight".into(),
                        f64::from(tod.seconds_since_midnight),
                    );
                    if let Some(d) = tod.day_of_year {
                        record.applied.insert("day_of_year".into(), f64::from(d));
                    }
                }
                Err(e) if e.code == ErrorCode::Unimplemented => self.cannot(c, &mut record, &e),
                Err(e) => return Err(refused(e)),
            }
            return Ok(record);
        }
        let mut w = self.weather.clone();
        let mut unmapped = Vec::new();
        match c.action.as_str() {
            "rain" | "snow" => {
                let p = (v("intensity").unwrap_or(0.0) / FULL_PRECIPITATION).clamp(0.0, 1.0);
                w.precipitation = p;
                w.wetness = p;
                w.preset = c.action.clone();
            }
            "wind" => {
                w.wind_intensity = (v("speed").unwrap_or(0.0) / FULL_WIND).clamp(0.0, 1.0);
                unmapped.push("direction");
            }
            "fog" => {
                let r = v("visual_range").unwrap_or(f64::INFINITY).max(0.0);
                w.fog_distance_m = r;
                w.fog_density = (1.0 - r / NO_FOG).clamp(0.0, 1.0);
            }
            "clouds" => w.cloudiness = (v("cloudiness").unwrap_or(0.0) / 8.0).clamp(0.0, 1.0),
            "assign_celestial_position" => {
                if let Some(az) = v("azimuth") {
                    w.sun_azimuth_deg = az.to_degrees().rem_euclid(360.0);
                }
                if let Some(el) = v("elevation") {
                    w.sun_altitude_deg = el.to_degrees();
                }
            }
            // air: nothing of the SSP's weather.
            _ => unmapped.extend(c.values.keys().map(String::as_str)),
        }
        unmapped.retain(|k| c.values.contains_key(*k));
        if !unmapped.is_empty() {
            record.note = format!(
                "{} recorded only: the simulator's weather has no field for it",
                unmapped.join(", ")
            );
        }
        if c.action == "air" {
            return Ok(record);
        }
        match ssp.set_weather(w) {
            Ok(applied) => {
                record.applied = weather_fields(&applied);
                self.weather = applied;
            }
            Err(e) if e.code == ErrorCode::Unimplemented => self.cannot(c, &mut record, &e),
            Err(e) => return Err(refused(e)),
        }
        Ok(record)
    }

    /// The simulator has no weather or time of day: said in the record
    /// and in the run's notes.
    fn cannot(&mut self, c: &EnvChange, record: &mut EnvironmentChange, e: &litesim_ssp::SspError) {
        record.note = format!("not applied: {}", e.message);
        self.notes.push(format!(
            "{}: environment.{} at t = {:.2} s is recorded in the log only: {}",
            c.at, c.action, record.time, e.message
        ));
    }
}

/// The weather's numeric fields by name.
fn weather_fields(w: &Weather) -> BTreeMap<String, f64> {
    [
        ("cloudiness", w.cloudiness),
        ("precipitation", w.precipitation),
        ("wetness", w.wetness),
        ("fog_density", w.fog_density),
        ("fog_distance_m", w.fog_distance_m),
        ("wind_intensity", w.wind_intensity),
        ("sun_azimuth_deg", w.sun_azimuth_deg),
        ("sun_altitude_deg", w.sun_altitude_deg),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}
