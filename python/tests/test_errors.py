"""Bad input raises a TandemError subclass carrying the Rust message: what
is wrong and where (file, line, key, joint, value)."""

import math

import numpy as np
import pytest
import tandem
from conftest import GRASP_FAMILY

HIERARCHY = {
    tandem.RobotError: tandem.TandemError,
    tandem.UrdfError: tandem.RobotError,
    tandem.ConfigurationError: tandem.RobotError,
    tandem.CollisionError: tandem.TandemError,
    tandem.ProblemError: tandem.TandemError,
    tandem.PlanningError: tandem.TandemError,
    tandem.IkError: tandem.PlanningError,
    tandem.OptimizationError: tandem.TandemError,
    tandem.ControlError: tandem.TandemError,
    tandem.DatasetError: tandem.TandemError,
}


def test_exception_hierarchy():
    for cls, parent in HIERARCHY.items():
        assert cls.__bases__ == (parent,), cls
        assert cls.__module__ == "tandem"
        assert cls.__doc__
    assert issubclass(tandem.TandemError, Exception)


URDF_WITH_BAD_LIMITS = """<?xml version="1.0"?>
<robot name="bad">
  <link name="base"/>
  <link name="arm"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/>
    <child link="arm"/>
    <axis xyz="0 0 1"/>
    <limit lower="1.0" upper="-1.0" effort="1" velocity="1"/>
  </joint>
</robot>
"""
VALID_URDF = URDF_WITH_BAD_LIMITS.replace('lower="1.0" upper="-1.0"', 'lower="-1" upper="1"')


def test_urdf_errors_name_file_line_and_element(tmp_path):
    with pytest.raises(tandem.UrdfError, match=r"<string>:5: joint 'shoulder' has lower limit 1 above upper limit -1"):
        tandem.RobotModel.from_urdf_string(URDF_WITH_BAD_LIMITS)
    with pytest.raises(tandem.UrdfError, match="malformed XML"):
        tandem.RobotModel.from_urdf_string("<robot name='x'><link name='a'></robot>")
    missing_mesh = VALID_URDF.replace(
        '<link name="arm"/>',
        '<link name="arm"><collision><geometry><mesh filename="package://nowhere/arm.stl"/></geometry></collision></link>',
    )
    path = tmp_path / "robot.urdf"
    path.write_text(missing_mesh)
    with pytest.raises(tandem.UrdfError, match=rf"{path}:4: link 'arm': mesh 'package://nowhere/arm.stl' not found"):
        tandem.RobotModel.from_urdf(path, ros_package_path=False)
    with pytest.raises(tandem.UrdfError, match="cannot read"):
        tandem.RobotModel.from_urdf(tmp_path / "absent.urdf")


def test_model_and_configuration_errors():
    robot = tandem.RobotModel.panda()
    q = robot.neutral_configuration()
    with pytest.raises(tandem.RobotError, match=r"unknown frame 'panda_hnd' \(did you mean panda_hand"):
        robot.frame_pose(q, "panda_hnd")
    with pytest.raises(IndexError, match="frame index 999"):
        robot.frame_pose(q, 999)
    with pytest.raises(tandem.ConfigurationError, match="expected 7 joint values .* got 6"):
        robot.frame_jacobian(q[:6], "panda_hand")
    bad = q.copy()
    bad[3] = math.nan
    with pytest.raises(tandem.ConfigurationError, match=r"joint 'panda_joint4' \(index 3\) has non-finite value NaN"):
        robot.frame_pose(bad, "panda_hand")
    with pytest.raises(tandem.ConfigurationError, match="non-finite value inf"):
        robot.frame_poses(np.full((2, 7), np.inf), "panda_hand")
    with pytest.raises(tandem.RobotError, match="unknown joint 'panda_joint9'"):
        tandem.RobotModel.from_urdf_string(VALID_URDF, joints=["panda_joint9"])
    with pytest.raises(ValueError, match="either chain"):
        tandem.RobotModel.from_urdf_string(VALID_URDF, chain=("a", "b"), joints=["c"])
    with pytest.raises(TypeError, match="1-D sequence of floats"):
        robot.frame_pose("not a configuration", "panda_hand")
    with pytest.raises(ValueError, match="1-D array, got shape"):
        robot.frame_pose(np.zeros((7, 1)), "panda_hand")
    with pytest.raises(ValueError, match="reference must be 'world' or 'local'"):
        robot.frame_jacobian(q, "panda_hand", "global")
    with pytest.raises(ValueError, match="qs has 6 columns, expected 7"):
        robot.frame_poses(np.zeros((3, 6)), "panda_hand")


def test_problem_errors_name_key_and_line(tmp_path):
    with pytest.raises(tandem.ProblemError, match="no builtin problem named 'nope' \\(have: panda_reach"):
        tandem.Problem.builtin("nope")
    text = 'name = "p"\nrobot = { urdf = "x.urdf" }\nstart = [0.0]\nbogus_key = 3\n'
    with pytest.raises(tandem.ProblemError, match=r"<mine>:4.*bogus_key"):
        tandem.Problem.from_toml(text, origin="<mine>")
    with pytest.raises(tandem.ProblemError, match="cannot read"):
        tandem.Problem.from_file(tmp_path / "absent.toml")
    with pytest.raises(tandem.ProblemError, match="cannot read"):
        tandem.ProblemFamily.from_file(tmp_path / "absent.toml")
    problem = tandem.Problem.builtin("panda_reach")
    with pytest.raises(tandem.ConfigurationError, match="outside the joint limits"):
        problem.with_start(problem.start + 10)
    with pytest.raises(tandem.CollisionError, match="padding"):
        problem.collision_model(padding=-1.0)


def test_planning_errors():
    problem = tandem.Problem.builtin("panda_reach")
    model = problem.collision_model()
    with pytest.raises(tandem.IkError, match="no joint configuration within limits reaches the target"):
        tandem.solve_ik(model, "panda_hand_tcp", [3.0, 0.0, 0.5], restarts=3)
    with pytest.raises(tandem.PlanningError):
        tandem.solve_ik(model, "panda_hand_tcp", [3.0, 0.0, 0.5], restarts=3)
    with pytest.raises(ValueError, match="axis .* and direction together"):
        tandem.solve_ik(model, "panda_hand_tcp", [0.5, 0.0, 0.5], axis=2)
    with pytest.raises(ValueError, match="rotation matrix"):
        tandem.solve_ik(model, "panda_hand_tcp", [0.5, 0.0, 0.5], orientation=np.eye(3) * 2)
    with pytest.raises(tandem.OptimizationError, match="horizon"):
        tandem.solve(problem, horizon=0)


def test_control_errors():
    reference = np.linspace([0.0, 0.0], [1.0, -1.0], 20)
    with pytest.raises(tandem.ControlError, match="time step 0 s is not positive"):
        tandem.TrackingPolicy(reference, 0.0)
    with pytest.raises(tandem.ControlError, match="weights"):
        tandem.TrackingPolicy(reference, 0.01, control_weight=-1.0)
    with pytest.raises(tandem.ControlError, match="waypoint 3: joint 'b' has non-finite value"):
        bad = reference.copy()
        bad[3, 1] = np.inf
        tandem.TrackingPolicy(bad, 0.01, joints=["a", "b"])
    policy = tandem.TrackingPolicy(reference, 0.01)
    with pytest.raises(tandem.ControlError, match="q"):
        policy.query([0.0])
    with pytest.raises(ValueError, match="schedule"):
        tandem.TrackingPolicy(reference, 0.01, schedule="sometimes")


def test_dataset_errors(tmp_path):
    with pytest.raises(tandem.DatasetError, match="--count must be at least 1"):
        tandem.generate(GRASP_FAMILY, tmp_path / "a", count=0)
    with pytest.raises(tandem.DatasetError, match="shard"):
        tandem.generate(GRASP_FAMILY, tmp_path / "a", count=1, shard=(2, 2))
    with pytest.raises(tandem.ProblemError, match="cannot read"):
        tandem.missing_parts(tmp_path / "absent.toml", tmp_path / "b", count=1)
    assert tandem.missing_parts(GRASP_FAMILY, tmp_path / "c", count=250) == [0, 1, 2]
    with pytest.raises(tandem.DatasetError, match="generated with seed = 0, this run asks 1"):
        tandem.missing_parts(GRASP_FAMILY, tmp_path / "c", count=250, seed=1)
