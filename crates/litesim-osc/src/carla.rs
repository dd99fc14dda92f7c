//! CARLA scenario_runner's OSC2 dialect, lowered to litesim's conventions
//! after it has been checked (the checker sees the user's program as
//! written; the elaborator sees litesim's). One tree rewrite, spans kept,
//! so a later error still points at what the user wrote.
//!
//! | CARLA                                   | litesim                                        |
//! |-----------------------------------------|------------------------------------------------|
//! | `scenario top:` (fields, modifiers, do) | `extend top.main:`                             |
//! | `ego_vehicle: Model3`                   | `sut.car` (every `ego_vehicle` renamed)        |
//! | `scenario dut.name:` (no `top`)         | the entry point, `dut` in it renamed `sut.car` |
//! | `path: Path`                            | `path: road`                                   |
//! | `path.set_map("Town04")`                | the test's map: `Town04.xodr` in the map folder |
//! | `path.path_min_driving_lanes(n)`        | `keep(path.min_lanes >= n)`                    |
//! | `path.path_length(lo, hi)`              | `keep(path.length >= lo)`, `keep(path.length <= hi)` |
//! | `path.path_over_junction(…)`            | `keep(path.into_junction == true)`             |
//! | `a.drive(path)`                         | `a.drive()`, plus `along(path, at: start)` in the actor's first drive unless a `position` places it |
//! | `set_position(d)`                       | `along(path, at: start, start_offset: d)`      |
//! | `lane(n)` (numbered from the left)      | `lane(n, from: left)`                          |
//! | `change_speed(v)` (the speed to reach)  | `change_speed(target: v)`                      |
//! | (no simulator profile)                  | `extend sim_info: set profile = "carla-0.9.15"` |
//! | `parallel(duration: t):`                | `parallel(): … with: duration(t)`              |
//!
//! Invariant: lowering never panics on a program that checked, and every
//! construct it cannot translate is a diagnostic (E06xx) at its place.

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::loader::Program;
use crate::source::Span;
use serde::Serialize;
use std::collections::BTreeSet;

/// What lowering found that is not in the tree.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CarlaInfo {
    /// The map `path.set_map("…")` names, and where it says so.
    pub map: Option<(String, Span)>,
}

/// The actor scenario_runner drives as the hero (litesim's `sut.car`).
pub const EGO: &str = "ego_vehicle";

/// The ego's actor type in scenario_runner's library: `scenario
/// dut.name:` is a scenario of the ego, and `dut` in it is the ego.
pub const DUT: &str = "dut";

/// The simulator profile a CARLA scenario runs under (blueprint ids and
/// bounding boxes, 20 Hz) unless it sets one.
pub const PROFILE: &str = "carla-0.9.15";

/// The Path modifiers the dialect knows.
const PATH_MODIFIERS: &[&str] = &[
    "set_map",
    "path_min_driving_lanes",
    "path_length",
    "path_over_junction",
];

fn name(text: &str, span: Span) -> Name {
    Name {
        text: text.into(),
        span,
    }
}

fn ident(text: &str, span: Span) -> Expr {
    Expr::Ident {
        name: text.into(),
        span,
    }
}

fn field(base: Expr, f: &str, span: Span) -> Expr {
    Expr::Field {
        base: Box::new(base),
        name: name(f, span),
        span,
    }
}

fn call(callee: Expr, args: Vec<Arg>, span: Span) -> Expr {
    Expr::Call {
        callee: Box::new(callee),
        args,
        span,
    }
}

fn arg(n: Option<&str>, value: Expr) -> Arg {
    let span = value.span();
    Arg {
        name: n.map(|t| name(t, span)),
        value,
    }
}

fn keep(expr: Expr) -> Member {
    let span = expr.span();
    Member::Keep {
        strength: None,
        expr,
        span,
    }
}

fn binary(op: &str, lhs: Expr, rhs: Expr, span: Span) -> Expr {
    Expr::Binary {
        op: op.into(),
        lhs: Box::new(lhs),
        rhs: Box::new(rhs),
        span,
    }
}

/// `sut.car` at `span`.
fn sut_car(span: Span) -> Expr {
    field(ident("sut", span), "car", span)
}

/// Renames every `ego_vehicle` to `sut.car` in an expression.
fn rename(e: &mut Expr) {
    match e {
        Expr::Ident { name, span } if name == EGO || name == DUT => *e = sut_car(*span),
        Expr::Unary { expr, .. } => rename(expr),
        Expr::Binary { lhs, rhs, .. } => {
            rename(lhs);
            rename(rhs);
        }
        Expr::Ternary {
            cond,
            then,
            otherwise,
            ..
        } => {
            rename(cond);
            rename(then);
            rename(otherwise);
        }
        Expr::Field { base, .. } | Expr::Cast { base, .. } => rename(base),
        Expr::Index { base, index, .. } => {
            rename(base);
            rename(index);
        }
        Expr::Call { callee, args, .. } => {
            rename(callee);
            for a in args {
                rename(&mut a.value);
            }
        }
        Expr::List { items, .. } => items.iter_mut().for_each(rename),
        Expr::Range { lo, hi, .. } => {
            if let Some(x) = lo {
                rename(x);
            }
            if let Some(x) = hi {
                rename(x);
            }
        }
        _ => {}
    }
}

fn rename_spec(s: &mut EventSpec) {
    if let Some(e) = &mut s.event {
        rename(e);
    }
    if let Some(e) = &mut s.cond {
        rename(e);
    }
}

fn rename_member(m: &mut Member) {
    match m {
        Member::Field(f) => {
            if let Some(d) = &mut f.default {
                rename(d);
            }
            f.with.iter_mut().for_each(rename_member);
        }
        Member::Event { is: Some(s), .. } | Member::Until(s) => rename_spec(s),
        Member::Keep { expr, .. } => rename(expr),
        Member::RemoveDefault { path, .. } => rename(path),
        Member::Coverage { args, .. } => args.iter_mut().for_each(|a| rename(&mut a.value)),
        Member::Modifier { call, .. } => rename(call),
        Member::Do(d) => rename_do(d),
        Member::On { event, body } => {
            rename_spec(event);
            body.iter_mut().for_each(rename_do);
        }
        Member::Set { path, value, .. } => {
            rename(path);
            rename(value);
        }
        Member::Event { is: None, .. } | Member::Method { .. } => {}
    }
}

fn rename_do(d: &mut DoMember) {
    match &mut d.kind {
        DoKind::Composition {
            args,
            children,
            with,
            ..
        } => {
            args.iter_mut().for_each(|a| rename(&mut a.value));
            children.iter_mut().for_each(rename_do);
            with.iter_mut().for_each(rename_member);
        }
        DoKind::Invoke { call, with } => {
            rename(call);
            with.iter_mut().for_each(rename_member);
        }
        DoKind::Wait(s) => rename_spec(s),
        DoKind::Emit { event } | DoKind::Call { call: event } => rename(event),
    }
}

/// `base.name(args)` → (base, name, args).
fn member_call(e: &Expr) -> Option<(&Expr, &Name, &[Arg])> {
    match e {
        Expr::Call { callee, args, .. } => match &**callee {
            Expr::Field { base, name, .. } => Some((base, name, args)),
            _ => None,
        },
        _ => None,
    }
}

/// The name of a call's modifier or behaviour (`speed` in `speed(…)` or
/// `a.speed(…)`).
fn call_name(e: &Expr) -> Option<&str> {
    match e {
        Expr::Call { callee, .. } => match &**callee {
            Expr::Field { name, .. } => Some(&name.text),
            Expr::Ident { name, .. } => Some(name),
            _ => None,
        },
        _ => None,
    }
}

/// `target.x == v` for each `keep(default x == v)` of actor type `ty`
/// (litesim's CARLA library: a blueprint's model and bounding box); the
/// blueprint's own, not its bases' (litesim's defaults cover those).
fn type_keeps(prog: &Program, ty: &str, target: &Expr) -> Vec<Member> {
    let mut out = Vec::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            let Decl::Compound {
                kind: DeclKind::Actor,
                name,
                members,
                ..
            } = d
            else {
                continue;
            };
            if name.actor.is_some() || name.name.text != ty {
                continue;
            }
            for m in members {
                if let Member::Keep {
                    strength: Some(st),
                    expr: Expr::Binary { op, lhs, rhs, span },
                    ..
                } = m
                    && st == "default"
                    && op == "=="
                    && let Some(path) = prefixed(lhs, target)
                {
                    out.push(Member::Keep {
                        strength: Some(st.clone()),
                        expr: binary("==", path, (**rhs).clone(), *span),
                        span: *span,
                    });
                }
            }
        }
    }
    out
}

/// `x.y` read as `target.x.y`.
fn prefixed(e: &Expr, target: &Expr) -> Option<Expr> {
    match e {
        Expr::Ident { name, span } => Some(field(target.clone(), name, *span)),
        Expr::Field { base, name, span } => Some(field(prefixed(base, target)?, &name.text, *span)),
        _ => None,
    }
}

/// `a` or `a.b.c` as text.
fn dotted(e: &Expr) -> Option<String> {
    match e {
        Expr::Ident { name, .. } => Some(name.clone()),
        Expr::Field { base, name, .. } => Some(format!("{}.{}", dotted(base)?, name.text)),
        _ => None,
    }
}

struct Lower<'a> {
    paths: &'a BTreeSet<String>,
    /// The first path (what `set_position` and placement refer to when a
    /// drive names none).
    default_path: Option<String>,
    /// Actors already placed (their first drive seen), by name as written.
    placed: BTreeSet<String>,
    diags: Vec<Diagnostic>,
}

impl Lower<'_> {
    fn do_member(&mut self, d: &mut DoMember) {
        match &mut d.kind {
            DoKind::Composition {
                args,
                children,
                with,
                ..
            } => {
                // `parallel(duration: t)`: litesim gives a phase its
                // duration in the `with:` block.
                let mut kept = Vec::new();
                for a in args.drain(..) {
                    if a.name.as_ref().is_some_and(|n| n.text == "duration") {
                        let span = a.value.span();
                        with.push(Member::Modifier {
                            label: None,
                            call: call(ident("duration", span), vec![arg(None, a.value)], span),
                        });
                    } else {
                        kept.push(a);
                    }
                }
                *args = kept;
                children.iter_mut().for_each(|c| self.do_member(c));
            }
            DoKind::Invoke { call: c, with } => self.invoke(c, with),
            _ => {}
        }
    }

    fn invoke(&mut self, c: &mut Expr, with: &mut Vec<Member>) {
        let Expr::Call { callee, args, span } = c else {
            return;
        };
        let span = *span;
        let Expr::Field {
            base, name: verb, ..
        } = &**callee
        else {
            return;
        };
        if !matches!(verb.text.as_str(), "drive" | "walk" | "move") {
            return;
        }
        let Some(actor) = dotted(base) else {
            return;
        };
        // `drive(path)`: the path argument goes; litesim drives on roads.
        let mut path = None;
        let mut kept = Vec::new();
        for a in args.drain(..) {
            match &a.value {
                Expr::Ident { name, .. } if a.name.is_none() && self.paths.contains(name) => {
                    path = Some(name.clone())
                }
                _ => kept.push(a),
            }
        }
        *args = kept;
        let path = path.or_else(|| self.default_path.clone());
        lower_modifier_args(with);
        // `set_position(d)` → `along(path, at: start, start_offset: d)`.
        for m in with.iter_mut() {
            let Member::Modifier { call: mc, .. } = m else {
                continue;
            };
            if call_name(mc) != Some("set_position") {
                continue;
            }
            let Expr::Call { args, span, .. } = mc else {
                continue;
            };
            let at = *span;
            let Some(p) = &path else {
                self.diags.push(Diagnostic::error(
                    "E0606",
                    at,
                    "set_position needs a path: this scenario declares no `Path`",
                ));
                continue;
            };
            let offset = match args.as_slice() {
                [one] => one.value.clone(),
                _ => {
                    self.diags.push(
                        Diagnostic::error(
                            "E0607",
                            at,
                            format!(
                                "set_position takes one argument (the distance along the path), {} given",
                                args.len()
                            ),
                        )
                        .with_hint("e.g. set_position(40m)"),
                    );
                    continue;
                }
            };
            *mc = call(
                ident("along", at),
                vec![
                    arg(None, ident(p, at)),
                    arg(Some("at"), ident("start", at)),
                    arg(Some("start_offset"), offset),
                ],
                at,
            );
        }
        if self.placed.insert(actor) {
            let placed = with.iter().any(|m| {
                matches!(m, Member::Modifier { call, .. }
                    if matches!(call_name(call), Some("position" | "along")))
            });
            if let (false, Some(p)) = (placed, &path) {
                with.push(Member::Modifier {
                    label: None,
                    call: call(
                        ident("along", span),
                        vec![
                            arg(None, ident(p, span)),
                            arg(Some("at"), ident("start", span)),
                        ],
                        span,
                    ),
                });
            }
        }
    }
}

/// The modifiers whose arguments mean another thing in scenario_runner:
/// `lane(n)` counts from the left, `change_speed(v)` is the speed to reach.
fn lower_modifier_args(with: &mut [Member]) {
    // `lane(n)`: CARLA numbers lanes from the left ("left to right:
    // [1..n]"), litesim from the right unless told `from: left`.
    for m in with.iter_mut() {
        if let Member::Modifier {
            call: Expr::Call { callee, args, span },
            ..
        } = m
            && matches!(&**callee, Expr::Ident { name, .. } if name == "lane")
            && args
                .iter()
                .any(|a| a.name.as_ref().is_none_or(|n| n.text == "lane"))
            && !args
                .iter()
                .any(|a| a.name.as_ref().is_some_and(|n| n.text == "from"))
        {
            args.push(arg(Some("from"), ident("left", *span)));
        }
    }
    // `change_speed(v)`: scenario_runner reaches the speed v; the
    // standard's argument is a change from the phase's start speed.
    for m in with.iter_mut() {
        if let Member::Modifier {
            call: Expr::Call { callee, args, .. },
            ..
        } = m
            && matches!(&**callee, Expr::Ident { name, .. } if name == "change_speed")
        {
            for a in args.iter_mut() {
                if a.name.as_ref().is_none_or(|n| n.text == "speed") {
                    let span = a.value.span();
                    a.name = Some(name("target", span));
                }
            }
        }
    }
}

/// The scenarios of the user's files (not litesim's library) declared on
/// actor `on` (`None`: on none) and, when given, named `named`, as (file,
/// declaration) indexes: `scenario top` and `scenario dut.name`.
fn user_scenarios(prog: &Program, on: Option<&str>, named: Option<&str>) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (fi, (id, f)) in prog.files.iter().enumerate() {
        if prog.is_builtin_file(*id) {
            continue;
        }
        for (di, d) in f.decls.iter().enumerate() {
            if let Decl::Compound {
                kind: DeclKind::Scenario,
                name,
                ..
            } = d
                && name.actor.as_ref().map(|a| a.text.as_str()) == on
                && named.is_none_or(|n| name.name.text == n)
            {
                out.push((fi, di));
            }
        }
    }
    out
}

/// The start of the entry file (the last loaded): where a missing entry
/// point is reported.
fn entry_start(prog: &Program) -> Span {
    Span {
        file: prog.files.last().map_or(0, |(id, _)| *id),
        start: 0,
        end: 0,
    }
}

/// Lowers a checked CARLA-dialect program in place (see the module's
/// table); returns the diagnostics of what it could not lower.
pub fn lower(prog: &mut Program) -> Vec<Diagnostic> {
    let mut diags = Vec::new();
    let Some((fi, di)) = entry(prog, &mut diags) else {
        return diags;
    };
    let Decl::Compound { members, .. } = &prog.files[fi].1.decls[di] else {
        return diags;
    };
    let members = members.clone();
    // Paths, the ego.
    let paths: BTreeSet<String> = members
        .iter()
        .filter_map(|m| match m {
            Member::Field(f) if f.ty.base.name.text == "Path" && !f.ty.list => {
                Some(f.names.iter().map(|n| n.text.clone()).collect::<Vec<_>>())
            }
            _ => None,
        })
        .flatten()
        .collect();
    let default_path = members.iter().find_map(|m| match m {
        Member::Field(f) if f.ty.base.name.text == "Path" => {
            f.names.first().map(|n| n.text.clone())
        }
        _ => None,
    });
    // Blueprint actors (`npc: Rubicon`) carry their model and size as
    // type-level `keep(default …)`; litesim reads them per instance.
    let mut blueprint_keeps: Vec<Member> = Vec::new();
    for m in &members {
        let Member::Field(f) = m else { continue };
        for n in &f.names {
            let target = if n.text == EGO {
                sut_car(n.span)
            } else {
                ident(&n.text, n.span)
            };
            blueprint_keeps.extend(type_keeps(prog, &f.ty.base.name.text, &target));
        }
    }
    let (mut out, info) = lower_members(members, &paths, &mut diags);
    out.iter_mut().for_each(rename_member);
    out.extend(blueprint_keeps);
    let mut l = Lower {
        paths: &paths,
        default_path,
        placed: BTreeSet::new(),
        diags: Vec::new(),
    };
    for m in &mut out {
        if let Member::Do(d) = m {
            l.do_member(d);
        }
    }
    diags.append(&mut l.diags);
    let at = top_span(prog, (fi, di));
    prog.files[fi].1.decls[di] = Decl::Extend {
        target: QualName {
            actor: Some(name("top", at)),
            name: name("main", at),
        },
        members: out,
    };
    carla_profile_unless_chosen(prog, fi, at);
    prog.carla = Some(info);
    diags
}

/// The entry scenario's members in litesim's terms: `Path` fields are
/// roads, the ego is sut.car, Path modifiers become road choices (the map
/// and its place go to the `CarlaInfo`); what the dialect does not know is
/// a diagnostic.
fn lower_members(
    members: Vec<Member>,
    paths: &BTreeSet<String>,
    diags: &mut Vec<Diagnostic>,
) -> (Vec<Member>, CarlaInfo) {
    let mut info = CarlaInfo::default();
    let mut map_at: Option<Span> = None;
    let mut out: Vec<Member> = Vec::new();
    for mut m in members {
        match &mut m {
            Member::Field(f) if f.ty.base.name.text == "Path" => {
                f.ty.base.name.text = "road".into();
                out.push(m);
            }
            Member::Field(f) if f.names.iter().any(|n| n.text == EGO) => {
                // The ego is litesim's sut.car; other names declared with
                // it (`ego_vehicle, npc: Model3`) stay actors of their own.
                f.names.retain(|n| n.text != EGO);
                if !f.names.is_empty() {
                    out.push(m);
                }
            }
            Member::Modifier { call: c, .. } => {
                let Some((base, verb, args)) = member_call(c) else {
                    out.push(m);
                    continue;
                };
                let on_path = matches!(base, Expr::Ident { name, .. } if paths.contains(name));
                if !on_path {
                    out.push(m);
                    continue;
                }
                let span = c.span();
                let p = base.clone();
                let prop = |f: &str| field(p.clone(), f, span);
                match verb.text.as_str() {
                    "set_map" => match args {
                        [Arg {
                            value: Expr::Str { value, .. },
                            ..
                        }] => {
                            if let Some(first) = map_at {
                                diags.push(
                                    Diagnostic::error("E0604", span, "the map is set twice")
                                        .with_related(first, "first set here"),
                                );
                            } else {
                                map_at = Some(span);
                                info.map = Some((value.clone(), span));
                            }
                        }
                        _ => diags.push(
                            Diagnostic::error(
                                "E0603",
                                span,
                                "set_map takes the map's name as one string",
                            )
                            .with_hint("e.g. path.set_map(\"Town04\"): Town04.xodr in --map-dir"),
                        ),
                    },
                    "path_min_driving_lanes" => match args {
                        [a] => out.push(keep(binary(
                            ">=",
                            prop("min_lanes"),
                            a.value.clone(),
                            span,
                        ))),
                        _ => diags.push(
                            Diagnostic::error(
                                "E0605",
                                span,
                                format!(
                                    "path_min_driving_lanes takes one argument (a lane count), {} given",
                                    args.len()
                                ),
                            )
                            .with_hint("e.g. path.path_min_driving_lanes(2)"),
                        ),
                    },
                    "path_length" => path_length(args, &prop, span, (&mut out, diags)),
                    "path_over_junction" => out.push(keep(binary(
                        "==",
                        prop("into_junction"),
                        Expr::Bool { value: true, span },
                        span,
                    ))),
                    other => diags.push(
                        Diagnostic::error(
                            "E0605",
                            verb.span,
                            format!("litesim's CARLA dialect does not know Path.{other}"),
                        )
                        .with_hint(format!("it knows: {}", PATH_MODIFIERS.join(", "))),
                    ),
                }
            }
            _ => out.push(m),
        }
    }
    (out, info)
}

/// `path.path_length(min[, max])` (or `min:`/`max:`): keeps on the road's
/// length; a call with neither, or more than two positional arguments, is
/// a diagnostic.
fn path_length(
    args: &[Arg],
    prop: &dyn Fn(&str) -> Expr,
    span: Span,
    (out, diags): (&mut Vec<Member>, &mut Vec<Diagnostic>),
) {
    let named = |n: &str| {
        args.iter()
            .find(|a| a.name.as_ref().is_some_and(|x| x.text == n))
    };
    let positional: Vec<&Arg> = args.iter().filter(|a| a.name.is_none()).collect();
    let lo = named("min").or(positional.first().copied());
    let hi = named("max").or(positional.get(1).copied());
    if lo.is_none() && hi.is_none() || positional.len() > 2 {
        diags.push(
            Diagnostic::error(
                "E0605",
                span,
                "path_length takes a minimum and an optional maximum length",
            )
            .with_hint("e.g. path.path_length(100m, 300m)"),
        );
    }
    if let Some(a) = lo {
        out.push(keep(binary(">=", prop("length"), a.value.clone(), span)));
    }
    if let Some(a) = hi {
        out.push(keep(binary("<=", prop("length"), a.value.clone(), span)));
    }
}

/// Where the compound declaration (file `fi`, declaration `di`) is named.
fn top_span(prog: &Program, (fi, di): (usize, usize)) -> Span {
    match &prog.files[fi].1.decls[di] {
        Decl::Compound { name, .. } => name.name.span,
        _ => Span::default(),
    }
}

/// The program's entry point, (file, declaration): `scenario top` in the
/// user's files, else the one scenario declared on the ego; none (with a
/// diagnostic) when there is none, several, or `top` twice.
fn entry(prog: &Program, diags: &mut Vec<Diagnostic>) -> Option<(usize, usize)> {
    // The entry point: `scenario top` in the user's files; without one,
    // the one scenario declared on the ego (`scenario dut.name:`).
    let mut tops = user_scenarios(prog, None, Some("top"));
    if tops.is_empty() {
        tops = user_scenarios(prog, Some(DUT), None);
        if tops.len() > 1 {
            let names: Vec<String> = tops
                .iter()
                .map(|&(fi, di)| match &prog.files[fi].1.decls[di] {
                    Decl::Compound { name, .. } => format!("dut.{}", name.name.text),
                    _ => String::new(),
                })
                .collect();
            diags.push(
                Diagnostic::error(
                    "E0601",
                    entry_start(prog),
                    format!(
                        "a CARLA program without `scenario top:` runs its one scenario of the ego, and this one declares {}: {}",
                        names.len(),
                        names.join(", ")
                    ),
                )
                .with_hint("add `scenario top:` that invokes the one to run, or keep one per file"),
            );
            return None;
        }
    }
    let Some(&(fi, di)) = tops.first() else {
        diags.push(
            Diagnostic::error(
                "E0601",
                entry_start(prog),
                "a CARLA scenario needs `scenario top:` (scenario_runner's entry point) or one `scenario dut.name:`",
            )
            .with_hint("or run it as a litesim program: --dialect litesim"),
        );
        return None;
    };
    if let Some(&second) = tops.get(1) {
        diags.push(
            Diagnostic::error(
                "E0602",
                top_span(prog, second),
                "'scenario top' is declared twice",
            )
            .with_related(top_span(prog, (fi, di)), "first declared here"),
        );
        return None;
    }
    Some((fi, di))
}

/// CARLA's blueprints and step: litesim's CARLA profile, unless the
/// program chose a profile itself (an `extend sim_info` setting it).
fn carla_profile_unless_chosen(prog: &mut Program, fi: usize, at: Span) {
    let chose = prog.files.iter().any(|(_, f)| {
        f.decls.iter().any(|d| {
            matches!(d, Decl::Extend { target, members }
                if target.actor.is_none() && target.name.text == "sim_info"
                    && members.iter().any(|m| matches!(m, Member::Set { path: Expr::Ident { name, .. }, .. } if name == "profile")))
        })
    });
    if !chose {
        prog.files[fi].1.decls.push(Decl::Extend {
            target: QualName {
                actor: None,
                name: name("sim_info", at),
            },
            members: vec![Member::Set {
                path: ident("profile", at),
                value: Expr::Str {
                    value: PROFILE.into(),
                    span: at,
                },
                span: at,
            }],
        });
    }
}
