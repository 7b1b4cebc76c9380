"""Model.rhs: the generated core's right-hand side in this process, as f(t, y) for solve_ivp, as
the C callback numbalsoda and numba take, and as Python source for numba; Model.eval on it."""

import ctypes
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import hamel

MODELS = Path(__file__).resolve().parents[3] / "models"


@pytest.fixture(scope="module")
def disk():
    model = hamel.Model.load(MODELS / "rolling_disk.toml")
    return model, model.rhs("velocities")


def random_states(rng, n, ell, sigma):
    q = rng.uniform(-1.2, 1.2, size=(n, ell))
    eta = rng.uniform(-2, 2, size=(n, sigma))
    return q, eta


def test_the_knife_integrated_by_solve_ivp_follows_its_closed_form():
    knife = hamel.Model.load(MODELS / "knife.toml")
    rhs = knife.rhs("paper", params={"m": 2.0})
    assert rhs.names == ["x", "y", "theta", "eta1", "eta2"]
    assert rhs.parameters["m"] == 2.0 and len(rhs) == 5
    # eta1 (speed along the blade) and eta2 = theta' are constant: theta = theta0 + w t,
    # x = x0 + v/w (sin theta - sin theta0), y = y0 - v/w (cos theta - cos theta0).
    x0, y0, th0, v, w = 0.1, -0.2, 0.3, 1.5, 0.7
    t = np.linspace(0, 5, 11)
    sol = solve_ivp(rhs, (0, 5), [x0, y0, th0, v, w], t_eval=t, rtol=1e-12, atol=1e-12, method="DOP853")
    assert sol.success
    th = th0 + w * t
    assert np.allclose(sol.y[0], x0 + v / w * (np.sin(th) - math.sin(th0)), rtol=0, atol=1e-9)
    assert np.allclose(sol.y[1], y0 - v / w * (np.cos(th) - math.cos(th0)), rtol=0, atol=1e-9)
    assert np.allclose(sol.y[2], th, rtol=0, atol=1e-9)


def test_rhs_equals_the_interpreted_evaluation_at_random_states(disk):
    model, rhs = disk
    rng = np.random.default_rng(611)
    q, eta = random_states(rng, 40, 5, 3)
    ref = model.eval(q, eta, choice="velocities", engine="interpreted")
    y = np.hstack([q, eta])
    one_by_one = np.array([rhs(0.0, row) for row in y])
    expected = np.hstack([ref["q_dot"], ref["eta_dot"]])
    scale = np.maximum(1.0, np.abs(expected))
    assert np.max(np.abs(one_by_one - expected) / scale) < 1e-12
    # solve_ivp's vectorized form: columns are states
    assert np.array_equal(rhs(0.0, y.T), one_by_one.T)
    assert np.array_equal(rhs.states(y), one_by_one)
    compiled = model.eval(q, eta, choice="velocities")
    for key in ("eta_dot", "q_dot", "energy"):
        assert np.max(np.abs(compiled[key] - ref[key]) / np.maximum(1.0, np.abs(ref[key]))) < 1e-12


def test_the_c_callback_and_its_data_block_give_the_same_values(disk):
    model, rhs = disk
    f = rhs.ctypes()
    assert ctypes.cast(f, ctypes.c_void_p).value == rhs.address
    y = np.array([0.3, 0.4, -0.2, 1.0, 2.0, 0.5, -1.0, 3.0])
    double_p = ctypes.POINTER(ctypes.c_double)

    def call(data):
        dy = np.zeros(8)
        f(0.0, y.ctypes.data_as(double_p), dy.ctypes.data_as(double_p), data.ctypes.data_as(double_p))
        return dy

    assert np.array_equal(call(rhs.data), rhs(0.0, y))
    weaker = rhs.with_params({"g": 5.0})
    assert weaker.parameters["g"] == 5.0
    assert np.array_equal(call(rhs.data_for({"g": 5.0})), weaker(0.0, y))
    assert not np.array_equal(weaker(0.0, y), rhs(0.0, y))


def test_numba_calls_the_callback_in_nopython_code(disk):
    numba = pytest.importorskip("numba")
    _, rhs = disk
    f = rhs.ctypes()

    @numba.njit
    def euler(y, data, h, steps):
        dy = np.empty_like(y)
        for _ in range(steps):
            f(0.0, y.ctypes, dy.ctypes, data.ctypes)
            y = y + h * dy
        return y

    y0 = np.array([0.3, 0.4, -0.2, 1.0, 2.0, 0.5, -1.0, 3.0])
    got = euler(y0.copy(), rhs.data, 1e-3, 10)
    y = y0.copy()
    for _ in range(10):
        y = y + 1e-3 * rhs(0.0, y)
    assert np.array_equal(got, y)


def test_the_python_source_is_the_same_equations(disk):
    model, rhs = disk
    namespace = {name: getattr(math, name) for name in ("sin", "cos", "tan", "sqrt")}
    exec(rhs.python_source(), namespace)
    rng = np.random.default_rng(612)
    for _ in range(20):
        y = rng.uniform(-1.2, 1.2, size=8)
        dy = np.zeros(8)
        namespace["rhs_into"](0.0, y, dy)
        expected = rhs(0.0, y)
        assert np.max(np.abs(dy - expected) / np.maximum(1.0, np.abs(expected))) < 1e-12


def test_eval_gives_the_constraint_forces_and_the_papers_equations(disk):
    model, _ = disk
    rng = np.random.default_rng(613)
    q, eta = random_states(rng, 10, 5, 3)
    out = model.eval(q, eta, choice="velocities", paper=True, forces=True)
    ref = model.eval(q, eta, choice="velocities", paper=True, engine="interpreted")
    assert np.max(np.abs(out["eta_dot_paper"] - ref["eta_dot_paper"])) < 1e-10
    forces = out["constraint_forces"]
    assert forces and all(v.shape == (10,) and np.all(np.isfinite(v)) for v in forces.values())


def test_bad_input_is_a_clear_error(disk):
    model, rhs = disk
    with pytest.raises(ValueError, match=r"ℓ \+ σ = 8"):
        rhs(0.0, np.zeros(3))
    with pytest.raises(hamel.ModelError, match="not a parameter"):
        rhs.with_params({"mass": 1.0})
    with pytest.raises(ValueError, match="engine"):
        model.eval(np.zeros((1, 5)), np.zeros((1, 3)), choice="velocities", engine="fast")
    y = np.array([0.0, 0.0, 0.0, 0.0, 0.0, math.nan, 0.0, 0.0])
    with pytest.raises(hamel.HamelError):
        rhs(0.0, y)
    assert np.all(np.isnan(rhs.states(y[None, :])))


def test_a_specialised_core_gives_the_same_values(disk):
    model, generic = disk
    special = model.rhs("velocities", params={"g": 5.0}, specialise=True)
    assert special.specialised and not generic.specialised
    assert special.parameters["g"] == 5.0 and special.choice == "velocities"
    rng = np.random.default_rng(614)
    weaker = generic.with_params({"g": 5.0})
    namespace = {name: getattr(math, name) for name in ("sin", "cos", "tan", "sqrt")}
    exec(special.python_source(), namespace)
    for _ in range(20):
        y = rng.uniform(-1.2, 1.2, size=8)
        expected = weaker(0.0, y)
        scale = np.maximum(1.0, np.abs(expected))
        assert np.max(np.abs(special(0.0, y) - expected) / scale) < 1e-12
        dy = np.zeros(8)
        namespace["rhs_into"](0.0, y, dy)
        assert np.max(np.abs(dy - expected) / scale) < 1e-12
    with pytest.raises(hamel.HamelError, match="specialise"):
        special.with_params({"g": 1.0})
