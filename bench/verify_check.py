#!/usr/bin/env python3
"""Compare η̇ of the SymPy baseline (`sympy_derive.py --check`) with `hamel eval`.

    python3 bench/verify_check.py [--hamel target/release/hamel] [--states N] [CASE ...]

A CASE is MODEL:ETA (default: the list below). For each case N random states (seeded) are
written to a temporary file, both programs evaluate η̇ (true and paper's) there, and the largest
relative difference max_k |a_k − b_k| / max(1, max_k |b_k|) (per state, relative to the
largest component of hamel's η̇) is printed. Exit status 1 if any exceeds 1e-10.
"""
import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# Definitions of the free functions of the choices that have some.
FUNCTIONS = {
    ("knife", "general"): {"z11": "1.2*cos(theta) + 0.1", "z12": "sin(theta) - 0.2*cos(theta)"},
    ("bar_blade", "paper_z13"): {"z13": "0.3 + 0.1*cos(phi)"},
    ("bar_wheels", "paper_z"): {"z13": "0.2 + 0.1*sin(phi)", "z14": "0.05*cos(phi)"},
    ("unicycle_rider", "family"): {
        "w1": "1 + 0.1*sin(theta)", "z13": "0.2*cos(theta1)", "z14": "0.3",
        "w2": "0.1*cos(theta)", "z23": "1 + 0.1*sin(theta1)", "z24": "0.5*sin(theta)"},
}
# Physical magnitudes of η where they are not velocities (momenta m R² ω are ~1e-2 here).
SCALE = {("rolling_disk", "momenta"): [0.01, 0.01, 1], ("unicycle_rider", "momenta"): [5, 0.1, 1, 1]}
DEFAULT = ["knife:paper", "knife:general", "vertical_knife:paper", "chaplygin_sleigh:paper_style",
           "remark22:paper", "bar_blade:paper", "bar_blade:paper_z13", "rolling_disk:momenta",
           "rolling_disk:velocities", "bar_wheels:paper"]


def states(model, eta, n, rng):
    with open(os.path.join(ROOT, "models", model + ".toml"), "rb") as fh:
        raw = tomllib.load(fh)
    sigma = len(raw["quasi_velocities"][eta]["eta"])
    out = []
    for _ in range(n):
        s = {"q": {c: rng.uniform(-1.2, 1.2) for c in raw["coordinates"]},
             "eta": [rng.uniform(-2, 2) * SCALE.get((model, eta), [1] * sigma)[i]
                     for i in range(sigma)]}
        if (model, eta) in FUNCTIONS:
            s["functions"] = FUNCTIONS[(model, eta)]
        out.append(s)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", default=DEFAULT)
    ap.add_argument("--hamel", default=os.path.join(ROOT, "target", "release", "hamel"))
    ap.add_argument("--states", type=int, default=5)
    args = ap.parse_args()
    rng = random.Random(2015)
    worst_all = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.cases:
            model, eta = case.split(":")
            path = os.path.join(ROOT, "models", model + ".toml")
            state_file, out_file = os.path.join(tmp, "s.json"), os.path.join(tmp, "h.json")
            with open(state_file, "w") as fh:
                json.dump(states(model, eta, args.states, rng), fh)
            subprocess.run([args.hamel, "eval", path, "--eta", eta, "--state", state_file,
                            "--output", out_file], check=True, stdout=subprocess.DEVNULL)
            with open(out_file) as fh:
                ham = json.load(fh)
            sym = json.loads(subprocess.run(
                [sys.executable, os.path.join(HERE, "sympy_derive.py"), path, eta,
                 "--check", state_file], check=True, capture_output=True, text=True).stdout)
            worst = {}
            for key in ("eta_dot", "eta_dot_paper"):
                worst[key] = max(max(abs(a - b) for a, b in zip(s[key], h[key]))
                                 / max(1.0, *map(abs, h[key])) for h, s in zip(ham, sym))
            worst_all = max(worst_all, *worst.values())
            example = ", ".join(f"{x:.12g}" for x in ham[0]["eta_dot"])
            print(f"{case:30s} max rel diff eta_dot {worst['eta_dot']:.2e}  "
                  f"eta_dot_paper {worst['eta_dot_paper']:.2e}  (state 1: eta_dot = [{example}])")
    print(f"worst relative difference: {worst_all:.2e}")
    sys.exit(0 if worst_all <= 1e-10 else 1)


if __name__ == "__main__":
    main()
