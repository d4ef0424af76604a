"""The type stubs (python/helixbif/__init__.pyi) as a user's editor sees them: every class and
function of the module is there, every method's arguments and defaults are the module's, and
every attribute a result answers to is annotated in its class."""

import ast
import inspect
import keyword
from pathlib import Path

import pytest

import helixbif

STUBS = Path(helixbif.__file__).with_name("__init__.pyi")


def stub_classes():
    tree = ast.parse(STUBS.read_text())
    classes = {}
    functions = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = {}
            for item in node.body:
                if isinstance(item, ast.AnnAssign):
                    members[item.target.id] = item
                elif isinstance(item, ast.FunctionDef):
                    members[item.name] = item
            classes[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            functions[node.name] = node
    return classes, functions


def stub_parameters(function):
    """(name, kind, default source) of a stub's parameters, without self."""
    args = function.args
    out = []
    positional = args.posonlyargs + args.args
    defaults = [None] * (len(positional) - len(args.defaults)) + list(args.defaults)
    for a, d in zip(positional, defaults):
        out.append((a.arg, "positional", None if d is None else ast.literal_eval(d)))
    if args.vararg:
        out.append((args.vararg.arg, "*", None))
    for a, d in zip(args.kwonlyargs, args.kw_defaults):
        out.append((a.arg, "keyword", None if d is None else ast.literal_eval(d)))
    if args.kwarg:
        out.append((args.kwarg.arg, "**", None))
    return [p for p in out if p[0] != "self"]


def module_parameters(function):
    kinds = {
        inspect.Parameter.POSITIONAL_ONLY: "positional",
        inspect.Parameter.POSITIONAL_OR_KEYWORD: "positional",
        inspect.Parameter.VAR_POSITIONAL: "*",
        inspect.Parameter.KEYWORD_ONLY: "keyword",
        inspect.Parameter.VAR_KEYWORD: "**",
    }
    out = []
    for p in inspect.signature(function).parameters.values():
        default = None if p.default is inspect.Parameter.empty else p.default
        out.append((p.name, kinds[p.kind], default))
    return [p for p in out if p[0] not in ("self", "$self")]


def test_every_name_of_the_module_is_in_the_stubs():
    classes, functions = stub_classes()
    for name in helixbif.__all__:
        assert name in classes or name in functions or name == "__version__", name


def test_study_signatures_are_the_modules():
    classes, functions = stub_classes()
    study = classes["Study"]
    for name in ["default", "from_file", "from_toml", "with_", "to_toml", "to_dict",
                 "locate", "branch", "solve", "boundary", "simulate", "orbits", "run"]:
        assert name in study, name
        assert stub_parameters(study[name]) == module_parameters(getattr(helixbif.Study, name)), name
    assert stub_parameters(functions["fit_power_law"]) == module_parameters(
        helixbif.fit_power_law
    )


def answered(result):
    """Every attribute a result answers to beyond the methods of its class (but Python's
    keywords, `from`, which only `getattr` and `result[key]` reach)."""
    names = set(dir(result)) - set(dir(type(result)))
    return {n for n in names if not keyword.iskeyword(n)}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    small = helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 20})
    out = tmp_path_factory.mktemp("stubs")
    return {
        "Located": [
            small.locate(single=True),
            small.locate(extrapolate=True, nodes=[20, 25, 30]),
            helixbif.Study.default().with_(**{"fluid.model": "lighthill", "discretization.nodes": 44}).locate(0.099),
        ],
        "Branch": [small.branch(omega_max=1.0, out=out / "branch")],
        "Solution": [small.solve(0.5)],
        "Simulation": [small.simulate(0.5, t_end=10, ramp_time=2, shape_every=20, out=out / "sim")],
        "Orbits": [small.orbits(max_orbits=3, steps=40, out=out / "orbits")],
        "Boundary": [
            helixbif.Study.default()
            .with_(**{"fluid.model": "lighthill", "discretization.nodes": 30})
            .boundary("shape.R_over_lambda", 0.318, 0.31, out=out / "boundary")
        ],
        "PowerLaw": [helixbif.fit_power_law([1.0, 2.0, 3.0], [1.0, 4.1, 8.9])],
        "StudyRun": [
            small.with_(
                study={"kind": "sweep", "vary": [{"key": "rod.E", "values": [1.2e6, 1.3e6]}]}
            ).run(out=out / "run")
        ],
    }


@pytest.mark.parametrize(
    "name",
    ["Located", "Branch", "Solution", "Simulation", "Orbits", "Boundary", "PowerLaw", "StudyRun"],
)
def test_every_attribute_of_a_result_is_annotated(results, name):
    classes, _ = stub_classes()
    annotated = set(classes[name]) | set(classes["_Result"])
    for result in results[name]:
        assert isinstance(result, getattr(helixbif, name))
        missing = answered(result) - annotated
        assert not missing, f"{name}: not in the stubs: {sorted(missing)}"
