#!/usr/bin/env bash
# Time the SymPy baseline on every model and quasi-velocity choice in models/ (one process each,
# run one after the other) and print a Markdown table. Usage: bench/time_all.sh [TIMEOUT_SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
timeout="${1:-300}"
echo "| model | choice | SymPy seconds | split_identity | energy_conserved |"
echo "| --- | --- | --- | --- | --- |"
for model in models/*.toml; do
    for eta in $(python3 -c 'import sys, tomllib; print(*tomllib.load(open(sys.argv[1], "rb")).get("quasi_velocities", {"identity": 0}))' "$model"); do
        python3 bench/sympy_derive.py "$model" "$eta" --timeout "$timeout" | python3 -c '
import json, sys
r = json.loads(sys.stdin.readline())
t = "%.3f" % r["seconds"] if r["status"] == "ok" else "timeout (> %g s)" % r["seconds"]
print("| %s | %s | %s | %s | %s |" % (r["model"], r["eta"], t, r["split_identity"], r["energy_conserved"]))'
    done
done
