"""Fixtures of the Python tests: the command line to compare with, and small studies.

The command line is $HELIXBIF_CLI, else target/release/helixbif of this repository (what
`cargo build --release` or `cargo test --release` makes), else `helixbif` on the PATH. Without
one the tests that compare with it are skipped, unless $HELIXBIF_CLI names one (then they fail).
"""

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

import helixbif

REPO = Path(__file__).resolve().parents[2]

# Keys whose values differ between two runs of the same computation (wall time and where it
# went, output folder).
VOLATILE = {"seconds", "time", "out"}


def find_cli():
    named = os.environ.get("HELIXBIF_CLI")
    if named:
        if not Path(named).is_file():
            raise RuntimeError(f"HELIXBIF_CLI={named} is not a file")
        return named
    built = REPO / "target" / "release" / "helixbif"
    if built.is_file():
        return str(built)
    return shutil.which("helixbif")


def scrub(value):
    """`value` without the volatile keys, at every depth."""
    if isinstance(value, dict):
        return {k: scrub(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [scrub(v) for v in value]
    return value


class Cli:
    """Runs the command line in a scratch folder."""

    def __init__(self, path, cwd):
        self.path = path
        self.cwd = cwd

    def run(self, *args):
        return subprocess.run(
            [self.path, *map(str, args)],
            capture_output=True,
            text=True,
            cwd=self.cwd,
            timeout=300,
        )

    def json(self, *args):
        """The JSON that `helixbif ARGS --json` prints (the command must succeed)."""
        done = self.run(*args, "--json")
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    def error(self, *args):
        """The exit code and the one line on stderr of a command that fails, without the
        `helixbif: error: ` prefix."""
        done = self.run(*args)
        assert done.returncode != 0, done.stdout
        line = done.stderr.strip().splitlines()[-1]
        prefix = "helixbif: error: "
        assert line.startswith(prefix), done.stderr
        return done.returncode, line[len(prefix):]


@pytest.fixture(scope="session")
def cli_path():
    path = find_cli()
    if path is None:
        pytest.skip("no helixbif command line to compare with (cargo build --release)")
    return path


@pytest.fixture
def cli(cli_path, tmp_path):
    return Cli(cli_path, tmp_path)


@pytest.fixture(scope="session")
def small():
    """The representative helix on Lighthill's operator at N = 20 (every run on it takes well
    under a second)."""
    return helixbif.Study.default().with_(
        **{"fluid.model": "lighthill", "discretization.nodes": 20}
    )
