"""Serializes ROS 2 messages with rosbags (an independent CDR serializer
that ships the ROS 2 message definitions), for tests/ros2_messages.rs.

Reads JSON from stdin: a list of {"type": "sensor_msgs/msg/JointState",
"value": {...fields...}}; prints one line per message: the CDR payload
(encapsulation included) in hex. control_msgs/JointJog, which rosbags does
not ship, is registered from its .msg definition.
"""
import json
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.msg import get_types_from_msg

JOINT_JOG = """
std_msgs/Header header
string[] joint_names
float64[] displacements
float64[] velocities
float64 duration
"""

NUMPY = {
    "bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
    "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32,
    "int64": np.int64, "uint64": np.uint64, "float32": np.float32, "float64": np.float64,
}


def build(ts, typename, value):
    _, fields = ts.fielddefs[typename]
    kwargs = {name: convert(ts, desc, value[name]) for name, desc in fields}
    return ts.types[typename](**kwargs)


def convert(ts, desc, value):
    kind, info = desc
    if kind.name == "BASE":
        base = info[0]
        return value if base == "string" else NUMPY[base](value).item()
    if kind.name == "NAME":
        return build(ts, info, value)
    element, _ = info
    if element[0].name == "BASE" and element[1][0] != "string":
        return np.array(value, dtype=NUMPY[element[1][0]])
    return [convert(ts, element, v) for v in value]


def main():
    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(JOINT_JOG, "control_msgs/msg/JointJog"))
    for item in json.load(sys.stdin):
        message = build(ts, item["type"], item["value"])
        print(bytes(ts.serialize_cdr(message, item["type"])).hex())


if __name__ == "__main__":
    main()
