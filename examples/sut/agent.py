"""A system under test for litesim, in Python: copy it and put your stack in step().
Run: python3 agent.py [--port 50061]; then: litesim run T.osc --sut grpc://127.0.0.1:50061
Needs grpcio and grpcio-tools (stubs are generated from litesim's .proto at start)."""
import argparse, math, os, sys, tempfile, time
from concurrent import futures
import grpc
from grpc_tools import protoc

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, default=50061)
ap.add_argument("--proto", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../proto"))
ap.add_argument("--exit-after", type=int, default=-1, help="crash after N steps (for tests)")
ap.add_argument("--hang-after", type=int, default=-1, help="stop answering after N steps (for tests)")
args = ap.parse_args()
out = tempfile.mkdtemp(prefix="litesim_sut_")
assert protoc.main(["protoc", f"-I{args.proto}", f"--python_out={out}", f"--grpc_python_out={out}",
                    os.path.join(args.proto, "litesim/sut/v1/sut.proto")]) == 0
for d in ("litesim", "litesim/sut", "litesim/sut/v1"):  # regular packages: the stubs win over
    open(os.path.join(out, d, "__init__.py"), "a").close()  # an installed `litesim` Python package
sys.path.insert(0, out)
from litesim.sut.v1 import sut_pb2 as pb, sut_pb2_grpc as rpc  # noqa: E402

class Agent(rpc.SystemUnderTestServicer):
    """Cruise at the requested speed, keep 2 s to the car ahead in the lane, follow the route."""
    def __init__(self):
        self.runs, self.steps = {}, 0
    def Reset(self, req, ctx):
        self.runs[req.run_id] = req
        return pb.ResetReply()
    def Step(self, obs, ctx):
        self.steps += 1
        if self.steps == args.exit_after:
            os._exit(3)
        if self.steps == args.hang_after:
            time.sleep(3600)
        info, e = self.runs[obs.run_id], obs.ego
        c, s = math.cos(e.yaw), math.sin(e.yaw)
        gap = math.inf  # nearest object ahead whose centre is within a lane width of our axis
        for o in obs.objects:
            ahead, side = (o.x - e.x) * c + (o.y - e.y) * s, -(o.x - e.x) * s + (o.y - e.y) * c
            if ahead > 0 and abs(side) < (e.width + o.width) / 2 + 0.3:
                gap = min(gap, ahead - (e.length + o.length) / 2)
        want = min(obs.requested_speed, max(0.0, (gap - 2.0) / 2.0))
        accel = max(-min(info.max_decel, 6.0), min(info.max_accel, 1.5 * (want - e.speed)))
        pts = info.route.points  # pure pursuit: aim at the first route point 8 m ahead
        tx, ty = next(((p.x, p.y) for p in pts if (p.x - e.x) * c + (p.y - e.y) * s > 8.0),
                      (pts[-1].x, pts[-1].y))
        lx, ly = (tx - e.x) * c + (ty - e.y) * s, -(tx - e.x) * s + (ty - e.y) * c
        curv = 2.0 * ly / max(lx * lx + ly * ly, 1e-6)
        return pb.Command(accel=pb.Accel(acceleration=accel, curvature=curv))

server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
rpc.add_SystemUnderTestServicer_to_server(Agent(), server)
port = server.add_insecure_port(f"127.0.0.1:{args.port}")
server.start()
print(f"listening on {port}", flush=True)
server.wait_for_termination()
