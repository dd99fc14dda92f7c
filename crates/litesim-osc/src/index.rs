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
}

/// A unit: its physical type and SI factor.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitDecl {
    /// The physical type it measures (`speed`).
    pub of: String,
    /// Multiply by this to get SI (`kph` → 1/3.6).
    pub factor: f64,
}

/// Every declaration of a program, by name.
#[derive(Clone, Debug, Default)]
pub struct DeclIndex<'a> {
    /// Physical types.
    pub physical: BTreeSet<String>,
    /// Units by name.
    pub units: BTreeMap<String, UnitDecl>,
    /// Enum members by enum (extensions merged).
    pub enums: BTreeMap<String, BTreeSet<String>>,
    /// Compounds by key ([`modifier_key`] for modifiers, the name otherwise).
    pub compounds: BTreeMap<String, CompoundDecl<'a>>,
    /// Global parameters and their types.
    pub globals: BTreeMap<String, TypeRef>,
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
        for (_, f) in &prog.files {
            for d in &f.decls {
                match d {
                    Decl::PhysicalType { name, .. } => {
                        ix.physical.insert(name.text.clone());
                    }
                    Decl::Unit { name, of, args } => {
                        let factor = args
                            .iter()
                            .find(|a| a.name.as_ref().is_some_and(|n| n.text == "factor"))
                            .and_then(|a| const_num(&a.value))
                            .unwrap_or(1.0);
                        ix.units.insert(
                            name.text.clone(),
                            UnitDecl {
                                of: of.text.clone(),
                                factor,
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
                        let entry = ix.compounds.entry(key).or_insert(CompoundDecl {
                            kind: *kind,
                            members: Vec::new(),
                            base: None,
                            owner: None,
                            body: Vec::new(),
                        });
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
        let mut out = Vec::new();
        let mut cur = Some(key);
        for _ in 0..64 {
            let Some(c) = cur.and_then(|n| self.compounds.get(n)) else {
                break;
            };
            out.extend(c.members.iter().filter(|m| kinds.contains(&m.kind)));
            cur = c.base.as_deref();
        }
        out
    }

    /// The parameters of an action, modifier or scenario (its fields,
    /// inherited ones after its own), in the order positional arguments
    /// bind to them.
    pub fn params(&self, key: &str) -> Vec<&MemberDecl> {
        self.members(key, &[MemberKind::Field])
    }

    /// `sub` is `sup` or inherits from it (directly or not).
    pub fn is_a(&self, sub: &str, sup: &str) -> bool {
        let mut cur = Some(sub);
        for _ in 0..64 {
            match cur {
                Some(n) if n == sup => return true,
                Some(n) => cur = self.compounds.get(n).and_then(|c| c.base.as_deref()),
                None => return false,
            }
        }
        false
    }

    /// Whether `name` is a member of some enum.
    pub fn is_enum_member(&self, name: &str) -> bool {
        self.enums.values().any(|m| m.contains(name))
    }
}
