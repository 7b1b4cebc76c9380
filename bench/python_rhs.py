#!/usr/bin/env python3
"""hamel's Python package on its compiled core: Model.eval on 10^5 states against the core's own
loop, and scipy's solve_ivp on Model.rhs against solve_ivp on a numba-compiled copy of the same
equations.

    python3 bench/python_rhs.py [MODEL.toml:CHOICE ...]   (default: knife, rolling disk, unicycle)

1. `eval`: `Model.eval(q, eta)` on N = 10^5 random states in one call (η̇, q̇ and the energy as
   arrays) against `hamel_rhs_states`, the core's own loop over the same states (η̇ and q̇,
   called once through ctypes on contiguous arrays): the ratio of times per state, the median
   of 7 runs each, alternated.
2. `solve_ivp`, with the parameters as inputs (`Model.rhs(eta)`) and folded in as a scene's
   (`specialise=True`): the same initial state, interval, method (DOP853 and RK45) and tolerances on
   `Model.rhs` (hamel's generated core, called through the extension) and on
   `rhs.python_source()` compiled by `numba.njit` (the same closed form, straight-line code,
   the parameters as numbers) wrapped as `f(t, y)` returning a new array; the numba function is
   compiled before timing (its JIT time is printed apart). The two right-hand sides are checked
   equal at the initial state to 1e-12; the final states' relative difference is printed (the
   two round differently, and a motion that falls or tumbles amplifies it). Ratio numba / hamel: above 1, hamel is faster.

Needs the package (pip install ./crates/hamel-python), scipy, and numba (pip install numba);
without numba it prints a message on stderr and exits with status 3.
"""

import ctypes
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

try:
    import numba
    from scipy.integrate import solve_ivp
except ImportError:
    print("python_rhs.py: numba and scipy are needed (pip install numba scipy); skipped", file=sys.stderr)
    sys.exit(3)

import hamel

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["models/knife.toml:paper", "models/rolling_disk.toml:velocities", "models/unicycle_rider.toml:velocities", "models/whipple_bicycle.toml:benchmark"]
MATH = ("sin", "cos", "tan", "sqrt", "exp", "log", "asin", "acos", "atan", "sinh", "cosh", "tanh")


def median_time(fun, runs=7):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fun()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def alternated(a, b, runs=5):
    """Median times of a and b, run in turn."""
    ta, tb = [], []
    for _ in range(runs):
        ta.append(median_time(a, 1))
        tb.append(median_time(b, 1))
    return statistics.median(ta), statistics.median(tb)


class EvalOut(ctypes.Structure):
    """capi.rs's EvalOut: where hamel_eval_states writes (null: not wanted)."""
    _fields_ = [(name, ctypes.c_void_p) for name in ("eta_dot", "q_dot", "energy", "eta_dot_paper", "forces")]


def eval_ratio(model, choice, rhs, n=100_000):
    rng = np.random.default_rng(1)
    ell, sigma = len(rhs.coordinates), len(rhs.quasi_velocities)
    q = rng.uniform(-1.0, 1.0, size=(n, ell))
    eta = rng.uniform(-1.0, 1.0, size=(n, sigma))
    y = np.ascontiguousarray(np.hstack([q, eta]))
    dy = np.empty_like(y)
    lib = ctypes.CDLL(rhs.library)
    lib.hamel_rhs_states.restype = ctypes.c_size_t
    lib.hamel_rhs_states.argtypes = [ctypes.c_size_t, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    data = rhs.data
    core = lambda: lib.hamel_rhs_states(n, y.ctypes.data, dy.ctypes.data, data.ctypes.data)
    outs = [np.empty((n, sigma)), np.empty((n, ell)), np.empty(n)]
    where = EvalOut(*(o.ctypes.data for o in outs), None, None)
    failed, err = ctypes.c_size_t(0), ctypes.create_string_buffer(1024)
    lib.hamel_eval_states.argtypes = [ctypes.c_size_t] + [ctypes.c_void_p] * 3 + [
        ctypes.POINTER(EvalOut), ctypes.POINTER(ctypes.c_size_t), ctypes.c_char_p, ctypes.c_size_t]
    qc, ec = np.ascontiguousarray(q), np.ascontiguousarray(eta)
    core_eval = lambda: lib.hamel_eval_states(n, qc.ctypes.data, ec.ctypes.data, data.ctypes.data,
                                              ctypes.byref(where), ctypes.byref(failed), err, 1024)
    package = lambda: model.eval(q, eta, choice=choice)
    package()
    assert core_eval() == 0, err.value
    t_eval, t_core = alternated(package, core)
    _, t_core_eval = alternated(package, core_eval)
    return t_eval / n, t_core / n, t_core_eval / n


def ivp_ratio(rhs, method, tol, y0, t_end):
    namespace = {name: getattr(math, name) for name in MATH}
    exec(rhs.python_source(), namespace)
    inner = numba.njit(namespace["rhs_into"])
    size = len(y0)

    @numba.njit
    def numba_rhs(t, y):
        dy = np.empty(size)
        inner(t, y, dy)
        return dy

    start = time.perf_counter()
    numba_rhs(0.0, y0)
    jit = time.perf_counter() - start
    run = lambda f: solve_ivp(f, (0.0, t_end), y0, method=method, rtol=tol, atol=tol)
    # The same equations: the same values at the start (to rounding), and solutions that agree
    # to the tolerance (their rounding differs, and the steps amplify it).
    f0, g0 = rhs(0.0, y0), numba_rhs(0.0, y0)
    assert np.max(np.abs(f0 - g0) / np.maximum(1.0, np.abs(f0))) < 1e-12, (f0, g0)
    a, b = run(rhs), run(numba_rhs)
    assert a.success and b.success
    apart = np.max(np.abs(a.y[:, -1] - b.y[:, -1])) / max(1.0, np.max(np.abs(a.y[:, -1])))
    t_hamel, t_numba = alternated(lambda: run(rhs), lambda: run(numba_rhs), runs=5)
    return t_hamel, t_numba, a.nfev, jit, apart


def params_label(specialise):
    return "folded in" if specialise else "inputs"


def main():
    specs = sys.argv[1:] or DEFAULT
    print("| model | choice | Model.eval per state (N = 10^5) | core's rhs loop | core's eval loop (η̇, q̇, E) "
          "| eval / rhs loop | eval / eval loop |")
    print("|---|---|---|---|---|---|---|")
    systems = []
    for spec in specs:
        path, _, choice = spec.partition(":")
        model = hamel.Model.load(ROOT / path if not Path(path).is_absolute() else path)
        choice = choice or None
        rhs = model.rhs(choice)
        systems.append((model, rhs))
        per_eval, per_core, per_core_eval = eval_ratio(model, choice, rhs)
        print(f"| {model.name} | {choice or model.choices[0]} | {per_eval * 1e9:.0f} ns | {per_core * 1e9:.0f} ns "
              f"| {per_core_eval * 1e9:.0f} ns | {per_eval / per_core:.2f} | {per_eval / per_core_eval:.2f} |")
    print()
    print("| model | parameters | method | rtol = atol | rhs evaluations | hamel | numba copy | numba / hamel "
          "| numba JIT | final states apart |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (model, generic), specialise in ((s, f) for s in systems for f in (False, True)):
        rhs = model.rhs(generic.choice, specialise=True) if specialise else generic
        rng = np.random.default_rng(2)
        y0 = rng.uniform(-0.5, 0.5, size=len(rhs))
        for method, tol in (("RK45", 1e-6), ("DOP853", 1e-10)):
            try:
                rhs.python_source()
            except hamel.HamelError as e:
                print(f"| {model.name} | {params_label(specialise)} | {method} | {tol:.0e} | | | no numba copy: {e} | | | |")
                continue
            t_hamel, t_numba, nfev, jit, apart = ivp_ratio(rhs, method, tol, y0, 5.0)
            print(f"| {model.name} | {params_label(specialise)} | {method} | {tol:.0e} | {nfev} | {t_hamel * 1e3:.1f} ms | {t_numba * 1e3:.1f} ms "
                  f"| {t_numba / t_hamel:.2f} | {jit:.2f} s | {apart:.0e} |")


if __name__ == "__main__":
    main()
