"""A rolling disk, the way a notebook goes: derive its equations, integrate them with scipy on
hamel's compiled right-hand side, check what must hold, plot.

    python crates/hamel-python/examples/rolling_disk.py [PLOT.png]

Run by the package's tests (tests/test_example.py). Needs numpy and scipy; plots when
matplotlib is installed (else says so).
"""

import sys
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import hamel

ROOT = Path(__file__).resolve().parents[3]

# 1. The model: a thin disk of radius R rolling without slipping on a plane. Coordinates:
#    the contact point (xC, yC), heading phi, spin psi, lean theta (0 upright).
disk = hamel.Model.load(ROOT / "models" / "rolling_disk.toml")
print(disk, disk.coordinates, disk.parameters)

# 2. The Boltzmann–Hamel equations with the quasi-velocities eta = (phi', psi', theta'),
#    exact (from the derivation store, or made in a worker process).
d = disk.derive("velocities")
print(d.text())

# 3. The compiled right-hand side, y = (q, eta), and an initial state: rolling at a spin of
#    10 rad/s (above the critical speed sqrt(g / 3R) = 4.7 rad/s), leaning 0.1 rad.
rhs = disk.rhs("velocities")
print(rhs.names)
y0 = np.array([0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 10.0, 0.0])
sol = solve_ivp(rhs, (0.0, 5.0), y0, method="DOP853", rtol=1e-10, atol=1e-10, dense_output=True)
assert sol.success, sol.message
t = np.linspace(0.0, 5.0, 501)
y = sol.sol(t).T
q, eta = y[:, :5], y[:, 5:]

# 4. What must hold: the energy is conserved, the disk rolls (the contact point moves as
#    R psi' along the heading), and above the critical speed the lean stays small.
out = disk.eval(q, eta, choice="velocities")
energy = out["energy"]
drift = np.ptp(energy) / abs(energy[0])
R = disk.parameters["R"]
xd, yd, phi, psid = out["q_dot"][:, 0], out["q_dot"][:, 1], q[:, 2], eta[:, 1]
speed = np.hypot(xd, yd)
print(f"energy {energy[0]:.6f} J, relative drift {drift:.1e}")
print(f"contact speed against R psi': {np.max(np.abs(speed - R * np.abs(psid))):.1e}")
print(f"largest lean {np.max(np.abs(q[:, 4])):.3f} rad")
assert drift < 1e-8
assert np.max(np.abs(speed - R * np.abs(psid))) < 1e-10
assert np.max(np.abs(q[:, 4])) < 0.2

# 5. A picture, when matplotlib is there.
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot")
else:
    fig, (path, lean) = plt.subplots(1, 2, figsize=(10, 4))
    path.plot(q[:, 0], q[:, 1])
    path.set(xlabel="xC [m]", ylabel="yC [m]", title="the contact point's track", aspect="equal")
    lean.plot(t, q[:, 4])
    lean.set(xlabel="t [s]", ylabel="theta [rad]", title="lean")
    target = sys.argv[1] if len(sys.argv) > 1 else "rolling_disk.png"
    fig.savefig(target, dpi=80)
    print(f"plotted: {target}")
