#!/usr/bin/env python3
"""heyoka's adaptive Taylor integrator on the same equations as `hamel tradeoff`, and the ratio
of times at equal error.

    hamel tradeoff SCENE.toml --export-python SYSTEM.json      (one per scene)
    python3 bench/heyoka_tradeoff.py SYSTEM.json [SYSTEM.json ...]

Several exports of one scene are rounds of one measurement, best of each side kept (wp.scenes).

heyoka (pip heyoka) builds its Taylor integrator from symbolic expressions and compiles the
recurrences with LLVM: the strongest peer for smooth ODEs at tight tolerances. The exported
right-hand side (`rhs`, the code generator's solved form, parameters as numbers) is evaluated
once on heyoka's variables, giving the expressions it compiles. Same output times, same
reference, same error measure as bench/numbalsoda_tradeoff.py: max |y - y_ref| / max(1, |y_ref|)
over the output times, on the requested components. Tolerances tol = 1e-4 ... 1e-14 (heyoka's
one tolerance, relative and absolute). The time of a run is the median of repeats of
`propagate_grid` from the initial state (up to ~50 ms in all, at least 5); the construction of
the integrator (decomposition and LLVM compilation, once per tolerance) is reported apart,
as `jit`. For every heyoka run, hamel's fastest run (any method, Taylor's included, timed inside
its compiled core) with an error at most as large, and hamel's time interpolated at exactly
heyoka's error on its work-precision front: heyoka / hamel, above 1 where hamel is faster.

Prints one table per scene, then the summary. Optional dependency (pip install heyoka): without
it, a message on stderr and exit status 3.

A row whose error is below twice the reference's own (`reference_check` in the export: the
reference's difference from its check run) is shown but not ranked: the reference cannot tell
which run is the more accurate there (the unicycle's below about 1.5e-12).
"""

import math
import sys
import time

try:
    import heyoka as hy
    import numpy as np
except ImportError:
    print("heyoka_tradeoff.py: heyoka is needed (pip install heyoka); skipped", file=sys.stderr)
    sys.exit(3)

from wp import compare, error, pareto, print_summary, ratio_texts, resolved, scenes, timed_rounds  # noqa: E402

FUNCTIONS = ("sin", "cos", "tan", "sqrt", "exp", "log", "atan", "asin", "acos", "sinh", "cosh", "tanh")


def equations(system):
    """The exported rhs evaluated on heyoka's variables: the system heyoka compiles."""
    n = len(system["y0"])
    names = [f"y{i}" for i in range(n)]
    variables = list(hy.make_vars(*names)) if n > 1 else [hy.make_vars(*names)]
    namespace = {name: getattr(hy, name) for name in FUNCTIONS if hasattr(hy, name)}
    namespace["atan2"] = hy.atan2
    exec(system["python"], namespace)
    rates = namespace["rhs"](hy.time, variables)
    as_expression = lambda v: v if isinstance(v, hy.expression) else hy.expression(float(v))
    return [(x, as_expression(v)) for x, v in zip(variables, rates)]


def measure(system, rounds):
    eqs = equations(system)
    times = system["times"]
    t0 = system.get("t0", 0.0)
    offset = 0 if times and times[0] == t0 else 1
    grid = np.array(([t0] if offset else []) + times, dtype=np.float64)
    y0 = np.array(system["y0"], dtype=np.float64)
    hamel = [r for r in system["hamel"] if r["complete"]]
    front = pareto(hamel)
    compact = len(system["python"]) > 50_000
    rows = []
    for k in range(4, 15):
        tol = 10.0 ** -k
        start = time.perf_counter()
        ta = hy.taylor_adaptive(eqs, y0, tol=tol, time=t0, compact_mode=compact)
        jit = time.perf_counter() - start

        def run():
            ta.time = t0
            ta.state[:] = y0
            return ta.propagate_grid(grid, max_delta_t=math.inf)

        result, seconds = timed_rounds(run, rounds)
        usol = result[-1]
        ok = str(result[0]).endswith("time_limit")
        err = error(usol, system, offset) if ok else math.inf
        best, ratio, inter = compare(system, hamel, front, err, seconds)
        rows.append((tol, err, seconds, jit, best, ratio, inter))
    return system, rows, compact


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    print(f"heyoka {hy.__version__}")
    summary = []
    for system, rounds in scenes(sys.argv[1:]):
        system, rows, compact = measure(system, rounds)
        mode = ", compact mode" if compact else ""
        mode += f", best of {rounds} rounds" if rounds > 1 else ""
        build = system.get("build", "portable")
        print(f"{system['model']}: heyoka's Taylor integrator{mode} against hamel (same equations, same reference; "
              f"hamel's core {build}{', HAMEL_NATIVE=1' if build == 'native' else ''})")
        print()
        print("| heyoka tol | error over span | time | jit | hamel's fastest at ≤ that error | heyoka / hamel "
              "| heyoka / hamel, hamel interpolated at that error |")
        print("|---|---|---|---|---|---|---|")
        for tol, err, seconds, jit, best, ratio, inter in rows:
            best_text = f"{best['method']} {best['tol']:.0e} ({best['seconds'] * 1e6:.1f} µs)" if best else "none"
            ratio_text, inter_text = ratio_texts(err, system, ratio, inter)
            print(f"| {tol:.0e} | {err:.1e} | {seconds * 1e6:.1f} µs | {jit:.2f} s | {best_text} | {ratio_text} "
                  f"| {inter_text} |")
        print()
        below = sum(1 for r in rows if math.isfinite(r[1]) and not resolved(r[1], system))
        summary.append((system["model"], [r[5] for r in rows if r[5]], [r[6] for r in rows if r[6]], len(rows), below))
    print_summary("heyoka", "1e-4 to 1e-14", summary)


if __name__ == "__main__":
    main()
