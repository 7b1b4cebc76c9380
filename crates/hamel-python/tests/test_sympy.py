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


def every_seed():
    """Every model of models/ (and models/bodies/) with every choice of its own."""
    pairs = []
    for path in sorted((ROOT / "models").glob("*.toml")) + sorted((ROOT / "models" / "bodies").glob("*.toml")):
        model = hamel.Model.load(path)
        pairs += [(path.relative_to(ROOT / "models").as_posix(), choice) for choice in model.choices]
    return pairs


def at_random_point(rng, names, digits=40):
    return {sp.Symbol(n, real=True): sp.Float(rng.uniform(-1, 1), digits) for n in names}


def multiplier_oracle(o, coordinates, values, q, eta):
    """η̇ from the Lagrange-multiplier form, built in SymPy from to_sympy()'s ingredients
    alone (A, α, Z, ∇U and the generalised forces, differentiated here): A q̈ + Ȧ q̇ −
    ½ q̇ᵀ ∂A/∂q q̇ − ∇U − F = αᵀλ, α q̈ + α̇ q̇ = 0, q̇ = Γ η with [Z; α] Γ = [I; 0], η̇ = Z q̈ + Ż q̇;
    in 30-digit arithmetic at one state."""
    syms = [sp.Symbol(c, real=True) for c in coordinates]
    ell, sigma = len(syms), o["z"].shape[0]
    point = dict(values)
    point.update({s_: sp.Float(v, 30) for s_, v in zip(syms, q)})
    num = lambda m: m.xreplace(point).evalf(30)
    a, alpha, z = o["a"], o["alpha"], o["z"]
    gamma = num(z.col_join(alpha)).inv()[:, :sigma]
    qd = gamma * sp.Matrix([sp.Float(v, 30) for v in eta])
    rates = {sp.Symbol(f"{c}_dot", real=True): qd[k] for k, c in enumerate(coordinates)}
    dot = lambda m: sum((num(m.diff(s_)) * qd[k] for k, s_ in enumerate(syms)), sp.zeros(*m.shape))
    an, alphan, zn = num(a), num(alpha), num(z)
    quad = sp.Matrix([(qd.T * num(a.diff(s_)) * qd)[0] / 2 for s_ in syms])
    forces = o.get("forces", sp.zeros(ell, 1))
    forces = forces.xreplace(rates).xreplace(point).evalf(30) if forces.shape[0] else sp.zeros(ell, 1)
    rhs = num(o["grad_u"]) + forces + quad - dot(a) * qd
    mu = alphan.shape[0]
    kkt = an.row_join(-alphan.T).col_join(alphan.row_join(sp.zeros(mu, mu)))
    qdd = kkt.LUsolve(rhs.col_join(-dot(alpha) * qd))[:ell, :]
    return [float(x) for x in zn * qdd + dot(z) * qd]


@pytest.mark.parametrize("path,choice", every_seed())
def test_every_seed_derivation_in_sympy_is_hamels(path, choice):
    """Every seed derivation's ingredients in SymPy give, through the Lagrange-multiplier form
    solved in SymPy, `eval`'s η̇ at random states to 1e-10; where the derivation has a closed
    form, Z Γ = I, α Γ = 0 and A_Γ = ΓᵀAΓ hold at random points in 40-digit arithmetic (below
    1e-30) and its equations solved for η̇ in SymPy give the same η̇."""
    model = hamel.Model.load(ROOT / "models" / path)
    d = model.derive(choice)
    if d.to_dict()["free_functions"]:
        pytest.skip(f"{path} {choice}: the choice has free functions (a family to search)")
    o = d.to_sympy()
    sigma = o["z"].shape[0]
    rng = np.random.default_rng(61)
    q = rng.uniform(-1, 1, size=(2, len(model.coordinates)))
    eta = rng.uniform(-1, 1, size=(2, sigma))
    out = model.eval(q, eta, choice=choice, engine="interpreted")
    values = {sp.Symbol(p, real=True): sp.Float(v, 30) for p, v in model.parameters.items()}
    for i in range(len(q)):
        got = multiplier_oracle(o, model.coordinates, values, q[i], eta[i])
        assert np.allclose(got, out["eta_dot"][i], rtol=1e-10, atol=1e-10), (path, choice, got, out["eta_dot"][i])
    if "gamma" not in o:
        return  # structured: no closed form to compare
    names = list(model.coordinates) + list(model.parameters)
    for _ in range(2):
        point = at_random_point(rng, names)
        for m in (o["z"] * o["gamma"] - sp.eye(sigma), o["alpha"] * o["gamma"],
                  o["a_gamma"] - o["gamma"].T * o["a"] * o["gamma"]):
            worst = max((abs(sp.N(e.xreplace(point), 40)) for e in m), default=0)
            assert worst < 1e-30, (path, choice, worst)
    rates = [sp.Symbol(f"eta{i + 1}_dot", real=True) for i in range(sigma)]
    for i in range(len(q)):
        values = {sp.Symbol(c, real=True): sp.Float(v, 30) for c, v in zip(model.coordinates, q[i])}
        values.update({sp.Symbol(p, real=True): sp.Float(v, 30) for p, v in model.parameters.items()})
        values.update({sp.Symbol(f"eta{k + 1}", real=True): sp.Float(v, 30) for k, v in enumerate(eta[i])})
        system = [sp.N(e.xreplace(values), 30) for e in o["equations"]]
        a, b = sp.linear_eq_to_matrix(system, rates)
        got = np.array([float(x) for x in a.LUsolve(b)])
        want = out["eta_dot"][i]
        assert np.allclose(got, want, rtol=1e-10, atol=1e-10), (path, choice, got, want)
