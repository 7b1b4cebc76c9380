"""Scenes from Python: the knife's scene against its closed form (η constant: the bar turns
at a steady rate and its midpoint runs on a circle), on both engines."""

from pathlib import Path

import numpy as np
import pytest

import hamel

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("engine", ["interpreted", "compiled"])
def test_the_knife_scene_follows_its_closed_form(engine):
    run = hamel.Scene.load(ROOT / "scenes" / "knife.toml").simulate(engine=engine)
    t = run["t"]
    assert run["complete"] and len(t) == 101
    # eta = (1, 0.5) constant: theta = 0.3 + t/2, x = 2(sin theta - sin 0.3), y = -2(cos theta - cos 0.3)
    th = 0.3 + 0.5 * t
    assert np.max(np.abs(run["q"]["theta"] - th)) < 1e-9
    assert np.max(np.abs(run["q"]["x"] - 2 * (np.sin(th) - np.sin(0.3)))) < 1e-9
    assert np.max(np.abs(run["q"]["y"] + 2 * (np.cos(th) - np.cos(0.3)))) < 1e-9
    assert run["eta"].shape == (101, 2)
    assert run["stats"]["rhs_evals"] > 0


def test_a_scene_with_a_bad_key_is_a_located_error(tmp_path):
    text = (ROOT / "scenes" / "knife.toml").read_text()
    text = text.replace("../models/knife.toml", str(ROOT / "models" / "knife.toml"))
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("t_end", "t_ned", 1))
    with pytest.raises(hamel.ModelError) as e:
        hamel.Scene.load(bad)
    assert e.value.file == str(bad)
    assert "t_ned" in str(e.value)
    with pytest.raises(ValueError, match="engine"):
        hamel.Scene.load(ROOT / "scenes" / "knife.toml").simulate(engine="fast")


def test_an_ensemble_given_from_python_follows_the_closed_form():
    scene = hamel.Scene.load(ROOT / "scenes" / "knife.toml")
    speeds = np.array([0.5, 1.0, 1.5, 2.0])
    turns = np.array([0.5, 0.25, np.nan, 1.0])  # NaN: the scene's eta2 = 0.5
    run = scene.ensemble({"eta1": speeds, "eta2": turns}, threads=2)
    assert list(run["member"]) == [0, 1, 2, 3] and all(run["complete"])
    assert run["errors"] == [None] * 4
    w = np.where(np.isnan(turns), 0.5, turns)
    th = 0.3 + w * 10.0
    final = run["values"]
    assert final["theta"].shape == (4,)
    assert np.max(np.abs(final["theta"] - th)) < 1e-9
    assert np.max(np.abs(final["x"] - speeds / w * (np.sin(th) - np.sin(0.3)))) < 1e-8
    assert np.array_equal(run["given"]["eta1"], speeds)
    every = scene.ensemble({"eta1": speeds[:2]}, save="outputs")
    assert every["values"]["theta"].shape == (2, 101) and every["t"].shape == (101,)


def test_the_scenes_own_ensemble_and_bad_members():
    run = hamel.Scene.load(ROOT / "scenes" / "knife_ensemble.toml").ensemble()
    assert len(run["member"]) == run["header"]["members"] and all(run["complete"])
    knife = hamel.Scene.load(ROOT / "scenes" / "knife.toml")
    with pytest.raises(hamel.ModelError, match="no \\[ensemble\\]"):
        knife.ensemble()
    with pytest.raises(hamel.ModelError, match="speed"):
        knife.ensemble({"speed": [1.0]})
    with pytest.raises(hamel.ModelError, match="equal length"):
        knife.ensemble({"eta1": [1.0], "eta2": [1.0, 2.0]})


def test_the_tradeoff_table_recommends_the_fastest_row_that_meets_the_target():
    t = hamel.Scene.load(ROOT / "scenes" / "knife.toml").tradeoff()
    rows = t["rows"]
    assert {"dop853", "dopri5", "rk4", "gauss-legendre"} <= {r["method"] for r in rows}
    assert t["reference_check"] < 1e-12 and t["engine"] == "compiled"
    err = {r["tol"]: r["error_span"] for r in rows if r["method"] == "dop853" and r["tol"]}
    assert err[1e-12] < 1e-3 * err[1e-5]
    meets = [r for r in rows if r["complete"] and r["target_ratio"] <= 1.0]
    assert rows[t["recommended"]]["seconds"] == min(r["seconds"] for r in meets)
    assert "dop853" in t["text"]
    with pytest.raises(ValueError, match="range"):
        hamel.Scene.load(ROOT / "scenes" / "knife.toml").tradeoff(range="some")
    # one run per setting: the same settings and errors, coarser times
    quick = hamel.Scene.load(ROOT / "scenes" / "knife.toml").tradeoff(range="adaptive", min_time=0)
    assert all(r["seconds"] > 0 for r in quick["rows"]) and quick["recommended"] is not None
    with pytest.raises(ValueError, match="min_time"):
        hamel.Scene.load(ROOT / "scenes" / "knife.toml").tradeoff(min_time=-1)
