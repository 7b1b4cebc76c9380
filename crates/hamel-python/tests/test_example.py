"""The worked example runs as a user runs it, and says what it checked."""

import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "rolling_disk.py"


def test_the_rolling_disk_example_runs(tmp_path):
    plot = tmp_path / "disk.png"
    run = subprocess.run([sys.executable, str(EXAMPLE), str(plot)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "relative drift" in run.stdout and "contact speed" in run.stdout
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert "matplotlib is not installed" in run.stdout
    else:
        assert plot.stat().st_size > 1000
