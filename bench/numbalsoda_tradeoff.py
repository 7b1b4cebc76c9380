#!/usr/bin/env python3
"""numbalsoda's DOP853 on the same equations as `hamel tradeoff`, and the ratio of times at equal error.

    hamel tradeoff SCENE.toml --export-python SYSTEM.json      (one per scene)
    python3 bench/numbalsoda_tradeoff.py SYSTEM.json [SYSTEM.json ...]

Several exports of one scene are rounds of one measurement, best of each side kept (wp.scenes).

What a performance-minded Python user runs instead of scipy's solve_ivp: the exported
right-hand side (`rhs_into`, the code generator's solved form, parameters as numbers) compiled
by numba (LLVM) into a C callback, integrated by numbalsoda's C++ port of Hairer's dop853.f.
Same output times, same reference (hamel's Taylor method at 3e-16), same error measure as
bench/scipy_tradeoff.py: max |y - y_ref| / max(1, |y_ref|) over the output times, on the
requested components. Tolerances rtol = atol = 1e-4 ... 1e-12. The time of a run is the median
of repeats (up to ~50 ms in all, at least 5), measured around the numbalsoda call (numbalsoda
allocates its output array in that call, as hamel's core does its solution). For every
numbalsoda run, the time of hamel's fastest run (DOP853 or DOPRI5, timed inside its compiled
core) with an error at most as large: the ratio numbalsoda / hamel at equal error, above 1
where hamel is faster. That rule is conservative: where hamel's run at the same tolerance has
an error a few per cent above numbalsoda's, it falls back to a run at a tighter tolerance. So
a second ratio sets numbalsoda's time against hamel's time at exactly numbalsoda's error,
interpolated (log–log, linearly) on hamel's work–precision front between the two runs that
bracket that error.

Prints one table per scene, then the summary: per scene, the range of numbalsoda / hamel.

Optional dependency (pip install numba numbalsoda; building numbalsoda needs gfortran and
cmake): without them it prints a message on stderr and exits with status 3.

A row whose error is below twice the reference's own (`reference_check` in the export: the
reference's difference from its check run) is shown but not ranked: the reference cannot tell
which run is the more accurate there (the unicycle's below about 1.5e-12).
"""

import math
import sys

try:
    import numpy as np
    from numba import carray, cfunc, njit
    from numbalsoda import dop853, lsoda_sig
except ImportError:
    print("numbalsoda_tradeoff.py: numba and numbalsoda are needed (pip install numba numbalsoda; "
          "numbalsoda builds with gfortran and cmake); skipped", file=sys.stderr)
    sys.exit(3)

from wp import compare, error, pareto, print_summary, ratio_texts, resolved, scenes, timed_rounds  # noqa: E402

MATH = ("sin", "cos", "tan", "sqrt", "exp", "log", "asin", "acos", "atan", "sinh", "cosh", "tanh")


def load(system):
    if "python_into" not in system:
        sys.exit(f"{system['model']}: no `python_into` (export it again with this hamel: hamel tradeoff SCENE --export-python FILE)")
    namespace = {name: getattr(math, name) for name in MATH}
    exec(system["python_into"], namespace)
    return system, compile_rhs(namespace["rhs_into"], len(system["y0"]))


def compile_rhs(rhs_into, n):
    """The C callback numbalsoda calls: f(t, u, du, p)."""
    inner = njit(rhs_into)

    @cfunc(lsoda_sig)
    def f(t, u_, du_, p):
        u = carray(u_, (n,))
        du = carray(du_, (n,))
        inner(t, u, du)

    return f.address


def measure(system, rounds):
    system, funcptr = load(system)
    times = system["times"]
    t0 = system.get("t0", 0.0)
    # numbalsoda starts at t_eval[0]: t0 first, unless it is already the first output.
    offset = 0 if times and times[0] == t0 else 1
    t_eval = np.array(([t0] if offset else []) + times, dtype=np.float64)
    y0 = np.array(system["y0"], dtype=np.float64)
    hamel = [r for r in system["hamel"] if r["complete"]]
    front = pareto(hamel)
    rows = []
    for k in range(4, 13):
        tol = 10.0 ** -k
        run = lambda: dop853(funcptr, y0, t_eval, rtol=tol, atol=tol, mxstep=10_000_000)
        (usol, success), seconds = timed_rounds(run, rounds)
        err = error(usol, system, offset) if success else math.inf
        best, ratio, inter = compare(system, hamel, front, err, seconds)
        rows.append((tol, err, seconds, best, ratio, inter))
    return system, rows


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    summary = []
    for system, rounds in scenes(sys.argv[1:]):
        system, rows = measure(system, rounds)
        best = f", best of {rounds} rounds" if rounds > 1 else ""
        print(f"{system['model']}: numbalsoda's DOP853 against hamel (same equations, same reference{best})")
        print()
        print("| numbalsoda DOP853 | error over span | time | hamel's fastest at ≤ that error | numbalsoda / hamel "
              "| numbalsoda / hamel, hamel interpolated at that error |")
        print("|---|---|---|---|---|---|")
        for tol, err, seconds, best, ratio, inter in rows:
            best_text = f"{best['method']} {best['tol']:.0e} ({best['seconds'] * 1e6:.1f} µs)" if best else "none"
            ratio_text, inter_text = ratio_texts(err, system, ratio, inter)
            print(f"| {tol:.0e} | {err:.1e} | {seconds * 1e6:.1f} µs | {best_text} | {ratio_text} | {inter_text} |")
        print()
        ratios = [r[4] for r in rows if r[4]]
        inters = [r[5] for r in rows if r[5]]
        below = sum(1 for r in rows if math.isfinite(r[1]) and not resolved(r[1], system))
        summary.append((system["model"], ratios, inters, len(rows), below))
    print_summary("numbalsoda", "1e-4 to 1e-12", summary)


if __name__ == "__main__":
    main()
