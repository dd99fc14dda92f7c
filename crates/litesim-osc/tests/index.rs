//! The declaration index both the checker and the scenario engine read.

use litesim_osc::index::{DeclIndex, MemberKind, modifier_key};

#[test]
fn the_index_merges_extends_inheritance_and_units() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("t.osc");
    std::fs::write(
        &f,
        "type length is SI(m: 1)\nunit km of length is SI(m: 1, factor: 1000)\nenum color: [red, green]\nextend color: [blue]\nactor thing:\n    size: length\nactor box inherits thing:\n    event hit\n    label: string\nmodifier box.bump:\n    by: length\n    times: int\nscenario box.go:\n    first: length\nextend box.go:\n    second: length\n",
    )
    .unwrap();
    let prog = litesim_osc::load(&f, &[], &|_| None).unwrap();
    assert!(!prog.has_errors(), "{:?}", prog.diagnostics);
    let ix = DeclIndex::build(&prog);
    assert_eq!(ix.units["km"].factor, 1000.0);
    assert_eq!(ix.units["km"].of, "length");
    assert!(ix.is_enum_member("blue") && !ix.is_enum_member("purple"));
    assert!(ix.is_a("box", "thing") && !ix.is_a("thing", "box"));
    // Own fields first, then inherited; events are members, not parameters.
    let names = |v: Vec<&litesim_osc::index::MemberDecl>| {
        v.into_iter().map(|m| m.name.clone()).collect::<Vec<_>>()
    };
    assert_eq!(names(ix.params("box")), ["label", "size"]);
    assert_eq!(
        names(ix.members("box", &[MemberKind::Field, MemberKind::Event])),
        ["hit", "label", "size"]
    );
    assert_eq!(names(ix.params(&modifier_key("bump"))), ["by", "times"]);
    // An extend adds to the scenario's parameters and body.
    assert_eq!(names(ix.params("go")), ["first", "second"]);
    assert_eq!(ix.compounds["go"].body.len(), 2);
    assert_eq!(ix.compounds["go"].owner.as_deref(), Some("box"));
}
