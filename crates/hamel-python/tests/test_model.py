"""hamel's Python API on the bundled models: names, derivations, evaluation on arrays,
located errors. Each check is against a fact the model states itself (its constraint, its
energy), not against hamel's own output."""

from pathlib import Path

import numpy as np
import pytest

import hamel

ROOT = Path(__file__).resolve().parents[3]
MODELS = ROOT / "models"


def test_a_model_s_names():
    knife = hamel.Model.load(MODELS / "knife.toml")
    assert knife.name == "knife"
    assert knife.coordinates == ["x", "y", "theta"]
    assert knife.parameters == {"m": 0.5, "l": 0.3}
    assert "paper" in knife.choices
    assert "knife" in repr(knife)


def test_a_bad_model_is_a_located_error():
    text = (MODELS / "knife.toml").read_text().replace(
        'no_slip = "sin(theta)*der(x) - cos(theta)*der(y)"',
        'no_slip = "sin(theta)*der(x) - cos(theta)*der(w)"',
    )
    with pytest.raises(hamel.ModelError) as e:
        hamel.Model.from_toml(text, name="bad_knife.toml")
    err = e.value
    assert err.file == "bad_knife.toml"
    assert err.key == "constraints.no_slip"
    assert err.line == text.splitlines().index(
        'no_slip = "sin(theta)*der(x) - cos(theta)*der(w)"') + 1
    assert err.column is not None and "w" in err.reason
    assert str(err).startswith("bad_knife.toml:")
    assert isinstance(err, hamel.HamelError)


def test_a_missing_file_names_it():
    with pytest.raises(hamel.ModelError) as e:
        hamel.Model.load(MODELS / "no_such_model.toml")
    assert "no_such_model.toml" in e.value.file
    assert "cannot read" in e.value.reason


def test_derive_prints_the_equations():
    d = hamel.Model.load(MODELS / "knife.toml").derive("paper")
    assert (d.model, d.eta_name, d.dims) == ("knife", "paper", (3, 2))
    assert d.coordinates == ["x", "y", "theta"]
    assert "theta" in d.text()
    latex = d.latex()
    assert latex.startswith("\\documentclass") and "\\end{document}" in latex
    assert "\\documentclass" not in d.latex(fragment=True)


def test_eval_on_arrays_keeps_the_constraint_and_gives_the_energy():
    knife = hamel.Model.load(MODELS / "knife.toml")
    rng = np.random.default_rng(61)
    n = 50
    q = rng.uniform(-2, 2, size=(n, 3))
    eta = rng.uniform(-1, 1, size=(n, 2))
    params = {"m": 2.0, "l": 0.5}
    out = knife.eval(q, eta, choice="paper", params=params)
    assert out["q_dot"].shape == (n, 3) and out["eta_dot"].shape == (n, 2)
    assert out["energy"].shape == (n,)
    xd, yd, thd = out["q_dot"].T
    th = q[:, 2]
    # the model's constraint: sin(theta) x' - cos(theta) y' = 0
    assert np.max(np.abs(np.sin(th) * xd - np.cos(th) * yd)) < 1e-13
    # the paper's quasi-velocities: eta1 = cos(theta) x' + sin(theta) y', eta2 = theta'
    assert np.allclose(np.cos(th) * xd + np.sin(th) * yd, eta[:, 0], rtol=0, atol=1e-13)
    assert np.allclose(thd, eta[:, 1], rtol=0, atol=1e-13)
    # its kinetic energy, T = m/2 (x'^2 + y'^2) + m l^2/24 theta'^2 (U = 0)
    m, l = params["m"], params["l"]
    energy = m / 2 * (xd**2 + yd**2) + m * l**2 / 24 * thd**2
    assert np.allclose(out["energy"], energy, rtol=1e-13, atol=0)


def test_eval_refuses_arrays_of_the_wrong_shape():
    knife = hamel.Model.load(MODELS / "knife.toml")
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        knife.eval(np.zeros((4, 2)), np.zeros((4, 2)), choice="paper")


def test_a_tyre_with_no_crown_is_the_thin_disk():
    """models/bodies/rolling_tyre.toml (a torus: wheels.disk.crown = "c") with c = 0 has the
    equations of the thin disk of rolling_disk_bodies.toml; with its crown it has others."""
    tyre = hamel.Model.load(MODELS / "bodies" / "rolling_tyre.toml")
    disk = hamel.Model.load(MODELS / "bodies" / "rolling_disk_bodies.toml")
    rng = np.random.default_rng(62)
    q = rng.uniform(-1.2, 1.2, size=(30, 5))
    eta = rng.uniform(-2, 2, size=(30, 3))
    flat = tyre.eval(q, eta, choice="velocities", params={"c": 0.0}, engine="interpreted")
    thin = disk.eval(q, eta, choice="velocities", engine="interpreted")
    for key in ("eta_dot", "q_dot", "energy"):
        scale = np.maximum(1.0, np.abs(thin[key]))
        assert np.max(np.abs(flat[key] - thin[key]) / scale) < 1e-12, key
    crowned = tyre.eval(q, eta, choice="velocities", engine="interpreted")
    assert np.max(np.abs(crowned["eta_dot"] - thin["eta_dot"])) > 1e-3
