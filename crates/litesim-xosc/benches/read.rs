//! Reading and checking a 1 MB `.xosc` (`cargo bench -p litesim-xosc`):
//! the issue's bound is 20 ms. The file is the corpus's cut-in grown to
//! 1 MB — hundreds of catalog-free vehicles, each with its Init actions,
//! and as many events with their triggers.
#![allow(missing_docs)]

use criterion::Criterion;
use std::hint::black_box;
use std::path::{Path, PathBuf};

/// A scenario of about `bytes` bytes (written beside the corpus: its map
/// path resolves).
pub fn big_scenario(bytes: usize) -> (String, PathBuf) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/xosc/corpus");
    let base = std::fs::read_to_string(dir.join("cond_time_headway.xosc")).unwrap();
    let entity = |i: usize| {
        format!(
            r#"    <ScenarioObject name="V{i}">
      <Vehicle name="V{i}_model" vehicleCategory="car">
        <BoundingBox><Center x="1.3" y="0" z="0.75"/><Dimensions width="1.9" length="4.6" height="1.5"/></BoundingBox>
        <Performance maxSpeed="70" maxAcceleration="6" maxDeceleration="9"/>
        <Axles><FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.8" positionZ="0.3"/><RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0" positionZ="0.3"/></Axles>
        <Properties/>
      </Vehicle>
    </ScenarioObject>
"#
        )
    };
    let init = |i: usize| {
        format!(
            r#"
        <Private entityRef="V{i}">
          <PrivateAction><TeleportAction><Position><LanePosition roadId="1" laneId="-{}" s="{}" offset="0"/></Position></TeleportAction></PrivateAction>
          <PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="step" dynamicsDimension="time" value="0"/><SpeedActionTarget><AbsoluteTargetSpeed value="${{20 + {} / 10}}"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction>
        </Private>"#,
            1 + i % 3,
            200 + 10 * (i / 3),
            i % 7
        )
    };
    let event = |i: usize| {
        format!(
            r#"
              <Event name="e{i}" priority="parallel" maximumExecutionCount="1">
                <Action name="a{i}"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="linear" dynamicsDimension="time" value="2"/><SpeedActionTarget><AbsoluteTargetSpeed value="15"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>
                <StartTrigger><ConditionGroup><Condition name="c{i}" delay="0" conditionEdge="rising"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule="any"><EntityRef entityRef="V{i}"/></TriggeringEntities><EntityCondition><RelativeDistanceCondition entityRef="Ego" value="20" freespace="true" rule="lessThan" relativeDistanceType="longitudinal" coordinateSystem="entity"/></EntityCondition></ByEntityCondition></Condition></ConditionGroup></StartTrigger>
              </Event>"#
        )
    };
    let (mut ents, mut inits, mut events) = (String::new(), String::new(), String::new());
    let mut i = 0;
    while ents.len() + inits.len() + events.len() + base.len() < bytes {
        ents += &entity(i);
        inits += &init(i);
        events += &event(i);
        i += 1;
    }
    let text = base
        .replacen("  </Entities>", &format!("{ents}  </Entities>"), 1)
        .replacen(
            "\n      </Actions>",
            &format!("{inits}\n      </Actions>"),
            1,
        )
        .replacen(
            "\n          </Maneuver>",
            &format!("{events}\n          </Maneuver>"),
            1,
        );
    (text, dir.join("big.xosc"))
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    let (text, path) = big_scenario(1 << 20);
    assert!(text.len() >= 1 << 20);
    let sc = litesim_xosc::read_str(&text, &path, &[]).unwrap();
    assert!(sc.entities.len() > 300, "{}", sc.entities.len());
    c.bench_function("read_and_check_1mb_xosc", |b| {
        b.iter(|| {
            black_box(
                litesim_xosc::read_str(&text, &path, &[])
                    .unwrap()
                    .entities
                    .len(),
            )
        })
    });
    c.final_summary();
}
