#!/usr/bin/env python3
"""Ensemble throughput: hamel's compiled core against numbalsoda in a numba prange loop.

    hamel tradeoff SCENE.toml --export-python SYSTEM.json          (the right-hand side)
    hamel simulate SCENE.toml --export-ensemble DIR                 (the core and its members)
    python3 bench/numbalsoda_ensemble.py SYSTEM.json DIR [SYSTEM.json DIR ...]

For each scene: the same members (DIR/job.json, every member's initial state), the same
equations (SYSTEM.json's `rhs_into`, the code generator's solved form with the scene's
parameters as numbers, compiled by numba into a C callback), the same method (DOP853), the same
rtol and atol and the same output times. hamel runs `DIR/core --job DIR/job.json --threads T`,
and its time is the one the core measures around its loop over the members (rayon, in
hamel_sim::integrate_many). numbalsoda runs in a numba `@njit(parallel=True)` function whose
`prange` loop calls numbalsoda's dop853 for each member and keeps its final state, timed around
that call after a warm-up run (so JIT compilation is not counted), with
numba.set_num_threads(T). Both on 1 and 2 threads, the median of --repeat runs (default 5).

hamel's ratio is measured on a copy of the job without the energy and constraint monitors
(DIR/job-state-only.json), since numbalsoda computes the state alone; the last column gives
hamel's rate with the scene's own monitors (the energy at every output time) for comparison.

Prints per scene the members per second of both, their ratio (above 1 where hamel is faster),
each one's scaling from 1 to 2 threads (2.0 is linear), and the largest difference between
the final states of the two (relative to max(1, |y|)), which should be of the tolerance's order.

The ensembles must vary initial states only (SYSTEM.json's right-hand side has the scene's
parameter values as numbers), use DOP853, and `save = "final"` or "outputs" alike.

Optional dependency (pip install numba numbalsoda; building numbalsoda needs gfortran and
cmake): without them it prints a message on stderr and exits with status 3.
"""

import json
import math
import os
import statistics
import subprocess
import sys
import time

try:
    import numba
    import numpy as np
    from numba import carray, cfunc, njit, prange
    from numbalsoda import dop853, lsoda_sig
except ImportError:
    print("numbalsoda_ensemble.py: numba and numbalsoda are needed (pip install numba numbalsoda; "
          "numbalsoda builds with gfortran and cmake); skipped", file=sys.stderr)
    sys.exit(3)

MATH = ("sin", "cos", "tan", "sqrt", "exp", "log", "asin", "acos", "atan", "sinh", "cosh", "tanh")


def compile_rhs(system):
    namespace = {name: getattr(math, name) for name in MATH}
    exec(system["python_into"], namespace)
    inner = njit(namespace["rhs_into"])
    n = len(system["y0"])

    @cfunc(lsoda_sig)
    def f(t, u_, du_, p):
        u = carray(u_, (n,))
        du = carray(du_, (n,))
        inner(t, u, du)

    return f.address


@njit(parallel=True)
def ensemble(funcptr, y0s, t_eval, rtol, atol, out, ok):
    for i in prange(y0s.shape[0]):
        usol, success = dop853(funcptr, y0s[i], t_eval, rtol=rtol, atol=atol, mxstep=10_000_000)
        out[i, :] = usol[-1, :]
        ok[i] = success


def state_only(directory):
    """A copy of the job without the energy and constraint monitors (what numbalsoda computes:
    the state at the output times), and the job itself."""
    with open(os.path.join(directory, "job.json")) as f:
        job = json.load(f)
    plain = dict(job, energy=False, residual=False)
    path = os.path.join(directory, "job-state-only.json")
    with open(path, "w") as f:
        json.dump(plain, f)
    return path, job


def run_hamel(directory, job_path, threads, repeat):
    """The core's loop time (median), and the final states (core order) with the state names."""
    out = os.path.join(directory, f"hamel-{threads}.jsonl")
    seconds = []
    for _ in range(repeat):
        cmd = [os.path.join(directory, "core"), "--job", job_path,
               "--threads", str(threads), "--output", out]
        subprocess.run(cmd, check=True)
        with open(out) as f:
            header = json.loads(f.readline())
            seconds.append(header["seconds"])
    with open(out) as f:
        header = json.loads(f.readline())
        finals = [json.loads(line)["solution"]["y"][-1] for line in f if line.strip()]
    return statistics.median(seconds), np.array(finals), header["state"]


def run_numbalsoda(funcptr, y0s, t_eval, rtol, atol, threads, repeat):
    numba.set_num_threads(threads)
    out = np.empty_like(y0s)
    ok = np.empty(y0s.shape[0], dtype=np.bool_)
    ensemble(funcptr, y0s[:4], t_eval, rtol, atol, out[:4], ok[:4])  # compile
    seconds = []
    for _ in range(repeat):
        start = time.perf_counter()
        ensemble(funcptr, y0s, t_eval, rtol, atol, out, ok)
        seconds.append(time.perf_counter() - start)
    if not ok.all():
        sys.exit(f"numbalsoda failed on {int((~ok).sum())} members")
    return statistics.median(seconds), out


def measure(system_path, directory, repeat):
    with open(system_path) as f:
        system = json.load(f)
    if "python_into" not in system or "state" not in system:
        sys.exit(f"{system_path}: export it again with this hamel (hamel tradeoff SCENE --export-python FILE)")
    job_path, job = state_only(directory)
    if job["method"] != "Dop853":
        sys.exit(f"{directory}: the ensemble's method is {job['method']}, not DOP853")
    funcptr = compile_rhs(system)
    t0, times = job["t0"], job["times"]
    offset = 0 if times and times[0] == t0 else 1
    t_eval = np.array(([t0] if offset else []) + times, dtype=np.float64)
    rtol, atol = job["options"]["rtol"], job["options"]["atol"]
    results = {}
    for threads in (1, 2):
        h_seconds, h_final, core_names = run_hamel(directory, job_path, threads, repeat)
        monitored, _, _ = run_hamel(directory, os.path.join(directory, "job.json"), threads, repeat)
        # The core's state order (kept coordinates in model order, then η) to the export's.
        perm = [core_names.index(name) for name in system["state"]]
        y0s = np.ascontiguousarray(np.array([m["y0"] for m in job["members"]], dtype=np.float64)[:, perm])
        n_seconds, n_final = run_numbalsoda(funcptr, y0s, t_eval, rtol, atol, threads, repeat)
        diff = np.max(np.abs(h_final[:, perm] - n_final) / np.maximum(1.0, np.abs(n_final)))
        results[threads] = (h_seconds, n_seconds, diff, monitored)
    return system["model"], len(job["members"]), rtol, atol, results


def main():
    args = sys.argv[1:]
    repeat = 5
    if "--repeat" in args:
        i = args.index("--repeat")
        repeat = int(args[i + 1])
        del args[i:i + 2]
    if not args or len(args) % 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    print("| scene | members | threads | hamel members/s | numbalsoda members/s | hamel / numbalsoda "
          "| final states differ by | hamel with the scene's monitors, members/s |")
    print("|---|---|---|---|---|---|---|---|")
    scaling = []
    for system_path, directory in zip(args[::2], args[1::2]):
        model, n, rtol, atol, results = measure(system_path, directory, repeat)
        for threads, (h, nb, diff, monitored) in results.items():
            print(f"| {model} (rtol {rtol:.0e}, atol {atol:.0e}) | {n} | {threads} | {n / h:,.0f} "
                  f"| {n / nb:,.0f} | {nb / h:.2f} | {diff:.1e} | {n / monitored:,.0f} |")
        scaling.append((model, results[1][0] / results[2][0], results[1][1] / results[2][1]))
    print()
    print("| scene | hamel: speed-up 1 → 2 threads | numbalsoda + numba prange: speed-up 1 → 2 threads |")
    print("|---|---|---|")
    for model, h, nb in scaling:
        print(f"| {model} | {h:.2f} | {nb:.2f} |")


if __name__ == "__main__":
    main()
