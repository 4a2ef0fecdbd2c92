"""tandem: motion for human-robot shared control, from Python.

Robot models from URDF with forward kinematics and frame Jacobians,
collision checking and signed distances, problem files and families,
inverse kinematics, RRT-Connect planning, KOMO-style trajectory
optimization, LQR tracking policies, the per-tick shared-control arbiter
and bulk dataset generation — the Rust library, with numpy arrays in and
out.

>>> import tandem
>>> panda = tandem.RobotModel.panda()
>>> q = panda.neutral_configuration()
>>> pose = panda.frame_pose(q, "panda_hand_tcp")           # 4 x 4, world frame
>>> jac = panda.frame_jacobian(q, "panda_hand_tcp")        # 6 x 7, linear rows first
>>> problem = tandem.Problem.builtin("panda_reach")
>>> solution = tandem.solve(problem, seed=1)               # RRT-Connect + optimizer
>>> solution.status
'converged'
>>> arbiter = tandem.Arbiter(tandem.Problem.builtin("panda_grasp_box"), mode="sos")
>>> qdot, status, info = arbiter.tick(problem.start, [0.1, 0.0, 0.0])  # gripper velocity, m/s

Every error is a :class:`TandemError` subclass carrying the Rust message
(file, line, key, joint or value at fault). Long calls (loading, planning,
solving, generation, batch queries) release the GIL. Bulk generation over a
Ray cluster: :mod:`tandem.distributed`. Gymnasium environments for learning
arbitration: :mod:`tandem.gym`.
"""

try:  # a build with MuJoCo physics links PyPI's libmujoco: load it first
    import mujoco  # noqa: F401
except ImportError:
    pass

from ._native import (  # noqa: E402
    Arbiter,
    ArbitrationEnv,
    ArbitrationError,
    CollisionError,
    CollisionModel,
    ConfigurationError,
    ControlError,
    DatasetError,
    Distance,
    IkError,
    OptimizationError,
    PlanningError,
    PlanResult,
    Problem,
    ProblemError,
    ProblemFamily,
    RobotError,
    RobotModel,
    Solution,
    TandemError,
    TrackingPolicy,
    UrdfError,
    __version__,
    generate,
    goal_configurations,
    missing_parts,
    part_count,
    part_ids,
    plan,
    run_planar_experiment,
    run_reach_grasp_experiment,
    solve,
    solve_ik,
)

__all__ = [
    "Arbiter",
    "ArbitrationError",
    "CollisionError",
    "CollisionModel",
    "ConfigurationError",
    "ControlError",
    "DatasetError",
    "Distance",
    "IkError",
    "OptimizationError",
    "PlanningError",
    "PlanResult",
    "Problem",
    "ProblemError",
    "ProblemFamily",
    "RobotError",
    "RobotModel",
    "Solution",
    "TandemError",
    "TrackingPolicy",
    "UrdfError",
    "__version__",
    "generate",
    "goal_configurations",
    "missing_parts",
    "part_count",
    "part_ids",
    "plan",
    "run_planar_experiment",
    "run_reach_grasp_experiment",
    "solve",
    "solve_ik",
]
