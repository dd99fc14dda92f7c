//! Passes over the whole program: redefinitions, inheritance, conditional
//! bases, behaviours' `do`s, declarations made once, units given twice.

use super::*;

/// Modifiers live in their own namespace (`lane` is both a struct and a
/// modifier in the domain model).
/// The name and arguments of `name(args)` or `x.name(args)`.
/// What is wrong with `name` (of `kind`) inheriting from the known `base`:
/// another kind of declaration (E0338), or a cycle back to `name` (E0339,
/// reported at the cycle's alphabetically first member only).
pub(super) fn inheritance_problem(
    m: &Model,
    kind: DeclKind,
    name: &str,
    base: &str,
) -> Option<(&'static str, String, String)> {
    let kind_of = |k: DeclKind| format!("{k:?}").to_lowercase();
    if kind != DeclKind::Modifier
        && let Some(b) = m.compounds.get(base)
        && b.0 != kind
    {
        return Some((
            "E0338",
            format!(
                "{} '{name}' cannot inherit from {} '{base}'",
                kind_of(kind),
                kind_of(b.0)
            ),
            {
                let k = kind_of(kind);
                let a = if k.starts_with(['a', 'e', 'i', 'o', 'u']) {
                    "an"
                } else {
                    "a"
                };
                format!("{a} {k} inherits from another {k}")
            },
        ));
    }
    let mut path = vec![name.to_string()];
    let mut cur = Some(base.to_string());
    while let Some(n) = cur {
        if n == name {
            if path.iter().any(|p| p.as_str() < name) {
                return None;
            }
            path.push(n);
            return Some((
                "E0339",
                format!("inheritance cycle: {}", path.join(" → ")),
                "a type cannot inherit from itself, directly or not".into(),
            ));
        }
        if path.contains(&n) || path.len() > 64 {
            // A cycle that does not pass through `name`: its own members report it.
            return None;
        }
        cur = m.compounds.get(&n).and_then(|c| c.2.clone());
        path.push(n);
    }
    None
}

/// Names defined twice (E0330–E0336), each with where it was first
/// defined: enum types, enum members (an `extend` included), enum values
/// that do not increase, physical types, units, SI base exponents, and the
/// members of one compound (its own and its `extend`s').
pub(super) fn redefinitions(prog: &Program, out: &mut Vec<Diagnostic>) {
    let mut enums: BTreeMap<String, Span> = BTreeMap::new();
    let mut enum_members: BTreeMap<String, BTreeMap<String, Span>> = BTreeMap::new();
    let mut enum_last: BTreeMap<String, i128> = BTreeMap::new();
    let mut physical: BTreeMap<String, (Span, Dimension)> = BTreeMap::new();
    let mut units: BTreeMap<String, (Span, precedence::UnitDef)> = BTreeMap::new();
    let mut globals: BTreeMap<String, Span> = BTreeMap::new();
    // (compound key) → member name → first span
    let mut members: BTreeMap<String, BTreeMap<String, Span>> = BTreeMap::new();
    let mut member_names = |key: String, ms: &[Member], out: &mut Vec<Diagnostic>| {
        let seen = members.entry(key.clone()).or_default();
        for m in ms {
            let names: Vec<&Name> = match m {
                Member::Field(f) => f.names.iter().collect(),
                Member::Event { name, .. } => vec![name],
                Member::Method { name, .. } => vec![name],
                _ => continue,
            };
            for n in names {
                if let Some(first) = first_place(seen, n) {
                    if precedence::overrides(prog, first, n.span) {
                        seen.insert(n.text.clone(), n.span);
                        continue;
                    }
                    out.push(twice(
                        "E0336",
                        n.span,
                        format!("'{}' is defined twice in '{key}'", n.text),
                        first,
                        "rename one of them; an `extend` adds members, it cannot redefine one",
                    ));
                }
            }
        }
    };
    for (_, f) in &prog.files {
        for d in &f.decls {
            match d {
                Decl::Enum { name, members: ms } | Decl::ExtendEnum { name, members: ms } => {
                    let builtin_enum = enums
                        .get(&name.text)
                        .is_some_and(|first| precedence::overrides(prog, *first, name.span));
                    if builtin_enum {
                        // CARLA's dialect: the file's enum adds to litesim's.
                        enums.insert(name.text.clone(), name.span);
                    } else if matches!(d, Decl::Enum { .. })
                        && let Some(first) = first_place(&mut enums, name)
                    {
                        out.push(twice(
                            "E0330",
                            name.span,
                            format!("enum '{}' is defined twice", name.text),
                            first,
                            "use `extend` to add members to an enum",
                        ));
                    }
                    enum_values(prog, name, ms, (&mut enum_members, &mut enum_last), out);
                }
                Decl::PhysicalType { name, si } => {
                    let dim = dimension(si);
                    match physical.get(&name.text) {
                        Some((first, first_dim))
                            if precedence::overrides(prog, *first, name.span) =>
                        {
                            out.extend(precedence::physical_type(name, &dim, *first, first_dim));
                            physical.insert(name.text.clone(), (name.span, dim));
                        }
                        Some((first, _)) => out.push(twice(
                            "E0333",
                            name.span,
                            format!("physical type '{}' is defined twice", name.text),
                            *first,
                            "one `type … is SI(…)` per physical type",
                        )),
                        None => {
                            physical.insert(name.text.clone(), (name.span, dim));
                        }
                    }
                    si_twice(si, out);
                }
                Decl::Unit { name, args, .. } => unit_twice(prog, name, args, &mut units, out),
                Decl::Compound {
                    name,
                    members: ms,
                    kind,
                    ..
                } if *kind != DeclKind::Modifier => member_names(qual_key(name), ms, out),
                Decl::Extend {
                    target,
                    members: ms,
                } => member_names(qual_key(target), ms, out),
                Decl::Global(f) => {
                    for n in &f.names {
                        if let Some(first) = first_place(&mut globals, n) {
                            out.push(twice(
                                "E0352",
                                n.span,
                                format!("global '{}' is defined twice", n.text),
                                first,
                                "a global parameter is defined once: set its value with `keep` where it is used",
                            ));
                        }
                    }
                }
                _ => {}
            }
        }
    }
    behaviour_dos(prog, out);
    conditional_bases(prog, out);
    inherited_redefinitions(prog, &members, out);
}

/// A unit defined twice (unit names are global), unless a file of CARLA's
/// dialect restates litesim's; a unit that gives an SI factor twice.
fn unit_twice(
    prog: &Program,
    name: &Name,
    args: &[Arg],
    units: &mut BTreeMap<String, (Span, precedence::UnitDef)>,
    out: &mut Vec<Diagnostic>,
) {
    let def = (dimension(args), crate::index::factor(args));
    match units.get(&name.text) {
        Some((first, first_def)) if precedence::overrides(prog, *first, name.span) => {
            out.extend(precedence::unit(name, &def, *first, first_def));
            units.insert(name.text.clone(), (name.span, def));
        }
        Some((first, _)) => out.push(twice(
            "E0334",
            name.span,
            format!("unit '{}' is defined twice", name.text),
            *first,
            "unit names are global: pick another name",
        )),
        None => {
            units.insert(name.text.clone(), (name.span, def));
        }
    }
    si_twice(args, out);
}

/// Per enum or compound: each name and where it is first defined.
type FirstPlaces = BTreeMap<String, BTreeMap<String, Span>>;

/// An error for a name defined twice, pointing at the first place.
fn twice(code: &'static str, span: Span, what: String, first: Span, hint: &str) -> Diagnostic {
    Diagnostic::error(code, span, what)
        .with_hint(hint)
        .with_related(first, "first defined here")
}

/// An enum's members (`ms`, in a declaration or an extension of enum
/// `name`): each once, values strictly increasing across all of the
/// enum's declarations (`enum_members`, `enum_last` carry what came
/// before).
fn enum_values(
    prog: &Program,
    name: &Name,
    ms: &[(Name, Option<Expr>)],
    (enum_members, enum_last): (&mut FirstPlaces, &mut BTreeMap<String, i128>),
    out: &mut Vec<Diagnostic>,
) {
    let seen = enum_members.entry(name.text.clone()).or_default();
    for (m, value) in ms {
        if let Some(first) = first_place(seen, m) {
            if precedence::overrides(prog, first, m.span) {
                continue; // the same member, as litesim's library has it
            }
            out.push(twice(
                "E0331",
                m.span,
                format!("'{}' is a member of enum '{}' twice", m.text, name.text),
                first,
                "each member once",
            ));
            continue;
        }
        // Values strictly increase: explicit ones as
        // written, implicit ones one above the last.
        let last = enum_last.get(&name.text).copied();
        let v = match value {
            Some(Expr::Int { value, .. }) => *value,
            _ => last.map_or(0, |l| l + 1),
        };
        if let (Some(l), Some(e)) = (last, value)
            && v <= l
        {
            out.push(
                Diagnostic::error(
                    "E0332",
                    e.span(),
                    format!(
                        "'{}' = {v} in enum '{}' does not increase (the member before is {l})",
                        m.text, name.text
                    ),
                )
                .with_hint("enum values must be strictly increasing"),
            );
        }
        enum_last.insert(name.text.clone(), v.max(last.unwrap_or(i128::MIN)));
    }
}

/// A member may not redefine one its type inherits (§3.5): the first
/// ancestor that defines the name is the other place; a method may be
/// overridden with `only` and the same signature (§3.10). `members`: each
/// compound's own member names and where they are first defined.
fn inherited_redefinitions(prog: &Program, members: &FirstPlaces, out: &mut Vec<Diagnostic>) {
    // A member may not redefine one its type inherits (§3.5): the first
    // ancestor that defines the name is the other place.
    let mut bases: BTreeMap<String, String> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((base, _)),
                ..
            } = d
            {
                bases
                    .entry(qual_key(name))
                    .or_insert_with(|| qual_key(base));
            }
        }
    }
    // Methods' signatures and `only`, for overrides (§3.10).
    let mut methods: BTreeMap<(String, String), (String, bool)> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            let (key, ms) = match d {
                Decl::Compound {
                    name,
                    members: ms,
                    kind,
                    ..
                } if *kind != DeclKind::Modifier => (qual_key(name), ms),
                Decl::Extend {
                    target,
                    members: ms,
                } => (qual_key(target), ms),
                _ => continue,
            };
            for m in ms {
                if let Member::Method {
                    name,
                    params,
                    ret,
                    only,
                    ..
                } = m
                {
                    methods
                        .entry((key.clone(), name.text.clone()))
                        .or_insert((signature(params, ret.as_ref()), *only));
                }
            }
        }
    }
    for (key, own) in members {
        for (name, span) in own {
            // The bases, nearest first; an inheritance cycle (E0339
            // reports it) ends the walk where it comes back.
            let ancestors = crate::index::lineage(key, |c| bases.get(c).map(String::as_str))
                .skip(1)
                .take_while(|b| *b != key.as_str());
            for b in ancestors {
                if let Some(first) = members.get(b).and_then(|m| m.get(name)) {
                    let mine = methods.get(&(key.clone(), name.clone()));
                    let theirs = methods.get(&(b.to_string(), name.clone()));
                    if let (Some((sig, only)), Some((base_sig, _))) = (mine, theirs) {
                        // A method may be overridden: with `only` and the
                        // same signature.
                        let problem = if !only {
                            Some(format!(
                                "'{name}' in '{key}' overrides the method it inherits from '{b}' without `only`"
                            ))
                        } else if sig != base_sig {
                            Some(format!(
                                "'{name}' in '{key}' overrides '{b}.{name}' with another signature: {sig} instead of {base_sig}"
                            ))
                        } else {
                            None
                        };
                        if let Some(msg) = problem {
                            out.push(
                                Diagnostic::error("E0350", *span, msg)
                                    .with_hint(format!("an override is written `def {name}(…) is only …`, with the inherited parameter and return types {base_sig}"))
                                    .with_related(*first, "the inherited method is here"),
                            );
                        }
                        break;
                    }
                    out.push(
                        Diagnostic::error(
                            "E0340",
                            *span,
                            format!("'{name}' in '{key}' redefines the member it inherits from '{b}'"),
                        )
                        .with_hint("an inherited member cannot be redefined: rename it, or constrain the inherited one with `keep`")
                        .with_related(*first, "inherited from here"),
                    );
                    break;
                }
            }
        }
    }
}

/// A conditional type (`actor truck inherits vehicle (vehicle_category ==
/// truck)`) may be inherited only conditionally (§3.5): an unconditional
/// subtype would be a truck without the condition that makes one (E0348).
pub(super) fn conditional_bases(prog: &Program, out: &mut Vec<Diagnostic>) {
    let mut conditional: BTreeMap<String, Span> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((_, Some(_))),
                ..
            } = d
            {
                conditional.entry(qual_key(name)).or_insert(name.name.span);
            }
        }
    }
    for (_, f) in &prog.files {
        for d in &f.decls {
            if let Decl::Compound {
                name,
                inherits: Some((base, None)),
                ..
            } = d
                && let b = qual_key(base)
                && let Some(&decl) = conditional.get(&b)
            {
                out.push(
                    Diagnostic::error(
                        "E0348",
                        base.name.span,
                        format!(
                            "'{}' inherits '{b}' unconditionally, but '{b}' is a conditional type; it can only be inherited with a condition",
                            qual_key(name)
                        ),
                    )
                    .with_hint(format!("inherit what '{b}' inherits, with a condition of its own, or give this inheritance a condition: `inherits {b} (field == value)`"))
                    .with_related(decl, "declared conditional here"),
                );
            }
        }
    }
}

/// `do` (§3.5, §3.13): only scenarios and actions have one (E0344), and
/// at most one effective `do` each, across the declaration, its
/// `extend`s and what it inherits (E0343; the engine would run one and
/// drop the others).
pub(super) fn behaviour_dos(prog: &Program, out: &mut Vec<Diagnostic>) {
    let dos_of = |ms: &[Member]| -> Vec<Span> {
        ms.iter()
            .filter_map(|m| match m {
                Member::Do(d) => Some(d.span),
                _ => None,
            })
            .collect()
    };
    // Compound key → kind, base and its `do`s in file order (declaration
    // and extensions).
    let mut kinds: BTreeMap<String, (DeclKind, Option<String>)> = BTreeMap::new();
    let mut dos: BTreeMap<String, Vec<Span>> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            match d {
                Decl::Compound {
                    name,
                    kind,
                    inherits,
                    members,
                    ..
                } => {
                    let key = qual_key(name);
                    // A name declared twice (E0336/E0337 report it) counts as
                    // a behaviour if one declaration is one: CARLA's
                    // `scenario top` beside the domain's `actor top`.
                    let entry = (*kind, inherits.as_ref().map(|(b, _)| qual_key(b)));
                    match kinds.get(&key) {
                        Some((DeclKind::Scenario | DeclKind::Action, _)) => {}
                        Some(_) if !matches!(kind, DeclKind::Scenario | DeclKind::Action) => {}
                        _ => {
                            kinds.insert(key.clone(), entry);
                        }
                    }
                    dos.entry(key).or_default().extend(dos_of(members));
                }
                Decl::Extend { target, members } => {
                    dos.entry(qual_key(target))
                        .or_default()
                        .extend(dos_of(members));
                }
                _ => {}
            }
        }
    }
    for (key, spans) in &dos {
        let Some((kind, base)) = kinds.get(key) else {
            continue; // an extend of an unknown type: reported elsewhere
        };
        if !matches!(kind, DeclKind::Scenario | DeclKind::Action) {
            let what = kind.noun();
            for &at in spans {
                out.push(
                    Diagnostic::error(
                        "E0344",
                        at,
                        format!("'{key}' is {what}: only scenarios and actions have a `do`"),
                    )
                    .with_hint("declare the behaviour as a scenario (on the actor: `scenario A.name:`) and give it the `do`"),
                );
            }
            continue;
        }
        if let [first, second, ..] = spans[..] {
            out.push(
                Diagnostic::error(
                    "E0343",
                    second,
                    format!("'{key}' has a second `do`; a scenario or action has at most one"),
                )
                .with_hint("put both in one `do` (e.g. `do serial:` with the two as its members), or remove one; with several `extend`s of one scenario, only one may add the `do`")
                .with_related(first, "its first `do` is here"),
            );
            continue;
        }
        // One of its own, and one it inherits: the nearest ancestor with one.
        let Some(&own) = spans.first() else { continue };
        let mut cur = base.clone();
        let mut guard = 0;
        while let Some(b) = cur {
            guard += 1;
            if guard > 64 || &b == key {
                break; // an inheritance cycle: E0339 reports it
            }
            if let Some(&inherited) = dos.get(&b).and_then(|v| v.first()) {
                out.push(
                    Diagnostic::error(
                        "E0343",
                        own,
                        format!("'{key}' has a `do` and inherits one from '{b}'; a scenario or action has at most one effective `do`"),
                    )
                    .with_hint("inherit from a scenario without a `do`, or invoke the base scenario from this one's `do` instead of inheriting it")
                    .with_related(inherited, "the inherited `do` is here"),
                );
                break;
            }
            cur = kinds.get(&b).and_then(|(_, bb)| bb.clone());
        }
    }
}

/// A declaration's key in the redefinition passes: `actor.name` for a
/// behaviour declared on an actor, the name otherwise.
pub(super) fn qual_key(q: &QualName) -> String {
    q.actor.as_ref().map_or(q.name.text.clone(), |a| {
        format!("{}.{}", a.text, q.name.text)
    })
}

/// A method's signature as written: `(int, list of length) -> speed`.
pub(super) fn signature(params: &[Field], ret: Option<&TypeRef>) -> String {
    let ty = |t: &TypeRef| {
        let base = t.base.actor.as_ref().map_or(t.base.name.text.clone(), |a| {
            format!("{}.{}", a.text, t.base.name.text)
        });
        if t.list {
            format!("list of {base}")
        } else {
            base
        }
    };
    let ps: Vec<String> = params
        .iter()
        .flat_map(|f| f.names.iter().map(move |_| ty(&f.ty)))
        .collect();
    match ret {
        Some(r) => format!("({}) -> {}", ps.join(", "), ty(r)),
        None => format!("({})", ps.join(", ")),
    }
}

/// Where `name` was first defined, if it was; else it is noted as first.
pub(super) fn first_place(seen: &mut BTreeMap<String, Span>, name: &Name) -> Option<Span> {
    match seen.get(&name.text) {
        Some(first) => Some(*first),
        None => {
            seen.insert(name.text.clone(), name.span);
            None
        }
    }
}

/// An SI base exponent given twice in `SI(m: 1, m: 2)` (E0335).
pub(super) fn si_twice(args: &[Arg], out: &mut Vec<Diagnostic>) {
    let mut seen: BTreeMap<&str, Span> = BTreeMap::new();
    for a in args {
        if let Some(n) = &a.name {
            if let Some(first) = seen.get(n.text.as_str()) {
                out.push(
                    Diagnostic::error(
                        "E0335",
                        n.span,
                        format!("'{}' is given twice in SI(…)", n.text),
                    )
                    .with_hint("each base unit once, with its exponent")
                    .with_related(*first, "first given here"),
                );
            } else {
                seen.insert(n.text.as_str(), n.span);
            }
        }
    }
}

/// Every name of the type namespace (physical types, enums, structs,
/// actors, scenarios, actions; a behaviour declared on an actor by
/// `actor.name`) and every modifier is declared once (E0307, with where it
/// was first declared). Two declarations of one kind are E0330/E0333's
/// (enums, physical types); two of different kinds are E0307's here.
/// CARLA's entry point `scenario top` may sit beside the domain's `actor top`.
pub(super) fn declared_once(prog: &Program, m: &Model, out: &mut Vec<Diagnostic>) {
    let carla = prog.dialect == crate::Dialect::Carla;
    let mut seen: BTreeMap<String, (Span, &'static str, Option<&str>)> = BTreeMap::new();
    for (_, f) in &prog.files {
        for d in &f.decls {
            let (key, span, what, base) = match d {
                Decl::PhysicalType { name, .. } => {
                    (name.text.clone(), name.span, "a physical type", None)
                }
                Decl::Enum { name, .. } => (name.text.clone(), name.span, "an enum", None),
                Decl::Compound {
                    name,
                    kind,
                    inherits,
                    ..
                } => {
                    let key = qual_key(name);
                    let key = if *kind == DeclKind::Modifier {
                        modifier_key(&key)
                    } else {
                        key
                    };
                    let base = inherits.as_ref().map(|(b, _)| b.name.text.as_str());
                    (key, name.name.span, kind.noun(), base)
                }
                _ => continue,
            };
            let Some(&(first, first_what, first_base)) = seen.get(&key) else {
                seen.insert(key, (span, what, base));
                continue;
            };
            let carla_top = carla && key == "top" && what == "a scenario";
            if carla_top {
                continue;
            }
            if precedence::overrides(prog, first, span) {
                // CARLA's dialect: the file's own declaration is used.
                if let Decl::Compound { name, .. } = d {
                    let is_a = |a: &str, b: &str| m.is_a(a, b);
                    out.extend(precedence::compound(
                        name, what, base, first, first_what, first_base, &is_a,
                    ));
                }
                seen.insert(key, (span, what, base.or(first_base)));
                continue;
            }
            let same_kind_elsewhere =
                first_what == what && matches!(d, Decl::PhysicalType { .. } | Decl::Enum { .. });
            if same_kind_elsewhere {
                continue;
            }
            let shown = key.strip_prefix("modifier ").unwrap_or(&key);
            let msg = if first_what == what {
                format!("'{shown}' is declared twice")
            } else {
                format!("'{shown}' is declared twice: as {what} here, first as {first_what}")
            };
            out.push(
                Diagnostic::error("E0307", span, msg)
                    .with_hint(if first_what == what {
                        "use `extend` to add to an existing declaration"
                    } else {
                        "types, behaviours and modifiers share one namespace: rename one of them"
                    })
                    .with_related(first, "first declared here"),
            );
        }
    }
}
