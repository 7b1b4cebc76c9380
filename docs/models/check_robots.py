#!/usr/bin/env python3
"""Independent check of hamel's `eval` on models/diff_drive.toml and models/segway.toml.

Both robots are re-modelled here by hand with sympy.physics.mechanics, from their physical
description only (nothing is read from hamel's derivation; from the TOML files only the
parameter values):

* reference frames by right-handed rotations (orient_axis): chassis/axle yawed by psi about
  the world z, the wheels spun by phiL, phiR about the chassis y axis at +-b, the segway body
  pitched by theta about the axle's y axis, the castor's swivel turned by beta about the
  chassis z axis d behind the axle and the castor wheel (trail e, centre at height rc) spun by
  phiC about the swivel's y axis;
* rigid bodies (mass, centre of mass, inertia about it in the body's axes), gravity -g z;
* rolling without slipping: the material point of each wheel at its contact (centre - R z,
  every wheel axle here stays horizontal) has zero velocity.  The two drive wheels' four
  world rows have rank 3; as a SymPy user would, the no-slip velocity is resolved in the
  chassis axes instead, where the two wheels' lateral rows are the same row: it is proved
  symbolically that they are, and the second is dropped (the castor's two rows are kept);
* motor torques: +T about the wheel's y axis on the wheel and -T on the chassis/body;
* Kane's method (KanesMethod) with generalised speeds u = qdot, independent speeds the wheel
  rates (and the pitch rate), dependent speeds the rest, and the velocity constraints above.

For each state {"q", "eta", "params"} it solves [Z; alpha] qdot = [eta; 0] (least squares over
all the world no-slip rows, rank-aware, residual checked), then the Kane system for qddot, and
eta_dot = Z qddot for the choice's constant Z.  It compares eta_dot, q_dot and the energy
T + sum m g height with hamel's "eta_dot", "q_dot" and "energy" (relative error = max abs
difference / max abs of hamel's vector) and exits 1 if any exceeds 1e-9.

Needs Python >= 3.11 and SymPy (mpmath comes with it).  Run from anywhere:

    python3 docs/models/check_robots.py --data /tmp/robots
        # reads DATA/{model}_states.json and DATA/{model}_{choice}_hamel.json
    python3 docs/models/check_robots.py --hamel target/release/hamel [--data DIR]
        # runs `hamel eval models/X.toml --eta CHOICE --state STATES --output OUT` itself,
        # on DATA/{model}_states.json, or on random states written to a temporary directory
"""

import argparse
import json
import random
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import mpmath
import sympy as sp
import sympy.physics.mechanics as me

ROOT = Path(__file__).resolve().parents[2]
TOL = 1e-9
mpmath.mp.dps = 30


def no_slip(frame, centre, radius, N):
    """Velocity of the wheel's material point at the contact centre - radius z."""
    return centre.vel(N) + frame.ang_vel_in(N).cross(-radius * N.z)


def wheel(name, parent, origin, q, P, m, r):
    """A thin disk spinning by q about parent.y, centred at origin + P (in the parent's axes)."""
    F = me.ReferenceFrame(name)
    F.orient_axis(parent, parent.y, q)
    c = origin.locatenew(name + "_c", P)
    body = me.RigidBody(name, c, F, m, (me.inertia(F, m * r**2 / 4, m * r**2 / 2, m * r**2 / 4), c))
    return F, c, body


def build(model):
    """The robot by hand: coordinates, speeds, bodies, loads, constraints and the eta choices."""
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    S = sp.symbols
    r, b, g, m_w, T_L, T_R = S("r b g m_w T_L T_R")
    if model == "diff_drive":
        names = ["x", "y", "psi", "phiL", "phiR", "beta", "phiC"]
        ind = ["phiL", "phiR"]
    else:
        names = ["x", "y", "psi", "theta", "phiL", "phiR"]
        ind = ["theta", "phiL", "phiR"]
    q = dict(zip(names, me.dynamicsymbols(names)))
    u = dict(zip(names, me.dynamicsymbols(["u_" + n for n in names])))
    qd2u = {q[n].diff(me.dynamicsymbols._t): u[n] for n in names}

    C = me.ReferenceFrame("C")                     # chassis (diff_drive) or axle (segway)
    C.orient_axis(N, N.z, q["psi"])
    P0 = O.locatenew("P0", q["x"] * N.x + q["y"] * N.y + r * N.z)   # axle midpoint
    L, cL, bL = wheel("L", C, P0, q["phiL"], b * C.y, m_w, r)
    R, cR, bR = wheel("R", C, P0, q["phiR"], -b * C.y, m_w, r)
    bodies = [bL, bR]
    if model == "diff_drive":
        m_c, I_c, rc, d, e, m_k = S("m_c I_c rc d e m_k")
        reaction = C
        bodies.append(me.RigidBody("chassis", P0, C, m_c, (me.inertia(C, I_c, I_c, I_c), P0)))
        Sw = me.ReferenceFrame("Sw")               # swivel, massless
        Sw.orient_axis(C, C.z, q["beta"])
        pivot = P0.locatenew("pivot", -d * C.x)
        K, cK, bK = wheel("K", Sw, pivot, q["phiC"], -e * Sw.x + (rc - r) * Sw.z, m_k, rc)
        bodies.append(bK)
        points = [P0, pivot, cL, cR, cK]
    else:
        m_b, l, I_bx, I_by, I_bz = S("m_b l I_bx I_by I_bz")
        B = me.ReferenceFrame("B")                 # body, pitched by theta
        B.orient_axis(C, C.y, q["theta"])
        reaction = B
        G = P0.locatenew("G", l * B.z)
        bodies.append(me.RigidBody("body", G, B, m_b, (me.inertia(B, I_bx, I_by, I_bz), G)))
        points = [P0, G, cL, cR]
    for p in points:
        p.set_vel(N, p.pos_from(O).dt(N).subs(qd2u))

    loads = [(L, T_L * L.y), (reaction, -T_L * L.y), (R, T_R * R.y), (reaction, -T_R * R.y)]
    loads += [(bd.masscenter, -bd.mass * g * N.z) for bd in bodies]

    vL = no_slip(L, cL, r, N).subs(qd2u)
    vR = no_slip(R, cR, r, N).subs(qd2u)
    world_rows = [vL.dot(N.x), vL.dot(N.y), vR.dot(N.x), vR.dot(N.y)]
    lateral = sp.simplify(sp.expand_trig(vL.dot(C.y) - vR.dot(C.y)))
    assert lateral == 0, f"{model}: the two lateral no-slip rows differ by {lateral}"
    kane_rows = [vL.dot(C.x), vL.dot(C.y), vR.dot(C.x)]   # vR.dot(C.y) is the same as vL's
    if model == "diff_drive":
        vK = no_slip(K, cK, rc, N).subs(qd2u)
        world_rows += [vK.dot(N.x), vK.dot(N.y)]
        kane_rows += [vK.dot(Sw.x), vK.dot(Sw.y)]

    U = [u[n] for n in names]
    eta = {"wheels": [u[n] for n in ind]}
    eta["body"] = ([u["theta"]] if model == "segway" else []) + [r / 2 * (u["phiL"] + u["phiR"]), u["psi"]]
    Z = {k: sp.Matrix(v).jacobian(U) for k, v in eta.items()}
    energy = sum(bd.kinetic_energy(N).subs(qd2u) + bd.mass * g * bd.masscenter.pos_from(O).dot(N.z)
                 for bd in bodies)

    kane = me.KanesMethod(N, q_ind=[q[n] for n in names], u_ind=[u[n] for n in ind],
                          kd_eqs=[q[n].diff() - u[n] for n in names],
                          u_dependent=[u[n] for n in names if n not in ind],
                          velocity_constraints=kane_rows)
    kane.kanes_equations(bodies, loads)
    return dict(names=names, q=q, u=u, kane=kane, alpha=sp.Matrix(world_rows).jacobian(U),
                Z=Z, energy=energy)


def compile_model(model):
    """Lambdify (mpmath) the Kane system, alpha, Z and the energy of the hand-built model."""
    sysm = build(model)
    names = sysm["names"]
    kane = sysm["kane"]
    qs = [sysm["q"][n] for n in names]
    us = list(kane.u)                               # Kane's order: independent, then dependent
    exprs = [kane.mass_matrix_full, kane.forcing_full, sysm["alpha"], sysm["energy"], *sysm["Z"].values()]
    free = set().union(*(e.free_symbols for e in exprs))
    params = sorted((s for s in free if s.name != "t"), key=lambda s: s.name)
    args = qs + us + params
    f = lambda e: sp.lambdify(args, e, modules="mpmath")
    return dict(names=names, u_order=[str(x.func)[2:] for x in us], params=params,
                mm=f(kane.mass_matrix_full), rhs=f(kane.forcing_full), alpha=f(sysm["alpha"]),
                energy=f(sysm["energy"]), Z={k: f(v) for k, v in sysm["Z"].items()})


def parameters(model):
    data = tomllib.loads((ROOT / "models" / f"{model}.toml").read_text())
    return {**data.get("parameters", {}), **data.get("inputs", {})}


def evaluate(cm, defaults, state, choice):
    """(eta_dot, q_dot, energy) for one state {"q", "eta", "params"}."""
    names = cm["names"]
    pv = {**defaults, **state.get("params", {})}
    qv = [mpmath.mpf(state["q"][n]) for n in names]
    pa = [mpmath.mpf(pv[s.name]) for s in cm["params"]]
    zero_u = [0] * len(names)                       # alpha and Z do not depend on u
    alpha = mpmath.matrix(cm["alpha"](*qv, *zero_u, *pa))
    Z = mpmath.matrix(cm["Z"][choice](*qv, *zero_u, *pa))  # constant in q: r/2 and 1
    A = mpmath.matrix(Z.rows + alpha.rows, len(names))
    for i in range(Z.rows):
        for j in range(len(names)):
            A[i, j] = Z[i, j]
    for i in range(alpha.rows):
        for j in range(len(names)):
            A[Z.rows + i, j] = alpha[i, j]
    rhs = mpmath.matrix([mpmath.mpf(x) for x in state["eta"]] + [0] * alpha.rows)
    qd = mpmath.lu_solve(A, rhs)       # least squares: [Z; alpha] has full column rank
    res = mpmath.norm(A * qd - rhs)    # zero: the dropped world row is implied by the others
    assert res < 1e-20, f"[Z; alpha] qdot = [eta; 0] is inconsistent (residual {res})"
    qdot = dict(zip(names, qd))
    uv = [qdot[n] for n in cm["u_order"]]
    x = mpmath.lu_solve(mpmath.matrix(cm["mm"](*qv, *uv, *pa)), mpmath.matrix(cm["rhs"](*qv, *uv, *pa)))
    qddot = dict(zip(cm["u_order"], x[len(names):]))  # x = [qdot; udot]
    eta_dot = Z * mpmath.matrix([qddot[n] for n in names])
    energy = cm["energy"](*qv, *uv, *pa)
    return [eta_dot[i] for i in range(Z.rows)], qdot, energy


def rel_err(mine, theirs):
    scale = max(abs(t) for t in theirs) or 1.0
    return float(max(abs(a - b) for a, b in zip(mine, theirs)) / scale)


def random_states(model, n=12, seed=7):
    rng = random.Random(seed)
    names = ["x", "y", "psi", "phiL", "phiR", "beta", "phiC"] if model == "diff_drive" else \
            ["x", "y", "psi", "theta", "phiL", "phiR"]
    k = 2 if model == "diff_drive" else 3
    return [{"q": {n: rng.uniform(-1.5, 1.5) for n in names}, "eta": [rng.uniform(-2, 2) for _ in range(k)],
             "params": {"T_L": rng.uniform(-1, 1), "T_R": rng.uniform(-1, 1)}} for _ in range(n)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=None,
                    help="directory with {model}_states.json and {model}_{choice}_hamel.json")
    ap.add_argument("--hamel", default=None, help="hamel binary: produce its results by `eval`")
    ap.add_argument("--models", nargs="*", default=["diff_drive", "segway"])
    args = ap.parse_args()
    if args.data is None and args.hamel is None:
        ap.error("give --data DIR (existing results) or --hamel BINARY")
    out_dir = Path(tempfile.mkdtemp(prefix="check_robots_")) if args.hamel else args.data
    worst = 0.0
    for model in args.models:
        states_file = (args.data / f"{model}_states.json") if args.data else None
        if states_file is None or not states_file.exists():
            if not args.hamel:
                sys.exit(f"missing {states_file}")
            states_file = out_dir / f"{model}_states.json"
            states_file.write_text(json.dumps(random_states(model), indent=1))
        states = json.loads(states_file.read_text())
        cm = compile_model(model)
        defaults = parameters(model)
        for choice in ("wheels", "body"):
            out = out_dir / f"{model}_{choice}_hamel.json"
            if args.hamel:
                subprocess.run([args.hamel, "eval", str(ROOT / "models" / f"{model}.toml"), "--eta", choice,
                                "--state", str(states_file), "--output", str(out)], check=True, cwd=ROOT)
            results = json.loads(out.read_text())
            if isinstance(results, dict):
                results = [results]
            assert len(results) == len(states), f"{out}: {len(results)} results for {len(states)} states"
            e_eta = e_qd = e_en = 0.0
            for st, h in zip(states, results):
                eta_dot, qdot, energy = evaluate(cm, defaults, st, choice)
                e_eta = max(e_eta, rel_err(eta_dot, h["eta_dot"]))
                e_qd = max(e_qd, rel_err([qdot[n] for n in cm["names"]], [h["q_dot"][n] for n in cm["names"]]))
                if "energy" in h:
                    e_en = max(e_en, rel_err([energy], [h["energy"]]))
            worst = max(worst, e_eta, e_qd, e_en)
            flag = "ok" if max(e_eta, e_qd, e_en) <= TOL else "MISMATCH"
            print(f"{model:10s} {choice:6s} {len(states):3d} states  max rel err: eta_dot {e_eta:.2e}  "
                  f"q_dot {e_qd:.2e}  energy {e_en:.2e}  {flag}")
    print(f"worst relative error {worst:.2e} (tolerance {TOL:g})")
    sys.exit(0 if worst <= TOL else 1)


if __name__ == "__main__":
    main()
