//! The syntax tree. Every node that a diagnostic may point at has a span.

use crate::source::Span;
use serde::Serialize;

/// A name with its span.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Name {
    /// Text.
    pub text: String,
    /// Where.
    pub span: Span,
}

/// A possibly qualified behaviour or type name: `sut.smoke`, `vehicle`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct QualName {
    /// Actor qualifier (`sut` in `sut.smoke`).
    pub actor: Option<Name>,
    /// Name.
    pub name: Name,
}

/// A type reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TypeRef {
    /// `list of T`.
    pub list: bool,
    /// The base type.
    pub base: QualName,
}

/// Expressions.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind")]
#[allow(missing_docs)] // variant fields are named after the grammar rules they hold
pub enum Expr {
    /// Integer (negative after folding unary minus).
    Int { value: i128, span: Span },
    /// Float.
    Float { value: f64, span: Span },
    /// Physical literal `20kph`.
    Physical {
        value: f64,
        unit: String,
        span: Span,
    },
    /// String.
    Str { value: String, span: Span },
    /// `true` / `false`.
    Bool { value: bool, span: Span },
    /// Identifier (or `it`, `actor`).
    Ident { name: String, span: Span },
    /// `enum!member`.
    EnumRef {
        enum_name: String,
        member: String,
        span: Span,
    },
    /// Unary minus or `not`.
    Unary {
        op: String,
        expr: Box<Expr>,
        span: Span,
    },
    /// Binary operator.
    Binary {
        op: String,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
        span: Span,
    },
    /// `c ? a : b`.
    Ternary {
        cond: Box<Expr>,
        then: Box<Expr>,
        otherwise: Box<Expr>,
        span: Span,
    },
    /// `x.f`.
    Field {
        base: Box<Expr>,
        name: Name,
        span: Span,
    },
    /// `x.as(T)` / `x.is(T)`.
    Cast {
        base: Box<Expr>,
        test: bool,
        ty: TypeRef,
        span: Span,
    },
    /// `x[i]`.
    Index {
        base: Box<Expr>,
        index: Box<Expr>,
        span: Span,
    },
    /// `f(args)`.
    Call {
        callee: Box<Expr>,
        args: Vec<Arg>,
        span: Span,
    },
    /// `[a, b]`.
    List { items: Vec<Expr>, span: Span },
    /// `[lo..hi]unit` / `range(lo, hi)`; open bounds are `None`.
    Range {
        lo: Option<Box<Expr>>,
        hi: Option<Box<Expr>>,
        unit: Option<String>,
        span: Span,
    },
    /// A placeholder after a syntax error (keeps the tree whole).
    Error { span: Span },
}

impl Expr {
    /// The span of any expression.
    pub fn span(&self) -> Span {
        match self {
            Expr::Int { span, .. }
            | Expr::Float { span, .. }
            | Expr::Physical { span, .. }
            | Expr::Str { span, .. }
            | Expr::Bool { span, .. }
            | Expr::Ident { span, .. }
            | Expr::EnumRef { span, .. }
            | Expr::Unary { span, .. }
            | Expr::Binary { span, .. }
            | Expr::Ternary { span, .. }
            | Expr::Field { span, .. }
            | Expr::Cast { span, .. }
            | Expr::Index { span, .. }
            | Expr::Call { span, .. }
            | Expr::List { span, .. }
            | Expr::Range { span, .. }
            | Expr::Error { span } => *span,
        }
    }
}

/// A call argument, positional or named.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Arg {
    /// Name for `name: value`.
    pub name: Option<Name>,
    /// Value.
    pub value: Expr,
}

/// Event specification (`@e`, `@e as x if c`, `rise(c)`, `elapsed(t)`, a condition).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EventSpec {
    /// `@path`.
    pub event: Option<Expr>,
    /// `as name`.
    pub bind: Option<Name>,
    /// Condition (`if …`, or the whole spec).
    pub cond: Option<Expr>,
    /// Span.
    pub span: Span,
}

/// A field or parameter declaration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Field {
    /// `var` (variable) or not (parameter).
    pub var: bool,
    /// Names declared together.
    pub names: Vec<Name>,
    /// Type.
    pub ty: TypeRef,
    /// Default.
    pub default: Option<Expr>,
    /// `with:` constraints.
    pub with: Vec<Member>,
}

/// Members of structs, actors, scenarios, actions, modifiers, `with:` blocks.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "member")]
#[allow(missing_docs)] // variant fields are named after the grammar rules they hold
pub enum Member {
    /// Parameter or variable.
    Field(Field),
    /// `event e(params) is spec`.
    Event {
        name: Name,
        params: Vec<Field>,
        is: Option<EventSpec>,
    },
    /// `keep([default|hard] expr)`.
    Keep {
        strength: Option<String>,
        expr: Expr,
        span: Span,
    },
    /// `remove_default(path)`.
    RemoveDefault { path: Expr, span: Span },
    /// `def name(params) -> T is [only] body`.
    Method {
        name: Name,
        params: Vec<Field>,
        ret: Option<TypeRef>,
        body: String,
        expr: Option<Expr>,
        /// `is only …`: overrides an inherited method of the same signature.
        #[serde(skip_serializing_if = "std::ops::Not::not", default)]
        only: bool,
    },
    /// `cover(...)` / `record(...)`.
    Coverage {
        record: bool,
        args: Vec<Arg>,
        span: Span,
    },
    /// A modifier application `speed(20kph)` or `car.lane(1)`, optionally labelled.
    Modifier { label: Option<Name>, call: Expr },
    /// `until spec` (in `with:` blocks).
    Until(EventSpec),
    /// `do …`.
    Do(DoMember),
    /// `on spec: …`.
    On {
        event: EventSpec,
        body: Vec<DoMember>,
    },
    /// Foretify's `set path = value` inside `extend`.
    Set { path: Expr, value: Expr, span: Span },
}

/// One element of a `do` tree.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DoMember {
    /// `label:`.
    pub label: Option<Name>,
    /// What it does.
    pub kind: DoKind,
    /// Span of the member's head.
    pub span: Span,
}

/// Kinds of `do` members.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "do")]
#[allow(missing_docs)] // variant fields are named after the grammar rules they hold
pub enum DoKind {
    /// `serial` / `parallel` / `one_of` with arguments, children and `with:`.
    Composition {
        op: String,
        args: Vec<Arg>,
        children: Vec<DoMember>,
        with: Vec<Member>,
    },
    /// A scenario or action invocation with its `with:` block.
    Invoke { call: Expr, with: Vec<Member> },
    /// `wait spec`.
    Wait(EventSpec),
    /// `emit e(args)`.
    Emit { event: Expr },
    /// `call m(args)`.
    Call { call: Expr },
}

/// Kinds of compound declarations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DeclKind {
    /// `struct`.
    Struct,
    /// `actor`.
    Actor,
    /// `scenario`.
    Scenario,
    /// `action`.
    Action,
    /// `modifier`.
    Modifier,
}

impl DeclKind {
    /// The kind with its article, for messages: "a struct", "an actor".
    pub fn noun(self) -> &'static str {
        match self {
            DeclKind::Struct => "a struct",
            DeclKind::Actor => "an actor",
            DeclKind::Scenario => "a scenario",
            DeclKind::Action => "an action",
            DeclKind::Modifier => "a modifier",
        }
    }
}

/// Top-level declarations.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "decl")]
#[allow(missing_docs)] // variant fields are named after the grammar rules they hold
pub enum Decl {
    /// `type speed is SI(m: 1, s: -1)`.
    PhysicalType { name: Name, si: Vec<Arg> },
    /// `unit kph of speed is SI(m: 1, s: -1, factor: 0.2777)` or Foretify's `unit kph is speed(factor: …)`.
    Unit {
        name: Name,
        of: Name,
        args: Vec<Arg>,
    },
    /// `enum name: [a, b = 3]`.
    Enum {
        name: Name,
        members: Vec<(Name, Option<Expr>)>,
    },
    /// `extend enum_name: [c]`.
    ExtendEnum {
        name: Name,
        members: Vec<(Name, Option<Expr>)>,
    },
    /// struct / actor / scenario / action / modifier.
    Compound {
        /// Which.
        kind: DeclKind,
        /// Name.
        name: QualName,
        /// `inherits` base, with its condition.
        inherits: Option<(QualName, Option<Expr>)>,
        /// `modifier m of behaviour`.
        of: Option<QualName>,
        /// Body.
        members: Vec<Member>,
    },
    /// `extend name: …`.
    Extend {
        target: QualName,
        members: Vec<Member>,
    },
    /// `global x: T = v`.
    Global(Field),
}

/// An import.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Import {
    /// The path as written.
    pub path: String,
    /// Where.
    pub span: Span,
}

/// One parsed file.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FileAst {
    /// Imports.
    pub imports: Vec<Import>,
    /// Declarations.
    pub decls: Vec<Decl>,
}
