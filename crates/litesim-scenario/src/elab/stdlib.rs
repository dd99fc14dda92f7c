//! The standard library's actions as the modifiers that plan them:
//! `keep_speed()` asks the `keep_speed()` modifier, `change_speed(v)` asks
//! `speed(v)` at its rate, `change_lane(n, side)` a
//! `change_lane(n, side)`, `keep_time_headway(x)` a kept headway to x.
//! What litesim cannot honour is an error naming it, never dropped
//! (docs/osc-stdlib.md).

use super::*;
use crate::intent::{Action, ModKind};

/// One call of a standard action: its name, place and bound arguments.
pub(super) struct StdCall<'a> {
    pub(super) name: &'static str,
    pub(super) at: &'a str,
    pub(super) bound: BTreeMap<String, CExpr>,
}

impl StdCall<'_> {
    /// Adds to `mods` (the call's `with:` block, already elaborated) what
    /// the action asks.
    pub(super) fn lower(
        &self,
        action: Action,
        mods: &mut Vec<Modifier>,
    ) -> Result<(), ScenarioError> {
        // An assignment is exact by definition: it cannot also be physical.
        if matches!(
            action,
            Action::AssignSpeed
                | Action::AssignPosition
                | Action::AssignOrientation
                | Action::AssignAcceleration
        ) && let Some(m) = mods.iter().find(|m| {
            m.kind == ModKind::PhysicalMovement
                && matches!(m.args.get("option"), Some(CExpr::Const(Value::Enum(o))) if o == "must_be_physical")
        }) {
            return Err(self.err(format!(
                "{} is exact (at once), which physical_movement(must_be_physical) at {} forbids: use its change_* action, which keeps to the vehicle's limits",
                self.name, m.at
            )));
        }
        match action {
            // What the keep_speed() modifier asks.
            Action::KeepSpeed => {
                self.no_speed_modifier(mods, "holds the speed it starts with")?;
                mods.push(self.implicit(ModKind::KeepSpeed, "keep_speed", Vec::new()));
                Ok(())
            }
            Action::ChangeSpeed => self.change_speed(mods),
            Action::AssignSpeed => {
                let v = self.either("speed", "target", "assign_speed(50kph)")?;
                self.no_speed_modifier(mods, "sets the speed itself")?;
                mods.push(self.best_effort_speed(v));
                Ok(())
            }
            Action::ChangeLane => self.change_lane(mods),
            // An offset from the lane's centre, reached at `rate_peak`
            // sideways (0.5 m/s by default) and held for the phase.
            Action::FollowLane => {
                if self.bound.contains_key("target") {
                    return self.refuse("target: …");
                }
                if self.is_zero("offset") {
                    return Ok(());
                }
                let mut args = vec![(
                    "offset",
                    self.required("offset", "follow_lane(offset: 0.5m)")?,
                )];
                if let Some(r) = self.bound.get("rate_peak") {
                    args.push(("rate", r.clone()));
                }
                mods.push(self.implicit(ModKind::LaneOffset, "follow_lane", args));
                Ok(())
            }
            Action::KeepSpaceGap
            | Action::KeepTimeHeadway
            | Action::ChangeSpaceGap
            | Action::ChangeTimeHeadway => self.keep_gap(action, mods),
            Action::AssignPosition => self.assign_position(mods),
            Action::ChangePosition => self.change_position(mods),
            Action::AssignOrientation => self.assign_orientation(mods),
            Action::FollowPath
            | Action::ReplayPath
            | Action::FollowTrajectory
            | Action::ReplayTrajectory => self.follow_path(action, mods),
            Action::AssignAcceleration | Action::ChangeAcceleration | Action::KeepAcceleration => {
                self.acceleration(action, mods)
            }
            Action::Drive | Action::RemainStationary | Action::Walk | Action::Move => Ok(()),
        }
    }

    fn err(&self, what: String) -> ScenarioError {
        ScenarioError::Elaboration(format!("{}: {what}", self.at))
    }

    fn refuse(&self, what: &str) -> Result<(), ScenarioError> {
        Err(self.err(format!(
            "{}({what}) is not supported by litesim (docs/osc-stdlib.md)",
            self.name
        )))
    }

    /// A parameter the action cannot go without.
    fn required(&self, key: &str, example: &str) -> Result<CExpr, ScenarioError> {
        self.bound
            .get(key)
            .cloned()
            .ok_or_else(|| self.err(format!("{} needs its {key}, e.g. `{example}`", self.name)))
    }

    /// The argument under its name `key` or its 2.0-era name `old` (one of
    /// the two).
    fn either(&self, key: &str, old: &str, example: &str) -> Result<CExpr, ScenarioError> {
        match (self.bound.get(key), self.bound.get(old)) {
            (Some(_), Some(_)) => Err(self.err(format!(
                "{}: `{key}` and `{old}` (its 2.0-era name) are the same argument: give one",
                self.name
            ))),
            (None, Some(v)) => Ok(v.clone()),
            _ => self.required(key, example),
        }
    }

    /// A length not given, or 0.
    fn is_zero(&self, key: &str) -> bool {
        match self.bound.get(key) {
            None => true,
            Some(CExpr::Const(Value::Num(v))) => *v == 0.0,
            Some(_) => false,
        }
    }

    /// A modifier made for the action, placed at the action.
    fn implicit(&self, kind: ModKind, name: &str, args: Vec<(&str, CExpr)>) -> Modifier {
        Modifier {
            kind,
            name: name.to_string(),
            args: args.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
            at: self.at.to_string(),
        }
    }

    /// `rate_profile: smooth`: the change follows a half-cosine (the other
    /// profiles, `none`, `constant` and `asap`, are the constant-rate ramp).
    fn smooth(&self) -> bool {
        self.enum_arg("rate_profile") == Some("smooth")
    }

    /// The enum literal given as `key` (`side: left` is `Some("left")`);
    /// `None` when not given or not a literal.
    fn enum_arg(&self, key: &str) -> Option<&str> {
        match self.bound.get(key) {
            Some(CExpr::Const(Value::Enum(e))) => Some(e.as_str()),
            _ => None,
        }
    }

    fn smooth_arg() -> CExpr {
        CExpr::Const(Value::Enum("smooth".into()))
    }

    /// `speed(v, run_mode: best_effort)`: a target the action reaches at
    /// its own pace (never a strict miss).
    fn best_effort_speed(&self, v: CExpr) -> Modifier {
        self.implicit(
            ModKind::Speed,
            "speed",
            vec![
                ("speed", v),
                ("run_mode", CExpr::Const(Value::Enum("best_effort".into()))),
            ],
        )
    }

    /// An action that sets or holds the speed itself refuses a speed
    /// modifier beside it.
    fn no_speed_modifier(&self, mods: &[Modifier], why: &str) -> Result<(), ScenarioError> {
        match mods
            .iter()
            .find(|m| matches!(m.kind, ModKind::Speed | ModKind::ChangeSpeed))
        {
            Some(m) => Err(ScenarioError::Elaboration(format!(
                "{}: {}() at {} {why}: a speed modifier contradicts it",
                m.at, self.name, self.at
            ))),
            None => Ok(()),
        }
    }

    fn change_speed(&self, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let target = self.required("target", "change_speed(80kph)")?;
        self.no_speed_modifier(mods, "sets the speed itself")?;
        let mut speed = self.best_effort_speed(target);
        if self.smooth() {
            speed.args.insert("rate_profile".into(), Self::smooth_arg());
        }
        mods.push(speed);
        if let Some(rate) = self.bound.get("rate_peak").cloned() {
            mods.push(self.implicit(
                ModKind::Acceleration,
                "acceleration",
                vec![("acceleration", rate)],
            ));
        }
        Ok(())
    }

    fn change_lane(&self, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let side = self.enum_arg("side");
        // An offset from the target lane's centre, reached sideways at
        // follow_lane's pace and held for the phase.
        if !self.is_zero("offset") {
            let offset = self
                .bound
                .get("offset")
                .cloned()
                .unwrap_or(CExpr::Const(Value::Num(0.0)));
            mods.push(self.implicit(ModKind::LaneOffset, "change_lane", vec![("offset", offset)]));
        }
        // Relative to another actor's lane: the lane beside it (or its own
        // lane, `same`), as a lane goal by the phase's end (one lane over;
        // more are refused).
        if let Some(reference) = self.bound.get("reference").cloned() {
            if !matches!(
                self.bound.get("num_of_lanes"),
                None | Some(CExpr::Const(Value::Num(1.0)))
            ) {
                return self.refuse("reference: …, num_of_lanes other than 1");
            }
            if self.bound.contains_key("rate_peak") {
                return self.refuse("reference: …, rate_peak: …");
            }
            let relation = match side {
                Some("right") => "right_of",
                Some("same") => "same_as",
                Some(s @ ("inside" | "outside")) => {
                    return self.refuse(&format!("reference: …, side: {s}"));
                }
                _ => "left_of",
            };
            mods.push(self.implicit(
                ModKind::Lane,
                "lane",
                vec![
                    (relation, reference),
                    ("at", CExpr::Const(Value::Enum("end".into()))),
                    ("run_mode", CExpr::Const(Value::Enum("best_effort".into()))),
                ],
            ));
            return Ok(());
        }
        if side == Some("same") {
            return Err(self.err(format!(
                "{}(side: same) changes to the lane of its `reference`, which is not given",
                self.name
            )));
        }
        let lanes = self
            .bound
            .get("num_of_lanes")
            .cloned()
            .unwrap_or(CExpr::Const(Value::Num(1.0)));
        let mut args = vec![("num_of_lanes", lanes)];
        if let Some(side) = self.bound.get("side").cloned() {
            args.push(("side", side));
        }
        // The peak sideways speed sets how long the change takes.
        if let Some(rate) = self.bound.get("rate_peak").cloned() {
            args.push(("rate", rate));
        }
        mods.push(self.implicit(ModKind::ChangeLane, "change_lane", args));
        Ok(())
    }

    fn keep_gap(&self, action: Action, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let change = matches!(action, Action::ChangeSpaceGap | Action::ChangeTimeHeadway);
        let example = if change {
            format!("{}(20m, reference: lead)", self.name)
        } else {
            format!("{}(lead)", self.name)
        };
        let reference = self.required("reference", &example)?;
        let direction = match self.enum_arg("direction") {
            Some(d) => d,
            None if action == Action::KeepSpaceGap => "longitudinal",
            None => "ahead",
        };
        let sideways = matches!(
            direction,
            "lateral" | "left" | "right" | "inside" | "outside"
        );
        if !sideways && !matches!(direction, "longitudinal" | "ahead" | "behind") {
            return self.refuse(&format!("direction: {direction}"));
        }
        // Sideways, the speed is the phase's own (its modifiers).
        if !sideways {
            self.no_speed_modifier(mods, "sets the speed itself")?;
        }
        let mut args = vec![("reference", reference)];
        args.push(("direction", CExpr::Const(Value::Enum(direction.into()))));
        if change {
            args.push(("target", self.required("target", &example)?));
        }
        let kind = if matches!(action, Action::KeepSpaceGap | Action::ChangeSpaceGap) {
            ModKind::KeepSpaceGap
        } else {
            ModKind::KeepTimeHeadway
        };
        mods.push(self.implicit(kind, self.name, args));
        Ok(())
    }

    /// `assign_position(position | odr_point | route_point)`: the one
    /// given, as a literal (`position_3d(x: 10m, y: 2m)`), is the place
    /// the actor jumps to.
    fn assign_position(&self, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let given: Vec<&str> = ["position", "odr_point", "route_point"]
            .into_iter()
            .filter(|k| self.bound.contains_key(*k))
            .collect();
        let [kind] = given[..] else {
            return Err(self.err(format!(
                "assign_position needs one of position, odr_point, route_point ({} given), e.g. `assign_position(odr_point: odr_point(road_id: \"1\", lane_id: \"-1\", s: 30m))`",
                if given.is_empty() { "none".to_string() } else { given.join(" and ") }
            )));
        };
        if !matches!(self.bound.get(kind), Some(CExpr::Const(Value::Str(_)))) {
            return Err(self.err(format!(
                "assign_position({kind}: …) takes a literal (`{kind}(…)`): a field holding one is not supported by litesim"
            )));
        }
        if matches!(self.bound.get("position.z"), Some(CExpr::Const(Value::Num(z))) if *z != 0.0) {
            return self.refuse("position: position_3d(z: …)");
        }
        let mut args: Vec<(&str, CExpr)> = vec![("kind", CExpr::Const(Value::Str(kind.into())))];
        for (k, v) in &self.bound {
            if k.strip_prefix(kind).is_some_and(|r| r.starts_with('.')) {
                args.push((k.as_str(), v.clone()));
            }
        }
        mods.push(self.implicit(ModKind::AssignPosition, "assign_position", args));
        Ok(())
    }

    /// `assign_orientation(orientation_3d(yaw: …))`: the heading relative
    /// to the road, kept while the actor stands; roll and pitch are refused.
    fn assign_orientation(&self, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        for p in ["orientation.roll", "orientation.pitch"] {
            if !self.is_zero(p) {
                return self.refuse(&format!("{p}: …"));
            }
        }
        let yaw = self.required(
            "orientation.yaw",
            "assign_orientation(orientation_3d(yaw: 90deg))",
        )?;
        mods.push(self.implicit(
            ModKind::Yaw,
            "yaw",
            vec![("angle", yaw), ("hold", CExpr::Const(Value::Bool(true)))],
        ));
        Ok(())
    }

    /// A path or trajectory action: the path elaboration read (`path`, an
    /// index), its reference and transform, as the modifier that plans it.
    fn follow_path(&self, action: Action, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let Some(path) = self.bound.get("path").cloned() else {
            return Err(self.err(format!(
                "{} needs its absolute or relative {}",
                self.name,
                if action.timed() { "trajectory" } else { "path" }
            )));
        };
        let mut args = vec![
            ("path", path),
            (
                "exact",
                CExpr::Const(Value::Bool(action == Action::ReplayTrajectory)),
            ),
        ];
        for k in ["reference", "transform", "start_offset", "end_offset"] {
            if let Some(v) = self.bound.get(k) {
                args.push((k, v.clone()));
            }
        }
        mods.push(self.implicit(ModKind::FollowPath, self.name, args));
        Ok(())
    }

    /// An acceleration action as the modifier that plans it: a target
    /// (assign: at once; change: at its `rate_peak` jerk, 2 m/s³ by
    /// default) or none (keep).
    fn acceleration(&self, action: Action, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        self.no_speed_modifier(mods, "sets the acceleration itself")?;
        let mut args = Vec::new();
        match action {
            Action::AssignAcceleration => {
                args.push((
                    "target",
                    self.either("acceleration", "target", "assign_acceleration(1mpsps)")?,
                ));
            }
            Action::ChangeAcceleration => {
                if self.smooth() {
                    args.push(("rate_profile", Self::smooth_arg()));
                }
                args.push((
                    "target",
                    self.required("target", "change_acceleration(-3mpsps)")?,
                ));
                let jerk = self
                    .bound
                    .get("rate_peak")
                    .cloned()
                    .unwrap_or(CExpr::Const(Value::Num(2.0)));
                args.push(("jerk", jerk));
            }
            _ => {}
        }
        mods.push(self.implicit(ModKind::Accel, self.name, args));
        Ok(())
    }

    /// `change_position(target_xyz | target_odr | target_st)`: the target
    /// as `assign_position`'s place (one of the three, a literal); off the
    /// road network (`on_road_network: false`), in a straight line to it.
    fn change_position(&self, mods: &mut Vec<Modifier>) -> Result<(), ScenarioError> {
        let off_road = matches!(
            self.bound.get("on_road_network"),
            Some(CExpr::Const(Value::Bool(false)))
        );
        match self.bound.get("interpolation") {
            _ if self.enum_arg("interpolation") == Some("smooth") => {
                return self.refuse("interpolation: smooth");
            }
            Some(_) if !off_road => {
                return Err(self.err(format!(
                    "{}(interpolation: …) shapes the way off the road network; on it the lanes are followed (give `on_road_network: false`)",
                    self.name
                )));
            }
            _ => {}
        }
        let kinds = [
            ("target_xyz", "position"),
            ("target_odr", "odr_point"),
            ("target_st", "route_point"),
        ];
        let given: Vec<(&str, &str)> = kinds
            .into_iter()
            .filter(|(k, _)| self.bound.contains_key(*k))
            .collect();
        let [(key, kind)] = given[..] else {
            return Err(self.err(format!(
                "change_position needs one of target_xyz, target_odr, target_st ({} given)",
                if given.is_empty() {
                    "none".to_string()
                } else {
                    given
                        .iter()
                        .map(|(k, _)| *k)
                        .collect::<Vec<_>>()
                        .join(" and ")
                }
            )));
        };
        if !matches!(self.bound.get(key), Some(CExpr::Const(Value::Str(_)))) {
            return Err(self.err(format!("change_position({key}: …) takes a literal")));
        }
        let mut args: Vec<(String, CExpr)> = vec![
            ("kind".into(), CExpr::Const(Value::Str(kind.into()))),
            ("off_road".into(), CExpr::Const(Value::Bool(off_road))),
        ];
        for (k, v) in &self.bound {
            if let Some(field) = k.strip_prefix(key).and_then(|r| r.strip_prefix('.')) {
                args.push((format!("{kind}.{field}"), v.clone()));
            }
        }
        mods.push(Modifier {
            kind: ModKind::AssignPosition,
            name: "change_position".into(),
            args: args.into_iter().collect(),
            at: self.at.to_string(),
        });
        Ok(())
    }
}
