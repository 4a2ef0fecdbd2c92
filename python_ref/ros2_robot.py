"""A robot and an operator on another DDS implementation (Eclipse Cyclone
DDS, PyPI `cyclonedds`) for `tandem ros2`'s interop test
(tests/ros2_node.rs) and its latency benchmark (benches/ros2_node.sh).

Reads one JSON object on stdin:
  {"domain": N, "ready": <the node's --json start line>, "urdf": PATH,
   "command_out": "trajectory" | "velocities", "out_topic": "/...",
   "node": "/tandem", "scenario": "grasp" | "latency" | "describe" | "hostile" | "late" | "camera",
   "seconds": S, "command_hz": HZ, "description": PATH, "robot_period_s": S}
("describe" publishes the URDF at PATH on /robot_description, transient
local, and stays for S seconds. "hostile" plays a careless or hostile
ROS 2 system: joint states naming a joint twice, a JointJog naming one
twice, an infinite twist, a flood of unknown mode names 10,000 characters
long at ~1 kHz for "flood_s" seconds (ticks counted from the diagnostics),
then the same object poses republished at 50 Hz while the operator heads
for the first goal. "late" plays a robot that executes each trajectory
point and reports its state one robot step late, every "robot_period_s"
(the node's period): the operator drives toward the goal, then stops
sending; every point received is printed, in order, with its phase.
"camera" plays a depth camera on "cloud_topic" too: first nothing, then
at 10 Hz a PointCloud2 of a 30 x 30 cm wall of points across the
operator's straight path to the goal, and of the arm itself (its frames'
origins at the configuration the robot is in), then nothing again; the
operator drives at the goal throughout. It reports, per phase, the codes
and motion, and the smallest distance from any of Pinocchio's frame
origins on the arm to a wall point.)
and prints one JSON object with what it saw.

The robot publishes /joint_states at 250 Hz (the arm's joints, and the
fingers the node does not drive) and executes what the node sends: a
JointTrajectory's point positions at once (an ideal position controller), or
Float64MultiArray velocities integrated every robot step. The operator
publishes TwistStamped commands in the robot's root frame toward the goal's
grasp point (10 cm above it first, then down), at 0.1 m/s, reading the
gripper's position from the robot's own joint states with Pinocchio (not
from tandem). Joint limits are Pinocchio's model's.

DDS discovery runs on the loopback interface by unicast only: Cyclone is
given 127.0.0.1 as its peer and multicast off (Linux does not route
multicast on `lo` by default, and the test must not reach other machines);
RustDDS sends its participant announcements to the same well-known
localhost ports, so the two find each other without multicast.
"""
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

REQUEST = json.load(sys.stdin)
DOMAIN = int(REQUEST["domain"])

_config = tempfile.NamedTemporaryFile("w", suffix=".xml", delete=False)
_config.write(
    '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    '<MaxAutoParticipantIndex>30</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)
_config.close()
os.environ["CYCLONEDDS_URI"] = "file://" + _config.name

from cyclonedds.core import Policy, Qos  # noqa: E402  (after the configuration)
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import float64, int8, int32, sequence, uint8, uint32  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402


# The ROS 2 messages as IDL structs under their DDS type names.
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class JointJog(IdlStruct, typename="control_msgs::msg::dds_::JointJog_"):
    header: Header
    joint_names: sequence[str]
    displacements: sequence[float64]
    velocities: sequence[float64]
    duration: float64


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    positions: sequence[float64]
    velocities: sequence[float64]
    accelerations: sequence[float64]
    effort: sequence[float64]
    time_from_start: Duration


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    header: Header
    joint_names: sequence[str]
    points: sequence[JointTrajectoryPoint]


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str
    size: uint32
    stride: uint32


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension]
    data_offset: uint32


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout
    data: sequence[float64]


@dataclass
class Int8(IdlStruct, typename="std_msgs::msg::dds_::Int8_"):
    data: int8


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseArray(IdlStruct, typename="geometry_msgs::msg::dds_::PoseArray_"):
    header: Header
    poses: sequence[Pose]


def now_stamp(t):
    sec = math.floor(t)
    return Time(sec=sec, nanosec=int(round((t - sec) * 1e9)) % 1_000_000_000)


def stamp_seconds(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


@dataclass
class String_(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
class PointField(IdlStruct, typename="sensor_msgs::msg::dds_::PointField_"):
    name: str
    offset: uint32
    datatype: uint8
    count: uint32


@dataclass
class PointCloud2(IdlStruct, typename="sensor_msgs::msg::dds_::PointCloud2_"):
    header: Header
    height: uint32
    width: uint32
    fields: sequence[PointField]
    is_bigendian: bool
    point_step: uint32
    row_step: uint32
    data: sequence[uint8]
    is_dense: bool


def point_cloud(points, frame):
    """A PointCloud2 as a depth camera driver lays it out: x, y, z FLOAT32
    and an rgb field after a 4-byte gap (point_step 20), unorganised."""
    n = len(points)
    rows = np.zeros(n, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("pad", "<u4"), ("rgb", "<f4")])
    rows["x"], rows["y"], rows["z"] = points[:, 0], points[:, 1], points[:, 2]
    fields = [PointField(name="x", offset=0, datatype=7, count=1), PointField(name="y", offset=4, datatype=7, count=1),
              PointField(name="z", offset=8, datatype=7, count=1), PointField(name="rgb", offset=16, datatype=7, count=1)]
    return PointCloud2(header=Header(frame_id=frame), height=1, width=n, fields=fields, is_bigendian=False,
                       point_step=20, row_step=20 * n, data=list(rows.tobytes()), is_dense=True)


def describe():
    """Publishes a URDF on /robot_description as robot_state_publisher
    does (reliable, transient-local), then stays for `seconds`."""
    dp = DomainParticipant(DOMAIN)
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
              Policy.History.KeepLast(1))
    writer = DataWriter(dp, Topic(dp, "rt/robot_description", String_), qos=qos)
    with open(REQUEST["description"]) as f:
        writer.write(String_(data=f.read()))
    print("published", flush=True)
    time.sleep(REQUEST["seconds"])


def main():
    if REQUEST["scenario"] == "describe":
        describe()
        return
    ready = REQUEST["ready"]
    node = REQUEST["node"]
    model = pin.buildModelFromUrdf(REQUEST["urdf"])
    data = model.createData()
    tcp = model.getFrameId(ready["gripper_frame"])
    names = [model.names[j] for j in range(1, model.njoints)]
    arm = [names.index(j) for j in ready["joints"]]
    q = pin.neutral(model)
    for i, v in zip(arm, ready["start"]):
        q[model.joints[i + 1].idx_q] = v
    fingers = [i for i in range(len(names)) if i not in arm]
    for i in fingers:
        q[model.joints[i + 1].idx_q] = 0.04
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit

    dp = DomainParticipant(DOMAIN)
    reliable = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(200))
    latest = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(1))
    states_w = DataWriter(dp, Topic(dp, "rt/joint_states", JointState), qos=latest)
    twist_w = DataWriter(dp, Topic(dp, f"rt{node}/delta_twist_cmds", TwistStamped), qos=latest)
    goals_w = DataWriter(dp, Topic(dp, f"rt{node}/goals", PoseArray), qos=latest)
    mode_w = DataWriter(dp, Topic(dp, f"rt{node}/mode", String_), qos=latest)
    status_r = DataReader(dp, Topic(dp, f"rt{node}/status", Int8), qos=reliable)
    diag_r = DataReader(dp, Topic(dp, f"rt{node}/diagnostics", Float64MultiArray), qos=reliable)
    out_type = JointTrajectory if REQUEST["command_out"] == "trajectory" else Float64MultiArray
    out_r = DataReader(dp, Topic(dp, "rt" + REQUEST["out_topic"], out_type), qos=reliable)

    qdot = np.zeros(model.nv)
    step = float(REQUEST.get("robot_period_s", 1.0 / 250.0))
    goal = np.array(ready["goals"][0]["position"])
    seen = {"limit_excess": 0.0, "min_distance": math.inf, "commands": 0, "diagnostics": 0, "statuses": 0,
            "goal_updates": 0, "mode_index": -1}
    log = []  # (time, phase, status)
    motion = []  # (time, phase, joint change)
    latencies = []
    sent = {}
    ticks_seen = []
    ticks_at = []  # (arrival, the node's tick count)
    holds = {}  # the diagnostics' hold index -> joints named
    reanchors = []  # the diagnostics' re-anchor count, per tick

    def gripper():
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        return data.oMf[tcp].translation.copy()

    listening = {"thread": False}

    # What the robot reports instead of its true state, when a phase says so
    # (a function of the true names and positions).
    report = {"states": None}
    # "late": the state published is the one of the step before; every
    # point received is kept (phase, positions, velocities, accelerations).
    late = {"previous": None, "points": [] if REQUEST["scenario"] == "late" else None}

    def robot_step(phase, t):
        nonlocal q
        before = q.copy()
        for s in out_r.take(N=1000):
            seen["commands"] += 1
            if late["points"] is not None and s.points:
                p = s.points[0]
                late["points"].append((phase, list(p.positions), list(p.velocities), list(p.accelerations)))
            if out_type is JointTrajectory and s.points:
                for name, v in zip(s.joint_names, s.points[0].positions):
                    q[model.joints[names.index(name) + 1].idx_q] = v
            elif out_type is Float64MultiArray:
                for k, i in enumerate(arm):
                    qdot[model.joints[i + 1].idx_v] = s.data[k]
        if out_type is Float64MultiArray:
            q = q + qdot * step
        change = float(np.max(np.abs(q - before)))
        if change > 0:
            motion.append((t, phase, change))
        seen["limit_excess"] = max(seen["limit_excess"], float(np.max(np.maximum(q - upper, lower - q))))
        state_names, state_q = names, list(map(float, q))
        if late["points"] is not None:
            state_q, late["previous"] = late["previous"] or state_q, state_q
        if report["states"] is not None:
            state_names, state_q = report["states"](state_names, state_q)
        states_w.write(JointState(header=Header(stamp=now_stamp(t)), name=state_names, position=state_q,
                                  velocity=[], effort=[]))
        for s in status_r.take(N=1000):
            seen["statuses"] += 1
            log.append((t, phase, int(s.data)))
        if not listening["thread"]:
            for s in diag_r.take(N=1000):
                diagnostics(s, time.time())

    def diagnostics(s, arrived):
        seen["diagnostics"] += 1
        d = s.data
        ticks_at.append((arrived, d[14]))
        if len(d) > 16:
            holds.setdefault(int(d[16]), set()).add(-1 if math.isnan(d[17]) else int(d[17]))
        if len(d) > 19:
            reanchors.append(int(d[19]))
        seen["min_distance"] = min(seen["min_distance"], d[6])
        seen["goal_updates"] = max(seen["goal_updates"], int(d[15]))
        seen["mode_index"] = int(d[12])
        ticks_seen.append(d[0])
        if not math.isnan(d[1]) and d[1] in sent:
            latencies.append(arrived - sent.pop(d[1]))

    def command(t, v, frame="panda_link0"):
        stamp = now_stamp(t)
        sent[stamp_seconds(stamp)] = time.time()
        twist_w.write(TwistStamped(header=Header(stamp=stamp, frame_id=frame),
                                   twist=Twist(linear=Vector3(*map(float, v)))))

    def run(phase, seconds, operator=None, until=None):
        began = time.time()
        k = 0
        next_t = began
        while time.time() - began < seconds:
            t = time.time()
            robot_step(phase, t)
            if operator is not None and k % 5 == 0:
                operator(t)
            if until is not None and until():
                return True
            k += 1
            next_t += step
            time.sleep(max(0.0, next_t - time.time()))
        return False

    if REQUEST["scenario"] == "latency":
        # Commands at command_hz (small, alternating directions) for
        # `seconds`; a thread blocks on the diagnostics reader and stamps
        # each arrival at once (the robot's 4 ms step would quantise it).
        import threading

        every = max(1, round(250 / REQUEST["command_hz"]))
        run("wait", 2.0)
        listening["thread"] = True
        stop_listening = threading.Event()

        def listen():
            while not stop_listening.is_set():
                for s in diag_r.take_iter(timeout=duration(milliseconds=50)):
                    diagnostics(s, time.time())

        listener = threading.Thread(target=listen, daemon=True)
        listener.start()
        k = [0]

        def operator_latency(t):
            k[0] += 1
            command(t, (0.0, 0.0, 0.01 if (k[0] // 50) % 2 else -0.01))

        began = time.time()
        i = 0
        next_t = began
        while time.time() - began < REQUEST["seconds"]:
            t = time.time()
            robot_step("measure", t)
            if i % every == 0:
                operator_latency(t)
            i += 1
            next_t += step
            time.sleep(max(0.0, next_t - time.time()))
        run("drain", 0.3)
        stop_listening.set()
        listener.join(timeout=1.0)
        print(json.dumps({"latency_s": latencies, "unanswered": len(sent), "tick_us": ticks_seen, **seen}))
        return

    if REQUEST["scenario"] == "late":
        run("idle", 1.5)
        above = goal + np.array([0.0, 0.0, 0.1])

        def toward(t):
            d = above - gripper()
            dist = np.linalg.norm(d)
            command(t, d / dist * min(0.1, 2.0 * dist) if dist > 1e-9 else np.zeros(3))

        run("driven", REQUEST["seconds"], toward)
        run("stopped", 1.5)
        # The node's own count of re-anchorings (the last diagnostics).
        print(json.dumps({"points": late["points"], "robot_period_s": step, "reanchors": reanchors[-1:], **seen}))
        return

    if REQUEST["scenario"] == "camera":
        camera(run, seen, log, motion, command, dp, ready, gripper, lambda: q.copy(), model, data, goal)
        return

    if REQUEST["scenario"] == "hostile":
        hostile(run, report, seen, log, motion, ticks_at, holds, command, goals_w, mode_w, ready, dp, node, gripper)
        return

    # The grasp scenario.
    run("idle", 1.5)  # discovery, then no command: the node holds (15)
    shift = np.array(REQUEST.get("move_box", [0.0, 0.0, 0.0]))
    if np.any(shift != 0.0):
        # A perception node reports the box elsewhere: the node re-plans
        # its goal; the operator aims at the moved grasp point.
        poses = [Pose(position=Point(*map(float, np.array(o["position"]) + shift)),
                      orientation=Quaternion(*map(float, o["orientation"]))) for o in ready["graspable"]]
        goals_w.write(PoseArray(header=Header(frame_id=ready["root_frame"]), poses=poses))
        run("replan", 15.0, until=lambda: seen["goal_updates"] >= 1)
        goal = goal + shift
    above = goal + np.array([0.0, 0.0, 0.1])
    state = {"target": above}

    def approach(t):
        p = gripper()
        if np.linalg.norm(p - state["target"]) < 0.01 and state["target"] is above:
            state["target"] = goal
        d = state["target"] - p
        dist = np.linalg.norm(d)
        command(t, d / dist * min(0.1, 2.0 * dist) if dist > 1e-9 else np.zeros(3))

    began = time.time()
    reached = run("approach", 40.0, approach, lambda: np.linalg.norm(gripper() - goal) < 0.005)
    time_to_reach = time.time() - began
    stopped = time.time()
    run("stopped", 0.6)
    run("nan", 0.5, lambda t: command(t, (math.nan, 0.0, 0.0)))
    run("frame", 0.4, lambda t: command(t, (0.05, 0.0, 0.0), frame="camera_link"))
    run("end", 0.3)
    # The mode by name at run time: an unknown name is refused (the mode
    # stays), then `direct` (index 0 of the mode table) takes over.
    mode_before = seen["mode_index"]
    mode_w.write(String_(data="fastest"))
    run("mode", 0.3)
    mode_after_unknown = seen["mode_index"]
    mode_w.write(String_(data="direct"))
    run("mode", 2.0, until=lambda: seen["mode_index"] == 0)
    modes = [mode_before, mode_after_unknown, seen["mode_index"]]

    last_motion_after_stop = max([t for t, ph, _ in motion if ph == "stopped"], default=stopped) - stopped
    codes = {}
    for _, phase, code in log:
        codes.setdefault(phase, {}).setdefault(str(code), 0)
        codes[phase][str(code)] += 1
    result = {
        "reached": bool(reached),
        "time_to_reach_s": time_to_reach,
        "final_distance_m": float(np.linalg.norm(gripper() - goal)),
        "hold_after_stop_s": last_motion_after_stop,
        "moved_in": sorted({ph for _, ph, _ in motion}),
        "codes": codes,
        "latency_s": latencies,
        "modes": modes,
        **seen,
    }
    print(json.dumps(result))


def hostile(run, report, seen, log, motion, ticks_at, holds, command, goals_w, mode_w, ready, dp, node, gripper):
    """The hostile scenario (see the module's docstring): prints, per phase,
    the status codes seen and whether the arm moved, the node's ticks a
    second under the flood, the holds the diagnostics named, and the goal
    updates under republished poses."""
    jog_w = DataWriter(dp, Topic(dp, f"rt{node}/delta_joint_cmds", JointJog),
                       qos=Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(1)))
    beliefs_r = DataReader(dp, Topic(dp, f"rt{node}/beliefs", Float64MultiArray),
                           qos=Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(200)))
    toward = (0.0, 0.0, -0.03)
    run("idle", 1.5)

    def duplicated(state_names, state_q):
        # panda_joint1 twice, the first value 1 rad off.
        k = state_names.index("panda_joint1")
        return ["panda_joint1"] + state_names, [state_q[k] + 1.0] + state_q

    # "republish_only": the republished poses alone (for the beliefs' figure).
    flood = {"sent": 0}
    flood_ticks_per_s = math.nan
    if not REQUEST.get("republish_only"):
        report["states"] = duplicated
        run("duplicate_state", 0.6, lambda t: command(t, toward))
        report["states"] = None
        run("settle", 0.3)

        def jog(t):
            jog_w.write(JointJog(header=Header(stamp=now_stamp(t)), joint_names=["panda_joint1", "panda_joint1"],
                                 displacements=[], velocities=[0.3, -0.3], duration=0.0))

        run("duplicate_jog", 0.5, jog)
        run("settle", 0.3)
        run("infinite_twist", 0.5, lambda t: command(t, (math.inf, 0.0, 0.0)))
        run("settle", 0.3)

        # The flood: ~1,000 unknown names a second (20 with every command),
        # each 10,000 characters.

        def flood_modes(t):
            for _ in range(20):
                mode_w.write(String_(data=f"fastest-{flood['sent']}-" + "x" * 10_000))
                flood["sent"] += 1

        flood_began = time.time()
        run("flood", REQUEST["flood_s"], flood_modes)
        flood_ended = time.time()
        in_flood = [n for at, n in ticks_at if flood_began + 0.5 <= at <= flood_ended]
        flood_ticks_per_s = (in_flood[-1] - in_flood[0]) / (flood_ended - flood_began - 0.5) if len(in_flood) > 1 else 0.0
        run("after_flood", 0.5)

    # The same poses at 50 Hz (with every command) while the operator
    # heads for the first goal.
    poses = [Pose(position=Point(*map(float, o["position"])), orientation=Quaternion(*map(float, o["orientation"])))
             for o in ready["graspable"]]
    updates_before = seen["goal_updates"]
    goal = np.array(ready["goals"][0]["position"])
    beliefs = []

    def republish(t):
        goals_w.write(PoseArray(header=Header(frame_id=ready["root_frame"]), poses=poses))
        for b in beliefs_r.take(N=1000):
            beliefs.append(list(b.data))
        p = gripper()
        d = goal + np.array([0.0, 0.0, 0.1]) - p
        dist = np.linalg.norm(d)
        command(t, d / dist * min(0.1, 2.0 * dist) if dist > 1e-9 else np.zeros(3))

    run("republish", REQUEST["republish_s"], republish)
    run("end", 0.3)

    codes = {}
    for _, phase, code in log:
        codes.setdefault(phase, {}).setdefault(str(code), 0)
        codes[phase][str(code)] += 1
    print(json.dumps({
        "codes": codes,
        "moved_in": sorted({ph for _, ph, _ in motion}),
        "largest_motion": {ph: max(c for _, p2, c in motion if p2 == ph) for ph in {p for _, p, _ in motion}},
        "flood_sent": flood["sent"],
        "flood_ticks_per_s": flood_ticks_per_s,
        "holds": {str(h): sorted(j) for h, j in holds.items()},
        "goal_updates_under_republish": seen["goal_updates"] - updates_before,
        "largest_belief": max((b[0] for b in beliefs), default=math.nan),
        "beliefs_seen": len(beliefs),
        **seen,
    }))


def camera(run, seen, log, motion, command, dp, ready, gripper, configuration, model, data, goal):
    """The camera scenario (see the module's docstring)."""
    cloud_w = DataWriter(dp, Topic(dp, "rt" + REQUEST["cloud_topic"], PointCloud2),
                         qos=Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(1)))
    start = gripper()
    above = goal + np.array([0.0, 0.0, 0.1])
    d = (above - start) / np.linalg.norm(above - start)
    centre = start + d * min(REQUEST["wall_at_m"], 0.5 * np.linalg.norm(above - start))
    # Two unit vectors across the path span the wall.
    u = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    grid = np.arange(-0.15, 0.1501, 0.01)
    wall = np.array([centre + a * u + b * v for a in grid for b in grid])
    arm_frames = [f for f in range(model.nframes) if model.frames[f].name.startswith("panda_")
                  and model.frames[f].name not in ("panda_link0",)]
    closest = {"m": math.inf}

    def toward(t):
        dd = above - gripper()
        dist = np.linalg.norm(dd)
        command(t, dd / dist * min(0.1, 2.0 * dist) if dist > 1e-9 else np.zeros(3))

    def frame_origins():
        pin.forwardKinematics(model, data, configuration())
        pin.updateFramePlacements(model, data)
        return np.array([data.oMf[f].translation for f in arm_frames])

    def watch():
        origins = frame_origins()
        gap = np.min(np.linalg.norm(origins[:, None, :] - wall[None, :, :], axis=2))
        closest["m"] = min(closest["m"], float(gap))

    k = {"n": 0}

    def seeing(t):
        toward(t)
        watch()
        k["n"] += 1
        if k["n"] % 5 == 0:  # every 100 ms (the operator runs every 5th robot step)
            cloud_w.write(point_cloud(np.vstack([wall, frame_origins()]), ready["root_frame"]))

    run("dark", 1.5, toward)
    run("seeing", REQUEST["seconds"], seeing)
    run("blind", 1.0, lambda t: (toward(t), watch()))
    codes = {}
    for _, phase, code in log:
        codes.setdefault(phase, {}).setdefault(str(code), 0)
        codes[phase][str(code)] += 1
    blind_motion = [t for t, ph, _ in motion if ph == "blind"]
    blind_began = min([t for t, ph, _ in log if ph == "blind"], default=math.nan)
    print(json.dumps({
        "codes": codes,
        "moved_in": sorted({ph for _, ph, _ in motion}),
        "travel_m": float(np.linalg.norm(gripper() - start)),
        "wall_from_start_m": float(np.dot(centre - start, d)),
        "gripper_past_wall_m": float(np.dot(gripper() - centre, d)),
        "closest_origin_to_wall_m": closest["m"],
        "last_blind_motion_s": (max(blind_motion) - blind_began) if blind_motion else 0.0,
        **seen,
    }))


if __name__ == "__main__":
    main()
