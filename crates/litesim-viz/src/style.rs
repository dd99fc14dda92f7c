//! Stylesheets: every colour, width, size and font size of the pictures,
//! in TOML, with a built-in default. Unknown keys are errors (a typo must
//! not silently do nothing).

use plotters::style::RGBColor;
use serde::{Deserialize, Serialize};

/// A stylesheet.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Style {
    /// Dashboard size in pixels (width, height).
    pub dashboard_size: [u32; 2],
    /// Animation / debug view size in pixels.
    pub frame_size: [u32; 2],
    /// Title font size (px).
    pub title_font: u32,
    /// Axis label font size (px).
    pub label_font: u32,
    /// Tick label font size (px).
    pub tick_font: u32,
    /// Line width of time series and trajectories (px).
    pub line_width: u32,
    /// Line width of the corridor (px).
    pub corridor_width: u32,
    /// Radius of sample markers (px).
    pub marker_size: u32,
    /// Background colour.
    pub background: String,
    /// Free space.
    pub free: String,
    /// Inflated safety margin.
    pub inflated: String,
    /// Hard obstacles.
    pub obstacle: String,
    /// Driven trajectory.
    pub trajectory: String,
    /// Smoothed corridor.
    pub corridor: String,
    /// Raw planner path.
    pub raw_path: String,
    /// MPC predicted horizon.
    pub horizon: String,
    /// Vehicle body.
    pub vehicle: String,
    /// FMT* samples.
    pub samples: String,
    /// FMT* tree edges.
    pub edges: String,
    /// Series colours, cycled.
    pub series: Vec<String>,
    /// Lane lines in replays.
    pub lanes: String,
    /// Road surface (drivable lanes) in replays.
    pub road: String,
    /// Sidewalks and other lanes in replays.
    pub sidewalk: String,
    /// Road marks of colour `standard`/`white`.
    pub mark_white: String,
    /// Road marks of colour `yellow` (and `orange`).
    pub mark_yellow: String,
}

impl Default for Style {
    fn default() -> Self {
        Self {
            dashboard_size: [1600, 1200],
            frame_size: [800, 600],
            title_font: 18,
            label_font: 14,
            tick_font: 12,
            line_width: 2,
            corridor_width: 2,
            marker_size: 2,
            background: "#ffffff".into(),
            free: "#f4f4f0".into(),
            inflated: "#f6c28b".into(),
            obstacle: "#3a3a3a".into(),
            trajectory: "#1f5fbf".into(),
            corridor: "#2ca02c".into(),
            raw_path: "#9467bd".into(),
            horizon: "#d62728".into(),
            vehicle: "#ff7f0e".into(),
            samples: "#7f7f7f".into(),
            edges: "#a6c8e8".into(),
            series: vec![
                "#1f77b4".into(),
                "#d62728".into(),
                "#2ca02c".into(),
                "#9467bd".into(),
                "#8c564b".into(),
            ],
            lanes: "#9a9a9a".into(),
            road: "#c8c8c8".into(),
            sidewalk: "#e6e1d3".into(),
            mark_white: "#ffffff".into(),
            mark_yellow: "#e8b400".into(),
        }
    }
}

/// A bad stylesheet.
#[derive(Debug, thiserror::Error)]
pub enum StyleError {
    /// Not valid TOML for a stylesheet.
    #[error("stylesheet: {0}")]
    Toml(#[from] toml::de::Error),
    /// A colour that is not `#rrggbb`.
    #[error("stylesheet: {field} = '{value}' is not a colour (expected #rrggbb)")]
    Color {
        /// Key.
        field: &'static str,
        /// Value.
        value: String,
    },
    /// A size out of range.
    #[error("stylesheet: {0}")]
    Size(String),
}

/// Parses `#rrggbb`.
pub fn color(s: &str) -> Option<RGBColor> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 {
        return None;
    }
    let v = u32::from_str_radix(h, 16).ok()?;
    Some(RGBColor((v >> 16) as u8, (v >> 8) as u8, v as u8))
}

impl Style {
    /// Parses and validates a stylesheet (missing keys take the defaults).
    pub fn from_toml(text: &str) -> Result<Self, StyleError> {
        let s: Style = toml::from_str(text)?;
        s.validate()?;
        Ok(s)
    }

    /// Checks colours and sizes.
    pub fn validate(&self) -> Result<(), StyleError> {
        let colours: [(&'static str, &String); 17] = [
            ("background", &self.background),
            ("free", &self.free),
            ("inflated", &self.inflated),
            ("obstacle", &self.obstacle),
            ("trajectory", &self.trajectory),
            ("corridor", &self.corridor),
            ("raw_path", &self.raw_path),
            ("horizon", &self.horizon),
            ("vehicle", &self.vehicle),
            ("samples", &self.samples),
            ("edges", &self.edges),
            ("lanes", &self.lanes),
            ("road", &self.road),
            ("sidewalk", &self.sidewalk),
            ("mark_white", &self.mark_white),
            ("mark_yellow", &self.mark_yellow),
            ("series", self.series.first().unwrap_or(&self.background)),
        ];
        for (field, value) in colours {
            if color(value).is_none() {
                return Err(StyleError::Color {
                    field,
                    value: value.clone(),
                });
            }
        }
        if let Some(bad) = self.series.iter().find(|c| color(c).is_none()) {
            return Err(StyleError::Color {
                field: "series",
                value: bad.clone(),
            });
        }
        if self.series.is_empty() {
            return Err(StyleError::Size("series needs at least one colour".into()));
        }
        for (name, [w, h]) in [
            ("dashboard_size", self.dashboard_size),
            ("frame_size", self.frame_size),
        ] {
            if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
                return Err(StyleError::Size(format!(
                    "{name} = [{w}, {h}] is outside [200..8000] × [150..8000] px"
                )));
            }
        }
        for (name, v) in [
            ("title_font", self.title_font),
            ("label_font", self.label_font),
            ("tick_font", self.tick_font),
        ] {
            if !(6..=96).contains(&v) {
                return Err(StyleError::Size(format!(
                    "{name} = {v} is outside 6..=96 px"
                )));
            }
        }
        Ok(())
    }

    /// A style colour by key (validated at load; falls back to black).
    pub fn c(&self, s: &str) -> RGBColor {
        color(s).unwrap_or(RGBColor(0, 0, 0))
    }

    /// The i-th series colour.
    pub fn series(&self, i: usize) -> RGBColor {
        self.c(&self.series[i % self.series.len().max(1)])
    }
}
