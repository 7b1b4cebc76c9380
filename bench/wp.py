"""Shared by the work-precision comparisons in bench/ (numbalsoda_tradeoff.py,
heyoka_tradeoff.py): the exports grouped into rounds, the error of a run against the exported
reference, a median timer, and hamel's work-precision front with interpolation on it."""

import json
import math
import statistics
import sys
import time

import numpy as np


def error(usol, system, offset):
    ref = system["reference"]
    req = system["requested"]
    if usol.shape[0] != len(ref) + offset or not np.all(np.isfinite(usol)):
        return math.inf
    worst = 0.0
    for j, row in enumerate(ref):
        for value, i in zip(row, req):
            worst = max(worst, abs(usol[j + offset, i] - value) / max(1.0, abs(value)))
    return worst


def scenes(paths):
    """The exports of `paths`, one entry per scene in the order first given, as (system, rounds).
    Several exports of one scene (the same model, initial state, output times and reference:
    `hamel tradeoff SCENE --export-python` run again) are rounds of one measurement: hamel's
    rows are merged, each setting at its fastest round, and the peer is timed as many rounds,
    its fastest kept. On a machine whose speed wanders (a shared virtual machine: ±40 % between
    runs minutes apart), the best of a few rounds on both sides is what compares the codes."""
    groups = {}
    for path in paths:
        with open(path) as f:
            system = json.load(f)
        key = (system["model"], json.dumps(system["y0"]), json.dumps(system["times"]))
        groups.setdefault(key, []).append((path, system))
    out = []
    for rounds in groups.values():
        path, first = rounds[0]
        fastest = {}
        for other, system in rounds:
            if system["reference"] != first["reference"]:
                sys.exit(f"{other}: not the reference of {path} (export both with the same hamel)")
            for r in system["hamel"]:
                key = (r["method"], r["tol"])
                if key not in fastest or r["seconds"] < fastest[key]["seconds"]:
                    fastest[key] = r
        out.append((dict(first, hamel=list(fastest.values())), len(rounds)))
    return out


def timed_rounds(fun, rounds):
    """`timed` `rounds` times: the last output and the fastest median."""
    best = math.inf
    for _ in range(rounds):
        out, seconds = timed(fun)
        best = min(best, seconds)
    return out, best


def timed(fun):
    runs, total = [], 0.0
    while True:
        start = time.perf_counter()
        out = fun()
        took = time.perf_counter() - start
        runs.append(took)
        total += took
        if (total > 0.05 and len(runs) >= 5) or len(runs) >= 2000:
            return out, statistics.median(runs)


# An error is resolved where it is at least this many times the reference's own (its difference
# from the check run, exported as `reference_check`): below, the reference cannot tell which of
# two runs is the more accurate, and the row is shown but not ranked.
RESOLUTION = 2.0


def resolved(err, system):
    return err >= RESOLUTION * system.get("reference_check", 0.0)


def compare(system, hamel, front, err, seconds):
    """A peer's run against hamel's: (hamel's fastest run at <= err, peer / hamel, peer / hamel
    with hamel's time interpolated at err). The ratios are None where err is not finite or
    below the reference's resolution."""
    best = min((r for r in hamel if r["error_span"] <= err), key=lambda r: r["seconds"], default=None)
    if not (math.isfinite(err) and resolved(err, system)):
        return best, None, None
    ratio = seconds / best["seconds"] if best else None
    at = interpolated(front, err)
    return best, ratio, seconds / at if at else None


def ratio_texts(err, system, ratio, inter):
    """The two ratio cells of a row."""
    if math.isfinite(err) and not resolved(err, system):
        below = f"below the reference's resolution ({system['reference_check']:.1e})"
        return below, below
    return (f"{ratio:.2f}" if ratio else "–"), (f"{inter:.2f}" if inter else "–")


def pareto(runs):
    """hamel's work–precision front: the runs that no run beats in both error and time, by
    increasing error (so decreasing time)."""
    front = []
    for r in sorted(runs, key=lambda r: (r["error_span"], r["seconds"])):
        if r["error_span"] > 0 and (not front or r["seconds"] < front[-1]["seconds"]):
            front.append(r)
    return front


def interpolated(front, err):
    """hamel's time at error `err` on its front, log–log linear between the two runs that
    bracket it (None outside the front)."""
    for lo, hi in zip(front, front[1:]):
        if lo["error_span"] <= err <= hi["error_span"]:
            x = (math.log(err) - math.log(lo["error_span"])) / (math.log(hi["error_span"]) - math.log(lo["error_span"]))
            return math.exp(math.log(lo["seconds"]) + x * (math.log(hi["seconds"]) - math.log(lo["seconds"])))
    return None


def print_summary(peer, span, summary):
    """The closing table of a comparison: per scene, the range of peer / hamel at equal error
    (hamel's fastest run at <= the error, and hamel's time interpolated at it) and how many
    rows were compared. `summary` holds (model, ratios, interpolated ratios, rows, rows below the
    reference's resolution)."""
    print(f"| scene | {peer} / hamel at equal error ({span}): hamel's fastest run at ≤ the error "
          "| the same, hamel's time interpolated at the error | rows compared |")
    print("|---|---|---|---|")
    for model, ratios, inters, count, below in summary:
        ratio_span = f"{min(ratios):.2f}–{max(ratios):.2f}" if ratios else "–"
        inter_span = f"{min(inters):.2f}–{max(inters):.2f}" if inters else "–"
        unranked = f" ({below} below the reference's resolution)" if below else ""
        print(f"| {model} | {ratio_span} | {inter_span} | {len(ratios)} of {count}{unranked} |")
