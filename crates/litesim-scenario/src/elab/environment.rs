//! The environment's actions (`environment.rain(…)`, …): a change of the
//! weather, the sun or the time of day at the action's time. Elaboration
//! vets the action and its arguments; the plan evaluates them and the
//! runtime hands them to the simulator (docs/osc-stdlib.md).

use super::*;

/// The environment actions litesim runs, each with the parameters it
/// needs (at least one of them for `air`).
const ACTIONS: [(&str, &[&str]); 8] = [
    ("air", &[]),
    ("rain", &["intensity"]),
    ("snow", &["intensity"]),
    ("wind", &["speed"]),
    ("fog", &["visual_range"]),
    ("clouds", &["cloudiness"]),
    ("assign_celestial_position", &["azimuth", "elevation"]),
    ("time_of_day", &["time"]),
];

impl Elab<'_> {
    /// Whether `b` (the base of a call) is the environment: the global
    /// `environment` or a field of that type.
    pub(super) fn is_environment(&self, b: &Expr, sc: &Scope) -> bool {
        if let Expr::Ident { name, .. } = b
            && !sc.fields.contains(name)
            && let Some(t) = self.lib.ix.globals.get(name)
        {
            return self.lib.is_a(&t.base.name.text, "environment");
        }
        match self.path(b, sc) {
            Some(CExpr::Var(p)) => self
                .test
                .vars
                .get(&p)
                .is_some_and(|v| self.lib.is_a(&v.type_name, "environment")),
            _ => false,
        }
    }

    /// `environment.NAME(args)` at `at`: the change it makes.
    pub(super) fn environment_action(
        &self,
        name: &str,
        args: &[Arg],
        sc: &Scope,
        at: String,
    ) -> Result<Node, ScenarioError> {
        let err =
            |what: String| ScenarioError::Elaboration(format!("{at}: environment.{name}: {what}"));
        let Some((_, needs)) = ACTIONS.iter().find(|(n, _)| *n == name) else {
            return Err(ScenarioError::Elaboration(format!(
                "{at}: the engine cannot execute environment.{name} (environment actions: {})",
                ACTIONS.map(|(n, _)| n).join(", ")
            )));
        };
        let params = self.lib.params(name);
        let args = self.bind(args, &params, sc);
        for p in *needs {
            if !args.contains_key(*p) {
                return Err(err(format!("needs its {p}")));
            }
        }
        if args.is_empty() {
            return Err(err(format!(
                "sets nothing: give at least one of {}",
                params.join(", ")
            )));
        }
        if let Some(CExpr::Const(Value::Enum(l))) = args.get("light_source")
            && l != "sun"
        {
            return Err(err(format!(
                "light_source: {l} is not supported by litesim (the simulator has a sun only)"
            )));
        }
        Ok(Node::Environment {
            id: 0,
            action: name.to_string(),
            args,
            at,
        })
    }
}
