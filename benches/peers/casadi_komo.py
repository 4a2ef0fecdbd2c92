"""The same trajectory problem written in casadi and solved by IPOPT.

    python casadi_komo.py PROBLEM.json [--reps 3] [--max-inits K] [--cutoff C] [--hessian exact|limited-memory]

PROBLEM.json comes from `examples/komo_seeds.rs --export`. The NLP is
tandem's, written out symbolically (casadi SX):

* variables q_1..q_T (the active joints); the k = 2 prefix configurations
  are the start; τ = duration / T;
* forward kinematics from the problem's URDF (joint origins, revolute
  joints about their axes, held joints fixed at their values), so robot
  frames and the collision spheres' centres are exact functions of q;
* every objective of the export with its slices, kind, scale, target and
  order: r_t = s·(Σ_j c_j φ(q_{t−j}) / τ^k − target) with c = [1], [1, −1],
  [1, −2, 1]; sos objectives make the cost Σ r², eq rows g = 0, ineq rows
  g ≤ 0;
* features: joint_state (q), position, position_difference, scalar_product,
  vector, orientation_difference (log of R_bᵀR_a, by the axis-angle formula),
  collision: for EVERY checked pair of the exchange (tandem's pairs) and
  every slice of the objective one row margin − d ≤ 0, d the signed distance
  — sphere–sphere |c_a − c_b| − r_a − r_b, sphere–box the exact signed
  distance of the centre to the box minus the radius (√(ε + ‖max(|p| − h, 0)‖²)
  + min(max_i(|p_i| − h_i), 0) − r, ε = 1e-12 m² so its derivative exists
  when the centre is inside the box);
* joint_limits with margin m as IPOPT variable bounds [lower + m, upper − m]
  (the same constraint, the form IPOPT handles natively);
* a vector equality v = d (v = R_bᵀR_a e_i, a unit vector, d a unit target)
  as the two components of v − d orthogonal to d (equalities) and d·v ≥ 0
  (an inequality, inactive at a solution, that rules out v = −d): the same
  set, but the three rows of v − d have rank 2 only, and IPOPT does not cope
  with that (panda_reach at T = 50: 'Infeasible_Problem_Detected' after 87
  iterations with the three rows, solved in 13 with this form);
  --literal-vector keeps the three rows.

Collision rows: by default one per checked pair and slice (tandem's full
set: 1339 pairs × T for the grasp problem). With --cutoff C only the pairs
closer than margin + C at the start point get rows — tandem itself gives rows
only to pairs within margin + 5 cm, re-deciding at every evaluation, which a
fixed NLP cannot — and when IPOPT's result violates a left-out pair, the pairs
within margin + C at the result are added and IPOPT starts again from the
initialisation (at most 5 rounds, all timed).

IPOPT (the one in the casadi wheel, MUMPS linear solver) starts at tandem's
initialisation (clipped into the bounds) with an exact Hessian of the
Lagrangian (casadi AD) unless --hessian limited-memory; tol 1e-6,
constr_viol_tol 1e-5 (tandem's own constraint tolerance), mu_strategy
adaptive (7 instead of 30 iterations on the grasp problem), max_wall_time
300 s, otherwise its defaults. A run has converged when IPOPT returns
Solve_Succeeded (Solved_To_Acceptable_Level is reported but not counted).
Building the casadi graph and the solver objects is NOT timed (nor for
re-solve rounds: they are built in an untimed first solve); the time of a
run is the solver calls (IPOPT plus casadi's evaluations of the functions
and derivatives).
casadi's C code generation was tried and dropped: gcc needs many minutes and
gigabytes for these expression graphs.

Before solving it checks its own cost and violations at each initialisation
against tandem's measures of it (`init_check`), so a mismatch in the model
shows.
"""

import argparse
import math
import sys
import time

import numpy as np

from komo_common import emit, load_problem, read_urdf, result, version_of

ca = None  # casadi, imported in main()


def rpy_matrix(r, p, y):
    """URDF fixed-axis roll-pitch-yaw: Rz(y) Ry(p) Rx(r), as numpy."""
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def axis_rotation(axis, angle):
    """Rodrigues' rotation about a unit axis by a symbolic angle."""
    x, y, z = axis
    c, s = ca.cos(angle), ca.sin(angle)
    t = 1 - c
    return ca.vertcat(
        ca.horzcat(t * x * x + c, t * x * y - s * z, t * x * z + s * y),
        ca.horzcat(t * x * y + s * z, t * y * y + c, t * y * z - s * x),
        ca.horzcat(t * x * z - s * y, t * y * z + s * x, t * z * z + c),
    )


class Kinematics:
    """Forward kinematics of the URDF tree for the exchange's active joints."""

    def __init__(self, exchange):
        self.base, self.joints, self.spheres = read_urdf(exchange["urdf"])
        self.active = {name: i for i, name in enumerate(exchange["joints"])}
        self.held = exchange.get("held", {})
        missing = set(self.active) - {j["name"] for j in self.joints}
        if missing:
            raise SystemExit(f"active joints missing from the URDF: {sorted(missing)}")

    def poses(self, q):
        """World (R, p) of every link for the symbolic configuration q."""
        poses = {self.base: (ca.SX.eye(3), ca.SX.zeros(3))}
        for j in self.joints:
            R, p = poses[j["parent"]]
            p1 = p + ca.mtimes(R, ca.DM(j["xyz"]))
            R1 = ca.mtimes(R, ca.DM(rpy_matrix(*j["rpy"])))
            n = np.asarray(j["axis"], dtype=float)
            n = n / np.linalg.norm(n)
            if j["name"] in self.active:
                v = q[self.active[j["name"]]]
                if j["type"] in ("revolute", "continuous"):
                    R1 = ca.mtimes(R1, axis_rotation(n, v))
                elif j["type"] == "prismatic":
                    p1 = p1 + ca.mtimes(R1, ca.DM(n)) * v
                else:
                    raise SystemExit(f"active joint {j['name']} of type {j['type']}")
            elif j["name"] in self.held and j["type"] != "fixed":
                v = float(self.held[j["name"]])
                if j["type"] == "prismatic":
                    p1 = p1 + ca.mtimes(R1, ca.DM(n * v))
                else:
                    R1 = ca.mtimes(R1, ca.DM(rotation_matrix(n, v)))
            poses[j["child"]] = (R1, p1)
        return poses


def rotation_matrix(axis, angle):
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1 - c
    return np.array([
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ])


def so3_log(R):
    """log(R) by the axis-angle formula (valid away from angle 0 and π, where
    a tiny regulariser keeps it differentiable)."""
    v = 0.5 * ca.vertcat(R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1])
    s = ca.sqrt(ca.sumsqr(v) + 1e-30)
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1)
    return v * (ca.atan2(s, c) / s)


class Model:
    """The NLP of one exported problem."""

    def __init__(self, problem, literal_vector=False):
        self.problem = problem
        self.literal_vector = literal_vector
        self.T = problem["horizon"]
        self.n = len(problem["joints"])
        self.k = problem["order"]
        self.tau = problem["duration"] / self.T
        self.kin = Kinematics(problem["exchange"])
        self.start = np.asarray(problem["start"], dtype=float)
        self.x = ca.SX.sym("q", self.n * self.T)
        self._poses = {}

    def q(self, t):
        """Configuration of slice t (≤ 0: the start)."""
        if t <= 0:
            return ca.DM(self.start)
        return self.x[(t - 1) * self.n: t * self.n]

    def poses(self, t):
        t = max(t, 0)
        if t not in self._poses:
            self._poses[t] = self.kin.poses(self.q(t))
        return self._poses[t]

    def frame(self, t, frame):
        """(R, p) of a feature frame at slice t."""
        if "robot" in frame:
            name = frame["robot"]
            if name not in self.poses(t):
                raise SystemExit(f"frame {name} is not a link of the URDF")
            return self.poses(t)[name]
        return ca.DM(frame["rotation"]), ca.DM(frame["translation"])

    def feature(self, o, t):
        f = o["feature"]
        if f == "joint_state":
            return self.q(t)
        if f == "position":
            return self.frame(t, o["frames"][0])[1]
        if f == "position_difference":
            return self.frame(t, o["frames"][0])[1] - self.frame(t, o["frames"][1])[1]
        if f == "scalar_product":
            (Ra, _), (Rb, _) = self.frame(t, o["frames"][0]), self.frame(t, o["frames"][1])
            return ca.dot(Ra[:, o["axes"][0]], Rb[:, o["axes"][1]])
        if f == "vector":
            (Ra, _), (Rb, _) = self.frame(t, o["frames"][0]), self.frame(t, o["frames"][1])
            return ca.mtimes(Rb.T, Ra[:, o["axes"][0]])
        if f == "orientation_difference":
            (Ra, _), (Rb, _) = self.frame(t, o["frames"][0]), self.frame(t, o["frames"][1])
            return so3_log(ca.mtimes(Rb.T, Ra))
        raise SystemExit(f"feature {f} is not mapped to casadi")

    def rows(self, o):
        """Rows r_t of a fixed-size feature objective over its slices."""
        coefficients = [[1.0], [1.0, -1.0], [1.0, -2.0, 1.0]][o["order"]]
        first, last = o["slices"]
        out = []
        for t in range(first, last + 1):
            value = sum(c * self.feature(o, t - j) for j, c in enumerate(coefficients))
            value = value / self.tau ** o["order"]
            if o["target"]:
                value = value - ca.DM(o["target"])
            out.append(o["scale"] * value)
        return ca.vertcat(*out)

    def distance_function(self):
        """A casadi Function of one configuration: the signed distance of
        every checked pair, in the exchange's pair order."""
        if getattr(self, "_distances", None) is not None:
            return self._distances
        e = self.problem["exchange"]
        elements = e["robot_elements"]
        n_robot = len(elements)
        pad = self.problem.get("padding", 0.0)
        local = []
        for r in elements:
            element = self.kin.spheres[r["link"]][r["index"]]
            if element is None:
                raise SystemExit(f"{r['link']} collision {r['index']}: only spheres are mapped")
            local.append((r["link"], np.asarray(element[0], dtype=float), element[1] + pad))
        boxes = []
        for ob in e["obstacles"]:
            if ob["shape"] != "box":
                raise SystemExit(f"obstacle {ob['name']}: only boxes are mapped, got {ob['shape']}")
            boxes.append((np.asarray(ob["rotation"], dtype=float), np.asarray(ob["translation"], dtype=float),
                          np.asarray(ob["half_extents"], dtype=float)))
        q = ca.SX.sym("q", self.n)
        poses = self.kin.poses(q)
        centres = [poses[link][1] + ca.mtimes(poses[link][0], ca.DM(xyz)) for link, xyz, _ in local]
        d = []
        for a, b in e["pairs"]:
            if a >= n_robot:
                a, b = b, a
            if a >= n_robot:
                raise SystemExit("obstacle–obstacle pairs are not mapped")
            ra = local[a][2]
            if b < n_robot:
                diff = centres[a] - centres[b]
                d.append(ca.sqrt(ca.sumsqr(diff) + 1e-24) - ra - local[b][2])
            else:
                R, t, h = boxes[b - n_robot]
                p = ca.mtimes(ca.DM(R.T), centres[a] - ca.DM(t))
                over = ca.fabs(p) - ca.DM(h)
                outside = ca.sqrt(ca.sumsqr(ca.fmax(over, 0)) + 1e-12)
                inside = ca.fmin(ca.fmax(over[0], ca.fmax(over[1], over[2])), 0)
                d.append(outside + inside - ra)
        self._distances = ca.Function("distances", [q], [ca.vertcat(*d)])
        self.pair_count = len(d)
        return self._distances

    def all_distances(self, x):
        """Numeric signed distances of every pair at every slice 1..T (T × pairs)."""
        f = self.distance_function()
        X = np.asarray(x, dtype=float).reshape(self.T, self.n)
        return np.asarray(f.map(self.T)(X.T)).T

    def collision_rows(self, o, active):
        """margin − d for the checked pairs (all, or `active[t]`) at every
        slice t of the objective."""
        distances = self.distance_function()
        first, last = o["slices"]
        rows = []
        for t in range(first, last + 1):
            d = distances(self.q(t))
            if active is not None:
                d = d[active.get(t, [])] if active.get(t) else ca.SX(0, 1)
            rows.append(o["scale"] * (o["margin"] - d))
        return ca.vertcat(*rows)

    def vector_rows(self, o):
        """A unit-vector equality v = d (|v| = 1 always) as IPOPT can take it:
        the two components of s·(v − d) orthogonal to d as equalities, and
        −s·(d·v) ≤ 0 (which picks +d over −d; inactive at a solution). The
        three rows of v − d have rank 2 only, which IPOPT does not cope with."""
        d = np.asarray(o["target"], dtype=float)
        if d.size != 3 or abs(np.linalg.norm(d) - 1.0) > 1e-9:
            raise SystemExit(f"{o['name']}: vector target {o['target']} is not a unit vector")
        helper = np.eye(3)[int(np.argmin(np.abs(d)))]
        e1 = np.cross(d, helper)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        first, last = o["slices"]
        orthogonal, along = [], []
        for t in range(first, last + 1):
            v = self.feature(o, t)
            orthogonal += [o["scale"] * ca.dot(ca.DM(e1), v), o["scale"] * ca.dot(ca.DM(e2), v)]
            along.append(-o["scale"] * ca.dot(ca.DM(d), v))
        return ca.vertcat(*orthogonal), ca.vertcat(*along)

    def build(self, active=None):
        """The NLP (sets f, g, lbg, ubg, lbx, ubx); `active` (slice → pair
        indices) restricts the collision rows, None keeps every pair."""
        cost, eq, ineq, measured_eq = [], [], [], []
        lower = np.tile(np.full(self.n, -np.inf), self.T)
        upper = np.tile(np.full(self.n, np.inf), self.T)
        self.collision, collision_rows = [], 0
        for o in self.problem["objectives"]:
            if o["feature"] == "joint_limits":
                if o["kind"] != "ineq" or o["order"] != 0:
                    raise SystemExit("joint_limits must be an order-0 inequality")
                first, last = o["slices"]
                for t in range(first, last + 1):
                    for i, (lo, hi) in enumerate(self.problem["joint_limits"]):
                        lower[(t - 1) * self.n + i] = lo + o["margin"]
                        upper[(t - 1) * self.n + i] = hi - o["margin"]
                continue
            if o["feature"] == "collision":
                if o["kind"] != "ineq":
                    raise SystemExit("only inequality collision objectives are mapped")
                self.collision.append(o)
                rows = self.collision_rows(o, active)
                collision_rows += rows.numel()
                ineq.append(rows)
                continue
            if o["feature"] == "vector" and o["kind"] == "eq" and o["order"] == 0 and not self.literal_vector:
                orthogonal, along = self.vector_rows(o)
                eq.append(orthogonal)
                ineq.append(along)
                measured_eq.append(self.rows(o))
                continue
            rows = self.rows(o)
            {"sos": cost, "eq": eq, "ineq": ineq}[o["kind"]].append(rows)
            if o["kind"] == "eq":
                measured_eq.append(rows)
        self.collision_row_count = collision_rows
        self.cost_rows = ca.vertcat(*cost) if cost else ca.SX(0, 1)
        self.eq = ca.vertcat(*eq) if eq else ca.SX(0, 1)
        self.ineq = ca.vertcat(*ineq) if ineq else ca.SX(0, 1)
        self.f = ca.sumsqr(self.cost_rows)
        self.g = ca.vertcat(self.eq, self.ineq)
        self.lbg = np.concatenate([np.zeros(self.eq.numel()), np.full(self.ineq.numel(), -np.inf)])
        self.ubg = np.zeros(self.eq.numel() + self.ineq.numel())
        self.lbx, self.ubx = lower, upper
        # Cost, equalities and the non-collision inequalities, for measuring.
        other = [self.rows(o) for o in self.problem["objectives"]
                 if o["kind"] == "ineq" and o["feature"] not in ("collision", "joint_limits")]
        self._measure = ca.Function("measure", [self.x], [self.f, ca.vertcat(ca.SX(0, 1), *measured_eq),
                                                          ca.vertcat(ca.SX(0, 1), *other)])

    def collision_values(self, x):
        """(t, pair index, margin − d, margin) for every collision objective at x, as arrays over slices."""
        d = self.all_distances(x)
        out = []
        for o in self.collision:
            first, last = o["slices"]
            out.append((first, last, o["scale"] * (o["margin"] - d[first - 1:last]), o["margin"]))
        return out, d

    def measures(self, x):
        """Cost, max |eq| and max ineq (every pair, bounds included) at x."""
        x = np.asarray(x, dtype=float).ravel()
        f, h, g = self._measure(x)
        h, g = np.asarray(h).ravel(), np.asarray(g).ravel()
        values, _ = self.collision_values(x)
        worst = max([float(np.max(v)) for _, _, v, _ in values] + [0.0])
        bounds = np.concatenate([self.lbx - x, x - self.ubx])
        return {"cost": float(f), "eq": float(np.max(np.abs(h), initial=0.0)),
                "ineq": float(max(np.max(g, initial=0.0), np.max(bounds, initial=0.0), worst, 0.0))}

    def near_pairs(self, x, cutoff, also=None):
        """slice → pair indices with d < margin + cutoff at x (joined with `also`)."""
        active = {t: set(v) for t, v in (also or {}).items()}
        d = self.all_distances(x)
        for o in self.collision:
            first, last = o["slices"]
            for t in range(first, last + 1):
                near = np.nonzero(d[t - 1] < o["margin"] + cutoff)[0]
                active.setdefault(t, set()).update(int(i) for i in near)
        return {t: sorted(v) for t, v in active.items()}


class Solvers:
    """IPOPT solvers of a model, one per collision row set (built on demand,
    not timed)."""

    def __init__(self, model, options):
        self.model, self.options, self.cache, self.build_s = model, options, {}, 0.0

    def get(self, active):
        key = None if active is None else tuple((t, tuple(v)) for t, v in sorted(active.items()))
        if key not in self.cache:
            began = time.perf_counter()
            m = self.model
            m.build(active)
            solver = ca.nlpsol("komo", "ipopt", {"x": m.x, "f": m.f, "g": m.g}, self.options)
            bounds = {"lbx": m.lbx, "ubx": m.ubx, "lbg": m.lbg, "ubg": m.ubg}
            self.cache[key] = (solver, bounds, int(m.collision_row_count))
            self.build_s += time.perf_counter() - began
        return self.cache[key]


def solve(solvers, x0, cutoff, max_rounds=5):
    """One timed solve from x0: all pairs (cutoff None), or the pairs within
    margin + cutoff at x0; while IPOPT's result violates a left-out pair, the
    pairs within margin + cutoff at that result are added and IPOPT starts
    again from x0. Returns (x, status, iterations, solver ms, rounds, rows of
    the last round)."""
    model = solvers.model
    active = None if cutoff is None else model.near_pairs(x0, cutoff)
    ms, iterations, rounds = 0.0, 0, 0
    while True:
        solver, bounds, rows = solvers.get(active)
        began = time.perf_counter()
        sol = solver(x0=np.clip(x0, bounds["lbx"], bounds["ubx"]), **bounds)
        ms += (time.perf_counter() - began) * 1e3
        stats = solver.stats()
        x = np.asarray(sol["x"], dtype=float).ravel()
        iterations += int(stats.get("iter_count", 0))
        rounds += 1
        if active is None or rounds >= max_rounds:
            break
        values, _ = model.collision_values(x)
        if all(float(np.max(v)) <= 1e-6 for _, _, v, _ in values):
            break
        active = model.near_pairs(x, cutoff, also=active)
    return x, stats.get("return_status", "?"), iterations, ms, rounds, rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("problem")
    ap.add_argument("--reps", type=int, default=3, help="timed solves per initialisation")
    ap.add_argument("--max-inits", type=int, default=None, help="use only the first K initialisations")
    ap.add_argument("--cutoff", type=float, default=None,
                    help="collision rows only for pairs within margin + CUTOFF (m) at the start point, "
                         "re-solving with more while a left-out pair is violated (default: every pair)")
    ap.add_argument("--literal-vector", action="store_true",
                    help="vector equalities as their 3 rank-2 rows (default: 2 orthogonal rows + a sign inequality)")
    ap.add_argument("--hessian", choices=("exact", "limited-memory"), default="exact")
    ap.add_argument("--mu-strategy", choices=("monotone", "adaptive"), default="adaptive")
    ap.add_argument("--max-iter", type=int, default=3000)
    ap.add_argument("--max-wall-time", type=float, default=300.0, help="IPOPT's time limit per solve (s)")
    ap.add_argument("--label", default=None, help="solver name in the output")
    args = ap.parse_args()
    problem = load_problem(args.problem)
    global ca
    import casadi as ca

    began = time.perf_counter()
    model = Model(problem, literal_vector=args.literal_vector)
    model.build()
    model_s = time.perf_counter() - began
    options = {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.tol": 1e-6,
        "ipopt.constr_viol_tol": 1e-5,
        "ipopt.max_iter": args.max_iter,
        "ipopt.max_wall_time": args.max_wall_time,
        "ipopt.hessian_approximation": args.hessian,
        "ipopt.mu_strategy": args.mu_strategy,
    }
    solvers = Solvers(model, options)

    inits = problem["inits"][: args.max_inits] if args.max_inits else problem["inits"]
    checks = []
    for init in inits:
        mine = model.measures(np.asarray(init["trajectory"], dtype=float).reshape(-1))
        checks.append({"init": init["init"], "casadi": mine,
                       "tandem": {k: init[k] for k in ("cost", "eq", "ineq")}})
    bad = [c for c in checks if abs(c["casadi"]["cost"] - c["tandem"]["cost"]) > 1e-8 * max(1.0, c["tandem"]["cost"])
           or abs(c["casadi"]["eq"] - c["tandem"]["eq"]) > 1e-8 or abs(c["casadi"]["ineq"] - c["tandem"]["ineq"]) > 1e-8]
    if bad:
        print(f"casadi_komo: warning: the casadi model disagrees with tandem at an initialisation: {bad[0]}",
              file=sys.stderr)

    runs = []
    for init in inits:
        x0 = np.asarray(init["trajectory"], dtype=float).reshape(-1)
        if args.cutoff is not None:
            solve(solvers, x0, args.cutoff)  # untimed: builds the solvers of this start's rounds
        times, cpu = [], []
        for _ in range(args.reps):
            c0 = time.process_time()
            x, status, iterations, ms, rounds, rows = solve(solvers, x0, args.cutoff)
            times.append(ms)
            cpu.append((time.process_time() - c0) * 1e3)
        runs.append({
            "init": init["init"],
            "times_ms": times,
            "cpu_ms": cpu,
            "converged": status == "Solve_Succeeded",
            "status": status,
            "iterations": iterations,
            "rounds": rounds,
            "collision_rows": rows,
            "own": model.measures(x),
            "trajectory": x.reshape(model.T, model.n).tolist(),
        })
    label = args.label or ("casadi + IPOPT" + ("" if args.cutoff is None else f" (pairs < margin + {args.cutoff} m)"))
    emit(result(problem, label, runs, {
        "model_s": model_s,
        "build_s": solvers.build_s,
        "variables": int(model.x.numel()),
        "collision_pairs": model.pair_count,
        "collision_rows_all": int(model.pair_count * sum(o["slices"][1] - o["slices"][0] + 1 for o in model.collision)),
        "cutoff": args.cutoff,
        "options": {k: v for k, v in options.items() if k.startswith("ipopt.")},
        "timed": "the nlpsol calls (IPOPT + casadi function evaluations); building the casadi graph and the "
                 "solvers excluded (also those of re-solve rounds)",
        "init_check": checks,
        "casadi_version": version_of("casadi"),
    }))


if __name__ == "__main__":
    main()
