//! CARLA scenario_runner's OSC2 dialect: detection, litesim's built-in
//! `basic.osc`, the checker's native modifiers, and the lowering's
//! translations and errors (each E06xx at its place, snapshotted).

use litesim_osc::ast::{Decl, DoKind, Expr, Member};
use litesim_osc::{Dialect, Program, Severity};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Loads `text` as `t.osc` in a fresh folder (plus `extra` files there).
fn load(text: &str, extra: &[(&str, &str)], dialect: Option<Dialect>) -> Program {
    let dir = tempfile::tempdir().unwrap();
    for (name, t) in extra {
        std::fs::write(dir.path().join(name), t).unwrap();
    }
    let p = dir.path().join("t.osc");
    std::fs::write(&p, text).unwrap();
    let mut prog = litesim_osc::load_with(&p, &[], &|_| None, dialect).unwrap();
    // Machine-independent names in rendered diagnostics.
    for f in prog.sources.files.iter_mut() {
        if let Some(n) = Path::new(&f.path).file_name()
            && f.path.starts_with(&*dir.path().to_string_lossy())
        {
            f.path = n.to_string_lossy().into_owned();
        }
    }
    prog
}

fn errors(p: &Program) -> Vec<String> {
    p.diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .map(|d| d.render(&p.sources))
        .collect()
}

fn codes(p: &Program) -> Vec<&'static str> {
    p.diagnostics.iter().map(|d| d.code).collect()
}

const CUT_IN: &str = "import basic.osc

scenario top:
    path: Path
    path.set_map(\"Town04\")
    path.path_min_driving_lanes(2)
    ego_vehicle: Model3
    npc: Rubicon
    do serial:
        a: parallel(duration: 15s):
            ego_vehicle.drive(path) with:
                speed(30kph)
                lane(1, at: start)
            npc.drive(path) with:
                lane(right_of: ego_vehicle, at: start)
                position(15m, behind: ego_vehicle, at: start)
";

/// The lowered `extend top.main` members.
fn top_main(p: &Program) -> &[Member] {
    p.files
        .iter()
        .flat_map(|(_, f)| &f.decls)
        .find_map(|d| match d {
            Decl::Extend { target, members }
                if target.actor.as_ref().is_some_and(|a| a.text == "top")
                    && target.name.text == "main" =>
            {
                Some(&members[..])
            }
            _ => None,
        })
        .expect("an extend top.main")
}

/// Every call in the lowered tree, as `name(arg names)` text.
fn calls(members: &[Member]) -> Vec<String> {
    fn expr(e: &Expr, out: &mut Vec<String>) {
        if let Expr::Call { callee, args, .. } = e {
            let name = match &**callee {
                Expr::Ident { name, .. } => name.clone(),
                Expr::Field { base, name, .. } => format!("{}.{}", dotted(base), name.text),
                _ => "?".into(),
            };
            let a: Vec<String> = args
                .iter()
                .map(|a| match (&a.name, &a.value) {
                    (Some(n), v) => format!("{}: {}", n.text, dotted(v)),
                    (None, v) => dotted(v),
                })
                .collect();
            out.push(format!("{name}({})", a.join(", ")));
        }
    }
    fn dotted(e: &Expr) -> String {
        match e {
            Expr::Ident { name, .. } => name.clone(),
            Expr::Field { base, name, .. } => format!("{}.{}", dotted(base), name.text),
            Expr::Int { value, .. } => value.to_string(),
            Expr::Physical { value, unit, .. } => format!("{value}{unit}"),
            _ => "…".into(),
        }
    }
    fn member(m: &Member, out: &mut Vec<String>) {
        match m {
            Member::Modifier { call, .. } => expr(call, out),
            Member::Do(d) => do_member(d, out),
            _ => {}
        }
    }
    fn do_member(d: &litesim_osc::ast::DoMember, out: &mut Vec<String>) {
        match &d.kind {
            DoKind::Composition { children, with, .. } => {
                children.iter().for_each(|c| do_member(c, out));
                with.iter().for_each(|m| member(m, out));
            }
            DoKind::Invoke { call, with } => {
                expr(call, out);
                with.iter().for_each(|m| member(m, out));
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    members.iter().for_each(|m| member(m, &mut out));
    out
}

#[test]
fn a_carla_scenario_is_detected_checked_and_lowered() {
    let p = load(CUT_IN, &[], None);
    assert_eq!(errors(&p), Vec::<String>::new());
    assert_eq!(p.dialect, Dialect::Carla);
    let map = p.carla.as_ref().unwrap().map.as_ref().unwrap();
    assert_eq!(map.0, "Town04");
    let m = top_main(&p);
    assert_eq!(
        calls(m),
        [
            "sut.car.drive()",
            "speed(30kph)",
            "lane(1, at: start, from: left)",
            "along(path, at: start)",
            "npc.drive()",
            "lane(right_of: sut.car, at: start)",
            "position(15m, behind: sut.car, at: start)",
            "duration(15s)",
        ]
    );
    // path: Path → road, with its lane count as a constraint; the
    // blueprints' model and size per instance; no `ego_vehicle` field.
    let text = format!("{m:?}");
    assert!(text.contains("\"road\""), "{text}");
    assert!(text.contains("min_lanes"), "{text}");
    assert!(text.contains("vehicle.jeep.wrangler_rubicon"), "{text}");
    assert!(text.contains("vehicle.tesla.model3"), "{text}");
    assert!(!text.contains("ego_vehicle"), "{text}");
}

#[test]
fn carla_change_speed_is_lowered_to_the_target_it_means() {
    // scenario_runner's change_speed(v) reaches v; the standard's is a
    // change by v, so the dialect names its argument `target`.
    for (written, lowered) in [
        ("change_speed(30kph)", "change_speed(target: 30kph)"),
        ("change_speed(speed: 30kph)", "change_speed(target: 30kph)"),
    ] {
        let text = CUT_IN.replacen("speed(30kph)", written, 1);
        let p = load(&text, &[], None);
        assert_eq!(errors(&p), Vec::<String>::new());
        let c = calls(top_main(&p));
        assert!(c.iter().any(|x| x == lowered), "{written}: {c:?}");
    }
}

#[test]
fn a_litesim_program_stays_litesim() {
    let p = litesim_osc::load(&root().join("examples/scenarios/cut_in.osc"), &[], &|_| {
        None
    })
    .unwrap();
    assert_eq!(p.dialect, Dialect::Litesim);
    assert!(p.carla.is_none());
    assert_eq!(errors(&p), Vec::<String>::new());
}

#[test]
fn every_carla_example_checks_clean() {
    let mut n = 0;
    let files = std::fs::read_dir(root().join("examples/carla"))
        .unwrap()
        .chain(std::fs::read_dir(root().join("examples/carla/runner")).unwrap())
        .filter(|e| e.as_ref().unwrap().file_name() != "basic.osc");
    for e in files {
        let f = e.unwrap().path();
        if f.extension().is_some_and(|x| x == "osc") {
            let p = litesim_osc::load(&f, &[], &|_| None).unwrap();
            assert_eq!(p.dialect, Dialect::Carla, "{}", f.display());
            assert_eq!(errors(&p), Vec::<String>::new(), "{}", f.display());
            n += 1;
        }
    }
    // examples/carla/runner's import scenario_runner's own library beside them.
    assert!(n >= 9, "examples/carla has {n} scenarios");
}

#[test]
fn native_modifiers_take_arguments_in_carla_only() {
    // The same program in litesim's dialect: `basic.osc` is not there,
    // and nothing else is CARLA's.
    let p = load(CUT_IN, &[], Some(Dialect::Litesim));
    assert_eq!(p.dialect, Dialect::Litesim);
    assert_eq!(codes(&p), ["E0202"], "{:?}", errors(&p));
    // Asked for explicitly, the dialect's library is there without the import.
    let p = load(
        &CUT_IN.replace("import basic.osc\n", ""),
        &[],
        Some(Dialect::Carla),
    );
    assert_eq!(errors(&p), Vec::<String>::new());
    // The entry is still file 0 (what --dump-ast prints); the library is
    // read before it.
    assert_eq!(p.sources.file(0).path, "t.osc");
    assert_eq!(p.files.last().unwrap().0, 0);
    // A litesim modifier with parameters is still checked in CARLA's dialect.
    let p = load(
        &CUT_IN.replace("speed(30kph)", "speed(30kph, bogus: 2)"),
        &[],
        None,
    );
    assert_eq!(codes(&p), ["E0308"], "{:?}", errors(&p));
}

/// scenario_runner's library as its users have it: its own physical types
/// and units, `actor dut`, `actor Path`, parameterless modifiers, vehicle
/// blueprints; `deg` with the inverted factor some copies have.
const THEIR_BASIC: &str = "type time is SI(s: 1)
unit s of time is SI(s: 1, factor: 1)
unit hour of time is SI(s: 1, factor: 3600)
unit h of time is SI(s: 1, factor: 3600)
unit minute of time is SI(s: 1, factor: 60)
unit min of time is SI(s: 1, factor: 60)
type length is SI(m: 1)
unit m of length is SI(m: 1, factor: 1)
unit meter of length is SI(m: 1, factor: 1)
unit km of length is SI(m: 1, factor: 1000)
type velocity is SI(m: 1, s: -1)
unit mps of velocity is SI(m: 1, s: -1, factor: 1)
unit kph of velocity is SI(m: 1, s: -1, factor: 0.277777778)
unit kmph of velocity is SI(m: 1, s: -1, factor: 0.277777778)
unit mph of velocity is SI(m: 1, s: -1, factor: 0.44704)
type angle is SI(rad: 1)
unit deg of angle is SI(rad: 1, factor: 57.295779513)
unit rad of angle is SI(rad: 1, factor: 1)
actor dut
actor Path
modifier Path.set_map
modifier Path.path_min_driving_lanes
actor Model3
actor Rubicon
";

#[test]
fn scenario_runners_own_basic_osc_is_read_as_written_and_takes_precedence() {
    let p = load(CUT_IN, &[("basic.osc", THEIR_BASIC)], None);
    assert_eq!(p.dialect, Dialect::Carla);
    assert_eq!(errors(&p), Vec::<String>::new());
    // Everything that matches litesim's library is silent; the one unit
    // that differs is used, with a warning that names both and ASAM's.
    let warnings: Vec<String> = p.diagnostics.iter().map(|d| d.render(&p.sources)).collect();
    insta::assert_snapshot!(warnings.join("\n"));
    // The file is read, not replaced: its text is among the sources, and
    // its `deg` is the program's.
    assert!(p.sources.files.iter().any(|f| f.path == "basic.osc"));
    let ix = litesim_osc::index::DeclIndex::build(&p);
    assert!((ix.units["deg"].factor - 57.295779513).abs() < 1e-9);
    assert!((ix.units["kph"].factor - 1.0 / 3.6).abs() < 1e-6);
    // Its `velocity` is litesim's `speed`: `speed(30kph)` checks.
    assert_eq!(ix.physical_alias["velocity"], "speed");
    // A basic.osc of the user's own (no `actor Path`) is theirs to keep.
    let mine = "import \"/nonexistent/config.osc\"\n";
    let p = load("import basic.osc\n", &[("basic.osc", mine)], None);
    assert_eq!(p.dialect, Dialect::Litesim);
    assert_eq!(codes(&p), ["E0202"]);
}

#[test]
fn redeclarations_of_litesims_names_warn_when_they_differ_and_conflicts_of_the_users_own_are_errors()
 {
    // Another kind, another base: used, with a warning naming both.
    let theirs = format!(
        "{THEIR_BASIC}actor bounding_box:\n    x: int\nactor Wheels\nactor Mustang inherits Wheels\n"
    );
    let text = CUT_IN.replace("npc: Rubicon", "npc: Rubicon\n    hs: bounding_box");
    let p = load(&text, &[("basic.osc", &theirs)], None);
    let w: Vec<String> = p
        .diagnostics
        .iter()
        .filter(|d| d.code == "W0212")
        .map(|d| d.message.clone())
        .collect();
    assert!(w.iter().any(|m| m.contains("'deg'")), "{w:?}");
    assert!(
        w.iter()
            .any(|m| m.contains("'Mustang' inherits 'Wheels' here, 'vehicle'")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|m| m.contains("'bounding_box' is an actor here, a struct in litesim's library")),
        "{w:?}"
    );
    assert_eq!(errors(&p), Vec::<String>::new());
    // Two declarations of one unit in the user's own files: an error
    // (the second against the user's first, not litesim's).
    let text = CUT_IN.replace(
        "import basic.osc\n",
        "import basic.osc\nunit deg of angle is SI(rad: 1, factor: 0.0174533)\n",
    );
    let p = load(&text, &[("basic.osc", THEIR_BASIC)], None);
    assert_eq!(
        codes(&p).iter().filter(|c| **c == "E0334").count(),
        1,
        "{:?}",
        errors(&p)
    );
    let e = errors(&p).join("\n");
    assert!(
        e.contains("basic.osc:17:6: note: first defined here"),
        "{e}"
    );
}

#[test]
fn the_stand_in_library_declares_every_name_of_scenario_runners() {
    // No basic.osc beside the scenario: litesim's stand-in has the units,
    // types, actors and modifiers scenario_runner's library declares.
    let text = "import basic.osc

scenario dut.names:
    path: Path
    path.set_map(\"straight\")
    path.path_min_driving_lanes(2)
    a: Model3
    b: Rubicon
    t1: time = 1hour
    t2: time = 1h
    t3: time = 2minute
    t4: time = 2min
    t5: time = 3s
    l1: length = 1km
    l2: length = 2meter
    l3: length = 3m
    v1: velocity = 1mps
    v2: velocity = 2kph
    v3: velocity = 3kmph
    v4: speed = 4mph
    a1: angle = 1deg
    a2: angle = 1rad
    do serial:
        dut.drive(path) with:
            speed(v2)
            change_lane(lane_changes: 1, side: left)
";
    let p = load(text, &[], None);
    assert_eq!(p.dialect, Dialect::Carla);
    assert_eq!(p.diagnostics.len(), 0, "{:?}", errors(&p));
    // `velocity` is `speed` (the same dimension): the literal of the other
    // name is not an error, a length is.
    let p = load(
        &text.replace("v4: speed = 4mph", "v4: velocity = 4m"),
        &[],
        None,
    );
    assert_eq!(codes(&p), ["E0303"], "{:?}", errors(&p));
}

#[test]
fn a_file_that_imports_itself_through_the_library_is_a_cycle() {
    let theirs = format!("import t.osc\n{THEIR_BASIC}");
    let p = load(CUT_IN, &[("basic.osc", &theirs)], None);
    let e = errors(&p).join("\n");
    assert!(
        e.contains("E0203") && e.contains("t.osc → basic.osc → t.osc"),
        "{e}"
    );
    let p = load(&format!("import t.osc\n{CUT_IN}"), &[], None);
    let e = errors(&p).join("\n");
    assert!(e.contains("E0203") && e.contains("t.osc → t.osc"), "{e}");
}

const DUT: &str = "import basic.osc

scenario dut.overtake:
    path: Path
    path.set_map(\"Town04\")
    npc: Rubicon
    do serial:
        a: parallel(duration: 5s):
            dut.drive(path) with:
                speed(60kph)
                lane(1, at: start)
            npc.drive(path) with:
                change_lane(lane_changes: [1..2], side: left)
";

#[test]
fn a_scenario_of_the_dut_is_the_entry_point_and_dut_is_the_ego() {
    for lib in [None, Some(THEIR_BASIC)] {
        let extra: Vec<(&str, &str)> = lib.iter().map(|t| ("basic.osc", *t)).collect();
        let p = load(DUT, &extra, None);
        assert_eq!(errors(&p), Vec::<String>::new());
        let c = calls(top_main(&p));
        assert!(c.iter().any(|x| x.starts_with("sut.car.drive")), "{c:?}");
        assert!(!c.iter().any(|x| x.contains("dut")), "{c:?}");
        assert!(c.iter().any(|x| x.starts_with("change_lane")), "{c:?}");
    }
    // Two scenarios of the dut and no top: which one runs is not guessed.
    let two = format!(
        "{DUT}\nscenario dut.other:\n    do serial:\n        dut.drive() with:\n            speed(10kph)\n"
    );
    let p = load(&two, &[], None);
    assert_eq!(codes(&p), ["E0601"], "{:?}", errors(&p));
    assert!(
        errors(&p)[0].contains("dut.overtake, dut.other"),
        "{:?}",
        errors(&p)
    );
}

#[test]
fn what_cannot_be_lowered_is_an_error_at_its_place() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "no_top",
            "import basic.osc\nscenario other:\n    x: int\n",
            "E0601",
        ),
        (
            "map_twice",
            "import basic.osc\nscenario top:\n    path: Path\n    path.set_map(\"A\")\n    path.set_map(\"B\")\n",
            "E0604",
        ),
        (
            "map_not_a_string",
            "import basic.osc\nscenario top:\n    path: Path\n    path.set_map(4)\n",
            "E0603",
        ),
        (
            "lanes_without_a_count",
            "import basic.osc\nscenario top:\n    path: Path\n    path.path_min_driving_lanes()\n",
            "E0605",
        ),
        (
            "set_position_two_arguments",
            "import basic.osc\nscenario top:\n    path: Path\n    ego_vehicle: Model3\n    do serial:\n        ego_vehicle.drive(path) with:\n            set_position(1m, 2m)\n",
            "E0607",
        ),
        (
            "set_position_without_a_path",
            "import basic.osc\nscenario top:\n    ego_vehicle: Model3\n    do serial:\n        ego_vehicle.drive() with:\n            set_position(10m)\n",
            "E0606",
        ),
        (
            "top_twice",
            "import basic.osc\nscenario top:\n    x: int\nscenario top:\n    y: int\n",
            "E0602",
        ),
        (
            "two_dut_scenarios_and_no_top",
            "import basic.osc\nscenario dut.a:\n    x: int\nscenario dut.b:\n    y: int\n",
            "E0601",
        ),
    ];
    let mut all = String::new();
    for (name, text, code) in cases {
        let p = load(text, &[], None);
        assert_eq!(p.dialect, Dialect::Carla, "{name}");
        assert_eq!(codes(&p), [*code], "{name}: {:?}", errors(&p));
        all += &format!("== {name}\n{}\n", errors(&p).join("\n"));
    }
    insta::assert_snapshot!(all);
}

#[test]
fn lowering_never_panics_on_mangled_carla_programs() {
    // Every prefix of a CARLA program (most are syntax errors; those
    // that check are lowered): no panic, a diagnostic or a clean load.
    let text = std::fs::read_to_string(root().join("examples/carla/slow_lead.osc")).unwrap();
    let mut cut = 0;
    while cut < text.len() {
        if text.is_char_boundary(cut) {
            let _ = load(&text[..cut], &[], None);
        }
        cut += 7;
    }
    // The same for a scenario of the dut beside scenario_runner's library,
    // and for every prefix of that library (redeclarations cut short).
    let mut cut = 0;
    while cut < DUT.len() {
        let _ = load(&DUT[..cut], &[("basic.osc", THEIR_BASIC)], None);
        cut += 5;
    }
    let mut cut = 0;
    while cut < THEIR_BASIC.len() {
        let _ = load(DUT, &[("basic.osc", &THEIR_BASIC[..cut])], None);
        cut += 11;
    }
}
