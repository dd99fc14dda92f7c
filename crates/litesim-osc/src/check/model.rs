//! The checker's model of a program: its types (`Ty`), and every compound's
//! fields, parameters, methods, variables and events, collected once from
//! the declaration index; "did you mean" hints.

use super::*;

pub(super) const BUILTIN_TYPES: &[&str] = &["int", "uint", "float", "bool", "string"];

/// A compound's kind, own parameters and base.
pub(super) type Compound = (DeclKind, Vec<(String, TypeRef)>, Option<String>);

/// A type's name inside [`Ty`]: shared, because types are copied at every
/// field lookup and literal (a copy is a count, not an allocation).
pub(super) type Sym = std::rc::Rc<str>;

/// The type of an expression, as far as the checker can tell.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Ty {
    /// Not known (builtin function results, method calls): never an error.
    Unknown,
    Bool,
    /// `int`, `uint` and `float` mix freely.
    Number,
    Str,
    Physical(Sym),
    Enum(Sym),
    Compound(Sym),
    List(Box<Ty>),
}

impl Ty {
    pub(super) fn describe(&self) -> String {
        match self {
            Ty::Unknown => "a value".into(),
            Ty::Bool => "a bool".into(),
            Ty::Number => "a plain number".into(),
            Ty::Str => "a string".into(),
            Ty::Physical(p) => format!("a {p}"),
            Ty::Enum(e) => format!("a value of enum {e}"),
            Ty::Compound(c) => format!("a {c}"),
            Ty::List(t) => format!("a list of {}", t.describe().trim_start_matches("a ")),
        }
    }
}

/// The declarations as the checker looks them up. Hash maps: name lookups
/// are the checker's hot path, and nothing is ever emitted in these maps'
/// order (suggestions are sorted, see `close_names`).
#[derive(Default)]
pub(super) struct Model {
    pub(super) physical: FxHashSet<String>,
    /// CARLA's dialect: a physical type → the type of its dimension that
    /// was declared first (`velocity` → `speed`); see `DeclIndex`.
    pub(super) physical_alias: FxHashMap<String, Sym>,
    pub(super) units: FxHashMap<String, Sym>,
    pub(super) enums: FxHashMap<String, BTreeSet<String>>,
    /// compound name (behaviours by their own name) → what it is
    pub(super) compounds: FxHashMap<String, Compound>,
    pub(super) globals: FxHashMap<String, TypeRef>,
    /// Every compound's visible fields (own, extended, inherited) and their
    /// types, built once: field lookups are the checker's hot path.
    pub(super) field_types: FxHashMap<String, FxHashMap<String, Ty>>,
    /// Every compound's parameters in declaration order (for positional
    /// arguments), with their types.
    pub(super) param_types: FxHashMap<String, Vec<(String, Ty)>>,
    /// The actor each actor-qualified action, scenario or modifier is
    /// declared on (`action vehicle.drive` → vehicle).
    pub(super) owners: FxHashMap<String, String>,
    /// Each compound's own methods (declaration and extensions), with
    /// whether they return a value.
    pub(super) methods: FxHashMap<String, Vec<(String, bool)>>,
    /// Each compound's own variables (declaration and extensions): name →
    /// where it is declared.
    pub(super) vars: FxHashMap<String, BTreeMap<String, Span>>,
    /// Each compound's own events (declaration and extensions): name →
    /// parameters in order, each with whether it has a default.
    pub(super) events: FxHashMap<String, BTreeMap<String, Vec<(String, bool)>>>,
}

pub(super) fn close_names<'a>(name: &str, all: impl Iterator<Item = &'a String>) -> String {
    // Names sharing a prefix (two characters, not bytes: names may be
    // non-ASCII) or differing by little: the usual typos.
    let prefix: String = name.chars().take(2).collect();
    // All candidates sorted before the first five are taken: the names may
    // come from hash maps, whose order must not reach a message.
    let mut v: Vec<&String> = all
        .filter(|n| n.starts_with(&prefix) || levenshtein(n, name) <= 2)
        .collect();
    v.sort();
    v.dedup();
    v.truncate(5);
    v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
}

pub(super) fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            cur.push(
                (prev[j] + usize::from(ca != *cb))
                    .min(prev[j + 1] + 1)
                    .min(cur[j] + 1),
            );
        }
        prev = cur;
    }
    prev[b.len()]
}

impl Model {
    pub(super) fn collect(prog: &Program) -> Self {
        Self::from_index(&DeclIndex::build(prog))
    }
    /// The checker's view of the shared declaration index, with each
    /// compound's field and parameter types resolved once.
    pub(super) fn from_index(ix: &DeclIndex<'_>) -> Self {
        let mut m = Model {
            physical: ix.physical.iter().cloned().collect(),
            physical_alias: ix
                .physical_alias
                .iter()
                .map(|(k, v)| (k.clone(), Sym::from(v.as_str())))
                .collect(),
            units: ix
                .units
                .iter()
                .map(|(k, u)| {
                    let of = ix.physical_alias.get(&u.of).unwrap_or(&u.of);
                    (k.clone(), Sym::from(of.as_str()))
                })
                .collect(),
            enums: ix
                .enums
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
            compounds: ix
                .compounds
                .iter()
                .map(|(k, c)| {
                    let own = c
                        .members
                        .iter()
                        .map(|d| (d.name.clone(), d.ty.clone()))
                        .collect();
                    (k.clone(), (c.kind, own, c.base.clone()))
                })
                .collect(),
            globals: ix
                .globals
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
            owners: ix
                .compounds
                .iter()
                .filter_map(|(k, c)| c.owner.clone().map(|o| (k.clone(), o)))
                .collect(),
            ..Model::default()
        };
        // Each compound's own methods, variables and events (declaration and
        // extensions), in one pass over the bodies.
        for (k, c) in &ix.compounds {
            let (mut methods, mut vars, mut events) =
                (Vec::new(), BTreeMap::new(), BTreeMap::new());
            for member in &c.body {
                match member {
                    Member::Method { name, ret, .. } => {
                        methods.push((name.text.clone(), ret.is_some()))
                    }
                    Member::Field(f) if f.var => {
                        vars.extend(f.names.iter().map(|n| (n.text.clone(), n.span)))
                    }
                    Member::Event { name, params, .. } => {
                        let ps = params
                            .iter()
                            .flat_map(|f| {
                                f.names
                                    .iter()
                                    .map(|n| (n.text.clone(), f.default.is_some()))
                            })
                            .collect();
                        events.insert(name.text.clone(), ps);
                    }
                    _ => {}
                }
            }
            m.methods.insert(k.clone(), methods);
            // Only compounds with variables: a `keep`'s every path step
            // looks here.
            if !vars.is_empty() {
                m.vars.insert(k.clone(), vars);
            }
            m.events.insert(k.clone(), events);
        }
        let names: Vec<String> = m.compounds.keys().cloned().collect();
        for n in names {
            let mut map = FxHashMap::default();
            // Typed straight from the lineage's declarations (no copies of
            // the declared types): this runs for every compound per load.
            let params: Vec<(String, Ty)> = m
                .lineage(&n)
                .filter_map(|c| m.compounds.get(c))
                .flat_map(|(_, p, _)| p.iter().map(|(f, t)| (f.clone(), m.ty_of(t))))
                .collect();
            map.reserve(params.len());
            // Own fields first win over a base's field of the same name.
            for (f, t) in &params {
                map.entry(f.clone()).or_insert_with(|| t.clone());
            }
            m.field_types.insert(n.clone(), map);
            m.param_types.insert(n, params);
        }
        m
    }
    pub(super) fn is_type(&self, t: &str) -> bool {
        BUILTIN_TYPES.contains(&t)
            || self.physical.contains(t)
            || self.enums.contains_key(t)
            || self.compounds.contains_key(t)
    }
    /// The names a compound's fields and its bases' go by (own first), for
    /// "did you mean" hints.
    pub(super) fn member_names(&self, name: &str) -> Vec<String> {
        self.lineage(name)
            .filter_map(|n| self.compounds.get(n))
            .flat_map(|(_, p, _)| p.iter().map(|(n, _)| n.clone()))
            .collect()
    }
    /// A compound and the ones it inherits from, nearest first (an
    /// inheritance cycle, which E0339 reports, cannot loop).
    pub(super) fn lineage<'m>(&'m self, start: &'m str) -> impl Iterator<Item = &'m str> + 'm {
        crate::index::lineage(start, |c| {
            self.compounds.get(c).and_then(|c| c.2.as_deref())
        })
    }
    /// `sub` is `sup` or inherits from it (directly or not).
    pub(super) fn is_a(&self, sub: &str, sup: &str) -> bool {
        self.lineage(sub).any(|n| n == sup)
    }
    pub(super) fn ty_of(&self, t: &TypeRef) -> Ty {
        let n = t.base.name.text.as_str();
        let base = match n {
            "int" | "uint" | "float" => Ty::Number,
            "bool" => Ty::Bool,
            "string" => Ty::Str,
            _ if self.physical.contains(n) => Ty::Physical(
                self.physical_alias
                    .get(n)
                    .cloned()
                    .unwrap_or_else(|| n.into()),
            ),
            _ if self.enums.contains_key(n) => Ty::Enum(n.into()),
            _ if self.compounds.contains_key(n) => Ty::Compound(n.into()),
            _ => Ty::Unknown,
        };
        if t.list {
            Ty::List(Box::new(base))
        } else {
            base
        }
    }
    /// The methods (`def`) a compound has, its own and inherited.
    pub(super) fn method_names(&self, compound: &str) -> Vec<&str> {
        self.lineage(compound)
            .filter_map(|c| self.methods.get(c))
            .flatten()
            .map(|(n, _)| n.as_str())
            .collect()
    }
    /// Whether the nearest method `name` of a compound (own or inherited)
    /// returns a value; `None` when it has no such method.
    pub(super) fn method_returns(&self, compound: &str, name: &str) -> Option<bool> {
        self.lineage(compound)
            .find_map(|c| self.methods.get(c)?.iter().find(|(n, _)| n == name))
            .map(|(_, r)| *r)
    }
    pub(super) fn field(&self, compound: &str, name: &str) -> Option<Ty> {
        self.field_types.get(compound)?.get(name).cloned()
    }
    /// Whether a value of type `got` may be given where `want` is expected.
    pub(super) fn fits(&self, got: &Ty, want: &Ty) -> bool {
        match (got, want) {
            (Ty::Unknown, _) | (_, Ty::Unknown) => true,
            (Ty::Compound(a), Ty::Compound(b)) => self.is_a(a, b),
            (Ty::List(a), Ty::List(b)) => self.fits(a, b),
            // A list value constrains a scalar parameter to one of its items.
            (Ty::List(a), b) => self.fits(a, b),
            (a, b) => a == b,
        }
    }
}
