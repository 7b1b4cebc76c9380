#!/usr/bin/env python3
"""scipy's solve_ivp on the same equations as `hamel tradeoff`, and the ratio of times at equal error.

    hamel tradeoff SCENE.toml --export-python SYSTEM.json
    python3 bench/scipy_tradeoff.py SYSTEM.json [--markdown]

SYSTEM.json holds the scene's planned system as a Python function (the code generator's solved
form, parameters as numbers), the initial state, the output times, hamel's reference solution
(DOP853 at 1e-14) on the requested state components and hamel's own DOP853/DOPRI5 runs measured
on the same components. This script runs solve_ivp with DOP853, RK45 and Radau at
rtol = atol = 1e-3 ... 1e-13, measures the wall time (median of repeats up to ~50 ms) and the
error max |y - y_ref| / max(1, |y_ref|) over the output times, and for every scipy run the time
hamel's fastest run with an error at most as large takes: the ratio scipy / hamel at equal error.

Optional dependency: without numpy/scipy it prints a message on stderr and exits with status 3.
"""

import json
import math
import statistics
import sys
import time

try:
    import numpy as np
    from scipy.integrate import solve_ivp
except ImportError:
    print("scipy_tradeoff.py: numpy and scipy are needed (pip install scipy); skipped", file=sys.stderr)
    sys.exit(3)


def load(path):
    with open(path) as f:
        system = json.load(f)
    namespace = {name: getattr(math, name) for name in ("sin", "cos", "tan", "sqrt", "exp", "log")}
    exec(system["python"], namespace)
    return system, namespace["rhs"]


def error(sol, system):
    ref = system["reference"]
    req = system["requested"]
    if not sol.success or sol.y.shape[1] != len(ref):
        return math.inf
    worst = 0.0
    for j, row in enumerate(ref):
        for value, i in zip(row, req):
            worst = max(worst, abs(sol.y[i, j] - value) / max(1.0, abs(value)))
    return worst


def timed(fun):
    runs, total = [], 0.0
    while True:
        start = time.perf_counter()
        out = fun()
        took = time.perf_counter() - start
        runs.append(took)
        total += took
        if total > 0.05 or len(runs) >= 20:
            return out, statistics.median(runs)


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    system, rhs = load(sys.argv[1])
    times = system["times"]
    t_span = (times[0], times[-1])
    hamel = [r for r in system["hamel"] if r["complete"]]
    rows = []
    for method in ("DOP853", "RK45", "Radau"):
        for k in range(3, 14):
            tol = 10.0 ** -k
            if method == "Radau" and tol < 1e-10:
                continue  # Radau's Newton iterations cannot resolve these in f64 in reasonable time
            run = lambda: solve_ivp(rhs, t_span, system["y0"], method=method, t_eval=times,
                                    rtol=tol, atol=tol)
            sol, seconds = timed(run)
            err = error(sol, system)
            faster = [r["seconds"] for r in hamel if r["error_span"] <= err]
            ratio = seconds / min(faster) if faster and math.isfinite(err) else None
            rows.append((method, tol, err, seconds, sol.nfev, ratio))
    print(f"{system['model']}: scipy solve_ivp against hamel (same equations, same reference)")
    print()
    print("| scipy setting | error over span | time | RHS evals | hamel's fastest at ≤ that error | scipy / hamel |")
    print("|---|---|---|---|---|---|")
    for method, tol, err, seconds, nfev, ratio in rows:
        best = min((r for r in hamel if r["error_span"] <= err), key=lambda r: r["seconds"], default=None)
        best_text = f"{best['method']} {best['tol']:.0e} ({best['seconds'] * 1e3:.2f} ms)" if best else "none"
        ratio_text = f"{ratio:.1f}×" if ratio else "–"
        print(f"| {method} {tol:.0e} | {err:.1e} | {seconds * 1e3:.2f} ms | {nfev} | {best_text} | {ratio_text} |")
    ratios = [r[5] for r in rows if r[5]]
    if ratios:
        print()
        print(f"scipy / hamel at equal error: median {statistics.median(ratios):.1f}×, range {min(ratios):.1f}–{max(ratios):.1f}×")


if __name__ == "__main__":
    main()
