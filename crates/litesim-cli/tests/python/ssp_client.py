"""A third-party client of litesim's SSP API: Python grpcio, stubs generated
from the .proto at test time with grpcio-tools.

Usage: python3 ssp_client.py HOST:PORT PROTO_ROOT

Creates two vehicles, drives one by pedals and one by xy trajectory for 300
steps of 20 ms, and checks what it reads back: the pedal car against a plain
Python transcription of the seed's Model SSP equations, the trajectory car
against the trajectory. Exits non-zero on the first mismatch.
"""
import math
import os
import sys
import tempfile

from grpc_tools import protoc
import grpc

addr, proto_root = sys.argv[1], sys.argv[2]
out = tempfile.mkdtemp(prefix="litesim_py_")
rc = protoc.main([
    "protoc", f"-I{proto_root}", f"--python_out={out}", f"--grpc_python_out={out}",
    os.path.join(proto_root, "litesim/ssp/v1/ssp.proto"),
])
assert rc == 0, "protoc failed"
# Regular packages (with __init__.py): the generated `litesim.ssp.v1` wins
# over an installed `litesim` Python package of the same top-level name.
for d in ("litesim", "litesim/ssp", "litesim/ssp/v1"):
    open(os.path.join(out, d, "__init__.py"), "a").close()
sys.path.insert(0, out)
from litesim.ssp.v1 import ssp_pb2 as pb  # noqa: E402
from litesim.ssp.v1 import ssp_pb2_grpc as rpc  # noqa: E402

stub = rpc.SimulatorSupportStub(grpc.insecure_channel(addr))
init = stub.Init(pb.InitRequest(client_name="python", step_size_ms=20, profile="dummy"))
sid = init.session_id
assert init.capabilities.step_size_ms == 20
stub.StartSimulation(pb.StartSimulationRequest(session_id=sid))
stub.WaitStartSimulation(pb.WaitStartSimulationRequest(session_id=sid, max_wait_ms=1000))

created = stub.CreateActor(pb.CreateActorRequest(
    session_id=sid, actor_id="pedal_car",
    description=pb.ActorDescription(actor_type="Vehicle", category=pb.ACTOR_CATEGORY_VEHICLE),
    position=pb.Coord6Dof(x=0.0, y=0.0, yaw=0.0)))
length = created.actual_description.length_m
stub.CreateActor(pb.CreateActorRequest(
    session_id=sid, actor_id="traj_car", position=pb.Coord6Dof(x=0.0, y=5.0, yaw=0.0)))
entry = next(e for e in init.capabilities.catalog if e.model_id == created.actual_description.model_id)

# Bad input is answered with the right status and the session goes on.
try:
    stub.SetDynamicMove(pb.SetDynamicMoveRequest(
        session_id=sid, actor_id="pedal_car", normalized=pb.NormalizedControls(throttle=float("nan"))))
    raise SystemExit("NaN throttle was accepted")
except grpc.RpcError as e:
    assert e.code() == grpc.StatusCode.INVALID_ARGUMENT and "throttle" in e.details(), e
try:
    stub.DestroyActor(pb.DestroyActorRequest(session_id=sid, actor_id="nobody"))
    raise SystemExit("unknown actor was accepted")
except grpc.RpcError as e:
    assert e.code() == grpc.StatusCode.NOT_FOUND, e

# The seed's model, transcribed (Model SSP §489.2.3).
MAX_SWA = 7.853981633974483  # litesim's documented MAX_STEERING_WHEEL_ANGLE (450°)
wheelbase = 0.6 * length
x = y = h = v = 0.0
dt = 0.02
V_TRAJ = 9.0

worst_pedal = worst_traj = 0.0
for k in range(300):
    now = k * 20
    if k % 10 == 0:
        pts = [pb.Coord6Dof(x=V_TRAJ * (now + 20 * j) / 1000.0, y=5.0) for j in range(13)]
        stub.SetXyTrajectory(pb.SetXyTrajectoryRequest(
            session_id=sid, actor_id="traj_car", start_time_ms=now, end_time_ms=now + 240, polyline=pts))
    throttle, brake, steering = (0.5, 0.0, 0.1) if k < 200 else (0.0, 0.2, -0.05)
    stub.SetDynamicMove(pb.SetDynamicMoveRequest(
        session_id=sid, actor_id="pedal_car",
        normalized=pb.NormalizedControls(throttle=throttle, brake=brake, steering=steering)))
    stub.StartStep(pb.StartStepRequest(session_id=sid))
    done = stub.WaitStep(pb.WaitStepRequest(session_id=sid, max_wait_ms=1000))
    assert done.sim_time_ms == now + 20, done
    states = {s.actor_id: s for s in stub.GetActorsStates(pb.GetActorsStatesRequest(session_id=sid)).states}

    # Seed equations for the pedal car.
    if brake > 0:
        a = -brake * entry.max_decel_mps2
    elif throttle > 0:
        a = throttle * entry.max_accel_mps2
    else:
        a = -math.copysign(2.0, v)
    wheels = (steering * MAX_SWA) / MAX_SWA * entry.max_steer_angle_deg
    w = v / (wheelbase / math.sin(math.radians(wheels))) if wheels != 0 else 0.0
    v = max(0.0, min(v + a * dt, 40.0))
    h += w * dt
    x += v * math.cos(h) * dt
    y += v * math.sin(h) * dt
    p = states["pedal_car"]
    err = max(abs(p.position.x - x), abs(p.position.y - y), abs(p.position.yaw - h), abs(p.speed_mps - v))
    worst_pedal = max(worst_pedal, err)
    assert err < 1e-9, f"step {k}: pedal car differs from the seed's equations by {err}"
    assert p.active_mode == pb.MOVE_MODE_DYNAMIC

    t = (now + 20) / 1000.0
    q = states["traj_car"]
    err = max(abs(q.position.x - V_TRAJ * t), abs(q.position.y - 5.0), abs(q.speed_mps - V_TRAJ))
    worst_traj = max(worst_traj, err)
    assert err < 1e-9, f"step {k}: trajectory car off by {err}"
    assert q.trajectory == pb.TRAJECTORY_STATUS_FOLLOWING

end = stub.EndSimulation(pb.EndSimulationRequest(session_id=sid, reason="python done"))
assert end.steps_executed == 300, end
stub.Shutdown(pb.ShutdownRequest(session_id=sid))
print(f"python client OK: 300 steps; max deviation pedal car {worst_pedal:.3g}, trajectory car {worst_traj:.3g}")
