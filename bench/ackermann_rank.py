#!/usr/bin/env python3
"""An outside check of tests/models/ackermann_two_angles.toml (numpy only, none of hamel's code):
its nine rows written by hand from the geometry have numerical rank 8 at random
configurations and 7 once dR is completed onto h = 0.  python3 bench/ackermann_rank.py"""
import numpy as np
rng = np.random.default_rng(1)
r, b, L = 0.3, 0.75, 2.5
def rows(q):
    x, y, psi, dL, dR = q[:5]
    R = np.array([[np.cos(psi), -np.sin(psi)], [np.sin(psi), np.cos(psi)]])
    out = []
    # coordinates: x y psi dL dR phiRL phiRR phiFL phiFR
    for k, (off, steer) in enumerate([((0, b), 0.0), ((0, -b), 0.0), ((L, b), dL), ((L, -b), dR)]):
        p = R @ np.array(off)
        # velocity of the wheel centre: (xdot, ydot) + psidot * z x p  -> columns
        vx = np.zeros(9); vy = np.zeros(9)
        vx[0] = 1; vy[1] = 1; vx[2] = -p[1]; vy[2] = p[0]
        h = psi + steer
        fwd = np.array([np.cos(h), np.sin(h)]); lat = np.array([-np.sin(h), np.cos(h)])
        roll = fwd[0] * vx + fwd[1] * vy; roll[5 + k] -= r
        out += [roll, lat[0] * vx + lat[1] * vy]
    dh = np.zeros(9)
    dh[3] = L * np.cos(dL - dR) - 2 * b * np.cos(dL) * np.sin(dR)
    dh[4] = -L * np.cos(dL - dR) - 2 * b * np.sin(dL) * np.cos(dR)
    return np.array(out + [dh])
def rank(m):
    s = np.linalg.svd(m, compute_uv=False)
    return int((s > 1e-10 * s[0]).sum())
off, on = set(), set()
for _ in range(20):
    q = rng.uniform(-1, 1, 9)
    off.add(rank(rows(q)))
    q[4] = np.arctan2(L * np.sin(q[3]), L * np.cos(q[3]) + 2 * b * np.sin(q[3]))
    on.add(rank(rows(q)))
print("rank off h = 0:", off, " on h = 0:", on)
