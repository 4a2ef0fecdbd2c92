"""Forward kinematics and frame Jacobians from Python against Pinocchio's
Python API, on tandem's Panda and example-robot-data's Panda (STL meshes,
mimic finger), every frame, 200 random configurations each.

Pinocchio is built without mimic support, so mimic joints are independent
there: their values follow their targets (multiplier, offset read from the
URDF here), and a mimicking joint's Jacobian column adds to its target's.
"""

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
import tandem
from conftest import PANDA_URDF

# Largest difference seen: 1.1e-15 (poses, both Jacobians, both robots).
TOLERANCE = 1e-13
CONFIGURATIONS = 200


def mimics(urdf):
    """{joint: (target, multiplier, offset)} from the URDF's <mimic> tags."""
    out = {}
    for joint in ET.parse(urdf).getroot().iter("joint"):
        m = joint.find("mimic")
        if m is not None:
            out[joint.get("name")] = (m.get("joint"), float(m.get("multiplier", 1)), float(m.get("offset", 0)))
    return out


class PinReference:
    """Pinocchio's model of a URDF, evaluated at tandem configurations."""

    def __init__(self, urdf, robot, held=None):
        self.model = pin.buildModelFromUrdf(str(urdf))
        self.data = self.model.createData()
        self.robot = robot
        self.mimics = mimics(urdf)
        self.held = held or {}
        for name in list(self.held) + robot.joint_names + list(self.mimics):
            assert self.model.existJointName(name), name

    def idx_q(self, name):
        return self.model.idx_qs[self.model.getJointId(name)]

    def q(self, q):
        """Pinocchio's configuration for tandem's ``q``."""
        values = dict(self.held)
        values.update(zip(self.robot.joint_names, q))
        for joint, (target, multiplier, offset) in self.mimics.items():
            values[joint] = multiplier * values[target] + offset
        out = pin.neutral(self.model)
        for name, value in values.items():
            out[self.idx_q(name)] = value
        return out

    def placement(self, frame):
        return self.data.oMf[self.model.getFrameId(frame)].homogeneous

    def jacobian(self, frame, reference):
        full = pin.getFrameJacobian(self.model, self.data, self.model.getFrameId(frame), reference)
        columns = []
        for name in self.robot.joint_names:
            column = full[:, self.idx_q(name)].copy()
            for joint, (target, multiplier, _) in self.mimics.items():
                if target == name:
                    column += multiplier * full[:, self.idx_q(joint)]
            columns.append(column)
        return np.stack(columns, axis=1)

    def evaluate(self, q):
        pin.computeJointJacobians(self.model, self.data, self.q(q))
        pin.updateFramePlacements(self.model, self.data)


def random_configurations(robot, rng, count=CONFIGURATIONS):
    lower, upper = robot.lower_limits, robot.upper_limits
    return lower + (upper - lower) * rng.random((count, robot.nq))


def unique_frames(robot, reference):
    """Frames named once in tandem (a link and a joint can share a name) and known to Pinocchio."""
    names = robot.frame_names
    return [n for n in names if names.count(n) == 1 and reference.model.existFrame(n)]


def check_against_pinocchio(robot, reference, seed):
    rng = np.random.default_rng(seed)
    frames = unique_frames(robot, reference)
    assert len(frames) >= 20
    worst = {"pose": 0.0, "world": 0.0, "local": 0.0}
    for q in random_configurations(robot, rng):
        reference.evaluate(q)
        for frame in frames:
            pose = robot.frame_pose(q, frame)
            worst["pose"] = max(worst["pose"], np.abs(pose - reference.placement(frame)).max())
            for name, pin_ref in [("world", pin.LOCAL_WORLD_ALIGNED), ("local", pin.LOCAL)]:
                jac = robot.frame_jacobian(q, frame, name)
                assert jac.shape == (6, robot.nq)
                worst[name] = max(worst[name], np.abs(jac - reference.jacobian(frame, pin_ref)).max())
    assert all(np.isfinite(v) for v in worst.values()), worst
    assert max(worst.values()) < TOLERANCE, worst
    return worst


def test_tandem_panda_against_pinocchio():
    robot = tandem.RobotModel.panda()
    assert robot.joint_names == [f"panda_joint{i}" for i in range(1, 8)]
    reference = PinReference(PANDA_URDF, robot, held={"panda_finger_joint1": 0.04})
    check_against_pinocchio(robot, reference, seed=1)
    # Limits as Pinocchio reads them.
    index = [reference.idx_q(n) for n in robot.joint_names]
    np.testing.assert_array_equal(robot.lower_limits, reference.model.lowerPositionLimit[index])
    np.testing.assert_array_equal(robot.upper_limits, reference.model.upperPositionLimit[index])
    np.testing.assert_array_equal(robot.velocity_limits, reference.model.velocityLimit[index])


def test_example_robot_data_panda_against_pinocchio(erd_panda):
    urdf, share = erd_panda
    # Every independent joint active: the arm and finger 1 (finger 2 mimics it).
    robot = tandem.RobotModel.from_urdf(urdf, package_dirs=[share / "example-robot-data" / "robots"])
    assert robot.nq == 8 and robot.joint_names[-1] == "panda_finger_joint1"
    check_against_pinocchio(robot, PinReference(urdf, robot), seed=2)


def test_chain_and_joint_selection_match_the_full_model(erd_panda):
    urdf, share = erd_panda
    packages = [share / "example-robot-data" / "robots"]
    arm = tandem.RobotModel.from_urdf(
        urdf, package_dirs=packages, chain=("panda_link0", "panda_hand"), hold={"panda_finger_joint1": 0.02}
    )
    listed = tandem.RobotModel.from_urdf(urdf, package_dirs=packages, joints=arm.joint_names[::-1])
    assert arm.joint_names == [f"panda_joint{i}" for i in range(1, 8)]
    assert listed.joint_names == arm.joint_names[::-1]
    q = np.linspace(-0.5, 0.5, 7)
    for frame in ["panda_hand", "panda_link4", "panda_joint7"]:
        pose = arm.frame_pose(q, frame)
        np.testing.assert_allclose(listed.frame_pose(q[::-1], frame), pose, atol=1e-15)
        np.testing.assert_allclose(listed.frame_jacobian(q[::-1], frame), arm.frame_jacobian(q, frame)[:, ::-1], atol=1e-15)


def test_batch_queries_equal_single_queries():
    robot = tandem.RobotModel.panda()
    qs = random_configurations(robot, np.random.default_rng(3), 25)
    poses = robot.frame_poses(qs, "panda_hand_tcp")
    world = robot.frame_jacobians(qs, "panda_hand_tcp")
    local = robot.frame_jacobians(qs, robot.frame_index("panda_hand_tcp"), "local")
    assert poses.shape == (25, 4, 4) and world.shape == (25, 6, 7)
    for i, q in enumerate(qs):
        np.testing.assert_array_equal(poses[i], robot.frame_pose(q, "panda_hand_tcp"))
        np.testing.assert_array_equal(world[i], robot.frame_jacobian(q, "panda_hand_tcp"))
        np.testing.assert_array_equal(local[i], robot.frame_jacobian(q, "panda_hand_tcp", "local"))
        pose, jac = robot.frame_pose_jacobian(q, "panda_hand_tcp")
        np.testing.assert_array_equal(pose, poses[i])
        np.testing.assert_array_equal(jac, world[i])
    placements = robot.frame_placements(qs[0])
    assert placements.shape == (len(robot.frame_names), 4, 4)
    for index, name in enumerate(robot.frame_names[:12]):
        np.testing.assert_array_equal(placements[index], robot.frame_pose(qs[0], index))
        if robot.frame_names.count(name) == 1:
            np.testing.assert_array_equal(placements[index], robot.frame_pose(qs[0], name))


def test_inputs_and_outputs():
    robot = tandem.RobotModel.panda()
    q = robot.neutral_configuration()
    expected = robot.frame_pose(q, "panda_hand_tcp")
    # Lists, tuples, strided views and other dtypes are accepted.
    np.testing.assert_array_equal(robot.frame_pose(list(q), "panda_hand_tcp"), expected)
    np.testing.assert_array_equal(robot.frame_pose(tuple(q), "panda_hand_tcp"), expected)
    np.testing.assert_array_equal(robot.frame_pose(np.repeat(q, 2)[::2], "panda_hand_tcp"), expected)
    np.testing.assert_array_equal(
        robot.frame_pose(np.zeros(7, dtype=np.int32), 0), robot.frame_pose(np.zeros(7), "panda_link0")
    )
    # out= writes in place and returns the same array.
    out = np.empty((4, 4))
    assert robot.frame_pose(q, "panda_hand_tcp", out=out) is out
    np.testing.assert_array_equal(out, expected)
    jac = np.empty((6, 7))
    assert robot.frame_jacobian(q, "panda_hand_tcp", out=jac) is jac
    np.testing.assert_array_equal(jac, robot.frame_jacobian(q, "panda_hand_tcp"))
    with pytest.raises(ValueError, match="shape"):
        robot.frame_jacobian(q, "panda_hand_tcp", out=np.empty((7, 6)))
    with pytest.raises(ValueError, match="contiguous"):
        robot.frame_jacobian(q, "panda_hand_tcp", out=np.empty((6, 7), order="F"))
    frozen = np.zeros((4, 4))
    frozen.setflags(write=False)
    with pytest.raises(ValueError, match="read-only"):
        robot.frame_pose(q, "panda_hand_tcp", out=frozen)
    assert not frozen.any()
    # A point on the hand: its Jacobian is the frame's linear rows shifted by ω × r.
    point = [0.01, -0.02, 0.03]
    world, jp = robot.point_jacobian(q, "panda_hand_tcp", point)
    pose, jac = robot.frame_pose_jacobian(q, "panda_hand_tcp")
    r = pose[:3, :3] @ point
    np.testing.assert_allclose(world, pose[:3, 3] + r, atol=1e-15)
    np.testing.assert_allclose(jp, jac[:3] + np.cross(jac[3:].T, r).T, atol=1e-14)
    assert robot.within_limits(q) and not robot.within_limits(q + 10)
