"""The runs: every result equals the command line's --json on the same input (every number to
the last digit, all but the wall time and the output folder), the arrays equal the CSV files
the command line writes, with the documented shapes and dtypes."""

import csv
import json

import numpy as np
import pytest

import helixbif
from conftest import scrub

# Lighthill's operator at N = 20: the runs compared take well under a second.
LIGHTHILL = ("--set", "fluid.model=lighthill")
SMALL = (*LIGHTHILL, "--set", "discretization.nodes=20")


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows


def assert_columns_equal(columns, path):
    """The arrays equal the CSV file's columns, number for number."""
    rows = read_csv(path)
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    assert list(columns) == header
    for name, array in columns.items():
        assert array.shape == (len(rows),), name
        cells = [r[name] for r in rows]
        if array.dtype == np.bool_:
            assert [str(v).lower() for v in array] == cells, name
        elif array.dtype == np.int64:
            assert [int(c) for c in cells] == array.tolist(), name
        elif array.dtype == np.float64:
            expected = [float(c) if c != "" else float("nan") for c in cells]
            np.testing.assert_array_equal(array, np.array(expected), err_msg=name)
        else:
            assert array.dtype.kind == "U", name
            assert array.tolist() == cells, name


def test_locate_single(cli, small):
    located = small.locate(single=True)
    assert isinstance(located, helixbif.Located)
    assert located.to_dict() == cli.json("locate", "--single", *SMALL)
    assert located.kind == "hopf" and located.resolution == "single"
    assert located.omega_b == located["omega_b"] and located.error is None
    assert isinstance(located.omega_b, float) and isinstance(located.nodes, int)
    assert located.criticality in ("subcritical", "supercritical", "undetermined")
    assert "omega_b" in dir(located) and "omega_b" in located.keys()


def test_locate_default_resolution(cli):
    """The representative helix at its own N = 60, on the default fluid (the RPY line)."""
    located = helixbif.Study.default().locate(single=True)
    assert located.to_dict() == cli.json("locate", "--single")


def test_locate_converged_default_answers_with_the_limit_of_its_rungs(cli):
    """The README's first command: the representative helix refined on the RPY line to 1e-3
    (rungs 60, 119, 237; about four seconds), the same from Python as from the command line. Its
    answer is the limit in N of the three rungs: the finest rung alone, whose own error is kept
    beside it, would not have reached the accuracy."""
    located = helixbif.Study.default().locate()
    assert scrub(located.to_dict()) == scrub(cli.json("locate"))
    assert located.answer == "limit" and located.reached
    assert [r["nodes"] for r in located.rungs] == [60, 119, 237]
    assert located.relative_error < 1e-3 < located.finest_error / located.omega_b_finest


@pytest.fixture(scope="module")
def refined():
    """A refinement of two rungs (N = 44, then 87, the largest admissible N: about a second)
    whose error estimate, 9.8e-2, is below the accuracy asked for."""
    return helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 44}).locate(0.099)


def test_locate_refined(cli, refined):
    expected = cli.json("locate", "--accuracy", "0.099", *LIGHTHILL, "--set", "discretization.nodes=44")
    assert scrub(refined.to_dict()) == scrub(expected)
    assert refined.resolution == "refine" and refined.reached
    assert [r["nodes"] for r in refined.rungs] == [44, 87]
    assert refined.error == refined["omega_b_error"] and refined.error > 0
    assert refined.relative_error < 0.099 and refined.stopped is None


def test_locate_short_of_its_accuracy(cli):
    """The default accuracy 1e-3 is out of reach below N = 87: the command line prints the
    report, then fails (exit 1) with one line; Python raises NumericalError with that line and
    the whole result as `partial`."""
    done = cli.run("locate", *LIGHTHILL, "--set", "discretization.nodes=44", "--json")
    assert done.returncode == 1, done.stderr
    line = done.stderr.strip().splitlines()[-1]
    with pytest.raises(helixbif.NumericalError) as raised:
        helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 44}).locate()
    error = raised.value
    assert line == "helixbif: error: " + str(error) and error.message == str(error)
    assert error.message.startswith("numerical failure: accuracy 1e-3 not reached at N = 87")
    located = error.partial
    assert isinstance(located, helixbif.Located)
    assert scrub(located.to_dict()) == scrub(json.loads(done.stdout))
    assert not located.reached and located.relative_error > 1e-3 and located.stopped
    assert [r["nodes"] for r in located.rungs] == [44, 87]


def test_locate_ladder_and_tol(cli, small):
    located = small.locate(extrapolate=True, nodes=[20, 25, 30], tol=1e-6)
    expected = cli.json(
        "locate", "--extrapolate", "--nodes", "20,25,30", "--tol", "1e-6", *SMALL
    )
    assert located.to_dict() == expected
    assert located.resolution == "ladder" and located.nodes == [20, 25, 30]


def test_locate_bad_options(small):
    for kwargs, field in [
        ({"accuracy": 0.5}, "accuracy"),
        ({"max_nodes": -3}, "max_nodes"),
        ({"tol": 0.5}, "tol"),
        ({"single": True, "extrapolate": True}, "single"),
        ({"single": True, "accuracy": 1e-3}, "accuracy"),
        ({"nodes": [20]}, "nodes"),
        ({"extrapolate": True, "nodes": [-1, 20]}, "nodes"),
    ]:
        with pytest.raises(ValueError, match=f"^invalid input: {field}: "):
            small.locate(**kwargs)
    # A refinement capped at the study's own N (20) has no finer rung.
    with pytest.raises(ValueError, match="^invalid input: max_nodes: must exceed discretization"):
        small.locate(max_nodes=20)


def test_branch(cli, small, tmp_path):
    out = tmp_path / "py"
    branch = small.branch(omega_max=1.5, out=out)
    expected = cli.json("branch", "--omega-max", "1.5", "--out", tmp_path / "cli", *SMALL)
    assert scrub(branch.to_dict()) == scrub(expected)
    assert branch.out == str(out) and (out / "branch.csv").is_file()
    assert_columns_equal(branch.columns, tmp_path / "cli" / "branch.csv")
    n = branch.points
    for name in ["s", "omega", "omegabar", "Fp", "Fpbar", "Fpbar_rigid", "Tp", "eta", "h", "hbar", "max_re"]:
        column = getattr(branch, name)
        assert column.dtype == np.float64 and column.shape == (n,), name
    assert branch.stable.dtype == np.bool_ and branch.n_unstable.dtype == np.int64
    assert np.isnan(branch.eta[0])  # undefined at rest
    assert [e["kind"] for e in branch.events] == ["hopf"]
    assert not branch.stable[-1] and branch.stable[0]


def test_branch_default_folder(small):
    branch = small.branch(omega_max=0.3)
    assert "helixbif-branch-" in branch.out


def test_unusable_out(small, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ValueError, match="^invalid input: out: cannot write results into "):
        small.branch(omega_max=0.3, out=blocker / "sub")
    with pytest.raises(ValueError, match="^invalid input: omega_max: "):
        small.branch(omega_max=float("inf"))


def test_solve(cli, small, tmp_path):
    solution = small.solve(0.5)
    assert solution.to_dict() == cli.json("solve", "--omega", "0.5", *SMALL)
    # Every observable with its error, from N = 11 (Lighthill: no quadrature of its own).
    assert solution.errors_missing is None and solution.errors["coarse_nodes"] == 11
    assert solution.errors["quadrature_compared_with"] is None
    assert all(solution.errors[k] > 0 for k in ["Fp", "Tp", "h", "hbar", "Fpbar_rigid"])
    shape = tmp_path / "shape.csv"
    cli.json("solve", "--omega", "0.5", "--shape", shape, *SMALL)
    rows = read_csv(shape)
    assert solution.positions.shape == (20, 3) and solution.positions.dtype == np.float64
    expected = np.array([[float(r[k]) for k in "xyz"] for r in rows])
    np.testing.assert_array_equal(solution.positions, expected)
    assert solution.theta.shape == (19,)
    np.testing.assert_array_equal(solution.theta, [float(r["theta"]) for r in rows[:-1]])
    with pytest.raises(ValueError, match="^invalid input: omega: "):
        small.solve(float("nan"))


def test_boundary(cli, tmp_path):
    study = helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 30})
    boundary = study.boundary("shape.R_over_lambda", 0.318, 0.3)
    expected = cli.json(
        "boundary", "--vary", "shape.R_over_lambda", "--from", "0.318", "--to", "0.3",
        "--out", tmp_path / "cli", *LIGHTHILL, "--set", "discretization.nodes=30",
    )
    assert scrub(boundary.to_dict()) == scrub(expected)
    assert_columns_equal(boundary.columns, tmp_path / "cli" / "boundary.csv")
    assert boundary.q.shape == (boundary["points"],) and boundary.q[0] == 0.318
    assert boundary.kind.dtype.kind == "U" and boundary.criticality.dtype.kind == "U"
    assert isinstance(boundary["criticality"], dict)


def test_boundary_failure_carries_the_partial_curve(cli, small, tmp_path):
    args = ["--vary", "shape.R_over_lambda", "--from", "0.318", "--to", "0.25"]
    code, line = cli.error("boundary", *args, "--out", tmp_path / "cli", *SMALL)
    assert code == 1
    with pytest.raises(helixbif.NumericalError) as raised:
        small.boundary("shape.R_over_lambda", 0.318, 0.25, out=tmp_path / "py")
    error = raised.value
    assert str(error) == line == error.message
    assert isinstance(error, RuntimeError)
    partial = error.partial
    assert isinstance(partial, helixbif.Boundary)
    assert partial.q.size > 0 and partial.out == str(tmp_path / "py")
    assert_columns_equal(partial.columns, tmp_path / "cli" / "boundary.csv")
    with pytest.raises(ValueError, match="^invalid input: vary: "):
        small.boundary("rod.nothing", 1.0, 2.0)
    with pytest.raises(ValueError, match="^invalid input: start/stop: "):
        small.boundary("rod.E", 1e6, 1e6)


def test_simulate(cli, small, tmp_path):
    args = ["--omega", "0.5", "--t-end", "30", "--ramp-time", "5", "--shape-every", "20"]
    expected = cli.json("simulate", *args, "--out", tmp_path / "cli", *SMALL)
    sim = small.simulate(0.5, t_end=30, ramp_time=5, shape_every=20, out=tmp_path / "py")
    assert scrub(sim.to_dict()) == scrub(expected)
    assert_columns_equal(sim.columns, tmp_path / "cli" / "timeseries.csv")
    assert sim.t.dtype == np.float64 and sim.t.shape == (sim.steps + 1,)
    frames = len(sim.shape_times)
    assert frames >= 2 and sim.shapes.shape == (frames, 20, 3)
    rows = read_csv(tmp_path / "cli" / "shapes.csv")
    np.testing.assert_array_equal(
        sim.shapes.reshape(-1, 3), [[float(r[k]) for k in "xyz"] for r in rows]
    )
    assert sim["omega"] == 0.5 and sim.omega.shape == sim.t.shape
    with pytest.raises(ValueError, match="^invalid input: perturb: "):
        small.simulate(0.5, t_end=1.0, perturb=1e-3)
    with pytest.raises(ValueError, match="^invalid input: t_end: "):
        small.simulate(0.5, t_end=-1.0)


def test_orbits(cli, small, tmp_path):
    args = ["--max-orbits", "4", "--steps", "40"]
    expected = cli.json("orbits", *args, "--out", tmp_path / "cli", *SMALL)
    orbits = small.orbits(max_orbits=4, steps=40, out=tmp_path / "py")
    assert scrub(orbits.to_dict()) == scrub(expected)
    assert_columns_equal(orbits.columns, tmp_path / "cli" / "orbits.csv")
    assert orbits.period.shape == (orbits["orbits"],) and orbits.stable.dtype == np.bool_
    assert orbits.verdict.dtype.kind == "U"
    steady = orbits.steady
    assert set(steady) >= {"omega", "hbar", "stable"} and steady["omega"].dtype == np.float64
    with pytest.raises(ValueError, match="^invalid input: max_orbits: "):
        small.orbits(max_orbits=1)


def test_fit_power_law(cli, tmp_path):
    x = [0.2, 0.25, 0.318, 0.4, 0.5]
    y = [3.1, 2.2, 1.5, 1.01, 0.71]
    path = tmp_path / "data.csv"
    path.write_text("x,y\n" + "".join(f"{a},{b}\n" for a, b in zip(x, y)))
    expected = cli.json("fit", path, "--x", "x", "--y", "y")
    fit = helixbif.fit_power_law(np.array(x), y)
    assert fit.to_dict() == {k: expected[k] for k in fit.keys()}
    assert set(fit.keys()) == {"C", "p", "C_ci", "p_ci", "n", "r2", "residuals"}
    assert fit.residuals.dtype == np.float64 and fit.residuals.shape == (5,)
    with pytest.raises(ValueError, match="^invalid input: fit: "):
        helixbif.fit_power_law([1.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="^invalid input: fit: "):
        helixbif.fit_power_law([1.0, 2.0, -3.0], [1.0, 2.0, 3.0])


def test_to_pandas(small, refined):
    pandas = pytest.importorskip("pandas")
    branch = small.branch(omega_max=0.5)
    frame = branch.to_pandas()
    assert isinstance(frame, pandas.DataFrame) and list(frame.columns) == list(branch.columns)
    assert len(frame) == branch.points
    assert list(refined.to_pandas()["nodes"]) == [44, 87]
    series = small.locate(single=True).to_pandas()
    assert series["omega_b"] == small.locate(single=True).omega_b


def test_result_attributes(small):
    located = small.locate(single=True)
    with pytest.raises(AttributeError):
        located.nothing
    with pytest.raises(KeyError):
        located["nothing"]
    assert repr(located).startswith("Located(study='representative', kind='hopf'")
    # to_dict gives a fresh dict each time.
    d = located.to_dict()
    d["omega_b"] = 0.0
    assert located.to_dict()["omega_b"] != 0.0


def test_boundary_carried_to_an_accuracy_falls_short_as_the_cli_does(cli, small, tmp_path):
    """Every point carried to 1e-3 with at most 30 nodes (Lighthill at N = 20 and 30 is far
    from it):
    the CLI prints the report and exits 1 with one line; Python raises that line with the whole
    boundary as `partial`, every point refined past the curve's N and marked not reached."""
    args = ["--vary", "shape.R_over_lambda", "--from", "0.318", "--to", "0.317"]
    refine = ["--accuracy", "1e-3", "--max-nodes", "30"]
    code, line = cli.error("boundary", *args, *refine, "--out", tmp_path / "cli", *SMALL)
    assert code == 1 and "accuracy 1e-3 not reached at" in line
    with pytest.raises(helixbif.NumericalError) as raised:
        small.boundary(
            "shape.R_over_lambda", 0.318, 0.317, accuracy=1e-3, max_nodes=30, out=tmp_path / "py"
        )
    assert str(raised.value) == line
    partial = raised.value.partial
    assert_columns_equal(partial.columns, tmp_path / "cli" / "boundary.csv")
    assert partial["not_reached"] == partial["carried"] == partial["points"] == partial.q.size
    assert partial["first_shortfall"] == (
        "at shape.R_over_lambda = 0.318, the next refinement would pass --max-nodes 30 (at N = 30)"
    )
    assert partial.reached.dtype == np.bool_
    assert (partial.curve_nodes == 20).all() and (partial.nodes == 30).all()
    assert (partial.omega_b != partial.curve_omega_b).all()
    assert (partial.answer == "refined").all()
    with pytest.raises(ValueError, match="^invalid input: accuracy: "):
        small.boundary("rod.E", 1e6, 2e6, accuracy=0.5)
    with pytest.raises(ValueError, match="^invalid input: max_nodes: "):
        small.boundary("rod.E", 1e6, 2e6, max_nodes=100)
    with pytest.raises(ValueError, match="^invalid input: max_nodes: must exceed discretization"):
        small.boundary("rod.E", 1e6, 2e6, accuracy=1e-3, max_nodes=20)
    with pytest.raises(ValueError, match="^invalid input: carry_spacing: .* needs accuracy$"):
        small.boundary("rod.E", 1e6, 2e6, carry_spacing=0.1)
    with pytest.raises(ValueError, match=r"^invalid input: carry_spacing: must be in \[0, 1\]"):
        small.boundary("rod.E", 1e6, 2e6, accuracy=1e-3, carry_spacing=2.0)


def test_run_a_study_file_as_the_command_line_does(cli, small, tmp_path):
    """`Study.run` is `helixbif run` on the same study: the same JSON (but the wall times and
    folders) and the kind's table at the top of `out` as columns, the call in `meta.json`."""
    sweep = small.with_(study={"kind": "sweep", "vary": [{"key": "rod.E", "values": [1.2e6, 1.3e6]}]})
    path = tmp_path / "sweep.toml"
    path.write_text(sweep.to_toml())
    expected = cli.json("run", path, "--out", tmp_path / "cli")
    run = helixbif.Study.from_file(path).run(out=tmp_path / "py")
    assert isinstance(run, helixbif.StudyRun)

    def in_dir(value, folder):
        """`value` with `folder` written as DIR (the summary names its table's path)."""
        return json.loads(json.dumps(scrub(value)).replace(str(tmp_path / folder), "DIR"))

    assert in_dir(run.to_dict(), "py") == in_dir(expected, "cli")
    assert run.kind == "sweep" and run.study == sweep.name and run.out == str(tmp_path / "py")
    assert run.result["summary"]["points"] == 2
    # sweep.csv as the command line wrote it, but each point's wall time.
    rows = read_csv(tmp_path / "cli" / "sweep.csv")
    timed = tmp_path / "timed.csv"
    with open(timed, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=[k for k in rows[0] if k != "seconds"])
        writer.writeheader()
        writer.writerows([{k: v for k, v in r.items() if k != "seconds"} for r in rows])
    assert_columns_equal({k: v for k, v in run.columns.items() if k != "seconds"}, timed)
    assert "omega_b" in run.columns and not hasattr(run, "omega_b")
    meta = json.loads((tmp_path / "py" / "meta.json").read_text())
    assert meta["command_line"] == ["python", "helixbif.Study.run", f"out={tmp_path / 'py'}"]
    assert meta["run"] == run.result


def test_run_of_several_cases_has_no_table_at_the_top_of_its_folder(small, tmp_path):
    """A branch study of two cases writes its tables in their subfolders: its result has no
    columns, even where a study of one case left a `branch.csv` at the top of the same folder."""
    one = small.with_(branch={"omega_max": 0.3}, study={"kind": "branch"})
    assert len(one.run(out=tmp_path).columns["omega"]) > 1
    cases = [{"label": "E1", "set": {"rod.E": 1.2e6}}, {"label": "E2", "set": {"rod.E": 1.3e6}}]
    two = small.with_(branch={"omega_max": 0.3}, study={"kind": "branch", "cases": cases}).run(out=tmp_path)
    assert (tmp_path / "branch.csv").exists() and (tmp_path / "e1" / "branch.csv").exists()
    assert two.columns == {} and [c["case"] for c in two.result["cases"]] == ["E1", "E2"]


def test_run_resumes_a_dynamics_study(small, tmp_path):
    """`resume=True` is `--resume`: each simulation goes on from the checkpoint the first run
    left, its rows up to it read back, not computed again (a row marked in the file stays, the
    series extended to the longer `t_end`); a checkpoint of a run with other options is refused
    before anything runs, naming `resume`."""
    plan = {"kind": "dynamics", "omegas": [0.3, 0.5], "t_end": 6.0, "transient": 3.0, "ramp_time": 2.0}
    first = small.with_(study=plan).run(out=tmp_path)
    series = sorted(tmp_path.glob("omega_*/timeseries.csv"))
    assert len(series) == 2 and len(first.columns["omega"]) == 2

    def hbar_of_first_step(path, value=None):
        lines = path.read_text().splitlines()
        column = lines[0].split(",").index("hbar")
        cells = lines[2].split(",")
        if value is not None:
            cells[column] = value
            lines[2] = ",".join(cells)
            path.write_text("\n".join(lines) + "\n")
        return cells[column], len(lines)

    counts = [hbar_of_first_step(p, "9.5")[1] for p in series]
    again = small.with_(study={**plan, "t_end": 8.0}).run(out=tmp_path, resume=True)
    for path, count in zip(series, counts):
        marked, lines = hbar_of_first_step(path)
        assert marked == "9.5" and lines > count
    assert all(a > b for a, b in zip(again.columns["steps"], first.columns["steps"]))
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["command_line"][-1] == "resume=True"
    other = small.with_(study={**plan, "ramp_time": 3.0})
    with pytest.raises(ValueError, match="^invalid input: resume: .*other options"):
        other.run(out=tmp_path, resume=True)
    fresh = small.with_(study=plan).run(out=tmp_path)
    assert all(hbar_of_first_step(p)[0] != "9.5" for p in series)
    assert fresh.columns["steps"].tolist() == first.columns["steps"].tolist()


def test_run_short_of_its_accuracy_raises_with_what_the_study_recorded(cli, tmp_path):
    """A study whose answer falls short of its accuracy (locate refined from N = 44 on
    Lighthill's operator, capped at N = 87) fails as `helixbif run` does (exit 1, the same line
    but the folder), after writing its results; `partial` holds what meta.json recorded."""
    study = helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 44})
    path = tmp_path / "short.toml"
    path.write_text(study.to_toml())
    code, line = cli.error("run", path, "--out", tmp_path / "cli")
    assert code == 1
    with pytest.raises(helixbif.NumericalError) as raised:
        study.run(out=tmp_path / "py")
    error = raised.value
    assert str(error).replace(str(tmp_path / "py"), "DIR") == line.replace(str(tmp_path / "cli"), "DIR")
    partial = error.partial
    assert isinstance(partial, helixbif.StudyRun) and partial.kind == "locate"
    recorded = json.loads((tmp_path / "py" / "meta.json").read_text())["run"]
    assert partial.result == recorded and partial.result["result"]["reached"] is False
    assert partial.columns == {}
    assert (tmp_path / "py" / "locate.json").exists()
