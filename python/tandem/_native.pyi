"""Type stubs of tandem's native module (python/src/, built by maturin).

Arrays are numpy float64 arrays; ``_ArrayLike`` arguments also accept lists
and tuples (a C-contiguous float64 array is read in place, anything else is
copied). Units are SI: m, rad, s. Poses are 4 × 4 homogeneous matrices in
the frame of the URDF's root link.
"""

import os
from collections.abc import Mapping, Sequence
from typing import Any, Literal, Optional, Union, final

import numpy as np
import numpy.typing as npt

_Vector = npt.NDArray[np.float64]
_Matrix = npt.NDArray[np.float64]
_ArrayLike = Union[npt.NDArray[Any], Sequence[float]]
_MatrixLike = Union[npt.NDArray[Any], Sequence[Sequence[float]]]
_Frame = Union[str, int]
_Reference = Literal["world", "world_aligned", "local_world_aligned", "local"]
_PathLike = Union[str, os.PathLike[str]]

__version__: str
__all__ = [
    "TandemError",
    "RobotError",
    "UrdfError",
    "ConfigurationError",
    "CollisionError",
    "ProblemError",
    "PlanningError",
    "IkError",
    "OptimizationError",
    "ControlError",
    "DatasetError",
    "ArbitrationError",
    "RobotModel",
    "CollisionModel",
    "Distance",
    "Problem",
    "ProblemFamily",
    "PlanResult",
    "Solution",
    "TrackingPolicy",
    "Arbiter",
    "plan",
    "solve",
    "goal_configurations",
    "solve_ik",
    "generate",
    "missing_parts",
    "part_count",
    "part_ids",
    "__version__",
]

class TandemError(Exception):
    """Base class of every error tandem raises; the message is the Rust error's."""

class RobotError(TandemError):
    """Robot model errors: unknown frame or joint, bad joint selection."""

class UrdfError(RobotError):
    """A URDF, SRDF or mesh file that cannot be loaded (file, line, element)."""

class ConfigurationError(RobotError):
    """A joint configuration of the wrong length or with NaN/inf values."""

class CollisionError(TandemError):
    """Collision shapes and models that cannot be built."""

class ProblemError(TandemError):
    """Problem and family files, MoveIt inputs and scenes (file, key, line)."""

class PlanningError(TandemError):
    """Planning that cannot start (a failed search is a status, not an error)."""

class IkError(PlanningError):
    """No configuration (or no collision-free one) reaches the target."""

class OptimizationError(TandemError):
    """Trajectory optimization that cannot be set up."""

class ControlError(TandemError):
    """Tracking policies: bad references, weights or query inputs."""

class DatasetError(TandemError):
    """Bulk generation and dataset files."""

class ArbitrationError(TandemError):
    """Arbiter setup: goal references that cannot be prepared, settings out of range, unknown modes."""

@final
class RobotModel:
    """A robot's kinematic model: a URDF with a choice of active joints.

    ``q`` holds one value per active joint (rad or m) in ``joint_names``
    order. Immutable; safe to share between threads.
    """

    @staticmethod
    def panda() -> RobotModel:
        """The embedded Franka Panda: 7 arm joints, fingers held open, gripper frame ``panda_hand_tcp``."""
    @staticmethod
    def from_urdf(
        path: _PathLike,
        *,
        package_dirs: Sequence[_PathLike] = ...,
        chain: Optional[tuple[str, str]] = None,
        joints: Optional[Sequence[str]] = None,
        hold: Mapping[str, float] = ...,
        ros_package_path: bool = True,
    ) -> RobotModel:
        """Loads a URDF; active joints from ``chain=(root_link, tip_frame)`` or ``joints``
        (default: every movable joint no mimic drives); ``hold`` sets inactive joints."""
    @staticmethod
    def from_urdf_string(
        text: str,
        *,
        package_dirs: Sequence[_PathLike] = ...,
        chain: Optional[tuple[str, str]] = None,
        joints: Optional[Sequence[str]] = None,
        hold: Mapping[str, float] = ...,
    ) -> RobotModel:
        """Parses URDF text; arguments as :meth:`from_urdf`."""
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int:
        """Number of active joints (the length of ``q``)."""
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def lower_limits(self) -> _Vector: ...
    @property
    def upper_limits(self) -> _Vector: ...
    @property
    def velocity_limits(self) -> _Vector: ...
    @property
    def effort_limits(self) -> _Vector: ...
    @property
    def frame_names(self) -> list[str]:
        """One frame per link, then one per joint, in URDF order."""
    @property
    def root_link(self) -> str: ...
    def frame_index(self, name: str) -> int: ...
    def neutral_configuration(self) -> _Vector: ...
    def within_limits(self, q: _ArrayLike) -> bool: ...
    def check_configuration(self, q: _ArrayLike) -> None:
        """Raises ConfigurationError unless ``q`` has one finite value per joint."""
    def frame_pose(self, q: _ArrayLike, frame: _Frame, *, out: Optional[_Matrix] = None) -> _Matrix:
        """World pose of ``frame`` at ``q`` (4 × 4)."""
    def frame_jacobian(
        self, q: _ArrayLike, frame: _Frame, reference: _Reference = "world", *, out: Optional[_Matrix] = None
    ) -> _Matrix:
        """Geometric Jacobian (6 × nq): linear rows, then angular; world-aligned or local axes."""
    def frame_pose_jacobian(self, q: _ArrayLike, frame: _Frame, reference: _Reference = "world") -> tuple[_Matrix, _Matrix]:
        """``(frame_pose, frame_jacobian)`` from one forward kinematics pass."""
    def point_jacobian(self, q: _ArrayLike, frame: _Frame, point: Sequence[float]) -> tuple[_Vector, _Matrix]:
        """World position and Jacobian (3 × nq) of a point fixed on ``frame`` (frame coordinates, m)."""
    def frame_placements(self, q: _ArrayLike) -> npt.NDArray[np.float64]:
        """World poses of all frames (F × 4 × 4), in ``frame_names`` order."""
    def frame_poses(self, qs: _MatrixLike, frame: _Frame) -> npt.NDArray[np.float64]:
        """Poses of ``frame`` at each row of ``qs`` (N × 4 × 4); releases the GIL."""
    def frame_jacobians(self, qs: _MatrixLike, frame: _Frame, reference: _Reference = "world") -> npt.NDArray[np.float64]:
        """Jacobians of ``frame`` at each row of ``qs`` (N × 6 × nq); releases the GIL."""

@final
class Distance:
    """Signed distance of one pair (robot side first); world frame, m."""

    pair: int
    bodies: tuple[str, str]
    distance: float
    point_a: _Vector
    point_b: _Vector
    normal: _Vector
    gradient: Optional[_Vector]

@final
class CollisionModel:
    """The robot (and a problem's scene) as collision geometry, with the pairs to check."""

    def __new__(cls, robot: RobotModel, *, srdf: Optional[_PathLike] = None, padding: float = 0.0) -> CollisionModel:
        """Self-collision model from the robot's URDF collision geometry (SRDF pairs disabled)."""
    @property
    def robot(self) -> RobotModel: ...
    @property
    def padding(self) -> float: ...
    @property
    def pairs(self) -> list[tuple[str, str]]: ...
    def collision_free(self, q: _ArrayLike) -> bool: ...
    def min_distance(self, q: _ArrayLike, *, gradient: bool = False) -> Optional[Distance]: ...
    def distances(self, q: _ArrayLike, cutoff: float = ..., *, gradients: bool = False) -> list[Distance]: ...
    def motion_free(self, q0: _ArrayLike, q1: _ArrayLike, resolution: float = 0.005) -> bool: ...
    def motion_free_certified(self, q0: _ArrayLike, q1: _ArrayLike, clearance: float) -> bool: ...
    def path_free(self, path: _MatrixLike, resolution: float = 0.005) -> bool: ...
    def collision_free_many(self, qs: _MatrixLike) -> npt.NDArray[np.bool_]: ...
    def min_distances(self, qs: _MatrixLike) -> _Vector: ...

@final
class Problem:
    """A motion problem: robot, scene, start, goal, planner and optimizer settings."""

    @staticmethod
    def from_file(path: _PathLike) -> Problem: ...
    @staticmethod
    def builtin(name: str) -> Problem: ...
    @staticmethod
    def builtin_names() -> list[str]: ...
    @staticmethod
    def from_toml(text: str, *, origin: str = "<string>", base_dir: Optional[_PathLike] = None) -> Problem: ...
    @staticmethod
    def from_moveit(urdf: _PathLike, srdf: _PathLike, scene: _PathLike, request: _PathLike) -> Problem: ...
    def with_start(self, q: _ArrayLike) -> Problem: ...
    def with_point_cloud(
        self,
        points: _MatrixLike,
        point_radius: float,
        *,
        name: str = "point_cloud",
        spacing: Optional[float] = None,
        pose: Optional[_MatrixLike] = None,
    ) -> Problem: ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def origin(self) -> str: ...
    @property
    def robot(self) -> RobotModel: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def gripper(self) -> Optional[str]: ...
    @property
    def start(self) -> _Vector: ...
    @property
    def goal(self) -> dict[str, Any]:
        """``{"kind": "joints" | "pose" | "grasp", ...}``."""
    @property
    def horizon(self) -> int: ...
    @property
    def duration(self) -> float: ...
    @property
    def planner_seed(self) -> int: ...
    @property
    def obstacles(self) -> list[dict[str, Any]]: ...
    @property
    def objects(self) -> list[dict[str, Any]]: ...
    def collision_model(self, padding: float = 0.0) -> CollisionModel: ...

@final
class ProblemFamily:
    """Problems sampled around a base problem; member i of seed s depends on (s, i) only."""

    @staticmethod
    def from_file(path: _PathLike) -> ProblemFamily: ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def base(self) -> Problem: ...
    def sample(self, i: int, seed: int = 0) -> Problem: ...

@final
class PlanResult:
    """RRT-Connect + shortcutting outcome."""

    @property
    def status(self) -> str: ...
    @property
    def solved(self) -> bool: ...
    @property
    def path(self) -> _Matrix: ...
    @property
    def raw_path(self) -> _Matrix: ...
    @property
    def goals(self) -> _Matrix: ...
    @property
    def certified(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def nodes(self) -> int: ...
    @property
    def attempts(self) -> int: ...
    @property
    def planning_time(self) -> float: ...
    @property
    def simplify_time(self) -> float: ...

@final
class Solution:
    """An optimized trajectory and its report."""

    @property
    def status(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def trajectory(self) -> _Matrix: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def time_step(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def eq_violation(self) -> float: ...
    @property
    def ineq_violation(self) -> float: ...
    @property
    def collision_free(self) -> bool: ...
    @property
    def within_limits(self) -> bool: ...
    @property
    def min_distance(self) -> Optional[float]: ...
    @property
    def iterations(self) -> tuple[int, int, int]: ...
    @property
    def solve_time(self) -> float: ...
    @property
    def total_time(self) -> float: ...
    @property
    def plan(self) -> PlanResult: ...
    def report(self) -> dict[str, Any]: ...

@final
class TrackingPolicy:
    """LQR tracking policy of a joint-space reference (velocity commands)."""

    def __new__(
        cls,
        reference: _MatrixLike,
        dt: float,
        *,
        joints: Optional[Sequence[str]] = None,
        position_weight: float = 100.0,
        velocity_weight: float = 1.0,
        control_weight: float = 0.1,
        schedule: Literal["constant", "time_varying"] = "constant",
        feedforward: Literal["velocity", "acceleration"] = "velocity",
        lookahead: int = 1,
    ) -> TrackingPolicy: ...
    @property
    def dof(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def reference(self) -> _Matrix: ...
    def gain(self, index: int = 0) -> _Matrix: ...
    def query(self, q: _ArrayLike, velocity: Optional[_ArrayLike] = None, *, out: Optional[_Vector] = None) -> _Vector: ...
    def query_with_info(self, q: _ArrayLike, velocity: Optional[_ArrayLike] = None) -> tuple[_Vector, float, float, float]:
        """``(command, closest point s, distance to it (rad), tracked point s)``: points of the
        reference polyline as waypoint coordinates (waypoint ``floor(s)`` plus a fraction of the next segment)."""
    def reset(self) -> None: ...
    def rollout(self, start: _ArrayLike, steps: int) -> _Matrix: ...

_Mode = Literal[
    "direct", "blend-timid", "blend-aggressive", "avoid", "natural-gradient", "natural-gradient-joint",
    "constrained", "sos", "learned",
]

@final
class Arbiter:
    """Shared control of a problem's goals: every tick, the operator's command blended with the
    robot policies under joint limits and distances (dissertation, chapters 4–5)."""

    def __new__(
        cls, problem: Problem, *, mode: _Mode = "sos", period: float = 1.0 / 15.0, margin: float = 0.005,
        seed: Optional[int] = None, actor: Optional[str | os.PathLike[str]] = None,
        sos_center: float = 0.0, constrained_center: float = 0.0,
    ) -> Arbiter:
        """``actor``: a trained arbitration actor (``tandem learn arbitration``) for ``mode="learned"``;
        ``sos_center``, ``constrained_center``: κ, the modes centred on κ times the robot's action
        (0: the dissertation's)."""
    def tick(
        self,
        q: _ArrayLike,
        command: _ArrayLike,
        *,
        kind: Literal["linear", "twist", "joint"] = "linear",
        velocity: Optional[_ArrayLike] = None,
        beliefs: Optional[_ArrayLike] = None,
        out: Optional[_Vector] = None,
    ) -> tuple[_Vector, str, dict[str, Any]]:
        """``(joint velocity for one period, status, diagnostics)``; bad numbers give zero velocity
        and a status such as ``"invalid_command"``, never an exception."""
    def reset(self) -> None: ...
    mode: _Mode
    @property
    def goals(self) -> list[str]: ...
    @property
    def goal_positions(self) -> list[tuple[float, float, float]]: ...
    @property
    def period(self) -> float: ...
    @property
    def nq(self) -> int: ...

@final
class ArbitrationEnv:
    """The arbitration-learning environment (§6.5 of the dissertation); :mod:`tandem.gym` wraps it for Gymnasium."""

    def __new__(
        cls,
        task: Literal["planar", "panda"] = "planar",
        *,
        reward: Literal["combined", "environment"] = "combined",
        max_time: Optional[float] = None,
        hard_collisions: bool = True,
        physics: bool = False,
    ) -> ArbitrationEnv: ...
    def reset(self, seed: int) -> _Vector:
        """Starts episode ``seed`` and returns the first state (17 values)."""
    def step(self, action: _ArrayLike) -> tuple[_Vector, float, bool, bool, dict[str, Any]]:
        """``(state, reward, terminated, truncated, info)`` as Gymnasium's ``step``."""
    @property
    def state_width(self) -> int: ...
    @property
    def action_width(self) -> int: ...
    @property
    def max_action(self) -> float: ...
    @property
    def human_offset(self) -> int: ...
    @property
    def gripper(self) -> tuple[float, float, float]: ...

def run_planar_experiment(tasks: int = 10, seed: int = 0) -> list[dict[str, Any]]:
    """Table 4.1's planar experiment, one dict per episode (``tandem experiment planar``)."""

def run_reach_grasp_experiment(
    tasks: int = 5, seed: int = 0, arm: Literal["right", "left", "both"] = "right"
) -> list[dict[str, Any]]:
    """Table 5.1's Panda reach-and-grasp experiment, one dict per episode (``tandem experiment reach-grasp``)."""

def plan(problem: Problem, seed: Optional[int] = None) -> PlanResult:
    """RRT-Connect + shortcutting, as ``tandem plan``; releases the GIL."""

def solve(
    problem: Problem,
    seed: Optional[int] = None,
    horizon: Optional[int] = None,
    validation_resolution: float = 0.002,
    initial_guess: Literal["planned", "straight"] = "planned",
) -> Solution:
    """Plan, optimize and validate, as ``tandem solve``; releases the GIL."""

def goal_configurations(problem: Problem, seed: Optional[int] = None) -> _Matrix:
    """The goal configurations the planner aims at (K × nq)."""

def solve_ik(
    model: CollisionModel,
    frame: _Frame,
    position: Sequence[float],
    *,
    orientation: Optional[Sequence[Sequence[float]]] = None,
    axis: Optional[int] = None,
    direction: Optional[Sequence[float]] = None,
    seed_q: Optional[_ArrayLike] = None,
    count: int = 1,
    seed: int = 0,
    restarts: int = 50,
    iterations: int = 150,
    position_tolerance: float = 1e-5,
    angle_tolerance: float = 1e-4,
    damping: float = 1e-3,
) -> _Matrix:
    """Up to ``count`` collision-free IK solutions (K × nq); raises IkError when none."""

def generate(
    family: _PathLike,
    out: _PathLike,
    *,
    count: int,
    seed: int = 0,
    horizon: Optional[int] = None,
    chunk_size: int = 100,
    attempts: int = 3,
    max_evaluations: int = 200,
    threads: Optional[int] = None,
    shard: Optional[tuple[int, int]] = None,
    progress: bool = False,
    initial_guess: Literal["planned", "straight"] = "planned",
) -> dict[str, Any]:
    """Bulk generation in this process, as ``tandem generate``; releases the GIL."""

def missing_parts(
    family: _PathLike,
    out: _PathLike,
    *,
    count: int,
    seed: int = 0,
    horizon: Optional[int] = None,
    chunk_size: int = 100,
    attempts: int = 3,
    max_evaluations: int = 200,
    initial_guess: Literal["planned", "straight"] = "planned",
) -> list[int]:
    """Part numbers of a run still missing from ``out`` (checks and writes ``_dataset.json``)."""

def part_count(*, count: int, chunk_size: int = 100) -> int: ...
def part_ids(k: int, *, count: int, chunk_size: int = 100) -> tuple[int, int]: ...
