"""Studies: construction, `with_` (the dotted keys and validation of `--set`), TOML round trips,
and bad input as ValueError with the command line's message."""

import os
import pickle
import subprocess
import sys

import pytest

import helixbif
from conftest import REPO

STUDIES = sorted((REPO / "studies").glob("*.toml"))


def test_default_is_the_representative_helix():
    study = helixbif.Study.default()
    assert study.name == "representative"
    assert study.nodes == 60
    assert study["rod.E"] == 1255e3
    assert study["shape.kind"] == "helix"
    assert study.overrides == []
    assert repr(study) == "Study('representative')"


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: p.name)
def test_toml_round_trip(path):
    study = helixbif.Study.from_file(path)
    again = helixbif.Study.from_toml(study.to_toml())
    assert again == study
    assert again.to_dict() == study.to_dict()
    assert pickle.loads(pickle.dumps(study)) == study


def test_with_does_not_mutate():
    study = helixbif.Study.default()
    before = (study.to_toml(), study.to_dict(), study.overrides)
    changed = study.with_(**{"rod.E": 2e6, "discretization.nodes": 80})
    assert (study.to_toml(), study.to_dict(), study.overrides) == before
    assert study["rod.E"] == 1255e3 and study.nodes == 60
    assert changed["rod.E"] == 2e6 and changed.nodes == 80
    assert changed.overrides == ["rod.E=2000000.0", "discretization.nodes=80"]
    assert changed != study
    # Chained, and the forms of the arguments.
    chained = study.with_({"rod.E": 2e6}).with_("discretization.nodes=80")
    assert chained == changed
    assert chained.overrides == ["rod.E=2000000.0", "discretization.nodes=80"]


def test_with_forms():
    study = helixbif.Study.default()
    left = study.with_("shape.handedness=left")
    assert left["shape.handedness"] == "left"
    assert study.with_(**{"shape.handedness": "left"}) == left
    assert study.with_(**{"fluid.model": "rpy"})["fluid.model"] == "rpy"
    # The helix ratios set the radius and the pitch.
    ratio = study.with_(**{"shape.R_over_lambda": 0.2})
    assert ratio["shape.R"] == pytest.approx(0.2 * study["shape.lambda"], rel=1e-15)
    # A dict replaces a whole table.
    straight = study.with_(shape={"kind": "straight", "L": 0.12, "alpha_deg": 15})
    assert straight["shape"] == {"kind": "straight", "L": 0.12, "alpha_deg": 15.0}
    # numpy scalars are numbers.
    np = pytest.importorskip("numpy")
    assert study.with_(**{"discretization.nodes": np.int64(30)}).nodes == 30
    assert study.with_(**{"rod.E": np.float64(2e6)})["rod.E"] == 2e6


def test_with_and_set_agree(cli):
    """The same overrides from Python and from --set give the same study: the same answer."""
    study = helixbif.Study.default().with_(
        **{"rod.E": 2e6, "discretization.nodes": 25, "shape.R_over_lambda": 0.25}
    )
    expected = cli.json(
        "locate", "--single",
        "--set", "rod.E=2e6", "--set", "discretization.nodes=25",
        "--set", "shape.R_over_lambda=0.25",
    )
    assert study.locate(single=True).to_dict() == expected


BAD = [
    ({"rod.E": -1}, "rod.E=-1"),
    ({"rod.EE": 1.0}, "rod.EE=1.0"),
    ({"discretization.nodes": 2}, "discretization.nodes=2"),
    # Past the admissible range of Lighthill's operator on this rod (N <= 87), refused by the run.
    (
        {"fluid.model": "lighthill", "discretization.nodes": 150},
        ("fluid.model=lighthill", "discretization.nodes=150"),
    ),
    ({"rod.E": "stiff"}, "rod.E=stiff"),
    ({"shape.handedness": "sideways"}, "shape.handedness=sideways"),
    ({"branch.omega_max": 0.0}, "branch.omega_max=0.0"),
    ({"continuation.tol": -1e-9}, "continuation.tol=-1e-9"),
    ({"rod..E": 1.0}, "rod..E=1.0"),
    # A Python string is a TOML string: `--set key="x"` (the message quotes the value as given).
    ({"shape.R_over_lambda": "x"}, 'shape.R_over_lambda="x"'),
]


@pytest.mark.parametrize(
    "overrides,set_arg", BAD, ids=[b[1] if isinstance(b[1], str) else b[1][-1] for b in BAD]
)
def test_bad_input_is_value_error_with_the_cli_message(cli, overrides, set_arg):
    sets = [set_arg] if isinstance(set_arg, str) else list(set_arg)
    code, line = cli.error("locate", "--single", *[a for s in sets for a in ("--set", s)])
    assert code == 2
    # Refused by `with_`, or (a node count outside the admissible range of the rod) by the run.
    with pytest.raises(ValueError) as raised:
        helixbif.Study.default().with_(**overrides).locate(single=True)
    assert str(raised.value) == line
    assert line.startswith("invalid input: ")


def test_bad_file(cli, tmp_path):
    missing = tmp_path / "missing.toml"
    code, line = cli.error("locate", missing)
    assert code == 2
    with pytest.raises(ValueError) as raised:
        helixbif.Study.from_file(missing)
    assert str(raised.value) == line
    with pytest.raises(ValueError, match="invalid input: study file"):
        helixbif.Study.from_toml("rod = [")
    with pytest.raises(ValueError, match="invalid input: "):
        helixbif.Study.from_toml("name = 'x'")


def test_lookup_and_types():
    study = helixbif.Study.default()
    with pytest.raises(KeyError):
        study["rod.nothing"]
    with pytest.raises(ValueError):
        study.with_(**{"rod.E": object()})
    with pytest.raises(ValueError):
        study.with_(3)
    assert isinstance(study.to_dict()["rod"], dict)


def test_a_kernel_copy_that_does_not_exist_refuses_the_import():
    env = dict(os.environ, HELIXBIF_KERNELS="avx3")
    child = subprocess.run(
        [sys.executable, "-c", "import helixbif"], env=env, capture_output=True, text=True
    )
    assert child.returncode != 0
    assert "ValueError" in child.stderr
    assert "invalid input: HELIXBIF_KERNELS: `avx3` is not a copy of the kernels" in child.stderr
    env["HELIXBIF_KERNELS"] = "baseline"
    ok = subprocess.run(
        [sys.executable, "-c", "import helixbif; print(helixbif.__version__)"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
