//! The declaration index of a loaded program: every physical type, unit,
//! enum, compound (struct, actor, scenario, action, modifier), global and
//! `extend`, collected once from all files. The checker and the scenario
//! engine's elaboration both read it, so a name means the same thing to the
//! diagnostics a user sees and to the run that follows.

use crate::ast::{Decl, DeclKind, Expr, Member, TypeRef};
use crate::loader::Program;
use std::collections::{BTreeMap, BTreeSet};

/// What a compound member is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemberKind {
    /// A field (a parameter of an action, modifier or scenario).
    Field,
    /// An event.
    Event,
    /// A method.
    Method,
}

/// One named member of a compound.
#[derive(Clone, Debug)]
pub struct MemberDecl {
    /// Its name.
    pub name: String,
    /// Its type (`?` for events and methods, whose types are not tracked).
    pub ty: TypeRef,
    /// Field, event or method.
    pub kind: MemberKind,
}

/// A compound declaration with its `extend`s merged.
#[derive(Clone, Debug)]
pub struct CompoundDecl<'a> {
    /// Struct, actor, scenario, action or modifier.
    pub kind: DeclKind,
    /// Named members, declaration first, then each `extend` in file order.
    pub members: Vec<MemberDecl>,
    /// The compound it inherits from.
    pub base: Option<String>,
    /// The actor a scenario, action or modifier is declared on.
    pub owner: Option<String>,
    /// The members' syntax (declaration and extensions), for elaboration.
    pub body: Vec<&'a Member>,
    /// Declared in litesim's built-in library (not in the user's files).
    pub builtin: bool,
}

/// A unit: its physical type and SI factor.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitDecl {
    /// The physical type it measures (`speed`).
    pub of: String,
    /// Multiply by this to get SI (`kph` → 1/3.6).
    pub factor: f64,
    /// Then add this (`celsius` → 273.15 K; 0 for most units).
    pub offset: f64,
}

/// Every declaration of a program, by name.
#[derive(Clone, Debug, Default)]
pub struct DeclIndex<'a> {
    /// Physical types.
    pub physical: BTreeSet<String>,
    /// Under CARLA's dialect, each physical type → the first declared type
    /// of the same dimension (`velocity` → litesim's `speed`): a file's
    /// own types of a known dimension are that dimension. Empty otherwise
    /// (types are told apart by name).
    pub physical_alias: BTreeMap<String, String>,
    /// Units by name.
    pub units: BTreeMap<String, UnitDecl>,
    /// Enum members by enum (extensions merged).
    pub enums: BTreeMap<String, BTreeSet<String>>,
    /// Compounds by key ([`modifier_key`] for modifiers, the name otherwise).
    pub compounds: BTreeMap<String, CompoundDecl<'a>>,
    /// Global parameters and their types.
    pub globals: BTreeMap<String, TypeRef>,
}

/// SI base exponents of a physical type or unit, without zeros, by base
/// unit name (`m`, `s`, `kg`, `rad`, …).
pub type Dimension = BTreeMap<String, i64>;

/// The dimension `SI(m: 1, s: -1, factor: …)` gives (`factor` and
/// `offset` are not exponents; an exponent that is not an integer literal
/// counts as 0, the checker reports it elsewhere).
pub fn dimension(si: &[crate::ast::Arg]) -> Dimension {
    si.iter()
        .filter_map(|a| {
            let n = a.name.as_ref()?;
            if n.text == "factor" || n.text == "offset" {
                return None;
            }
            let v = const_num(&a.value)? as i64;
            (v != 0).then(|| (n.text.clone(), v))
        })
        .collect()
}

/// The SI factor of a unit's `SI(…, factor: f)` (1 when not given).
pub fn factor(si: &[crate::ast::Arg]) -> f64 {
    si_arg(si, "factor").unwrap_or(1.0)
}

/// The SI offset of a unit's `SI(…, offset: o)` (0 when not given): a
/// value in the unit is `v · factor + offset` in SI (`celsius`).
pub fn offset(si: &[crate::ast::Arg]) -> f64 {
    si_arg(si, "offset").unwrap_or(0.0)
}

fn si_arg(si: &[crate::ast::Arg], name: &str) -> Option<f64> {
    si.iter()
        .find(|a| a.name.as_ref().is_some_and(|n| n.text == name))
        .and_then(|a| const_num(&a.value))
}

/// The most bases an inheritance walk follows: a cycle (the checker
/// reports it) cannot make it loop.
pub const MAX_LINEAGE: usize = 64;

/// A compound and the ones it inherits from, nearest first, with
/// `base_of` naming each one's base; at most [`MAX_LINEAGE`] names. The one
/// walk of an inheritance chain, for the index and the checker's model.
pub fn lineage<'a>(
    start: &'a str,
    base_of: impl Fn(&'a str) -> Option<&'a str> + 'a,
) -> impl Iterator<Item = &'a str> + 'a {
    std::iter::successors(Some(start), move |c| base_of(c)).take(MAX_LINEAGE)
}

/// The index key of a modifier (modifiers and behaviours may share names).
pub fn modifier_key(name: &str) -> String {
    format!("modifier {name}")
}

/// The value of a numeric literal (with a leading minus), if it is one.
pub fn const_num(e: &Expr) -> Option<f64> {
    match e {
        Expr::Int { value, .. } => Some(*value as f64),
        Expr::Float { value, .. } => Some(*value),
        Expr::Unary { op, expr, .. } if op == "-" => const_num(expr).map(|v| -v),
        _ => None,
    }
}

fn members_of(members: &[Member]) -> Vec<MemberDecl> {
    let mut out = Vec::new();
    for m in members {
        match m {
            Member::Field(f) => out.extend(f.names.iter().map(|n| MemberDecl {
                name: n.text.clone(),
                ty: f.ty.clone(),
                kind: MemberKind::Field,
            })),
            Member::Event { name, .. } | Member::Method { name, .. } => out.push(MemberDecl {
                name: name.text.clone(),
                ty: TypeRef {
                    list: false,
                    base: crate::ast::QualName {
                        actor: None,
                        name: crate::ast::Name {
                            text: "?".into(),
                            span: name.span,
                        },
                    },
                },
                kind: if matches!(m, Member::Event { .. }) {
                    MemberKind::Event
                } else {
                    MemberKind::Method
                },
            }),
            _ => {}
        }
    }
    out
}

impl<'a> DeclIndex<'a> {
    /// Collects the declarations of every file, then merges `extend`s.
    pub fn build(prog: &'a Program) -> Self {
        let mut ix = DeclIndex::default();
        let carla = prog.dialect == crate::Dialect::Carla;
        // Physical types in declaration order: the first of a dimension
        // names it (litesim's library loads before the user's files).
        let mut by_dimension: BTreeMap<Dimension, String> = BTreeMap::new();
        // (compound, the base a user's file gives it) over a built-in base.
        let mut user_bases: Vec<(String, String)> = Vec::new();
        for (id, f) in &prog.files {
            let builtin = prog.is_builtin_file(*id);
            for d in &f.decls {
                match d {
                    Decl::PhysicalType { name, si } => {
                        ix.physical.insert(name.text.clone());
                        if carla {
                            let canon = by_dimension
                                .entry(dimension(si))
                                .or_insert_with(|| name.text.clone());
                            ix.physical_alias.insert(name.text.clone(), canon.clone());
                        }
                    }
                    Decl::Unit { name, of, args } => {
                        ix.units.insert(
                            name.text.clone(),
                            UnitDecl {
                                of: of.text.clone(),
                                factor: factor(args),
                                offset: offset(args),
                            },
                        );
                    }
                    Decl::Enum { name, members } | Decl::ExtendEnum { name, members } => {
                        ix.enums
                            .entry(name.text.clone())
                            .or_default()
                            .extend(members.iter().map(|(n, _)| n.text.clone()));
                    }
                    Decl::Compound {
                        kind,
                        name,
                        inherits,
                        members,
                        ..
                    } => {
                        let key = if *kind == DeclKind::Modifier {
                            modifier_key(&name.name.text)
                        } else {
                            name.name.text.clone()
                        };
                        let fresh = CompoundDecl {
                            kind: *kind,
                            members: Vec::new(),
                            base: None,
                            owner: None,
                            body: Vec::new(),
                            builtin,
                        };
                        let entry = ix.compounds.entry(key.clone()).or_insert(fresh);
                        // CARLA's dialect: a file's own declaration of a
                        // built-in name adds its members to litesim's; its
                        // base is taken only if it is one of litesim's
                        // base's kind (decided below, once every base is
                        // known). litesim's library is written against its
                        // own kinds and bases: the checker says when a
                        // file's differ (W0212).
                        let over = carla && entry.builtin && !builtin;
                        if over && let Some((b, _)) = inherits {
                            if entry.base.is_some() {
                                user_bases.push((key, b.name.text.clone()));
                            } else {
                                entry.base = Some(b.name.text.clone());
                            }
                            entry.members.extend(members_of(members));
                            entry.body.extend(members.iter());
                            continue;
                        }
                        entry.members.extend(members_of(members));
                        entry.body.extend(members.iter());
                        if let Some((b, _)) = inherits {
                            entry.base = Some(b.name.text.clone());
                        }
                        if let Some(a) = &name.actor {
                            entry.owner = Some(a.text.clone());
                        }
                    }
                    Decl::Global(f) => {
                        for n in &f.names {
                            ix.globals.insert(n.text.clone(), f.ty.clone());
                        }
                    }
                    _ => {}
                }
            }
        }
        for (key, base) in user_bases {
            let kept = ix.compounds.get(&key).and_then(|c| c.base.clone());
            if kept.is_some_and(|k| ix.is_a(&base, &k))
                && let Some(c) = ix.compounds.get_mut(&key)
            {
                c.base = Some(base);
            }
        }
        for (_, f) in &prog.files {
            for d in &f.decls {
                if let Decl::Extend { target, members } = d
                    && let Some(c) = ix.compounds.get_mut(&target.name.text)
                {
                    c.members.extend(members_of(members));
                    c.body.extend(members.iter());
                }
            }
        }
        ix
    }

    /// Named members of a compound and its bases (own first), each of
    /// `kinds`; an inheritance cycle stops the walk (the checker reports it).
    pub fn members(&self, key: &str, kinds: &[MemberKind]) -> Vec<&MemberDecl> {
        self.lineage(key)
            .map_while(|n| self.compounds.get(n))
            .flat_map(|c| c.members.iter().filter(|m| kinds.contains(&m.kind)))
            .collect()
    }

    /// A compound and the ones it inherits from, nearest first (see
    /// [`lineage`]).
    pub fn lineage<'s>(&'s self, start: &'s str) -> impl Iterator<Item = &'s str> + 's {
        lineage(start, |c| {
            self.compounds.get(c).and_then(|c| c.base.as_deref())
        })
    }

    /// The parameters of an action, modifier or scenario (its fields,
    /// inherited ones after its own), in the order positional arguments
    /// bind to them.
    pub fn params(&self, key: &str) -> Vec<&MemberDecl> {
        self.members(key, &[MemberKind::Field])
    }

    /// `sub` is `sup` or inherits from it (directly or not).
    pub fn is_a(&self, sub: &str, sup: &str) -> bool {
        self.lineage(sub).any(|n| n == sup)
    }

    /// Whether `name` is a member of some enum.
    pub fn is_enum_member(&self, name: &str) -> bool {
        self.enums.values().any(|m| m.contains(name))
    }
}
