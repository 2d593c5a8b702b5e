"""The traffic service as `trafficmesh up` starts it: a runtime's gRPC
client (stubs generated here with grpcio-tools from the project's .proto
files) finds the cluster's map among the scenes and drives a session, and a
Zenoh subscriber on the cluster's bus sees the session's actors, and so
does the admin's live map (its websocket). Prints OK.

usage: traffic_service.py PROTO_DIR GRPC_ADDRESS ZENOH_ENDPOINT CLUSTER ADMIN_URL
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import websocket
import zenoh

proto, address, endpoint, cluster, admin = sys.argv[1:6]
stubs = tempfile.mkdtemp()
subprocess.run(
    [sys.executable, "-m", "grpc_tools.protoc", "-I", proto, f"--python_out={stubs}",
     f"--grpc_python_out={stubs}", os.path.join(proto, "common.proto"), os.path.join(proto, "traffic.proto")],
    check=True,
)
sys.path.insert(0, stubs)
import grpc  # noqa: E402
import common_pb2 as common  # noqa: E402
import traffic_pb2 as traffic  # noqa: E402
import traffic_pb2_grpc  # noqa: E402

channel = grpc.insecure_channel(address)
grpc.channel_ready_future(channel).result(timeout=60)
stub = traffic_pb2_grpc.TrafficServiceStub(channel)
metadata = stub.get_metadata(common.Empty())
assert list(metadata.supported_map_ids) == ["four_way"], metadata

seen = []
conf = zenoh.Config()
conf.insert_json5("mode", '"peer"')
conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
conf.insert_json5("scouting/multicast/enabled", "false")
bus = zenoh.open(conf)
watcher = bus.declare_subscriber(f"{cluster}/traffic/*/objects", lambda s: seen.append(json.loads(s.payload.to_string())))
time.sleep(1.0)


def pose_at(t_us, x, y):
    return common.PoseAtTime(
        pose=common.Pose(vec=common.Vec3(x=x, y=y, z=0.75), quat=common.Quat(w=1.0)), timestamp_us=t_us
    )


log = common.Trajectory(poses=[pose_at(t, 20.0 + 10.0 * t / 1e6, -1.75) for t in range(0, 1_500_001, 100_000)])
stub.start_session(
    traffic.TrafficSessionRequest(
        session_uuid="s1",
        map_id="four_way",
        random_seed=1,
        logged_object_trajectories=[
            traffic.ObjectTrajectory(object_id="car", aabb=common.AABB(size_x=4.5, size_y=2.0, size_z=1.5), trajectory=log)
        ],
        handover_time_us=600_000,
    )
)
for t in range(100_000, 3_000_001, 100_000):
    r = stub.simulate(traffic.TrafficRequest(session_uuid="s1", time_query_us=t))
    assert [u.object_id for u in r.object_trajectory_updates] == ["car"], r
x = r.object_trajectory_updates[0].trajectory.poses[0].pose.vec.x
assert x > 40.0, f"the car drives on after handover: x = {x}"
deadline = time.monotonic() + 5
while not any(v["time_us"] == 3_000_000 for v in seen) and time.monotonic() < deadline:
    time.sleep(0.05)
last = [v for v in seen if v["time_us"] == 3_000_000]
assert last and last[0]["session"] == "s1" and last[0]["objects"][0]["driver"] == "model", seen[-3:]

# The live map's feed carries the session's actors while it is live.
ws = websocket.create_connection(admin.replace("http://", "ws://") + "/api/v1/live?hz=10", timeout=5)
drawn = None
deadline = time.monotonic() + 5
while drawn is None and time.monotonic() < deadline:
    m = ws.recv()
    if isinstance(m, str):
        m = json.loads(m)
        if m.get("type") == "sessions":
            drawn = next((s for s in m["sessions"] if s["session"] == "s1"), None)
ws.close()
assert drawn and [o["id"] for o in drawn["objects"]] == ["car"], drawn
stub.close_session(traffic.TrafficSessionCloseRequest(session_uuid="s1"))
watcher.undeclare()
bus.close()
print("OK")
