"""The example under examples/ runs and draws its figure (where matplotlib is installed: the
`test` extra brings it)."""

import subprocess
import sys

import pytest

from conftest import REPO


def test_python_figure(tmp_path):
    pytest.importorskip("matplotlib")
    figure = tmp_path / "figure.png"
    done = subprocess.run(
        [sys.executable, str(REPO / "examples" / "python_figure.py"), str(figure)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "omega_b = 0.522184 rad/s (hopf, subcritical)" in done.stdout
    assert figure.stat().st_size > 10_000
