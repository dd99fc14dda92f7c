#!/usr/bin/env python3
"""Writes litesim's OpenSCENARIO XML corpus (examples/xosc/corpus/*.xosc).

Each file exercises one element or a few related ones, on the straight
three-lane motorway (examples/maps/highway.xodr: road 1 along +x, lanes -1,
-2, -3 with centres at y = -1.75, -5.25, -8.75) or the signalled junction
(examples/maps/junction.xodr). crates/litesim-scenario/tests/xosc.rs runs
every file and checks its meaning on the log against closed-form values;
crates/litesim-xosc/tests/schema.rs validates every file against ASAM's XSD
for its FileHeader revision.

Run from anywhere: python3 examples/xosc/generate.py
"""

from pathlib import Path

OUT = Path(__file__).resolve().parent / "corpus"

# ---------------------------------------------------------------- positions


def lane_pos(road, lane, s, offset=0.0, h=None, rel=True):
    o = orientation(h, rel)
    return f'<LanePosition roadId="{road}" laneId="{lane}" s="{s}" offset="{offset}">{o}</LanePosition>' if o else \
        f'<LanePosition roadId="{road}" laneId="{lane}" s="{s}" offset="{offset}"/>'


def orientation(h, rel=True):
    if h is None:
        return ""
    return f'<Orientation type="{"relative" if rel else "absolute"}" h="{h}" p="0" r="0"/>'


def world_pos(x, y, h=None):
    hh = f' h="{h}"' if h is not None else ""
    return f'<WorldPosition x="{x}" y="{y}" z="0"{hh}/>'


def position(inner):
    return f"<Position>{inner}</Position>"


# ------------------------------------------------------------------ entities


def vehicle(name, length=4.6, max_speed=70, ctrl=None, category="car"):
    controller = ""
    if ctrl:
        controller = f"""
      <ObjectController>
        <Controller name="{ctrl}">
          <Properties/>
        </Controller>
      </ObjectController>"""
    return f"""    <ScenarioObject name="{name}">
      <Vehicle name="{name}_model" vehicleCategory="{category}">
        <BoundingBox>
          <Center x="{length / 2 - 1.0:.2f}" y="0" z="0.75"/>
          <Dimensions width="1.9" length="{length}" height="1.5"/>
        </BoundingBox>
        <Performance maxSpeed="{max_speed}" maxAcceleration="6" maxDeceleration="9"/>
        <Axles>
          <FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.8" positionZ="0.3"/>
          <RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0" positionZ="0.3"/>
        </Axles>
        <Properties/>
      </Vehicle>{controller}
    </ScenarioObject>
"""


def pedestrian(name):
    return f"""    <ScenarioObject name="{name}">
      <Pedestrian name="{name}_model" mass="80" model="walker" pedestrianCategory="pedestrian">
        <BoundingBox>
          <Center x="0" y="0" z="0.9"/>
          <Dimensions width="0.5" length="0.5" height="1.8"/>
        </BoundingBox>
        <Properties/>
      </Pedestrian>
    </ScenarioObject>
"""


def obstacle(name):
    return f"""    <ScenarioObject name="{name}">
      <MiscObject name="{name}_model" mass="100" miscObjectCategory="obstacle">
        <BoundingBox>
          <Center x="0" y="0" z="0.5"/>
          <Dimensions width="1" length="1" height="1"/>
        </BoundingBox>
        <Properties/>
      </MiscObject>
    </ScenarioObject>
"""


# ------------------------------------------------------------------- actions


def private(entity, *actions):
    body = "".join(f"\n          <PrivateAction>{a}</PrivateAction>" for a in actions)
    return f'\n        <Private entityRef="{entity}">{body}\n        </Private>'


def teleport(pos):
    return f"<TeleportAction>{position(pos)}</TeleportAction>"


def speed(value, shape="step", dim="time", dv=0, follow=None):
    fm = f' followingMode="{follow}"' if follow else ""
    return f"""<LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="{shape}" dynamicsDimension="{dim}" value="{dv}"{fm}/><SpeedActionTarget><AbsoluteTargetSpeed value="{value}"/></SpeedActionTarget></SpeedAction></LongitudinalAction>"""


def speed_rel(entity, value, kind="delta", continuous="false", shape="step", dim="time", dv=0):
    return f"""<LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape="{shape}" dynamicsDimension="{dim}" value="{dv}"/><SpeedActionTarget><RelativeTargetSpeed entityRef="{entity}" value="{value}" speedTargetValueType="{kind}" continuous="{continuous}"/></SpeedActionTarget></SpeedAction></LongitudinalAction>"""


def lane_change(target, shape="sinusoidal", dim="time", dv=3, offset=None):
    off = f' targetLaneOffset="{offset}"' if offset is not None else ""
    return f"""<LateralAction><LaneChangeAction{off}><LaneChangeActionDynamics dynamicsShape="{shape}" dynamicsDimension="{dim}" value="{dv}"/><LaneChangeTarget>{target}</LaneChangeTarget></LaneChangeAction></LateralAction>"""


def relative_lane(entity, value):
    return f'<RelativeTargetLane entityRef="{entity}" value="{value}"/>'


def absolute_lane(value):
    return f'<AbsoluteTargetLane value="{value}"/>'


def lane_offset(target, shape="sinusoidal", max_acc=0.5, continuous="false"):
    return f"""<LateralAction><LaneOffsetAction continuous="{continuous}"><LaneOffsetActionDynamics dynamicsShape="{shape}" maxLateralAcc="{max_acc}"/><LaneOffsetTarget>{target}</LaneOffsetTarget></LaneOffsetAction></LateralAction>"""


def action(name, inner, kind="PrivateAction"):
    return f"""
                <Action name="{name}">
                  <{kind}>{inner}</{kind}>
                </Action>"""


# ---------------------------------------------------------------- conditions


def sim_time(value, rule="greaterThan", name="time", edge="rising", delay=0):
    return f"""<Condition name="{name}" delay="{delay}" conditionEdge="{edge}"><ByValueCondition><SimulationTimeCondition value="{value}" rule="{rule}"/></ByValueCondition></Condition>"""


def by_entity(entity, test, name="cond", edge="rising", delay=0, rule="any"):
    ents = "".join(f'<EntityRef entityRef="{e}"/>' for e in entity.split(","))
    return f"""<Condition name="{name}" delay="{delay}" conditionEdge="{edge}"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule="{rule}">{ents}</TriggeringEntities><EntityCondition>{test}</EntityCondition></ByEntityCondition></Condition>"""


def trigger(*groups, tag="StartTrigger"):
    gs = "".join(f"<ConditionGroup>{''.join(g)}</ConditionGroup>" for g in groups)
    return f"<{tag}>{gs}</{tag}>"


def event(name, actions, start=None, priority="override", count=1):
    st = start if start is not None else ""
    return f"""
              <Event name="{name}" priority="{priority}" maximumExecutionCount="{count}">{actions}
                {st}
              </Event>"""


def story(actors, events, act_start=None, group_count=1, name="story", act_stop=""):
    acts = "".join(f'<EntityRef entityRef="{a}"/>' for a in actors)
    start = act_start if act_start is not None else trigger([sim_time(0, "greaterOrEqual", "act_start", "none")])
    return f"""
    <Story name="{name}">
      <Act name="{name}_act">
        <ManeuverGroup name="{name}_group" maximumExecutionCount="{group_count}">
          <Actors selectTriggeringEntities="false">{acts}</Actors>
          <Maneuver name="{name}_maneuver">{events}
          </Maneuver>
        </ManeuverGroup>
        {start}{act_stop}
      </Act>
    </Story>"""


def scenario(desc, entities, init, stories, stop=10, minor=2, params="", road="highway", catalogs="", network_extra="", variables=""):
    stop_trigger = trigger([sim_time(stop, "greaterThan", "end")], tag="StopTrigger") if stop is not None else ""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<!-- litesim corpus: {desc} -->
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="{minor}" date="2026-11-28T00:00:00" description="{desc}" author="litesim"/>
  <ParameterDeclarations>{params}</ParameterDeclarations>{variables}
  <CatalogLocations>{catalogs}</CatalogLocations>
  <RoadNetwork>
    <LogicFile filepath="../../maps/{road}.xodr"/>{network_extra}
  </RoadNetwork>
  <Entities>
{entities}  </Entities>
  <Storyboard>
    <Init>
      <Actions>{init}
      </Actions>
    </Init>{stories}
    {stop_trigger}
  </Storyboard>
</OpenSCENARIO>
"""


def two_cars(ego_v=20, lead_v=20, gap=30, lead_lane=-2):
    """Ego in lane -2 at s = 50 m; Lead `gap` m ahead in `lead_lane`."""
    ents = vehicle("Ego") + vehicle("Lead")
    init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(ego_v)) + \
        private("Lead", teleport(lane_pos(1, lead_lane, 50 + gap)), speed(lead_v))
    return ents, init


def at_time(t, name="go"):
    return trigger([sim_time(t, "greaterThan", name)])


FILES = {}


def add(name, text):
    FILES[name] = text


# ------------------------------------------------------------ speed actions
ents, init = two_cars(ego_v=10, lead_lane=-3)
for shape in ["linear", "cubic", "sinusoidal"]:
    add(f"speed_{shape}_time", scenario(
        f"a {shape} SpeedAction over 2 s from 10 to 20 m/s, starting at 1 s",
        ents, init, story(["Ego"], event("accelerate", action("speed", speed(20, shape, "time", 2)), at_time(1)))))
add("speed_step", scenario("a step SpeedAction to 15 m/s at 1 s", ents, init,
                           story(["Ego"], event("jump", action("speed", speed(15, "step", "time", 0)), at_time(1)))))
add("speed_linear_rate", scenario("a linear SpeedAction at 2 m/s² from 10 to 20 m/s, starting at 1 s", ents, init,
                                  story(["Ego"], event("accelerate", action("speed", speed(20, "linear", "rate", 2)), at_time(1)))))
add("speed_linear_distance", scenario("a linear SpeedAction over 45 m from 10 to 20 m/s (3 s at the mean speed)", ents, init,
                                      story(["Ego"], event("accelerate", action("speed", speed(20, "linear", "distance", 45)), at_time(1)))))
add("speed_follow_limits", scenario("a step SpeedAction to 30 m/s in followingMode follow: within maxAcceleration 6 m/s²", ents, init,
                                    story(["Ego"], event("accelerate", action("speed", speed(30, "step", "time", 0, follow="follow")), at_time(1)))))
ents, init = two_cars(ego_v=10, lead_v=25, lead_lane=-1)
add("speed_relative_delta", scenario("a relative SpeedAction: the lead's speed minus 5 m/s, linear over 2 s", ents, init,
                                     story(["Ego"], event("match", action("speed", speed_rel("Lead", -5, "delta", "false", "linear", "time", 2)), at_time(1)))))
add("speed_relative_factor_continuous", scenario(
    "a continuous relative SpeedAction: half the lead's speed while the lead slows to 10 m/s", ents, init,
    story(["Ego"], event("track", action("speed", speed_rel("Lead", 0.5, "factor", "true", "linear", "rate", 10)), at_time(0.5)), name="ego")
    + story(["Lead"], event("slow", action("slow", speed(10, "linear", "time", 4)), at_time(2)), name="lead")))

# ------------------------------------------------------------- lane changes
ents, init = two_cars()
add("lane_change_sinusoidal", scenario("a sinusoidal lane change over 3 s to the lane left of the ego's", ents, init,
                                       story(["Ego"], event("change", action("lc", lane_change(relative_lane("Ego", 1))), at_time(1)))))
add("lane_change_linear_distance", scenario("a linear lane change over 40 m of travel (2 s at 20 m/s) to lane -3", ents, init,
                                            story(["Ego"], event("change", action("lc", lane_change(absolute_lane(-3), "linear", "distance", 40)), at_time(1)))))
add("lane_change_cubic_offset", scenario("a cubic lane change over 4 s to lane -1, ending 0.5 m left of its centre", ents, init,
                                         story(["Ego"], event("change", action("lc", lane_change(absolute_lane(-1), "cubic", "time", 4, 0.5)), at_time(1)))))
add("lane_offset_absolute", scenario("a sinusoidal LaneOffsetAction to 1 m left at 0.5 m/s² sideways (T = π·√(1/(2·0.5)) s)", ents, init,
                                     story(["Ego"], event("offset", action("off", lane_offset('<AbsoluteTargetLaneOffset value="1"/>')), at_time(1)))))
add("lane_offset_relative", scenario("a cubic LaneOffsetAction 0.8 m right of the lead's offset (0) at 1 m/s²", ents, init,
                                     story(["Ego"], event("offset", action("off", lane_offset('<RelativeTargetLaneOffset entityRef="Lead" value="-0.8"/>', "cubic", 1)), at_time(1)))))

# ------------------------------------------------------- distance, synchronize
ents, init = two_cars(ego_v=20, lead_v=20, gap=60)
add("longitudinal_distance_rigid", scenario("a rigid LongitudinalDistanceAction: 25 m behind the lead (reference points), at once", ents, init,
                                            story(["Ego"], event("close", action("dist", '<LongitudinalAction><LongitudinalDistanceAction entityRef="Lead" distance="25" freespace="false" continuous="true"/></LongitudinalAction>'), at_time(1)))))
add("longitudinal_time_gap", scenario("a LongitudinalDistanceAction with dynamic constraints: a 1.5 s time gap, bumper to bumper", ents, init,
                                      story(["Ego"], event("close", action("dist", '<LongitudinalAction><LongitudinalDistanceAction entityRef="Lead" timeGap="1.5" freespace="true" continuous="true"><DynamicConstraints maxAcceleration="3" maxDeceleration="6" maxSpeed="40"/></LongitudinalDistanceAction></LongitudinalAction>'), at_time(1))), stop=20))
ents = vehicle("Ego") + vehicle("Other")
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(20)) + private("Other", teleport(lane_pos(1, -1, 20)), speed(10))
add("synchronize", scenario("a SynchronizeAction: Other reaches s = 300 m when Ego reaches s = 250 m, at 25 m/s", ents, init,
                            story(["Other"], event("sync", action("sync", f'<SynchronizeAction masterEntityRef="Ego" targetToleranceMaster="1" targetTolerance="1"><TargetPositionMaster>{lane_pos(1, -2, 250)}</TargetPositionMaster><TargetPosition>{lane_pos(1, -1, 300)}</TargetPosition><FinalSpeed><AbsoluteSpeed value="25"/></FinalSpeed></SynchronizeAction>'), at_time(0.5))), stop=15))

# -------------------------------------------------------------- trajectories


def follow(traj, timing=True, mode="position"):
    tr = '<Timing domainAbsoluteRelative="relative" scale="1" offset="0"/>' if timing else "<None/>"
    return f"""<RoutingAction><FollowTrajectoryAction><TrajectoryRef>{traj}</TrajectoryRef><TimeReference>{tr}</TimeReference><TrajectoryFollowingMode followingMode="{mode}"/></FollowTrajectoryAction></RoutingAction>"""


ents = vehicle("Ego")
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(10))
poly = '<Trajectory name="poly" closed="false"><Shape><Polyline>' + "".join(
    f'<Vertex time="{t}"><Position>{world_pos(x, y)}</Position></Vertex>' for t, x, y in [(0, 60, -5.25), (2, 80, -5.25), (4, 100, -1.75)]) + "</Polyline></Shape></Trajectory>"
add("trajectory_polyline", scenario("a timed polyline trajectory: (60, -5.25) at 0 s, (80, -5.25) at 2 s, (100, -1.75) at 4 s after its start at 1 s", ents, init,
                                    story(["Ego"], event("follow", action("traj", follow(poly)), at_time(1)))))
clothoid = f'<Trajectory name="clothoid" closed="false"><Shape><Clothoid curvature="0" curvaturePrime="0.0002" length="40" startTime="0" stopTime="4"><Position>{world_pos(60, -5.25, 0)}</Position></Clothoid></Shape></Trajectory>'
add("trajectory_clothoid", scenario("a clothoid trajectory (curvature 0 rising 0.0002/m² over 40 m, 4 s): it ends heading 0.16 rad, 2.13 m to the left", ents, init,
                                    story(["Ego"], event("follow", action("traj", follow(clothoid)), at_time(1)))))
nurbs = '<Trajectory name="nurbs" closed="false"><Shape><Nurbs order="3">' + "".join(
    f'<ControlPoint time="{t}" weight="1"><Position>{world_pos(x, y)}</Position></ControlPoint>' for t, x, y in [(0, 60, -5.25), (2, 80, -5.25), (4, 100, -1.75)]) + \
    "".join(f'<Knot value="{k}"/>' for k in [0, 0, 0, 1, 1, 1]) + "</Nurbs></Shape></Trajectory>"
add("trajectory_nurbs", scenario("a quadratic NURBS trajectory through (60,-5.25), (80,-5.25), (100,-1.75) over 4 s: a Bézier curve", ents, init,
                                 story(["Ego"], event("follow", action("traj", follow(nurbs)), at_time(1)))))
add("trajectory_untimed_follow", scenario("an untimed polyline followed in followingMode follow at the entity's own 10 m/s", ents, init,
                                          story(["Ego"], event("follow", action("traj", follow(poly, timing=False, mode="follow")), at_time(1)))))

# -------------------------------------------------------------- routes (junction)
ents = vehicle("Ego")
init = private("Ego", teleport(lane_pos(1, -1, 20)), speed(8))
# Every road's end is at the junction: lane -1 leads in, lane 1 out.
route = f'<Route name="right_turn" closed="false"><Waypoint routeStrategy="shortest"><Position>{lane_pos(1, -1, 20)}</Position></Waypoint><Waypoint routeStrategy="shortest"><Position>{lane_pos(2, 1, 50)}</Position></Waypoint></Route>'
add("assign_route", scenario("an AssignRouteAction from road 1 into road 2 (a right turn) through the junction", ents, init,
                             story(["Ego"], event("route", action("route", f"<RoutingAction><AssignRouteAction>{route}</AssignRouteAction></RoutingAction>"), at_time(0.1))),
                             stop=20, road="junction"))
add("acquire_position", scenario("an AcquirePositionAction to road 3 lane 1 at s = 40 m (straight across the junction)", ents, init,
                                 story(["Ego"], event("go", action("acquire", f"<RoutingAction><AcquirePositionAction>{position(lane_pos(3, 1, 40))}</AcquirePositionAction></RoutingAction>"), at_time(0.1))),
                                 stop=20, road="junction"))

# -------------------------------------------------------- signals (junction)
signals = """
    <TrafficSignals>
      <TrafficSignalController name="ctrl" delay="0">
        <Phase name="stop" duration="3"><TrafficSignalState trafficSignalId="tl1" state="on;off;off"/></Phase>
        <Phase name="go" duration="5"><TrafficSignalState trafficSignalId="tl1" state="off;off;on"/></Phase>
      </TrafficSignalController>
    </TrafficSignals>"""
ents = vehicle("Ego")
init = private("Ego", teleport(lane_pos(1, -1, 20)), speed(0))
add("traffic_signal_state", scenario("a TrafficSignalStateAction turns tl1 green at 2 s; a TrafficSignalCondition starts Ego then", ents, init,
                                     story(["Ego"], event("green", action("green", '<InfrastructureAction><TrafficSignalAction><TrafficSignalStateAction name="tl1" state="off;off;on"/></TrafficSignalAction></InfrastructureAction>', "GlobalAction"), at_time(2))
                                           + event("start", action("go", speed(5, "step")), trigger(['<Condition name="isgreen" delay="0" conditionEdge="rising"><ByValueCondition><TrafficSignalCondition name="tl1" state="off;off;on"/></ByValueCondition></Condition>']), priority="parallel")),
                                     stop=6, road="junction"))
add("traffic_signal_controller", scenario("a signal controller cycling stop (3 s) and go (5 s); a TrafficSignalControllerAction jumps to go at 1 s", ents, init,
                                          story(["Ego"], event("jump", action("jump", '<InfrastructureAction><TrafficSignalAction><TrafficSignalControllerAction trafficSignalControllerRef="ctrl" phase="go"/></TrafficSignalAction></InfrastructureAction>', "GlobalAction"), at_time(1))
                                                + event("start", action("go", speed(5, "step")), trigger(['<Condition name="isgreen" delay="0" conditionEdge="rising"><ByValueCondition><TrafficSignalCondition name="tl1" state="off;off;on"/></ByValueCondition></Condition>']), priority="parallel")),
                                          stop=6, road="junction", network_extra=signals))

# ---------------------------------------------------------- entities come and go
ents = vehicle("Ego") + vehicle("Late")
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(10))
add("add_delete_entity", scenario("AddEntityAction puts Late 40 m ahead of Ego at 1 s; DeleteEntityAction removes it at 3 s", ents, init,
                                  story(["Ego"], event("add", action("add", f'<EntityAction entityRef="Late"><AddEntityAction>{position(lane_pos(1, -1, 100))}</AddEntityAction></EntityAction>', "GlobalAction"), at_time(1))
                                        + event("delete", action("delete", '<EntityAction entityRef="Late"><DeleteEntityAction/></EntityAction>', "GlobalAction"), at_time(3), priority="parallel"))))

# ---------------------------------------------------------------- positions
ents = vehicle("Ego") + vehicle("A") + vehicle("B") + vehicle("C") + vehicle("D") + vehicle("E") + vehicle("F")
init = (private("Ego", teleport(lane_pos(1, -2, 100)), speed(0))
        + private("A", teleport(world_pos(150, -1.75, 0)), speed(0))
        + private("B", teleport(f'<RelativeWorldPosition entityRef="Ego" dx="10" dy="3.5"/>'), speed(0))
        + private("C", teleport(f'<RelativeObjectPosition entityRef="Ego" dx="-20" dy="-3.5"/>'), speed(0))
        + private("D", teleport(f'<RoadPosition roadId="1" s="200" t="-5.25"/>'), speed(0))
        + private("E", teleport(f'<RelativeRoadPosition entityRef="D" ds="30" dt="3.5"/>'), speed(0))
        + private("F", teleport(f'<RelativeLanePosition entityRef="E" dLane="-1" dsLane="25" offset="0.3"/>'), speed(0)))
add("positions", scenario("every position kind in the Init: World, RelativeWorld, RelativeObject, Road, RelativeRoad, RelativeLane (dsLane)", ents, init, "", stop=1))
ents = vehicle("Ego") + vehicle("A") + vehicle("B")
route_p = '<RouteRef><Route name="r" closed="false"><Waypoint routeStrategy="shortest"><Position>' + lane_pos(1, -2, 10) + \
    '</Position></Waypoint><Waypoint routeStrategy="shortest"><Position>' + lane_pos(1, -2, 900) + '</Position></Waypoint></Route></RouteRef>'
init = (private("Ego", teleport(f'<RoutePosition>{route_p}<InRoutePosition><FromLaneCoordinates pathS="120" laneId="-3" laneOffset="0.2"/></InRoutePosition></RoutePosition>'), speed(0))
        + private("A", teleport(f'<RelativeLanePosition entityRef="Ego" dLane="2" ds="-15"/>'), speed(0))
        + private("B", teleport(lane_pos(1, -2, 300, h=0.3, rel=True)), speed(0)))
add("positions_route_orientation", scenario("a RoutePosition (lane coordinates), a RelativeLanePosition by ds, a relative Orientation", ents, init, "", stop=1))

# -------------------------------------------------------------- conditions


def start_when(test, ents_init, desc, name, actors=("Ego",), act=None, edge="rising", stop=20, delay=0):
    ents, init = ents_init
    act = act or speed(0, "step")
    add(name, scenario(desc, ents, init, story(list(actors), event("react", action("react", act), trigger([by_entity(actors[0], test, edge=edge, delay=delay)]))), stop=stop))


start_when('<TimeHeadwayCondition entityRef="Lead" value="1.5" freespace="false" rule="lessThan" coordinateSystem="entity" relativeDistanceType="longitudinal"/>',
           two_cars(ego_v=25, lead_v=15, gap=60), "a TimeHeadwayCondition: Ego stops when its headway to the lead drops below 1.5 s", "cond_time_headway")
start_when('<TimeToCollisionCondition value="3" freespace="true" rule="lessThan" coordinateSystem="entity" relativeDistanceType="longitudinal"><TimeToCollisionConditionTarget><EntityRef entityRef="Lead"/></TimeToCollisionConditionTarget></TimeToCollisionCondition>',
           two_cars(ego_v=25, lead_v=15, gap=60), "a TimeToCollisionCondition (freespace): Ego stops when its TTC to the lead drops below 3 s", "cond_ttc")
start_when('<RelativeDistanceCondition entityRef="Lead" value="20" freespace="true" rule="lessThan" relativeDistanceType="longitudinal" coordinateSystem="entity"/>',
           two_cars(ego_v=25, lead_v=15, gap=60), "a RelativeDistanceCondition (longitudinal, freespace) below 20 m", "cond_relative_distance")
ents, init = two_cars(ego_v=20, lead_v=20, gap=0, lead_lane=-1)
add("cond_relative_distance_lateral", scenario(
    "a lateral RelativeDistanceCondition in the lane frame: Ego changes to lane -3 (sinusoidal, 3 s from 1 s); Lead stops once more than 5 m lie between them sideways",
    ents, init,
    story(["Ego"], event("away", action("lc", lane_change(absolute_lane(-3))), at_time(1)), name="ego")
    + story(["Lead"], event("react", action("stop", speed(0)), trigger([by_entity("Lead", '<RelativeDistanceCondition entityRef="Ego" value="5" freespace="false" rule="greaterThan" relativeDistanceType="lateral" coordinateSystem="lane"/>')])), name="lead")))
start_when(f'<DistanceCondition value="10" freespace="false" rule="lessThan" coordinateSystem="entity" relativeDistanceType="euclidianDistance">{position(world_pos(200, -5.25))}</DistanceCondition>',
           two_cars(ego_v=20), "a DistanceCondition to a world position: Ego stops within 10 m of (200, -5.25)", "cond_distance")
start_when(f'<ReachPositionCondition tolerance="2">{position(lane_pos(1, -2, 150))}</ReachPositionCondition>',
           two_cars(ego_v=20), "a ReachPositionCondition (1.0 syntax, deprecated in 1.2): within 2 m of s = 150 m", "cond_reach_position")
ents, init = two_cars(ego_v=20, lead_v=20, gap=60)
add("cond_relative_speed", scenario(
    "a RelativeSpeedCondition: the lead speeds up at 2 m/s² from 1 s; Ego changes lane once it is more than 4 m/s slower",
    ents, init,
    story(["Lead"], event("up", action("up", speed(30, "linear", "rate", 2)), at_time(1)), name="lead")
    + story(["Ego"], event("react", action("lc", lane_change(relative_lane("Ego", 1))), trigger([by_entity("Ego", '<RelativeSpeedCondition entityRef="Lead" value="-4" rule="lessThan"/>')])), name="ego")))
start_when('<TraveledDistanceCondition value="100"/>', two_cars(ego_v=20),
           "a TraveledDistanceCondition: Ego stops once it has driven 100 m", "cond_traveled_distance")
start_when('<EndOfRoadCondition duration="1"/>', (vehicle("Ego"), private("Ego", teleport(lane_pos(1, -2, 3900)), speed(25))),
           "an EndOfRoadCondition: 1 s after Ego reaches the motorway's end", "cond_end_of_road", act=lane_change(relative_lane("Ego", 1)), stop=12)
start_when('<CollisionCondition><EntityRef entityRef="Lead"/></CollisionCondition>', two_cars(ego_v=20, lead_v=0, gap=30),
           "a CollisionCondition: Ego runs into the standing lead", "cond_collision", act=speed(0))

ents, init = two_cars(ego_v=10)
add("cond_speed", scenario("a SpeedCondition: after a linear speed-up of 1 m/s² from 10 m/s, Ego changes lane once at 15 m/s", ents, init,
                           story(["Ego"], event("speedup", action("up", speed(20, "linear", "rate", 1)), at_time(0.5))
                                 + event("react", action("lc", lane_change(relative_lane("Ego", 1))), trigger([by_entity("Ego", '<SpeedCondition value="15" rule="greaterOrEqual"/>')]), priority="parallel"))))
add("cond_standstill", scenario("a StandStillCondition: Ego stops at 1 s and drives off at 5 m/s 2 s later", ents, init,
                                story(["Ego"], event("stop", action("stop", speed(0, "step")), at_time(1))
                                      + event("react", action("go", speed(5)), trigger([by_entity("Ego", '<StandStillCondition duration="2"/>')]), priority="parallel"))))
ents, init = two_cars(ego_v=20)
add("cond_acceleration", scenario("an AccelerationCondition: Ego brakes at 4 m/s² from 2 s and changes lane when braking harder than 3 m/s²", ents, init,
                                  story(["Ego"], event("brake", action("brake", speed(8, "linear", "rate", 4)), at_time(2))
                                        + event("react", action("lc", lane_change(relative_lane("Ego", 1))), trigger([by_entity("Ego", '<AccelerationCondition value="-3" rule="lessThan"/>')]), priority="parallel"))))
ents, init = (vehicle("Ego"), private("Ego", teleport(lane_pos(1, -3, 50)), speed(10)))
add("cond_offroad", scenario("an OffroadCondition: Ego offsets 7 m right, off the road, and stops 0.5 s after leaving it", ents, init,
                             story(["Ego"], event("leave", action("leave", lane_offset('<AbsoluteTargetLaneOffset value="-7"/>', "linear", 2)), at_time(1))
                                   + event("react", action("stop", speed(0)), trigger([by_entity("Ego", '<OffroadCondition duration="0.5"/>')]), priority="parallel")), stop=8))

ents = vehicle("Ego")
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(0), speed(20, "linear", "time", 4),
               lane_change(absolute_lane(-1), "sinusoidal", "time", 3))
add("init_actions_go_on", scenario("Init actions that take time go on after the start: a linear speed-up to 20 m/s over 4 s and a lane change over 3 s", ents, init, "", stop=6))

# ----------------------------------------------------------------- storyboard
ents, init = two_cars(ego_v=10, lead_lane=-3)
add("storyboard_element_state", scenario("a StoryboardElementStateCondition: the lane change starts when the speed-up event ends", ents, init,
                                         story(["Ego"], event("speedup", action("up", speed(20, "linear", "time", 2)), at_time(1))
                                               + event("after", action("lc", lane_change(relative_lane("Ego", 1))), trigger(['<Condition name="ended" delay="0" conditionEdge="none"><ByValueCondition><StoryboardElementStateCondition storyboardElementType="event" storyboardElementRef="speedup" state="endTransition"/></ByValueCondition></Condition>']), priority="parallel"))))
add("priority_override", scenario("priority override: a second speed event at 2 s stops the first (linear to 30 m/s over 4 s) and holds 15 m/s", ents, init,
                                  story(["Ego"], event("first", action("up", speed(30, "linear", "time", 4)), at_time(1))
                                        + event("second", action("hold", speed(15, "step")), at_time(2), priority="override"))))
add("priority_skip", scenario("priority skip: a second event at 2 s is skipped while the first (1 s to 5 s) runs", ents, init,
                              story(["Ego"], event("first", action("up", speed(30, "linear", "time", 4)), at_time(1))
                                    + event("second", action("hold", speed(15, "step")), at_time(2), priority="skip"))))
add("priority_parallel", scenario("priority parallel: a lane change at 2 s runs beside the speed-up", ents, init,
                                  story(["Ego"], event("first", action("up", speed(30, "linear", "time", 4)), at_time(1))
                                        + event("second", action("lc", lane_change(relative_lane("Ego", 1))), at_time(2), priority="parallel"))))
add("event_execution_count", scenario("an Event with maximumExecutionCount 3: +2 m/s each time Ego's speed is a whole 2 m/s above 10 (rising)", ents, init,
                                      story(["Ego"], event("bump", action("bump", speed_rel("Ego", 2, "delta", "false", "step")),
                                                           trigger([sim_time(1, "greaterThan", "t1")], [sim_time(2, "greaterThan", "t2")], [sim_time(3, "greaterThan", "t3")]), count=3))))
add("maneuver_group_count", scenario("a ManeuverGroup with maximumExecutionCount 2: its speed event (+3 m/s over 1 s, edge none) runs twice", ents, init,
                                     story(["Ego"], event("bump", action("bump", speed_rel("Ego", 3, "delta", "false", "linear", "time", 1)), trigger([sim_time(1, "greaterThan", "go", "none")])), group_count=2)))
add("edges_and_delay", scenario("edges and a delay: falling (speed below 12 after being above) and a 1.5 s delay", ents, init,
                                story(["Ego"], event("up", action("up", speed(15, "step")), at_time(1))
                                      + event("down", action("down", speed(10, "step")), at_time(3), priority="parallel")
                                      + event("react", action("lc", lane_change(relative_lane("Ego", 1))),
                                              trigger([by_entity("Ego", '<SpeedCondition value="12" rule="greaterThan"/>', edge="falling", delay=1.5)]), priority="parallel"))))
add("act_stop_trigger", scenario("an Act's StopTrigger at 2 s stops its running speed change (linear to 30 m/s over 4 s from 1 s)", ents, init,
                                 story(["Ego"], event("up", action("up", speed(30, "linear", "time", 4)), at_time(1)),
                                       act_stop=trigger([sim_time(2, "greaterThan", "stop_act")], tag="StopTrigger"))))
add("condition_groups", scenario("condition groups: (t > 5 and speed > 100) or (t > 2): the OR fires at 2 s", ents, init,
                                 story(["Ego"], event("go", action("lc", lane_change(relative_lane("Ego", 1))),
                                                      trigger([sim_time(5, "greaterThan", "late"), by_entity("Ego", '<SpeedCondition value="100" rule="greaterThan"/>', edge="none")],
                                                              [sim_time(2, "greaterThan", "early")])))))

# -------------------------------------------------- parameters, variables, versions
params = """
    <ParameterDeclaration name="Speed" parameterType="double" value="15"/>
    <ParameterDeclaration name="Half" parameterType="double" value="${$Speed / 2}"/>
    <ParameterDeclaration name="Flag" parameterType="integer" value="0"/>"""
ents = vehicle("Ego")
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed("$Half"))
add("parameters_and_expressions", scenario("parameters and expressions: Ego starts at ${$Speed / 2} = 7.5 m/s; a ParameterSetAction at 1 s lets a ParameterCondition change its speed to $Speed", ents, init,
                                           story(["Ego"], event("set", action("set", '<ParameterAction parameterRef="Flag"><SetAction value="1"/></ParameterAction>', "GlobalAction"), at_time(1), priority="overwrite")
                                                 + event("react", action("speed", speed("$Speed")), trigger(['<Condition name="flag" delay="0" conditionEdge="none"><ByValueCondition><ParameterCondition parameterRef="Flag" value="1" rule="equalTo"/></ByValueCondition></Condition>']), priority="parallel")),
                                           params=params, minor=1))
add("variables", scenario("variables (1.2): a VariableAction adds 3 to Count at 1 s and 2 s; Ego stops when Count reaches 6", ents,
                          private("Ego", teleport(lane_pos(1, -2, 50)), speed(10)),
                          story(["Ego"], event("add", action("add", '<VariableAction variableRef="Count"><ModifyAction><Rule><AddValue value="3"/></Rule></ModifyAction></VariableAction>', "GlobalAction"),
                                               trigger([sim_time(1, "greaterThan", "a")], [sim_time(2, "greaterThan", "b")]), count=2)
                                + event("react", action("stop", speed(0)), trigger(['<Condition name="six" delay="0" conditionEdge="none"><ByValueCondition><VariableCondition variableRef="Count" value="6" rule="greaterOrEqual"/></ByValueCondition></Condition>']), priority="parallel")),
                          variables='\n  <VariableDeclarations><VariableDeclaration name="Count" variableType="int" value="0"/></VariableDeclarations>'))
ents, init = two_cars(ego_v=10)
add("version_1_0", scenario("an OpenSCENARIO 1.0 file: priority overwrite, an Act and Event with their start triggers", ents, init,
                            story(["Ego"], event("up", action("up", speed(20, "linear", "time", 2)), at_time(1), priority="overwrite"),
                                  act_start=trigger([sim_time(-1, "greaterThan", "act_start", "none")])), minor=0))
act_free = story(["Ego"], event("up", action("up", speed(20, "linear", "time", 2)), at_time(1)), act_start="")
add("version_1_3", scenario("an OpenSCENARIO 1.3 file: an Act without a StartTrigger starts with the storyboard", ents, init, act_free, minor=3))

# ------------------------------------------------ catalogs, objects, selections, notes
catalogs = """
    <VehicleCatalog><Directory path="../catalogs"/></VehicleCatalog>
    <ControllerCatalog><Directory path="../catalogs"/></ControllerCatalog>"""
ents = """    <ScenarioObject name="Ego">
      <CatalogReference catalogName="VehicleCatalog" entryName="car"><ParameterAssignments><ParameterAssignment parameterRef="Length" value="5.2"/></ParameterAssignments></CatalogReference>
      <ObjectController><CatalogReference catalogName="ControllerCatalog" entryName="ExternalController"/></ObjectController>
    </ScenarioObject>
    <ScenarioObject name="Truck">
      <CatalogReference catalogName="VehicleCatalog" entryName="truck"/>
    </ScenarioObject>
"""
init = private("Ego", teleport(lane_pos(1, -2, 50)), speed(20),
               '<ControllerAction><ActivateControllerAction longitudinal="true" lateral="true"/></ControllerAction>') + \
    private("Truck", teleport(lane_pos(1, -1, 120)), speed(15))
add("catalogs_and_controllers", scenario("catalog entries with a parameter assignment (Length 5.2 m), an ExternalController activated in the Init", ents, init,
                                         story(["Truck"], event("slow", action("slow", speed(10, "linear", "time", 3)), at_time(2))), catalogs=catalogs))
ents = vehicle("Ego") + pedestrian("Walker") + obstacle("Box")
init = (private("Ego", teleport(lane_pos(1, -2, 50)), speed(10))
        + private("Walker", teleport(world_pos(150, -14, 1.5708)), speed(0))
        + private("Box", teleport(lane_pos(1, -3, 120))))
add("pedestrian_and_object", scenario("a Pedestrian crosses (1.5 m/s from 1 s) in front of Ego, beside a MiscObject", ents, init,
                                      story(["Walker"], event("walk", action("walk", speed(1.5, "step")), at_time(1))), stop=15))
sel_ents = vehicle("Ego") + vehicle("A") + vehicle("B") + """    <EntitySelection name="Pair">
      <Members><EntityRef entityRef="A"/><EntityRef entityRef="B"/></Members>
    </EntitySelection>
"""
init = (private("Ego", teleport(lane_pos(1, -2, 50)), speed(10)) + private("A", teleport(lane_pos(1, -1, 80)), speed(10))
        + private("B", teleport(lane_pos(1, -3, 80)), speed(10)))
add("entity_selection", scenario("an EntitySelection as actors: both members speed up to 20 m/s", sel_ents, init,
                                 story(["Pair"], event("up", action("up", speed(20, "linear", "time", 2)), at_time(1)))))
ents, init = two_cars()
env = '<EnvironmentAction><Environment name="rain"><TimeOfDay animation="false" dateTime="2026-06-01T12:00:00"/><Weather cloudState="overcast"><Sun intensity="0.5" azimuth="0" elevation="1"/><Fog visualRange="1000"/><Precipitation precipitationType="rain" intensity="5"/></Weather><RoadCondition frictionScaleFactor="0.8"/></Environment></EnvironmentAction>'
custom = '<CustomCommandAction type="log">hello from the storyboard</CustomCommandAction>'
add("notes_environment_custom", scenario("an EnvironmentAction and a CustomCommandAction: read and logged as notes", ents, init,
                                         story(["Ego"], event("env", action("env", env, "GlobalAction") + action("custom", custom, "UserDefinedAction"), at_time(1), priority="overwrite")),
                                         minor=1))


def main():
    OUT.mkdir(exist_ok=True)
    for old in OUT.glob("*.xosc"):
        old.unlink()
    for name, text in sorted(FILES.items()):
        (OUT / f"{name}.xosc").write_text(text)
    print(f"wrote {len(FILES)} files to {OUT}")


if __name__ == "__main__":
    main()
