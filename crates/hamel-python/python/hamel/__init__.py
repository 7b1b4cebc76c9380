"""hamel: the Boltzmann–Hamel equations of nonholonomic systems, derived exactly, evaluated on
numpy arrays.

    >>> import hamel
    >>> disk = hamel.Model.load("models/rolling_disk.toml")
    >>> d = disk.derive("velocities")       # from the derivation store, or made in a worker
    >>> print(d.text())
    >>> out = disk.eval(q, eta, choice="velocities")   # q: (N, ℓ), eta: (N, σ)
    >>> rhs = disk.rhs("velocities")         # f(t, y) for solve_ivp; rhs.address, rhs.data for numbalsoda
    >>> bike = hamel.Model.load("models/whipple_bicycle.toml")
    >>> bike.linearize("upright", sweep="v=0:10:21")["crossings"]   # weave and capsize
    >>> hamel.Scene.load("scenes/knife.toml").ensemble({"eta1": speeds})

Errors in a model are ``hamel.ModelError`` with ``file``, ``line``, ``column``, ``key`` and
``reason``. The computer algebra (Symbolica) never runs in this process: a derivation the
store lacks is made by ``python -m hamel._worker``, which exits when it is done.
"""

from . import _hamel
from ._hamel import Derivation, HamelError, Model, ModelError, Rhs, Scene, version

# hamel's caches key their entries by the code that made them: this extension, not the
# interpreter that runs it.
_hamel._use_identity(_hamel.__file__)

__all__ = ["Derivation", "HamelError", "Model", "ModelError", "Rhs", "Scene", "version"]
__version__ = version()
