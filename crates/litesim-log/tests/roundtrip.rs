//! Writers and reader: round trip, atomicity, bad files.

use litesim_core::{
    Actor, ActorDescription, ActorState, ControlMode, NormalizedPedals, Pose, SspDynamics,
    VehicleInput, VehicleModelKind, World,
};
use litesim_log::{LogError, LogRecorder, SimulationLog};

fn sample_log() -> SimulationLog {
    let mut w = World::with_step_ms(20).unwrap();
    let car = ActorDescription::car("test.car");
    w.add_actor(Actor::new(
        "ego",
        car.clone(),
        ActorState::at_rest(Pose::planar(0.0, 0.0, 0.0)),
        Some(VehicleModelKind::Ssp(SspDynamics::for_length(4.6))),
    ))
    .unwrap();
    w.add_actor(Actor::new(
        "parked, \"odd\" id",
        car,
        ActorState::at_rest(Pose::planar(10.0, 2.0, 0.0)),
        None,
    ))
    .unwrap();
    w.set_mode(
        "ego",
        ControlMode::Dynamic {
            input: VehicleInput::Pedals(NormalizedPedals {
                throttle: 0.5,
                brake: 0.0,
                steering: 0.1,
            }),
            valid_until_tick: None,
        },
    )
    .unwrap();
    let mut rec = LogRecorder::new(w.dt());
    rec.meta("profile", "dummy");
    for _ in 0..50 {
        w.step();
        rec.record_world(&w);
    }
    rec.finish()
}

#[test]
fn json_round_trip_keeps_every_bit_and_nan() {
    let log = sample_log();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sub/log.json");
    log.write_json(&p).unwrap();
    let back = SimulationLog::read_json(&p).unwrap();
    assert_eq!(back.tracks.len(), 2);
    let (a, b) = (&log.tracks[0], &back.tracks[0]);
    assert_eq!(
        a.state.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        b.state.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    assert_eq!(a.control.throttle, b.control.throttle);
    assert!(back.tracks[1].control.throttle.iter().all(|v| v.is_nan()));
    assert_eq!(back.meta["profile"], "dummy");
    assert!(log.tracks[0].state.speed[49] > 0.0);
    // No temporary files are left behind.
    assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
}

#[test]
fn csv_has_a_row_per_actor_and_tick() {
    let log = sample_log();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("log.csv");
    log.write_csv(&p).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 2 * 50);
    assert!(lines[0].starts_with("tick,time_s,actor_id,mode,x_m"));
    assert!(lines[1].starts_with("1,0.02,ego,dynamic,"));
    assert!(lines[51].starts_with("1,0.02,\"parked, \"\"odd\"\" id\",stored,10,2,"));
    let cols = lines[0].split(',').count();
    assert_eq!(lines[1].split(',').count(), cols);
}

#[test]
fn bad_files_are_precise_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.json");
    std::fs::write(&p, "{\"format_version\": 1,\n \"dt\": 0.02, \"tick\": [1,").unwrap();
    match SimulationLog::read_json(&p) {
        Err(LogError::Json { line: 2, .. }) => {}
        other => panic!("{other:?}"),
    }
    let mut log = sample_log();
    log.tracks[0].state.y.pop();
    let text = serde_json::to_string(&log).unwrap();
    let e = SimulationLog::from_json_str(&text, &p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("track 'ego': column state.y has 49 entries, expected 50"),
        "{e}"
    );
    assert!(matches!(
        SimulationLog::read_json(&dir.path().join("missing.json")),
        Err(LogError::Io { .. })
    ));
    assert!(SimulationLog::from_json_str("", &p).is_err());
    // Each message names the place once, and says what a file that is
    // not a log at all is.
    let e = SimulationLog::read_json(&p).unwrap_err().to_string();
    assert!(
        e.ends_with("line 2, column 24: EOF while parsing a value"),
        "{e}"
    );
    std::fs::write(&p, " \n").unwrap();
    let e = SimulationLog::read_json(&p).unwrap_err().to_string();
    assert!(
        e.ends_with("bad.json: the file is empty (expected a litesim log: JSON)"),
        "{e}"
    );
    std::fs::write(&p, [0x8b_u8, 0xff, 0x00, 0x12]).unwrap();
    let e = SimulationLog::read_json(&p).unwrap_err().to_string();
    assert!(
        e.ends_with("bad.json: not UTF-8 text: not a litesim log (JSON)"),
        "{e}"
    );
}

/// Pieces of a log by tick index: clamped at both ends, every track cut to
/// its samples at those ticks (an actor present only in some ticks too).
#[test]
fn ticks_between_cuts_every_track_at_the_same_ticks() {
    use litesim_log::{ActorSample, LogRecorder};
    let mut rec = LogRecorder::new(0.1);
    rec.actor("a", "vehicle/car", "car", 4.0, 2.0, 1000.0);
    rec.actor("b", "person", "person", 0.5, 0.5, 80.0);
    for k in 0..6u64 {
        rec.begin(k, k as f64 * 0.1);
        let s = ActorSample::from_kinematics(
            litesim_core::Pose::planar(k as f64, 0.0, 0.0),
            litesim_core::Vec3::new(1.0, 0.0, 0.0),
            litesim_core::Vec3::new(0.0, 0.0, 0.0),
            0.0,
            1.0,
            2.6,
        );
        rec.sample("a", "trajectory", &s);
        if (2..=3).contains(&k) {
            rec.sample("b", "trajectory", &s);
        }
    }
    let log = rec.finish();
    let p = log.ticks_between(1, 3);
    assert_eq!(p.tick, vec![1, 2]);
    assert_eq!(p.time.len(), 2);
    assert_eq!(p.tracks[0].state.x, vec![1.0, 2.0]);
    assert_eq!(p.tracks[1].tick, vec![2]);
    assert!(p.tracks.iter().all(|t| t.bad_columns().is_empty()));
    assert_eq!(p.meta, log.meta);
    // Clamped: past the end, backwards, empty.
    assert!(log.ticks_between(4, 99).tick == vec![4, 5]);
    assert!(log.ticks_between(5, 2).tick.is_empty());
    assert!(log.ticks_from(6).tracks.iter().all(|t| t.tick.is_empty()));
    // The whole log again (compared as JSON: NaN is not equal to itself).
    let json = |l: &SimulationLog| serde_json::to_string(&l.tracks).unwrap();
    assert_eq!(json(&log.ticks_from(0)), json(&log));
}

/// Columns read straight into numbers: `null` is NaN, numbers keep their
/// bits, and anything else in a column is refused with its place and what
/// a column holds.
#[test]
fn columns_read_nulls_as_nan_and_refuse_other_values() {
    let log = sample_log();
    let p = std::path::Path::new("log.json");
    let mut v = serde_json::to_value(&log).unwrap();
    let x = &mut v["tracks"][0]["state"]["x"];
    let n = x.as_array().unwrap().len();
    x[0] = serde_json::Value::Null;
    x[1] = serde_json::json!(0.1 + 0.2);
    let back = SimulationLog::from_json_str(&v.to_string(), p).unwrap();
    let col = &back.tracks[0].state.x;
    assert_eq!(col.len(), n);
    assert!(col[0].is_nan());
    assert_eq!(col[1].to_bits(), (0.1f64 + 0.2).to_bits());
    assert_eq!(&col[2..], &log.tracks[0].state.x[2..]);
    v["tracks"][0]["state"]["x"][2] = serde_json::json!("fast");
    let e = SimulationLog::from_json_str(&v.to_string(), p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 1, column") && e.contains("expected f64"),
        "{e}"
    );
    v["tracks"][0]["state"]["x"] = serde_json::json!({"a": 1});
    let e = SimulationLog::from_json_str(&v.to_string(), p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("a sequence of numbers or nulls"), "{e}");
}
