"""A runtime's client of the traffic service, generated with grpcio-tools
from the project's .proto files: document 003's usage example end to end,
then the checks of the traffic service's behaviour and errors.

A Zenoh subscriber (eclipse-zenoh, not the code under test) watches the
sessions' actors on the bus meanwhile.

usage: client.py <generated stubs dir> <address> <zenoh endpoint> <cluster>
"""

import json
import math
import sys
import threading
import time

import zenoh

sys.path.insert(0, sys.argv[1])

import grpc  # noqa: E402
import common_pb2 as common  # noqa: E402
import traffic_pb2 as traffic  # noqa: E402
import traffic_pb2_grpc  # noqa: E402

address = sys.argv[2]

seen = []
seen_lock = threading.Lock()
conf = zenoh.Config()
conf.insert_json5("mode", '"peer"')
conf.insert_json5("connect/endpoints", json.dumps([sys.argv[3]]))
conf.insert_json5("scouting/multicast/enabled", "false")
bus = zenoh.open(conf)


def on_sample(sample):
    with seen_lock:
        seen.append((str(sample.key_expr), json.loads(sample.payload.to_string())))


watcher = bus.declare_subscriber(f"{sys.argv[4]}/traffic/*/objects", on_sample)
time.sleep(1.0)
stub = traffic_pb2_grpc.TrafficServiceStub(grpc.insecure_channel(address))
STEP = 100_000
HANDOVER = 600_000


def pose_at(t_us, x, y, yaw=0.0, z=0.75):
    return common.PoseAtTime(
        pose=common.Pose(
            vec=common.Vec3(x=x, y=y, z=z),
            quat=common.Quat(w=math.cos(yaw / 2), x=0.0, y=0.0, z=math.sin(yaw / 2)),
        ),
        timestamp_us=t_us,
    )


def car_log():
    """Eastbound at 10 m/s on the four-way map's J0_0_out_E0 (y = -1.75), 1.5 s of log."""
    return common.Trajectory(
        poses=[pose_at(t, 20.0 + 10.0 * t / 1e6, -1.75) for t in range(0, 1_500_001, STEP)]
    )


def logged():
    return [
        traffic.ObjectTrajectory(
            object_id="car",
            aabb=common.AABB(size_x=4.5, size_y=2.0, size_z=1.5),
            trajectory=car_log(),
            is_static=False,
        ),
        traffic.ObjectTrajectory(
            object_id="parked",
            aabb=common.AABB(size_x=5.0, size_y=2.1, size_z=1.6),
            trajectory=common.Trajectory(poses=[pose_at(0, -60.0, 9.0, yaw=1.0)]),
            is_static=True,
        ),
        traffic.ObjectTrajectory(
            object_id="offroad",
            aabb=common.AABB(size_x=4.0, size_y=1.8, size_z=1.5),
            trajectory=common.Trajectory(
                poses=[pose_at(t, -80.0 + 5.0 * t / 1e6, 40.0) for t in range(0, 1_500_001, STEP)]
            ),
            is_static=False,
        ),
    ]


EGO_X = 60.0


def ego(t_us, x=EGO_X):
    """An ego standing on the car's lane ahead of it, poses up to t_us."""
    return traffic.ObjectTrajectoryUpdate(
        object_id="ego",
        trajectory=common.Trajectory(poses=[pose_at(t, x, -1.75) for t in range(0, t_us + 1, STEP)][-3:]),
    )


def start(session, seed=42, map_id="four_way", objects=None):
    stub.start_session(
        traffic.TrafficSessionRequest(
            session_uuid=session,
            map_id=map_id,
            random_seed=seed,
            logged_object_trajectories=objects if objects is not None else logged(),
            handover_time_us=HANDOVER,
        )
    )


def run(session, with_ego=True, until=10_000_000):
    answers = []
    for t in range(STEP, until + 1, STEP):
        updates = [ego(t)] if with_ego else []
        r = stub.simulate(traffic.TrafficRequest(session_uuid=session, time_query_us=t, object_trajectory_updates=updates))
        answers.append((t, r))
    return answers


def xy(update, k=0):
    v = update.trajectory.poses[k].pose.vec
    return (v.x, v.y)


def code_of(call):
    try:
        call()
    except grpc.RpcError as e:
        return e.code(), e.details()
    raise AssertionError("the call succeeded")


# The standard health service and server reflection (what grpcurl uses).
from grpc_health.v1 import health_pb2, health_pb2_grpc  # noqa: E402
from grpc_reflection.v1alpha import reflection_pb2, reflection_pb2_grpc  # noqa: E402

channel = grpc.insecure_channel(address)
health = health_pb2_grpc.HealthStub(channel)
for name in ["", "traffic.TrafficService"]:
    status = health.Check(health_pb2.HealthCheckRequest(service=name)).status
    assert status == health_pb2.HealthCheckResponse.SERVING, (name, status)
reflection = reflection_pb2_grpc.ServerReflectionStub(channel)
listed = next(iter(reflection.ServerReflectionInfo(iter([reflection_pb2.ServerReflectionRequest(list_services="")]))))
services = {s.name for s in listed.list_services_response.service}
assert {"traffic.TrafficService", "grpc.health.v1.Health"} <= services, services

# Metadata and scenes.
metadata = stub.get_metadata(common.Empty())
assert metadata.version_id.version_id, metadata
assert metadata.version_id.git_hash, metadata
assert metadata.minimum_history_length_us == 1_000_000, metadata
assert "four_way" in metadata.supported_map_ids, metadata
scenes = stub.get_available_scenes(common.Empty())
assert list(scenes.scene_ids) == list(metadata.supported_map_ids), scenes

# The usage example: start, 10 s at 10 Hz, close.
start("a")
answers = run("a")
log = {p.timestamp_us: p for p in car_log().poses}
for t, r in answers:
    ids = [u.object_id for u in r.object_trajectory_updates]
    assert ids == ["car", "parked", "offroad"], (t, ids)
    for u in r.object_trajectory_updates:
        assert u.trajectory.poses[0].timestamp_us == t, (t, u.object_id, u.trajectory.poses[0])
        stamps = [p.timestamp_us for p in u.trajectory.poses]
        assert stamps == sorted(stamps) and len(stamps) == 21, (t, u.object_id, stamps)
    car = r.object_trajectory_updates[0]
    if t < 1_000_000:
        # Log replay before the model takes over: the logged pose unchanged.
        assert car.trajectory.poses[0].pose == log[t].pose, (t, car.trajectory.poses[0], log[t])
    parked = r.object_trajectory_updates[1]
    assert xy(parked) == (-60.0, 9.0), (t, parked)
car_end = xy(answers[-1][1].object_trajectory_updates[0])
car_before = xy(answers[-11][1].object_trajectory_updates[0])
ego_rear = EGO_X - 4.9 / 2
assert car_end[0] + 4.5 / 2 < ego_rear, f"the car stops behind the ego: {car_end}"
assert car_end[0] > 40.0, f"the car drove on after handover: {car_end}"
assert abs(car_end[0] - car_before[0]) < 0.05, f"the car stands: {car_before} -> {car_end}"
assert abs(car_end[1] + 1.75) < 0.2, f"the car keeps its lane: {car_end}"
off = xy(answers[-1][1].object_trajectory_updates[2])
assert off[0] > -80.0 + 5.0 * 9.0 and abs(off[1] - 40.0) < 1e-3, f"off the lanes it goes on straight: {off}"

# Session a's actors reached a subscriber on the bus, the car handed over.
time.sleep(0.5)
with seen_lock:
    views = [v for k, v in seen if k == f"{sys.argv[4]}/traffic/a/objects"]
assert len(views) >= 90, f"{len(views)} of session a's 100 answers seen on the bus"
last = views[-1]
assert [o["id"] for o in last["objects"]] == ["car", "parked", "offroad"], last
assert last["map_id"] == "four_way" and last["time_us"] == 10_000_000, last
drivers = {o["id"]: o["driver"] for o in last["objects"]}
assert drivers == {"car": "model", "parked": "static", "offroad": "model"}, drivers
assert abs(last["objects"][0]["x"] - car_end[0]) < 1e-3, (last["objects"][0], car_end)
assert views[0]["objects"][0]["driver"] == "log", views[0]

# Without the ego the same car drives past where the ego stood.
start("b")
free_run = run("b", with_ego=False)
assert xy(free_run[-1][1].object_trajectory_updates[0])[0] > EGO_X + 10, free_run[-1][1]

# Same seed and inputs: the same answers, whatever else runs.
start("c")
assert [r for _, r in run("c")] == [r for _, r in answers], "a session is deterministic"

# Errors, each naming the problem, and none harming the other sessions.
code, _ = code_of(lambda: stub.simulate(traffic.TrafficRequest(session_uuid="nope", time_query_us=STEP)))
assert code == grpc.StatusCode.NOT_FOUND, code
code, _ = code_of(lambda: start("a"))
assert code == grpc.StatusCode.ALREADY_EXISTS, code
start("d")
stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=500_000, object_trajectory_updates=[ego(500_000)]))
code, details = code_of(
    lambda: stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=400_000, object_trajectory_updates=[ego(400_000)]))
)
assert code == grpc.StatusCode.INVALID_ARGUMENT and "backwards" in details, (code, details)
code, details = code_of(
    lambda: stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=700_000, object_trajectory_updates=[ego(600_000)]))
)
assert code == grpc.StatusCode.INVALID_ARGUMENT and "ego" in details, (code, details)
nan_ego = traffic.ObjectTrajectoryUpdate(object_id="ego", trajectory=common.Trajectory(poses=[pose_at(700_000, float("nan"), 0.0)]))
code, details = code_of(
    lambda: stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=700_000, object_trajectory_updates=[nan_ego]))
)
assert code == grpc.StatusCode.INVALID_ARGUMENT and "NaN" in details, (code, details)
empty = traffic.ObjectTrajectoryUpdate(object_id="ego", trajectory=common.Trajectory())
code, details = code_of(
    lambda: stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=700_000, object_trajectory_updates=[empty]))
)
assert code == grpc.StatusCode.INVALID_ARGUMENT and "empty" in details, (code, details)
code, details = code_of(
    lambda: start("e", objects=[traffic.ObjectTrajectory(object_id="x", aabb=common.AABB(size_x=4, size_y=2, size_z=1))])
)
assert code == grpc.StatusCode.INVALID_ARGUMENT and "empty" in details, (code, details)
# Session d goes on after its refused requests, and a goes on untouched.
stub.simulate(traffic.TrafficRequest(session_uuid="d", time_query_us=700_000, object_trajectory_updates=[ego(700_000)]))
r = stub.simulate(traffic.TrafficRequest(session_uuid="a", time_query_us=10_100_000, object_trajectory_updates=[ego(10_100_000)]))
assert xy(r.object_trajectory_updates[0]) == car_end or abs(xy(r.object_trajectory_updates[0])[0] - car_end[0]) < 0.05

# An unknown map falls back to the map-less mode: the car goes on straight.
start("f", map_id="no-such-map")
straight = run("f", with_ego=False, until=3_000_000)
fx, fy = xy(straight[-1][1].object_trajectory_updates[0])
assert abs(fy + 1.75) < 1e-3 and fx > 45.0, (fx, fy)

for s in ["a", "b", "c", "d", "f"]:
    stub.close_session(traffic.TrafficSessionCloseRequest(session_uuid=s))
code, _ = code_of(lambda: stub.close_session(traffic.TrafficSessionCloseRequest(session_uuid="a")))
assert code == grpc.StatusCode.NOT_FOUND, code
stub.shut_down(common.Empty())
watcher.undeclare()
bus.close()
print("OK")
