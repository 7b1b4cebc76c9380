"""The computer algebra runs in worker processes, never in the Python process, and its
notice is printed, not hidden."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]

SCRIPT = """
import hamel, hamel._hamel as h
d = hamel.Model.load({model!r}).derive("paper")
print("derived", d.model, d.eta_name, "cas started here:", h._cas_started(), flush=True)
"""


def run_fresh(tmp_path):
    """A derivation in a new process with an empty derivation store."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = dict(os.environ, HAMEL_CACHE=str(cache))
    code = SCRIPT.format(model=str(ROOT / "models" / "knife.toml"))
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300)


def test_a_derivation_is_made_in_a_worker_and_symbolica_s_notice_shows(tmp_path):
    first = run_fresh(tmp_path)
    assert first.returncode == 0, first.stderr
    assert "derived knife paper cas started here: False" in first.stdout
    if not os.environ.get("SYMBOLICA_LICENSE"):
        # the worker's output is the process's own: the notice is there, untouched
        assert "Symbolica" in first.stdout
    # the second time it comes from the store: no worker, no notice
    cache = tmp_path / "cache"
    env = dict(os.environ, HAMEL_CACHE=str(cache))
    code = SCRIPT.format(model=str(ROOT / "models" / "knife.toml"))
    second = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                            text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    assert "cas started here: False" in second.stdout
    assert "Symbolica" not in second.stdout
