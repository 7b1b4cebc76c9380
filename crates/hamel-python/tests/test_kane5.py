"""SymPy's own test of the rolling disc (sympy/physics/mechanics/tests/test_kane5.py, SymPy
1.14) through hamel's Python API, on models/bodies/rolling_disc_sympy.toml: the disc written
from bodies under SymPy's coordinates q1..q5 and its independent speeds u1, u2, u3 (the disc's
angular velocity in its own axes). The expected state derivatives [q1'..q5', u1'..u5'] are
the test's, to its 1e-10; with SymPy installed, its KanesMethod is also run here and compared
at random states."""

from pathlib import Path

import numpy as np
import pytest

import hamel

ROOT = Path(__file__).resolve().parents[3]
MODEL = ROOT / "models" / "bodies" / "rolling_disc_sympy.toml"
R = 0.26  # the test's (g, r, m) = (9.81, 0.26, 3.43), the model's defaults

# test_kane5.py's two states and expected [q1'..q5', u1'..u5'], verbatim.
STATES = [
    ((0.3, 0.1, 1.97, -0.35, 2.27), (-0.2, 1.3, 0.15), (
        0.126603940595934, 0.215942571601660, 1.28736069604936,
        0.319764288376543, 0.0989146857254898, -0.925848952664489,
        -0.0181350656532944, 2.91695398184589, -0.00992793421754526,
        0.0412861634829171)),
    ((3.97, -0.28, 8.2, -0.35, 2.27), (-0.25, -2.2, 0.62), (
        0.0259159090798597, 0.668041660387416, -2.19283799213811,
        0.385441810852219, 0.420109283790573, 1.45030568179066,
        -0.0110924422400793, -8.35617840186040, -0.154098542632173,
        -0.146102664410010)),
]


def state_derivatives(q, u, out):
    """[q', u1'..u3', u4', u5'] from hamel's q' and u' (= eta_dot). u4 = q4' and u5 = q5' are
    SymPy's dependent speeds, r cos(q1) q3' and r sin(q1) q3' by its constraints; their
    derivatives by the chain rule through SymPy's kinematics q3' = u1 s3 t2 + u2 - u3 c3 t2."""
    q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2]
    u1, u2, u3 = u.T
    qd = out["q_dot"]
    ud = out["eta_dot"]
    q1d, q2d, q3d = qd[:, 0], qd[:, 1], qd[:, 2]
    t2, sec2 = np.tan(q2), 1 / np.cos(q2) ** 2
    s3, c3 = np.sin(q3), np.cos(q3)
    q3dd = (ud[:, 0] * s3 * t2 + u1 * c3 * q3d * t2 + u1 * s3 * sec2 * q2d + ud[:, 1]
            - ud[:, 2] * c3 * t2 + u3 * s3 * q3d * t2 - u3 * c3 * sec2 * q2d)
    u4d = R * (-np.sin(q1) * q1d * q3d + np.cos(q1) * q3dd)
    u5d = R * (np.cos(q1) * q1d * q3d + np.sin(q1) * q3dd)
    return np.column_stack([qd, ud, u4d, u5d])


def test_sympy_s_rolling_disc_states_through_the_python_api():
    disc = hamel.Model.load(MODEL)
    q = np.array([s[0] for s in STATES])
    u = np.array([s[1] for s in STATES])
    out = disc.eval(q, u, choice="sympy")
    got = state_derivatives(q, u, out)
    expected = np.array([s[2] for s in STATES])
    assert np.max(np.abs(got - expected)) < 1e-10, got - expected


def test_sympy_s_kanes_method_agrees_at_random_states():
    sympy = pytest.importorskip("sympy")
    from sympy.physics.mechanics import KanesMethod, dynamicsymbols
    from sympy.physics.mechanics.tests.test_kane5 import _create_rolling_disc

    props = _create_rolling_disc()
    kane = KanesMethod(props["frame"], props["q_ind"], props["u_ind"], props["kdes"],
                       u_dependent=props["u_dep"], velocity_constraints=props["fnh"],
                       bodies=props["bodies"], forcelist=props["loads"],
                       explicit_kinematics=False, constraint_solver="LU")
    kane.kanes_equations()
    qs, us = dynamicsymbols("q1:6"), dynamicsymbols("u1:6")
    p = sympy.symbols("g r m")
    system = sympy.lambdify((qs, us, p), (kane.mass_matrix_full, kane.forcing_full), cse=True)
    dependent = sympy.lambdify((qs, us[:3], p), kane._Ars * sympy.Matrix(us[:3]), cse=True)
    p_vals = (9.81, R, 3.43)
    rng = np.random.default_rng(5)
    q = rng.uniform(-1.2, 1.2, size=(20, 5))
    u = rng.uniform(-3, 3, size=(20, 3))
    got = state_derivatives(q, u, hamel.Model.load(MODEL).eval(q, u, choice="sympy"))
    for i in range(len(q)):
        ui = list(u[i]) + list(np.asarray(dependent(q[i], u[i], p_vals), float)[:2, 0])
        mass, forcing = (np.asarray(x, float) for x in system(q[i], ui, p_vals))
        want = np.linalg.solve(mass, forcing)[:, 0]
        assert np.max(np.abs(got[i] - want)) < 1e-10 * max(1.0, np.max(np.abs(want))), i
