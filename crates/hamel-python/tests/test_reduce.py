"""Model.reduce and Model.search: the exact decisions of `hamel reduce` and `hamel search`,
made in worker processes (never in this one), as Python objects."""

from pathlib import Path

import pytest

import hamel

MODELS = Path(__file__).resolve().parents[3] / "models"


def test_reduce_decides_which_coordinates_drop_out():
    knife = hamel.Model.load(MODELS / "knife.toml")
    r = knife.reduce(["x", "y", "theta"], eta="paper")
    assert r["eliminate"] == ["x", "y", "theta"] and r["eta_name"] == "paper"
    assert sorted(r["ground_truth"]["absent"]) == ["theta", "x", "y"], r["ground_truth"]
    assert "x" in r["text"] and r["text"].strip()
    assert not hamel._hamel._cas_started()
    with pytest.raises(hamel.ModelError, match="nope"):
        knife.reduce(["nope"], eta="paper")


def test_search_finds_the_knifes_choice_within_its_budget():
    knife = hamel.Model.load(MODELS / "knife.toml")
    r = knife.search(["x", "y", "theta"], budget=60)
    rows = r["candidates"]
    assert rows and all(c["eliminated"] == ["x", "y", "theta"] for c in rows)
    assert any("cos(theta)*der(x) + sin(theta)*der(y)" in c["eta"] for c in rows)
    assert r["stop"]["reason"] == "completed"
    assert not hamel._hamel._cas_started()


def test_search_of_a_model_given_as_text_and_a_bad_budget():
    text = (MODELS / "knife.toml").read_text()
    knife = hamel.Model.from_toml(text, name="knife_from_text.toml")
    r = knife.search(["x", "y", "theta"], budget=60, max=2)
    assert 1 <= len(r["candidates"]) <= 2
    with pytest.raises(ValueError, match="budget"):
        knife.search(["x"], budget=0)
