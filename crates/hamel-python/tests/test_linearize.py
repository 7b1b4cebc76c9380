"""Model.linearize: the Whipple bicycle's weave and capsize speeds from Python equal the
command line's (`hamel linearize ... --sweep v=0:10:21 --format json`), and a point's
matrices are arrays."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import hamel

ROOT = Path(__file__).resolve().parents[3]
BICYCLE = ROOT / "models" / "whipple_bicycle.toml"
# Meijaard et al. (2007), Table 2: the benchmark's weave and capsize speeds.
WEAVE, CAPSIZE = 4.292382835, 6.024262367


def hamel_binary():
    built = ROOT / "target" / "release" / "hamel"
    return str(built) if built.exists() else shutil.which("hamel")


@pytest.fixture(scope="module")
def sweep():
    return hamel.Model.load(BICYCLE).linearize("upright", sweep="v=0:10:21")


def test_the_bicycles_weave_and_capsize_speeds(sweep):
    kinds = [c["kind"] for c in sweep["crossings"]]
    assert kinds == ["hopf", "real_zero"]
    weave, capsize = (c["value"] for c in sweep["crossings"])
    assert abs(weave - WEAVE) < 1e-6 and abs(capsize - CAPSIZE) < 1e-6
    points = sweep["points"]
    assert len(points) == 21
    assert all(p["eigenvalues"].dtype == complex and p["eigenvalues"].shape == (4,) for p in points)
    assert not hamel._hamel._cas_started()  # derived (if at all) in a worker process


def test_they_equal_the_command_lines(sweep, tmp_path):
    exe = hamel_binary()
    if exe is None:
        pytest.skip("no hamel binary (cargo build --release) to compare with")
    out = tmp_path / "sweep.json"
    args = [exe, "linearize", str(BICYCLE), "--steady", "upright", "--sweep", "v=0:10:21",
            "--format", "json", "--output", str(out)]
    run = subprocess.run(args, capture_output=True, text=True, timeout=600, env={**os.environ})
    assert run.returncode == 0, run.stderr
    cli = json.loads(out.read_text())
    assert [c["value"] for c in cli["crossings"]] == [c["value"] for c in sweep["crossings"]]
    assert [c["kind"] for c in cli["crossings"]] == [c["kind"] for c in sweep["crossings"]]


def test_a_point_gives_the_matrices_as_arrays():
    at = hamel.Model.load(BICYCLE).linearize("upright", at={"v": 5.0})
    a, b = at["a"], at["second_order"]
    assert a.shape == (4, 4) and at["eigenvalues"].shape == (4,)
    m, c, k = b["m"], b["c"], b["k"]
    assert m.shape == (2, 2) and c.shape == (2, 2) and k.shape == (2, 2)
    # 5 m/s lies between the weave and capsize speeds: the benchmark is stable there
    assert np.all(at["eigenvalues"].real < 0)


def test_a_bad_sweep_is_a_clear_error():
    bicycle = hamel.Model.load(BICYCLE)
    with pytest.raises(hamel.ModelError, match="sweep"):
        bicycle.linearize("upright", sweep="v=0:10")
    with pytest.raises(hamel.ModelError):
        bicycle.linearize("no_such_motion")
