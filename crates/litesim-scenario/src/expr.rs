//! Expressions over actors' states, in one place: the evaluator that
//! `wait`/`until` conditions (on the plan while planning, on the simulated
//! state in closed loop) and coverage items share, the one table of actor
//! fields they read, the rise/fall edge detector and the printer used in
//! messages.
//!
//! What an expression reads comes through a [`Scope`]: the planner's scope
//! reads the planned samples, the runtime's the simulated world, coverage's
//! the live actors with their boxes. A scope that cannot show something
//! (a planned lane, a parameter in a condition) answers `None`, and the
//! expression is then "not evaluable there" rather than false.

use crate::elab::{CExpr, Value};
use std::collections::BTreeMap;

/// An actor attribute an expression can read (`a.speed`, …).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// `speed` (m/s).
    Speed,
    /// `acceleration` (m/s²).
    Acceleration,
    /// `position.x` (m).
    X,
    /// `position.y` (m).
    Y,
    /// `yaw` (rad).
    Yaw,
    /// `lane` (the map's lane id).
    Lane,
}

/// The attribute suffixes, in the order they are tried.
const FIELDS: [(&str, Field); 6] = [
    (".speed", Field::Speed),
    (".acceleration", Field::Acceleration),
    (".position.x", Field::X),
    (".position.y", Field::Y),
    (".yaw", Field::Yaw),
    (".lane", Field::Lane),
];

/// Splits `actor.field` into the actor's path and the field, when the path
/// ends in one of the readable attributes.
pub fn field_of(path: &str) -> Option<(&str, Field)> {
    FIELDS
        .iter()
        .find_map(|(suffix, f)| path.strip_suffix(suffix).map(|a| (a, *f)))
}

/// A measure between two actors: `a.gap_to(b)` or `a.ttc_to(b)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pair {
    /// Box-to-box distance (m).
    Gap,
    /// Time to collision (s).
    Ttc,
}

/// What an expression can read. Ids are actor ids (paths are mapped to ids
/// before a scope is asked).
pub trait Scope {
    /// An actor's attribute; `None` when the actor or the attribute is not
    /// known here.
    fn field(&self, id: &str, field: Field) -> Option<f64>;
    /// A measure between two actors; `None` by default.
    fn pair(&self, _pair: Pair, _a: &str, _b: &str) -> Option<f64> {
        None
    }
    /// A scenario parameter's value; `None` by default.
    fn param(&self, _path: &str) -> Option<&Value> {
        None
    }
}

/// What an expression evaluates to.
#[derive(Clone, Debug, PartialEq)]
pub enum Val {
    /// A number (SI units).
    Num(f64),
    /// A truth value.
    Bool(bool),
    /// An enum member or a string.
    Word(String),
}

/// An actor path as the scope's id: its id when `ids` knows the path, else
/// the path itself (`sut.car` is its own id).
fn id_of<'a>(ids: &'a BTreeMap<String, String>, path: &'a str) -> &'a str {
    ids.get(path).map_or(path, String::as_str)
}

/// Evaluates `e` in `scope`. `None`: it reads something the scope cannot
/// show, or applies an operator to values it does not take.
pub fn value(e: &CExpr, ids: &BTreeMap<String, String>, scope: &dyn Scope) -> Option<Val> {
    let num = |e: &CExpr| match value(e, ids, scope)? {
        Val::Num(x) => Some(x),
        _ => None,
    };
    let truth = |e: &CExpr| match value(e, ids, scope)? {
        Val::Bool(b) => Some(b),
        _ => None,
    };
    Some(match e {
        CExpr::Const(Value::Num(x)) => Val::Num(*x),
        CExpr::Const(Value::Bool(b)) => Val::Bool(*b),
        CExpr::Const(Value::Enum(w) | Value::Str(w)) => Val::Word(w.clone()),
        CExpr::Unary(op, x) if op == "-" => Val::Num(-num(x)?),
        CExpr::Unary(op, x) if op == "not" => Val::Bool(!truth(x)?),
        CExpr::Binary(op, a, b) if op == "gap_to" || op == "ttc_to" => {
            let (CExpr::Var(a), CExpr::Var(b)) = (&**a, &**b) else {
                return None;
            };
            let pair = if op == "gap_to" { Pair::Gap } else { Pair::Ttc };
            Val::Num(scope.pair(pair, id_of(ids, a), id_of(ids, b))?)
        }
        CExpr::Binary(op, a, b) if op == "and" || op == "or" => {
            // Both sides are evaluated: one the scope cannot show makes the
            // whole condition not evaluable, whatever the other says.
            let (a, b) = (truth(a)?, truth(b)?);
            Val::Bool(if op == "and" { a && b } else { a || b })
        }
        CExpr::Binary(op, a, b) => {
            let (a, b) = (num(a)?, num(b)?);
            match op.as_str() {
                "+" => Val::Num(a + b),
                "-" => Val::Num(a - b),
                "*" => Val::Num(a * b),
                "/" => Val::Num(a / b),
                "<" => Val::Bool(a < b),
                "<=" => Val::Bool(a <= b),
                ">" => Val::Bool(a > b),
                ">=" => Val::Bool(a >= b),
                "==" => Val::Bool((a - b).abs() < 1e-9),
                "!=" => Val::Bool((a - b).abs() >= 1e-9),
                _ => return None,
            }
        }
        CExpr::Var(path) => {
            if let Some(v) = scope.param(path) {
                return value(&CExpr::Const(v.clone()), ids, scope);
            }
            let (actor, f) = field_of(path)?;
            Val::Num(scope.field(id_of(ids, actor), f)?)
        }
        _ => return None,
    })
}

/// Whether a condition holds in `scope`; `None` when it cannot be
/// evaluated there or is not a truth value.
pub fn truth(e: &CExpr, ids: &BTreeMap<String, String>, scope: &dyn Scope) -> Option<bool> {
    match value(e, ids, scope)? {
        Val::Bool(b) => Some(b),
        _ => None,
    }
}

/// How a condition fires over time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// Whenever it holds.
    Hold,
    /// `rise(c)`: when it becomes true.
    Rise,
    /// `fall(c)`: when it becomes false.
    Fall,
}

impl Edge {
    /// The edge of a condition and the condition under it.
    pub fn of(c: &CExpr) -> (Edge, &CExpr) {
        match c {
            CExpr::Unary(op, x) if op == "rise" => (Edge::Rise, &**x),
            CExpr::Unary(op, x) if op == "fall" => (Edge::Fall, &**x),
            c => (Edge::Hold, c),
        }
    }

    /// Whether the condition fires now, given its truth at the previous
    /// look (`None`: not looked at before; an edge needs a previous look).
    pub fn fires(self, before: Option<bool>, now: bool) -> bool {
        match self {
            Edge::Rise => before == Some(false) && now,
            Edge::Fall => before == Some(true) && !now,
            Edge::Hold => now,
        }
    }
}

/// An expression as text, for messages and summaries.
pub fn show(e: &CExpr) -> String {
    match e {
        CExpr::Const(Value::Num(v)) => format!("{v}"),
        CExpr::Const(v) => format!("{v:?}"),
        CExpr::Var(p) => p.clone(),
        CExpr::Unary(op, x) => format!("{op}({})", show(x)),
        CExpr::Binary(op, a, b) => format!("{} {op} {}", show(a), show(b)),
        CExpr::Range(a, b) => format!(
            "[{}..{}]",
            a.map_or(String::new(), |v| v.to_string()),
            b.map_or(String::new(), |v| v.to_string())
        ),
        other => format!("{other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Two;
    impl Scope for Two {
        fn field(&self, id: &str, f: Field) -> Option<f64> {
            match (id, f) {
                ("a", Field::Speed) => Some(10.0),
                ("b", Field::Speed) => Some(4.0),
                ("a", Field::X) => Some(1.0),
                _ => None,
            }
        }
    }

    fn var(p: &str) -> Box<CExpr> {
        Box::new(CExpr::Var(p.into()))
    }
    fn num(v: f64) -> Box<CExpr> {
        Box::new(CExpr::Const(Value::Num(v)))
    }
    fn bin(op: &str, a: Box<CExpr>, b: Box<CExpr>) -> Box<CExpr> {
        Box::new(CExpr::Binary(op.into(), a, b))
    }

    #[test]
    fn fields_are_read_through_ids_and_compared() {
        let ids = BTreeMap::from([("x.car".to_string(), "a".to_string())]);
        let e = bin(">", var("x.car.speed"), bin("*", num(2.0), var("b.speed")));
        assert_eq!(truth(&e, &ids, &Two), Some(true));
        let e = bin("-", var("x.car.position.x"), num(3.0));
        assert_eq!(value(&e, &ids, &Two), Some(Val::Num(-2.0)));
    }

    #[test]
    fn what_the_scope_cannot_show_is_not_evaluable_not_false() {
        let ids = BTreeMap::new();
        // b's position is unknown: the `or` is not evaluable even though
        // its other side holds.
        let e = bin(
            "or",
            bin(">", var("a.speed"), num(1.0)),
            bin(">", var("b.position.x"), num(0.0)),
        );
        assert_eq!(truth(&e, &ids, &Two), None);
        assert_eq!(value(&bin("gap_to", var("a"), var("b")), &ids, &Two), None);
        assert_eq!(value(&var("a.colour"), &ids, &Two), None);
    }

    #[test]
    fn edges_need_a_previous_look() {
        let c = CExpr::Unary("rise".into(), var("a.speed"));
        let (edge, inner) = Edge::of(&c);
        assert_eq!(edge, Edge::Rise);
        assert_eq!(show(inner), "a.speed");
        assert!(!Edge::Rise.fires(None, true));
        assert!(Edge::Rise.fires(Some(false), true));
        assert!(Edge::Fall.fires(Some(true), false));
        assert!(!Edge::Fall.fires(Some(false), false));
        assert!(Edge::Hold.fires(None, true));
        assert_eq!(show(&c), "rise(a.speed)");
    }
}
