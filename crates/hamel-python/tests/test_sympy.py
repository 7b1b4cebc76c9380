"""A derivation's objects as SymPy expressions: the identities that define them hold exactly
in SymPy (Z Γ = I, α Γ = 0, A_Γ = Γᵀ A Γ: each entry simplifies to 0), and the equations
solved for η̇ in SymPy give hamel's numeric η̇ at random states."""

from pathlib import Path

import numpy as np
import pytest

import hamel

sp = pytest.importorskip("sympy")
ROOT = Path(__file__).resolve().parents[3]

SEEDS = [("knife", "paper"), ("chaplygin_sleigh", "paper_style"),
         ("rolling_disk", "velocities"), ("vertical_knife", None), ("bar_blade", None)]


def zero(m):
    return all(sp.simplify(e) == 0 for e in m)


@pytest.mark.parametrize("name,choice", SEEDS)
def test_the_objects_in_sympy_keep_their_identities(name, choice):
    model = hamel.Model.load(ROOT / "models" / f"{name}.toml")
    choice = choice or model.choices[0]
    o = model.derive(choice).to_sympy()
    sigma = o["gamma"].shape[1]
    assert zero(o["z"] * o["gamma"] - sp.eye(sigma))
    assert zero(o["alpha"] * o["gamma"])
    assert zero(o["a_gamma"] - o["gamma"].T * o["a"] * o["gamma"])


@pytest.mark.parametrize("name,choice", SEEDS)
def test_the_equations_in_sympy_give_hamel_s_rates(name, choice):
    model = hamel.Model.load(ROOT / "models" / f"{name}.toml")
    choice = choice or model.choices[0]
    o = model.derive(choice).to_sympy()
    sigma = o["gamma"].shape[1]
    rates = [sp.Symbol(f"eta{i + 1}_dot", real=True) for i in range(sigma)]
    rng = np.random.default_rng(7)
    q = rng.uniform(-1, 1, size=(5, len(model.coordinates)))
    eta = rng.uniform(-1, 1, size=(5, sigma))
    out = model.eval(q, eta, choice=choice)
    for i in range(len(q)):
        values = {sp.Symbol(c, real=True): sp.Float(v, 30) for c, v in zip(model.coordinates, q[i])}
        values.update({sp.Symbol(p, real=True): sp.Float(v, 30) for p, v in model.parameters.items()})
        values.update({sp.Symbol(f"eta{k + 1}", real=True): sp.Float(v, 30) for k, v in enumerate(eta[i])})
        equations = [e.xreplace(values) for e in o["equations"]]
        solved = sp.solve(equations, rates, dict=True)[0]
        got = np.array([float(solved[r]) for r in rates])
        assert np.allclose(got, out["eta_dot"][i], rtol=1e-12, atol=1e-12), (got, out["eta_dot"][i])
