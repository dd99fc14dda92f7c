//! Reading the corpus and the errors of bad input.

use litesim_xosc::*;
use std::path::{Path, PathBuf};

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/xosc")
        .join(name)
}

#[test]
fn the_cut_in_reads_with_its_catalogs_and_parameters() {
    let s = read(&corpus("cut_in.xosc"), &[]).unwrap();
    assert_eq!(s.version, (1, 2));
    assert_eq!(s.entities.len(), 2);
    let ego = &s.entities[0];
    assert!(ego.controller.as_ref().unwrap().external);
    match &s.entities[1].kind {
        EntityKind::Vehicle { performance, .. } => assert_eq!(performance[0], 40.0),
        k => panic!("{k:?}"),
    }
    match &ego.kind {
        EntityKind::Vehicle { performance, .. } => assert_eq!(performance[0], 50.0),
        k => panic!("{k:?}"),
    }
    assert!(s.map.as_ref().unwrap().ends_with("maps/highway.xodr"));
    // ${$EgoSpeed - 3}
    assert!(matches!(
        s.init[3].kind,
        ActionKind::Speed {
            target: SpeedTarget::Absolute(v),
            ..
        } if v == 22.0
    ));
    let ev = &s.stories[0].acts[0].groups[0].maneuvers[0].events[0];
    assert_eq!(ev.priority, Priority::Override);
    assert!(ev.start.is_some());
}

/// `base` (a corpus file) with `from` replaced by `to`, read from beside
/// the corpus.
fn mutated(base: &str, from: &str, to: &str) -> Result<Scenario, XoscError> {
    let text = std::fs::read_to_string(corpus(&format!("corpus/{base}.xosc"))).unwrap();
    assert!(text.contains(from), "{base} has no {from}");
    let text = text.replacen(from, to, 1);
    read_str(&text, &corpus(&format!("corpus/{base}.bad.xosc")), &[])
}

fn err(r: Result<Scenario, XoscError>) -> String {
    r.expect_err("an error").to_string()
}

#[test]
fn bad_parameters_and_expressions_are_errors_at_their_place() {
    let p = "parameters_and_expressions";
    let e = err(mutated(
        p,
        r#"value="${$Speed / 2}""#,
        r#"value="${$Speed / (2 - 2)}""#,
    ));
    assert!(e.contains("division by zero"), "{e}");
    assert!(e.contains("parameters_and_expressions.bad.xosc:"), "{e}");
    let e = err(mutated(
        p,
        r#"value="${$Speed / 2}""#,
        r#"value="${$Nope / 2}""#,
    ));
    assert!(e.contains("unknown parameter $Nope"), "{e}");
    // A reference to a later declaration (a cycle is one).
    let e = err(mutated(p, r#"value="15""#, r#"value="$Half""#));
    assert!(e.contains("refers to $Half, declared after it"), "{e}");
    let e = err(mutated(p, r#"value="${$Speed / 2}""#, r#"value="$Half""#));
    assert!(e.contains("refers to $Half, declared by itself"), "{e}");
    let e = err(mutated(
        p,
        r#"AbsoluteTargetSpeed value="$Half""#,
        r#"AbsoluteTargetSpeed value="$Missing""#,
    ));
    assert!(e.contains("unknown parameter $Missing"), "{e}");
    // A value of the wrong type.
    let e = err(mutated(
        p,
        r#"parameterType="double" value="15""#,
        r#"parameterType="double" value="fast""#,
    ));
    assert!(
        e.contains(r#""fast" is not a value of its type Double"#),
        "{e}"
    );
    // Set from outside: known and unknown names.
    let f = corpus("corpus/parameters_and_expressions.xosc");
    let s = read(&f, &[("Speed".into(), "30".into())]).unwrap();
    assert!(
        s.parameters.contains(&("Half".into(), "15".into())),
        "{:?}",
        s.parameters
    );
    let e = read(&f, &[("Sped".into(), "30".into())])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("parameter 'Sped', which is not declared here"),
        "{e}"
    );
}

#[test]
fn missing_files_catalog_entries_and_references_are_errors() {
    let e = err(mutated(
        "speed_step",
        "../../maps/highway.xodr",
        "../../maps/nowhere.xodr",
    ));
    assert!(
        e.contains("the map ../../maps/nowhere.xodr is not there (tried "),
        "{e}"
    );
    let e = err(mutated(
        "catalogs_and_controllers",
        r#"entryName="truck""#,
        r#"entryName="lorry""#,
    ));
    assert!(
        e.contains("has no entry 'lorry' (it has car, truck)"),
        "{e}"
    );
    let e = err(mutated(
        "catalogs_and_controllers",
        r#"catalogName="VehicleCatalog" entryName="truck""#,
        r#"catalogName="Trucks" entryName="truck""#,
    ));
    assert!(e.contains("no catalog named 'Trucks'"), "{e}");
    let e = err(mutated(
        "catalogs_and_controllers",
        r#"parameterRef="Length""#,
        r#"parameterRef="Width""#,
    ));
    assert!(
        e.contains("parameter 'Width', which is not declared here (declared: Length, MaxSpeed)"),
        "{e}"
    );
    let e = err(mutated(
        "speed_step",
        r#"<EntityRef entityRef="Ego"/></Actors>"#,
        r#"<EntityRef entityRef="Egg"/></Actors>"#,
    ));
    assert!(
        e.contains("entity 'Egg' does not exist (declared: Ego, Lead)"),
        "{e}"
    );
    let e = err(mutated(
        "storyboard_element_state",
        r#"storyboardElementRef="speedup""#,
        r#"storyboardElementRef="speedy""#,
    ));
    assert!(
        e.contains("storyboard element Event 'speedy' does not exist"),
        "{e}"
    );
    // An Event without a start trigger: fine from 1.1, an error in 1.0.
    let text = std::fs::read_to_string(corpus("corpus/version_1_0.xosc")).unwrap();
    let a = text
        .find("<StartTrigger><ConditionGroup><Condition name=\"go\"")
        .unwrap();
    let b = a + text[a..].find("</StartTrigger>").unwrap() + "</StartTrigger>".len();
    let cut = format!("{}{}", &text[..a], &text[b..]);
    let e = read_str(&cut, &corpus("corpus/v10.xosc"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("an Event needs a StartTrigger in OpenSCENARIO 1.0"),
        "{e}"
    );
}

#[test]
fn hostile_files_get_an_error_not_a_crash() {
    // 10,000-deep nesting: refused at the first element out of place.
    let deep = format!(
        "<?xml version=\"1.0\"?><OpenSCENARIO><FileHeader revMajor=\"1\" revMinor=\"2\" date=\"d\" description=\"d\" author=\"a\"/>{}{}</OpenSCENARIO>",
        "<Storyboard>".repeat(10_000),
        "</Storyboard>".repeat(10_000)
    );
    let e = read_str(&deep, &corpus("deep.xosc"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unexpected element <Storyboard> in <Storyboard>"),
        "{e}"
    );
    // Deep expressions.
    let text = std::fs::read_to_string(corpus("corpus/parameters_and_expressions.xosc")).unwrap();
    let nested = format!("${{{}1{}}}", "(".repeat(5_000), ")".repeat(5_000));
    let e = read_str(
        &text.replacen(
            r#"value="${$Speed / 2}""#,
            &format!("value=\"{nested}\""),
            1,
        ),
        &corpus("corpus/x.xosc"),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nested deeper than 64 levels"), "{e}");
    // Not XML, not UTF-8, empty, truncated.
    for (bad, says) in [
        ("", "no root element"),
        ("<OpenSCENARIO>", "malformed xml"),
        ("<OpenSCENARIO><FileHeader", "malformed xml"),
        ("<Other/>", "not <openscenario>"),
    ] {
        let e = read_str(bad, &corpus("x.xosc"), &[])
            .unwrap_err()
            .to_string();
        assert!(e.to_lowercase().contains(says), "{bad:?}: {e}");
    }
    // A file over the limit is refused before it is read.
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.xosc");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(MAX_FILE_BYTES + 1).unwrap();
    let e = read(&big, &[]).unwrap_err().to_string();
    assert!(e.contains("more than the 64 MB a file may have"), "{e}");
    let e = read(&dir.path().join("absent.xosc"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot read the scenario"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
    /// Any bytes cut from or spliced into a valid file: an answer, never a
    /// panic.
    #[test]
    fn any_damage_to_a_file_is_an_answer(cut in 0usize..4000, len in 0usize..200, splice in ".{0,40}") {
        let text = std::fs::read_to_string(corpus("corpus/cond_time_headway.xosc")).unwrap();
        let mut cut = cut.min(text.len());
        while !text.is_char_boundary(cut) { cut -= 1; }
        let mut end = (cut + len).min(text.len());
        while !text.is_char_boundary(end) { end -= 1; }
        let damaged = format!("{}{}{}", &text[..cut], splice, &text[end..]);
        let _ = read_str(&damaged, &corpus("corpus/damaged.xosc"), &[]);
    }
}

#[test]
fn distributions_expand_into_their_variations_seeded() {
    let d = read_distribution(&corpus("cut_in_sweep.xosc")).unwrap();
    assert!(d.scenario.ends_with("cut_in.xosc"));
    let pairs: Vec<(String, String)> = d
        .variations
        .iter()
        .map(|v| (v[0].1.clone(), v[1].1.clone()))
        .collect();
    let want: Vec<(String, String)> = [
        ("20", "10"),
        ("20", "15"),
        ("25", "10"),
        ("25", "15"),
        ("30", "10"),
        ("30", "15"),
    ]
    .iter()
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .collect();
    assert_eq!(pairs, want);
    let a = read_distribution(&corpus("cut_in_random.xosc")).unwrap();
    let b = read_distribution(&corpus("cut_in_random.xosc")).unwrap();
    assert_eq!(a, b, "the same draws every time");
    assert_eq!(a.variations.len(), 8);
    for v in &a.variations {
        let speed: f64 = v[0].1.parse().unwrap();
        let gap: f64 = v[1].1.parse().unwrap();
        assert!(
            (18.0..=32.0).contains(&speed) && (8.0..=20.0).contains(&gap),
            "{v:?}"
        );
    }
    // Different draws for different runs.
    assert_ne!(a.variations[0], a.variations[1]);
    assert!(is_distribution(&corpus("cut_in_sweep.xosc")));
    assert!(!is_distribution(&corpus("cut_in.xosc")));
    // A distribution run as a scenario says what it is.
    let e = read(&corpus("cut_in_sweep.xosc"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("this is a parameter distribution file"), "{e}");
    // Bad ranges and unknown kinds are errors at their place.
    let text = std::fs::read_to_string(corpus("cut_in_sweep.xosc")).unwrap();
    let dir = tempfile::tempdir_in(corpus("")).unwrap();
    let f = dir.path().join("bad.xosc");
    std::fs::write(
        &f,
        text.replace(r#"stepWidth="5""#, r#"stepWidth="0""#)
            .replace("cut_in.xosc", "../cut_in.xosc"),
    )
    .unwrap();
    let e = read_distribution(&f).unwrap_err().to_string();
    assert!(e.contains("the step must be above 0"), "{e}");
    std::fs::write(&f, text.replace("cut_in.xosc", "../nowhere.xosc")).unwrap();
    let e = read_distribution(&f).unwrap_err().to_string();
    assert!(e.contains("nowhere.xosc is not there"), "{e}");
}
