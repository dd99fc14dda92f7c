//! CARLA's dialect: a file's own declarations take precedence over
//! litesim's built-in library.
//!
//! scenario_runner's library declares its own physical types, units,
//! actors and modifiers (`type velocity is SI(m: 1, s: -1)`, `unit kmph`,
//! `actor dut`, `modifier Path.set_map`). Read as written, they meet
//! litesim's built-in declarations of the same names. A redeclaration is
//! not an error there:
//!
//! - one that matches (same SI exponents and factor; the same kind and a
//!   compatible base) is used silently;
//! - a physical type or unit that differs is used, with warning W0212
//!   naming both definitions (and, for a unit of ASAM's standard library,
//!   what ASAM defines);
//! - an actor, struct or behaviour of another kind, or with a base that is
//!   not of the built-in base's kind, adds its members to litesim's, whose
//!   kind and base stay (litesim's library and runtime are written against
//!   them), with warning W0212 saying so.
//!
//! Two declarations of one name in the user's own files remain an error,
//! and outside the dialect nothing here applies.

use crate::ast::{Name, QualName};
use crate::diag::Diagnostic;
use crate::index::Dimension;
use crate::loader::Program;
use crate::source::Span;

/// Units of ASAM's standard library (§4.1) and their factors to SI: what a
/// warning about a redefined unit quotes.
const ASAM_UNITS: &[(&str, f64)] = &[
    ("m", 1.0),
    ("meter", 1.0),
    ("km", 1000.0),
    ("cm", 0.01),
    ("s", 1.0),
    ("second", 1.0),
    ("ms", 0.001),
    ("min", 60.0),
    ("minute", 60.0),
    ("h", 3600.0),
    ("hour", 3600.0),
    ("mps", 1.0),
    ("kph", 1.0 / 3.6),
    ("kmph", 1.0 / 3.6),
    ("mph", 0.44704),
    ("mpsps", 1.0),
    ("rad", 1.0),
    ("deg", std::f64::consts::PI / 180.0),
    ("degree", std::f64::consts::PI / 180.0),
    ("radps", 1.0),
    ("degps", std::f64::consts::PI / 180.0),
    ("kg", 1.0),
    ("ton", 1000.0),
];

/// Whether the declaration at `later` is a CARLA-dialect file's own
/// redeclaration of litesim's built-in declaration at `first`: then it
/// takes precedence instead of being a redefinition error.
pub(crate) fn overrides(prog: &Program, first: Span, later: Span) -> bool {
    // scenario_runner's `basic.osc` counts as the program's own file when
    // litesim supplies it (its units restate some of the domain's: `h`).
    let carla_basic = |file: u32| {
        prog.sources.files.get(file as usize).is_some_and(|f| {
            f.path == crate::builtin::path_of(crate::builtin::CARLA_BASIC).to_string_lossy()
        })
    };
    prog.dialect == crate::Dialect::Carla
        && prog.is_builtin_file(first.file)
        && (!prog.is_builtin_file(later.file)
            || (carla_basic(later.file) && !carla_basic(first.file)))
}

fn si(dim: &Dimension) -> String {
    let parts: Vec<String> = dim.iter().map(|(b, e)| format!("{b}: {e}")).collect();
    format!("SI({})", parts.join(", "))
}

fn differs(at: Span, msg: String, first: Span) -> Diagnostic {
    Diagnostic::warning("W0212", at, msg)
        .with_hint("this program's declaration is used; rename it to keep litesim's")
        .with_related(first, "litesim's built-in declaration")
}

/// A physical type redeclared with other SI exponents (W0212), or nothing.
pub(crate) fn physical_type(
    name: &Name,
    dim: &Dimension,
    first: Span,
    first_dim: &Dimension,
) -> Option<Diagnostic> {
    (dim != first_dim).then(|| {
        differs(
            name.span,
            format!(
                "physical type '{}' is {} here, {} in litesim's library",
                name.text,
                si(dim),
                si(first_dim)
            ),
            first,
        )
    })
}

/// A unit: its SI exponents and factor.
pub(crate) type UnitDef = (Dimension, f64);

/// `1 rad`, `1 m·s^-1`: a value in the SI units of a dimension, with six
/// significant digits.
fn in_si(value: f64, dim: &Dimension) -> String {
    let unit: Vec<String> = dim
        .iter()
        .map(|(b, e)| {
            if *e == 1 {
                b.clone()
            } else {
                format!("{b}^{e}")
            }
        })
        .collect();
    let v = format!("{value:.6e}").parse::<f64>().unwrap_or(value);
    if unit.is_empty() {
        format!("{v}")
    } else {
        format!("{v} {}", unit.join("·"))
    }
}

/// A unit redeclared with another dimension or factor (W0212; the factor
/// compared to 1 part in a million, as libraries write 1/3.6 to a few
/// digits), or nothing.
pub(crate) fn unit(
    name: &Name,
    def: &UnitDef,
    first: Span,
    first_def: &UnitDef,
) -> Option<Diagnostic> {
    let same_factor = (def.1 - first_def.1).abs() <= 1e-6 * def.1.abs().max(first_def.1.abs());
    if def.0 == first_def.0 && same_factor {
        return None;
    }
    let n = &name.text;
    let mut msg = format!(
        "unit '{n}' is {} here, {} in litesim's library",
        in_si(def.1, &def.0),
        in_si(first_def.1, &first_def.0)
    );
    if let Some((_, f)) = ASAM_UNITS.iter().find(|(u, _)| u == n) {
        msg.push_str(&format!(
            " (ASAM's standard library defines 1{n} as {})",
            in_si(*f, &first_def.0)
        ));
    }
    Some(differs(name.span, msg, first).with_hint(format!(
        "this program's declaration is used: 1{n} is {} here; rename it to keep litesim's",
        in_si(def.1, &def.0)
    )))
}

/// A compound redeclared as another kind, or with a base that is neither
/// litesim's nor of its kind (W0212), or nothing. Unlike a unit or a
/// type, litesim keeps its own kind and base then (its library and
/// runtime are written against them) and adds the file's members; the
/// warning says so. `is_a` tells whether one type inherits another in the
/// program as loaded.
pub(crate) fn compound(
    name: &QualName,
    what: &str,
    base: Option<&str>,
    first: Span,
    first_what: &str,
    first_base: Option<&str>,
    is_a: &dyn Fn(&str, &str) -> bool,
) -> Option<Diagnostic> {
    let shown = &name.name.text;
    let kept = |msg: String| {
        Diagnostic::warning("W0212", name.name.span, msg)
            .with_hint("litesim's declaration is kept (its library and runtime are written against it) and the members declared here are added to it; rename this one to declare a type of your own")
            .with_related(first, "litesim's built-in declaration")
    };
    if what != first_what {
        return Some(kept(format!(
            "'{shown}' is {what} here, {first_what} in litesim's library"
        )));
    }
    match (base, first_base) {
        (Some(b), Some(fb)) if b != fb && !is_a(b, fb) => Some(kept(format!(
            "'{shown}' inherits '{b}' here, '{fb}' in litesim's library, and '{b}' is not a kind of '{fb}'"
        ))),
        _ => None,
    }
}
