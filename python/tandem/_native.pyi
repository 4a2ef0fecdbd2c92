"""Type stubs of tandem's native module (python/src/, built by maturin).

Arrays are numpy float64 arrays; ``ArrayLike`` arguments also accept lists
and tuples (a C-contiguous float64 array is read in place, anything else is
copied). Units are SI: m, rad, s. Poses are 4 × 4 homogeneous matrices in
the frame of the URDF's root link.
"""

import os
from collections.abc import Mapping, Sequence
from typing import Any, Literal, Optional, Union

import numpy as np
import numpy.typing as npt

Vector = npt.NDArray[np.float64]
Matrix = npt.NDArray[np.float64]
ArrayLike = Union[npt.NDArray[Any], Sequence[float]]
MatrixLike = Union[npt.NDArray[Any], Sequence[Sequence[float]]]
Frame = Union[str, int]
Reference = Literal["world", "world_aligned", "local_world_aligned", "local"]
PathLike = Union[str, os.PathLike[str]]

__version__: str

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
        path: PathLike,
        *,
        package_dirs: Sequence[PathLike] = (),
        chain: Optional[tuple[str, str]] = None,
        joints: Optional[Sequence[str]] = None,
        hold: Mapping[str, float] = {},
        ros_package_path: bool = True,
    ) -> RobotModel:
        """Loads a URDF; active joints from ``chain=(root_link, tip_frame)`` or ``joints``
        (default: every movable joint no mimic drives); ``hold`` sets inactive joints."""
    @staticmethod
    def from_urdf_string(
        text: str,
        *,
        package_dirs: Sequence[PathLike] = (),
        chain: Optional[tuple[str, str]] = None,
        joints: Optional[Sequence[str]] = None,
        hold: Mapping[str, float] = {},
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
    def lower_limits(self) -> Vector: ...
    @property
    def upper_limits(self) -> Vector: ...
    @property
    def velocity_limits(self) -> Vector: ...
    @property
    def effort_limits(self) -> Vector: ...
    @property
    def frame_names(self) -> list[str]:
        """One frame per link, then one per joint, in URDF order."""
    @property
    def root_link(self) -> str: ...
    def frame_index(self, name: str) -> int: ...
    def neutral_configuration(self) -> Vector: ...
    def within_limits(self, q: ArrayLike) -> bool: ...
    def check_configuration(self, q: ArrayLike) -> None:
        """Raises ConfigurationError unless ``q`` has one finite value per joint."""
    def frame_pose(self, q: ArrayLike, frame: Frame, *, out: Optional[Matrix] = None) -> Matrix:
        """World pose of ``frame`` at ``q`` (4 × 4)."""
    def frame_jacobian(
        self, q: ArrayLike, frame: Frame, reference: Reference = "world", *, out: Optional[Matrix] = None
    ) -> Matrix:
        """Geometric Jacobian (6 × nq): linear rows, then angular; world-aligned or local axes."""
    def frame_pose_jacobian(self, q: ArrayLike, frame: Frame, reference: Reference = "world") -> tuple[Matrix, Matrix]:
        """``(frame_pose, frame_jacobian)`` from one forward kinematics pass."""
    def point_jacobian(self, q: ArrayLike, frame: Frame, point: Sequence[float]) -> tuple[Vector, Matrix]:
        """World position and Jacobian (3 × nq) of a point fixed on ``frame`` (frame coordinates, m)."""
    def frame_placements(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """World poses of all frames (F × 4 × 4), in ``frame_names`` order."""
    def frame_poses(self, qs: MatrixLike, frame: Frame) -> npt.NDArray[np.float64]:
        """Poses of ``frame`` at each row of ``qs`` (N × 4 × 4); releases the GIL."""
    def frame_jacobians(self, qs: MatrixLike, frame: Frame, reference: Reference = "world") -> npt.NDArray[np.float64]:
        """Jacobians of ``frame`` at each row of ``qs`` (N × 6 × nq); releases the GIL."""

class Distance:
    """Signed distance of one pair (robot side first); world frame, m."""

    pair: int
    bodies: tuple[str, str]
    distance: float
    point_a: Vector
    point_b: Vector
    normal: Vector
    gradient: Optional[Vector]

class CollisionModel:
    """The robot (and a problem's scene) as collision geometry, with the pairs to check."""

    def __init__(self, robot: RobotModel, *, srdf: Optional[PathLike] = None, padding: float = 0.0) -> None:
        """Self-collision model from the robot's URDF collision geometry (SRDF pairs disabled)."""
    @property
    def robot(self) -> RobotModel: ...
    @property
    def padding(self) -> float: ...
    @property
    def pairs(self) -> list[tuple[str, str]]: ...
    def collision_free(self, q: ArrayLike) -> bool: ...
    def min_distance(self, q: ArrayLike, *, gradient: bool = False) -> Optional[Distance]: ...
    def distances(self, q: ArrayLike, cutoff: float = ..., *, gradients: bool = False) -> list[Distance]: ...
    def motion_free(self, q0: ArrayLike, q1: ArrayLike, resolution: float = 0.005) -> bool: ...
    def motion_free_certified(self, q0: ArrayLike, q1: ArrayLike, clearance: float) -> bool: ...
    def path_free(self, path: MatrixLike, resolution: float = 0.005) -> bool: ...
    def collision_free_many(self, qs: MatrixLike) -> npt.NDArray[np.bool_]: ...
    def min_distances(self, qs: MatrixLike) -> Vector: ...

class Problem:
    """A motion problem: robot, scene, start, goal, planner and optimizer settings."""

    @staticmethod
    def from_file(path: PathLike) -> Problem: ...
    @staticmethod
    def builtin(name: str) -> Problem: ...
    @staticmethod
    def builtin_names() -> list[str]: ...
    @staticmethod
    def from_toml(text: str, *, origin: str = "<string>", base_dir: Optional[PathLike] = None) -> Problem: ...
    @staticmethod
    def from_moveit(urdf: PathLike, srdf: PathLike, scene: PathLike, request: PathLike) -> Problem: ...
    def with_start(self, q: ArrayLike) -> Problem: ...
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
    def start(self) -> Vector: ...
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

class ProblemFamily:
    """Problems sampled around a base problem; member i of seed s depends on (s, i) only."""

    @staticmethod
    def from_file(path: PathLike) -> ProblemFamily: ...
    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def base(self) -> Problem: ...
    def sample(self, i: int, seed: int = 0) -> Problem: ...

class PlanResult:
    """RRT-Connect + shortcutting outcome."""

    @property
    def status(self) -> str: ...
    @property
    def solved(self) -> bool: ...
    @property
    def path(self) -> Matrix: ...
    @property
    def raw_path(self) -> Matrix: ...
    @property
    def goals(self) -> Matrix: ...
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

class Solution:
    """An optimized trajectory and its report."""

    @property
    def status(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def trajectory(self) -> Matrix: ...
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

class TrackingPolicy:
    """LQR tracking policy of a joint-space reference (velocity commands)."""

    def __init__(
        self,
        reference: MatrixLike,
        dt: float,
        *,
        joints: Optional[Sequence[str]] = None,
        position_weight: float = 100.0,
        velocity_weight: float = 1.0,
        control_weight: float = 0.1,
        schedule: Literal["constant", "time_varying"] = "constant",
        feedforward: Literal["velocity", "acceleration"] = "velocity",
        lookahead: int = 1,
    ) -> None: ...
    @property
    def dof(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def reference(self) -> Matrix: ...
    def gain(self, index: int = 0) -> Matrix: ...
    def query(self, q: ArrayLike, velocity: Optional[ArrayLike] = None, *, out: Optional[Vector] = None) -> Vector: ...
    def query_with_info(self, q: ArrayLike, velocity: Optional[ArrayLike] = None) -> tuple[Vector, int, float, int]:
        """``(command, closest index, distance to it (rad), tracked index)``."""
    def reset(self) -> None: ...
    def rollout(self, start: ArrayLike, steps: int) -> Matrix: ...

def plan(problem: Problem, seed: Optional[int] = None) -> PlanResult:
    """RRT-Connect + shortcutting, as ``tandem plan``; releases the GIL."""

def solve(
    problem: Problem, seed: Optional[int] = None, horizon: Optional[int] = None, validation_resolution: float = 0.002
) -> Solution:
    """Plan, optimize and validate, as ``tandem solve``; releases the GIL."""

def goal_configurations(problem: Problem, seed: Optional[int] = None) -> Matrix:
    """The goal configurations the planner aims at (K × nq)."""

def solve_ik(
    model: CollisionModel,
    frame: Frame,
    position: Sequence[float],
    *,
    orientation: Optional[Sequence[Sequence[float]]] = None,
    axis: Optional[int] = None,
    direction: Optional[Sequence[float]] = None,
    seed_q: Optional[ArrayLike] = None,
    count: int = 1,
    seed: int = 0,
    restarts: int = 50,
    iterations: int = 150,
    position_tolerance: float = 1e-5,
    angle_tolerance: float = 1e-4,
    damping: float = 1e-3,
) -> Matrix:
    """Up to ``count`` collision-free IK solutions (K × nq); raises IkError when none."""

def generate(
    family: PathLike,
    out: PathLike,
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
) -> dict[str, Any]:
    """Bulk generation in this process, as ``tandem generate``; releases the GIL."""

def missing_parts(
    family: PathLike,
    out: PathLike,
    *,
    count: int,
    seed: int = 0,
    horizon: Optional[int] = None,
    chunk_size: int = 100,
    attempts: int = 3,
    max_evaluations: int = 200,
) -> list[int]:
    """Part numbers of a run still missing from ``out`` (checks and writes ``_dataset.json``)."""

def part_count(*, count: int, chunk_size: int = 100) -> int: ...
def part_ids(k: int, *, count: int, chunk_size: int = 100) -> tuple[int, int]: ...
