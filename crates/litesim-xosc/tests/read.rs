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
