"""The rolling disc's contact force from SymPy, as SymPy's tutorial "A rolling disc, with Kane's
method and constraint forces" derives it: auxiliary speeds u4, u5, u6 at the contact point along
L.x (the heading), Y.z x L.x (across it, on the ground) and Y.z (up), and the forces f1, f2, f3
along them, solved from KanesMethod's auxiliary equations with u' from its equations of motion.

Prints one JSON object per line for random states (seeded): the tutorial's q1 (yaw), q2 (lean,
about the heading), q3 (spin), the generalised speeds' q1', q2', q3', the parameters, and
f1, f2, f3. tests/constraint_forces.rs runs it and compares hamel's `disk.longitudinal`,
`disk.lateral` and `disk.normal` of models/bodies/rolling_disk_bodies.toml (whose lean theta is
about -x: theta = -q2) at the same states.

    python3 bench/sympy_rolling_disc_forces.py [STATES] [SEED]
"""

import json
import random
import sys

import sympy as sm
from sympy.physics.mechanics import (
    KanesMethod,
    Point,
    ReferenceFrame,
    RigidBody,
    dot,
    dynamicsymbols,
    inertia,
)


def equations():
    """q, u, q', f and the auxiliary equations solved for f with u' substituted."""
    q1, q2, q3, u1, u2, u3 = dynamicsymbols("q1 q2 q3 u1 u2 u3")
    u4, u5, u6, f1, f2, f3 = dynamicsymbols("u4 u5 u6 f1 f2 f3")
    r, m, g = sm.symbols("r m g")
    N = ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [q1, N.z])
    L = Y.orientnew("L", "Axis", [q2, Y.x])
    R = L.orientnew("R", "Axis", [q3, L.y])
    w_R_N_qd = R.ang_vel_in(N)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    C = Point("C")
    C.set_vel(N, u4 * L.x + u5 * (Y.z ^ L.x) + u6 * Y.z)
    Dmc = C.locatenew("Dmc", r * L.z)
    Dmc.v2pt_theory(C, N, R)
    I = inertia(L, m / 4 * r**2, m / 2 * r**2, m / 4 * r**2)
    kd = [dot(R.ang_vel_in(N) - w_R_N_qd, uv) for uv in L]
    forces = [(Dmc, -m * g * Y.z), (C, f1 * L.x + f2 * (Y.z ^ L.x) + f3 * Y.z)]
    disc = RigidBody("disc", Dmc, R, m, (I, Dmc))
    km = KanesMethod(
        N, q_ind=[q1, q2, q3], u_ind=[u1, u2, u3], kd_eqs=kd, u_auxiliary=[u4, u5, u6]
    )
    km.kanes_equations([disc], forces)
    kdd = km.kindiffdict()
    udot = km.mass_matrix.LUsolve(km.forcing).subs(kdd)
    ud = [sm.diff(u, sm.Symbol("t")) for u in (u1, u2, u3)]
    aux = km.auxiliary_eqs.subs(kdd).subs(dict(zip(ud, udot)))
    fs = sm.solve(list(aux), [f1, f2, f3], dict=True)[0]
    args = [q1, q2, q3, u1, u2, u3, r, m, g]
    qdot = [kdd[sm.diff(q, sm.Symbol("t"))] for q in (q1, q2, q3)]
    return (
        sm.lambdify(args, [fs[f1], fs[f2], fs[f3]], "math"),
        sm.lambdify(args, qdot, "math"),
    )


def main():
    states = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 58)
    forces, qdot = equations()
    for _ in range(states):
        q = [rng.uniform(-3, 3), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)]
        u = [rng.uniform(-2, 2), rng.uniform(-8, 8), rng.uniform(-2, 2)]
        p = {"r": rng.uniform(0.1, 0.5), "m": rng.uniform(0.2, 3.0), "g": 9.81}
        args = q + u + [p["r"], p["m"], p["g"]]
        f = forces(*args)
        print(json.dumps({"q": q, "qdot": qdot(*args), "params": p, "f": f}))


if __name__ == "__main__":
    main()
