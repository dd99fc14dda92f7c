"""Reads a litesim MCAP file the way third-party tools do and checks it
against the run's log.json:
python3 check_mcap.py RUN.mcap LOG.json

- the `mcap` reader with CRC validation (chunks, data and summary section)
  and the summary's statistics;
- topics, schema names and encodings as Foxglove documents them
  (foxglove.SceneUpdate / foxglove.FrameTransforms in protobuf, JSON with a
  jsonschema), every protobuf message decoded by `mcap-protobuf-support`
  from the schema stored in the file;
- every /osi/ground_truth message decoded with osi-python's own osi3
  classes: one moving object per actor, positions equal to log.json to 1 mm,
  timestamps equal to the log's times, lanes and boundaries present when the
  run had a map;
- a run that changed the environment: one /environment JSON message per
  change of log.json's `environment`, with the first tick it holds for, and OSI's
  environmental_conditions in every GroundTruth from the first change on
  (none before).
"""
import json
import math
import sys

from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import SeekingReader
from mcap_protobuf.decoder import DecoderFactory
from osi3.osi_groundtruth_pb2 import GroundTruth



class JsonDecoders(McapDecoderFactory):
    """JSON messages, as Foxglove reads them."""

    def decoder_for(self, message_encoding, schema):
        return json.loads if message_encoding == "json" else None


path, log_path = sys.argv[1:3]
log = json.load(open(log_path))
ticks = len(log["tick"])
tracks = log["tracks"]
ids = [t["id"] for t in tracks]

with open(path, "rb") as f:
    reader = SeekingReader(f, validate_crcs=True, decoder_factories=[DecoderFactory(), JsonDecoders()])
    summary = reader.get_summary()
    topics = {c.topic: c for c in summary.channels.values()}
    schema = lambda t: summary.schemas[topics[t].schema_id]
    want = {
        "/scene": ("foxglove.SceneUpdate", "protobuf", "protobuf"),
        "/map": ("foxglove.SceneUpdate", "protobuf", "protobuf"),
        "/tf": ("foxglove.FrameTransforms", "protobuf", "protobuf"),
        "/osi/ground_truth": ("osi3.GroundTruth", "protobuf", "protobuf"),
    }
    for i in ids:
        want[f"/actors/{i}/state"] = ("litesim.ActorState", "jsonschema", "json")
    for t, (name, senc, menc) in want.items():
        assert t in topics, f"no topic {t}: {sorted(topics)}"
        s = schema(t)
        got = (s.name, s.encoding, topics[t].message_encoding)
        assert got == (name, senc, menc), f"{t}: {got}"
    json.loads(schema(f"/actors/{ids[0]}/state").data)  # a real JSON Schema
    env = log.get("environment", [])
    if env:
        s = schema("/environment")
        got = (s.name, s.encoding, topics["/environment"].message_encoding)
        assert got == ("litesim.EnvironmentChange", "jsonschema", "json"), got
        json.loads(s.data)
    else:
        assert "/environment" not in topics, "no change, no /environment topic"
    counts = summary.statistics.channel_message_counts
    for t in ["/scene", "/tf", "/osi/ground_truth"]:
        n = counts[topics[t].id]
        assert n == ticks, f"{t}: {n} messages for {ticks} ticks"

    # Per tick: what the log says each actor's position was.
    where = {}
    for t in tracks:
        for k, tick in enumerate(t["tick"]):
            where[(tick, t["id"])] = (t["state"]["x"][k], t["state"]["y"][k])
    times = dict(zip(log["tick"], log["time"]))
    time_to_tick = {round(v * 1e9): k for k, v in times.items()}

    n_gt = n_scene = n_tf = n_state = 0
    env_seen = []
    first_change = env[0]["tick"] if env else None
    lanes_seen = 0
    for sch, channel, message, decoded in reader.iter_decoded_messages():
        tick = time_to_tick.get(message.log_time)
        assert tick is not None, f"{channel.topic}: log time {message.log_time} is no tick's time"
        assert message.publish_time == message.log_time
        if channel.topic == "/osi/ground_truth":
            gt = GroundTruth.FromString(message.data)  # osi-python's own class
            n_gt += 1
            ns = gt.timestamp.seconds * 1_000_000_000 + gt.timestamp.nanos
            assert ns == message.log_time, (ns, message.log_time)
            assert (gt.version.version_major, gt.version.version_minor) == (3, 8)
            objs = list(gt.moving_object)
            present = [i for i in ids if (tick, i) in where]
            assert len(objs) == len(present), (tick, len(objs), present)
            for o in objs:
                aid = ids[o.id.value - 1]
                x, y = where[(tick, aid)]
                p = o.base.position
                assert abs(p.x - x) <= 1e-3 and abs(p.y - y) <= 1e-3, (tick, aid, p, x, y)
                assert o.base.dimension.length > 0 and o.base.dimension.width > 0
                assert o.type in (2, 3)  # TYPE_VEHICLE, TYPE_PEDESTRIAN
            assert gt.host_vehicle_id.value >= 1
            lanes_seen = max(lanes_seen, len(gt.lane))
            changed = first_change is not None and tick >= first_change
            assert gt.HasField("environmental_conditions") == changed, (tick, first_change)
            if gt.lane:
                bids = {b.id.value for b in gt.lane_boundary}
                for lane in gt.lane:
                    c = lane.classification
                    assert len(c.centerline) >= 2
                    for b in list(c.left_lane_boundary_id) + list(c.right_lane_boundary_id):
                        assert b.value in bids, f"lane {lane.id.value}: unknown boundary {b.value}"
        elif channel.topic == "/scene":
            n_scene += 1
            for e in decoded.entities:
                x, y = where[(tick, e.id)]
                c = e.cubes[0].pose.position
                assert abs(c.x - x) <= 1e-3 and abs(c.y - y) <= 1e-3
                assert e.frame_id == "map"
        elif channel.topic == "/tf":
            n_tf += 1
            for tr in decoded.transforms:
                x, y = where[(tick, tr.child_frame_id)]
                assert abs(tr.translation.x - x) <= 1e-3 and tr.parent_frame_id == "map"
        elif channel.topic == "/environment":
            env_seen.append((decoded["tick"], decoded["action"], decoded["values"]))
            # Published with the first logged tick it holds for.
            first = min(k for k in times if k >= decoded["tick"])
            assert tick == first, (decoded["tick"], tick)
        elif channel.topic == "/map":
            assert sum(len(l.points) for e in decoded.entities for l in e.lines) > 0
        else:
            n_state += 1
            s = decoded
            x, y = where[(tick, s["id"])]
            assert abs(s["x"] - x) <= 1e-9 and abs(s["y"] - y) <= 1e-9
    assert n_gt == n_scene == n_tf == ticks, (n_gt, n_scene, n_tf, ticks)
    assert n_state == len(where), (n_state, len(where))
    assert env_seen == [(e["tick"], e["action"], e["values"]) for e in env], env_seen
    if "--map" in sys.argv:
        assert lanes_seen > 0, "the run had a map: GroundTruth must carry its lanes"
print(f"mcap ok: {ticks} ticks, {len(ids)} actors, {lanes_seen} lanes, {len(env)} environment changes")
