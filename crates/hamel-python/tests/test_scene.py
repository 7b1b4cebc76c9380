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
