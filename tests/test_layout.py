"""The package's layers: imports point one way, core <- scenarios <- experiments <- figures.

Every module of ``pfcourse`` belongs to one layer (README, "Layout"):

0. **core**: the top-level modules ``pfcourse/*.py`` (the engine, its compiled loops, weights
   and resampling, results, errors and checks, angles, the Gaussian density, plot style, and
   the generic algorithms, one idea per module named after it: the linear-Gaussian model, the
   Kalman filter, proposals, jitters, smoothing, PMMH, the executor loop), and the package
   ``pfcourse.book.exercises`` (the exercises' checkers, one module per part of the book);
1. **scenarios**: ``pfcourse.scenarios.landmarks``, ``pfcourse.scenarios.robot``, ``pfcourse.scenarios.terrain``;
2. **experiments**: ``pfcourse.studies``;
3. **figures**: ``pfcourse.book.figures``.

A module may import from its own layer or a lower one, and a scenario only from the core and
from itself (scenarios do not know each other).  A generic algorithm is defined in its core
module only (``CORE_HOMES``).  ``pfcourse/__init__.py`` is the public
facade: it re-exports core and scenario names, never experiments or figures, so that
``import pfcourse`` stays light.  Imports are read with ``ast`` (every ``import`` statement,
including those inside functions), so nothing is executed.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pfcourse"
SCENARIOS = ("landmarks", "robot", "terrain", "maprobot")
LAYER = {"core": 0, "exercises": 0, **{s: 1 for s in SCENARIOS}, "experiments": 2, "figures": 3}


def module_name(path: Path, package: Path = PACKAGE) -> str:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def group(module: str) -> str:
    """``core``, a scenario name, ``experiments`` or ``figures`` for a ``pfcourse...`` module name
    (``pfcourse.book.exercises.*`` is core)."""
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] in LAYER and parts[1] != "exercises":
        return parts[1]
    return "core"


def imported_modules(path: Path, package_dir: Path = PACKAGE) -> list[tuple[int, str]]:
    """``(line, module)`` of every pfcourse module imported by the file (relative imports resolved)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    here = module_name(path, package_dir).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names if alias.name.split(".")[0] == "pfcourse"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "pfcourse":
                continue
            # ``from pfcourse import robot`` imports the subpackage ``pfcourse.scenarios.robot``
            for alias in node.names:
                candidate = f"{target}.{alias.name}"
                sub = package_dir.parent / Path(*candidate.split("."))
                out.append((node.lineno, candidate if sub.is_dir() or sub.with_suffix(".py").exists() else target))
    return out


def violations(path: Path, package_dir: Path = PACKAGE) -> list[str]:
    me = module_name(path, package_dir)
    mine = group(me)
    bad = []
    for line, target in imported_modules(path, package_dir):
        theirs = group(target)
        if me == "pfcourse":  # the facade: core and scenarios only
            allowed = LAYER[theirs] <= 1
        elif mine in SCENARIOS:
            allowed = theirs in ("core", mine)
        else:
            allowed = LAYER[theirs] <= LAYER[mine]
        if not allowed:
            bad.append(f"{path.relative_to(package_dir.parent)}:{line}: {me} ({mine}) imports {target} ({theirs})")
    return bad


MODULES = sorted(PACKAGE.rglob("*.py"))


def test_every_subpackage_is_a_known_layer():
    subpackages = {p.parent.name for p in MODULES if p.parent != PACKAGE}
    assert subpackages <= set(LAYER), subpackages - set(LAYER)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path):
    assert violations(path) == []


def test_the_rule_catches_an_upward_import(tmp_path):
    """The checker itself: a core module importing a scenario, and a scenario importing
    experiments or another scenario, are each reported; downward imports are not."""
    fake = tmp_path / "pfcourse"
    (fake / "robot").mkdir(parents=True)
    (fake / "experiments").mkdir()
    (fake / "filter.py").write_text("from pfcourse.scenarios.robot.scenario import RobotModel\n")
    (fake / "robot" / "scenario.py").write_text(
        "from ..experiments import study\nfrom pfcourse.scenarios.landmarks import simulate\nfrom ..filter import x\n"
    )
    (fake / "experiments" / "study.py").write_text("from pfcourse.scenarios.robot import scenario\nimport pfcourse.filter\n")
    assert len(violations(fake / "filter.py", fake)) == 1
    assert len(violations(fake / "robot" / "scenario.py", fake)) == 2
    assert violations(fake / "experiments" / "study.py", fake) == []


def test_the_array_alias_is_defined_once():
    """``Array`` (``np.ndarray``) lives in pfcourse.checks; other modules import it."""
    defined = [f"{path.relative_to(PACKAGE)}:{node.lineno}"
               for path in sorted(PACKAGE.rglob("*.py"))
               for node in ast.walk(ast.parse(path.read_text()))
               if isinstance(node, (ast.Assign, ast.AnnAssign))
               and any(isinstance(t, ast.Name) and t.id == "Array"
                       for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))]
    assert len(defined) == 1 and defined[0].startswith("checks.py:"), defined


#: The generic algorithms, each in the core module named after it (README, "The package").
CORE_HOMES = {
    "run_tasks": "executor",
    "SerialExecutor": "executor",
    "StudyWarning": "executor",
    "ffbsm": "smoothing",
    "rts_smoother": "smoothing",
    "SmootherResult": "smoothing",
    "pmmh": "pmmh",
    "PMMHChain": "pmmh",
    "LinearGaussianModel": "linear_gaussian",
    "kalman_filter": "kalman",
    "gaussian_filter": "kalman",
    "GaussianModel": "kalman",
    "Linearised": "kalman",
    "Unscented": "kalman",
    "TransitionProposal": "proposals",
    "DensityProposal": "proposals",
    "OptimalProposal": "proposals",
    "FullyAdaptedAuxiliary": "proposals",
    "ProgressiveCorrection": "proposals",
    "Roughening": "jitter",
    "RegularisedJitter": "jitter",
    "FilterConfig": "filter_config",
    "configurations": "filter_config",
}


def top_level_definitions(path: Path) -> set[str]:
    """Names of the functions and classes a module defines at its top level."""
    return {node.name for node in ast.parse(path.read_text()).body
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}


@pytest.mark.parametrize("name", sorted(CORE_HOMES))
def test_a_generic_algorithm_lives_in_its_core_module_only(name):
    homes = [module_name(path) for path in MODULES if name in top_level_definitions(path)]
    assert homes == [f"pfcourse.{CORE_HOMES[name]}"], homes


ROOT = PACKAGE.parent
#: The registries of named filter configurations (README, "Layout"): one per scenario of a comparison.
FILTER_REGISTRIES = ("pfcourse.studies.rb_study", "pfcourse.studies.terrain_remedies", "pfcourse.scenarios.robot.mcl",
                     "pfcourse.studies.maprobot")


@pytest.mark.parametrize("module", FILTER_REGISTRIES)
def test_a_scenario_names_its_filters_in_one_registry(module):
    """``FILTERS``: ``{name: FilterConfig}`` (pfcourse.filter_config), each filter built by its entry."""
    import importlib

    from pfcourse.filter_config import FilterConfig

    filters = importlib.import_module(module).FILTERS
    assert filters and all(isinstance(c, FilterConfig) and c.name == name for name, c in filters.items())


def test_no_string_dispatch_factory():
    """No ``make_filter`` (the factories that dispatched on a name with an if-chain) in the package or the
    chapters: a filter is looked up by name in its registry (``FILTERS[name].build(...)``)."""
    sources = [*MODULES, *sorted((ROOT / "book").rglob("*.py"))]
    offenders = [str(path.relative_to(ROOT)) for path in sources
                 if any(isinstance(node, ast.Name) and node.id == "make_filter" or
                        isinstance(node, (ast.FunctionDef, ast.alias)) and getattr(node, "name", None) == "make_filter"
                        for node in ast.walk(ast.parse(path.read_text())))]
    assert not offenders, offenders


def test_every_stored_study_is_registered():
    """``python3 tasks.py study NAME`` runs a registered Study; ``tools/studies/`` keeps only the PMMH chains
    (a chain is one dependent sequence, not independent seeded runs: see tools/studies/pmmh.py), and no
    test loads a study script through ``sys.path``."""
    assert sorted(p.name for p in (ROOT / "tools" / "studies").glob("*.py")) == ["pmmh.py"]
    for test in sorted((ROOT / "tests").glob("test_*.py")):
        source = test.read_text()
        for node in ast.walk(ast.parse(source)):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and ast.unparse(node.func.value) == "sys.path"):
                assert "studies" not in ast.get_source_segment(source, node), test.name


#: The experiment-level result classes that one run record replaced (issue 28): an experiment
#: records a filter on a run as a pfcourse.studies.record.RunRecord.
REPLACED_BY_THE_RUN_RECORD = ("RunMetrics", "GlobalRun", "RunScores", "MonteCarloResult", "Track", "ConvergenceResult")


def test_one_run_record():
    defined = {name: [module_name(path) for path in MODULES if name in top_level_definitions(path)]
               for name in ("RunRecord", "record_run", *REPLACED_BY_THE_RUN_RECORD)}
    assert defined.pop("RunRecord") == ["pfcourse.studies.record"]
    assert defined.pop("record_run") == ["pfcourse.studies.record"]
    assert all(not homes for homes in defined.values()), defined


#: filterpy's Kalman classes and the modules allowed to import them: the family's one loop is
#: pfcourse.kalman.gaussian_filter (README, "The package"); smoothing uses only KalmanFilter's RTS pass.
FILTERPY_HOMES = {"KalmanFilter": {"pfcourse.smoothing"}, "ExtendedKalmanFilter": set(),
                  "UnscentedKalmanFilter": set(), "MerweScaledSigmaPoints": {"pfcourse.kalman"},
                  "unscented_transform": {"pfcourse.kalman"}}


@pytest.mark.parametrize("name", sorted(FILTERPY_HOMES))
def test_the_kalman_family_runs_in_one_loop(name):
    users = {module_name(path) for path in MODULES
             for node in ast.walk(ast.parse(path.read_text()))
             if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("filterpy")
             and any(alias.name == name for alias in node.names)}
    assert users == FILTERPY_HOMES[name], users


#: The modules that may catch a filter's collapse (a StepError): the one failure policy (the run record and
#: the study runner), and the likelihood estimate, whose value is exactly 0 (-inf in logs) when every
#: particle has zero weight (an estimate, not a recorded failure).
COLLAPSE_CATCHERS = {"pfcourse.studies.record", "pfcourse.studies.study", "pfcourse.likelihood"}


def test_only_the_failure_policy_catches_a_collapse():
    """A row function lets a StepError through to the study runner, which records it (issue 28)."""
    collapse = {"StepError", "DegenerateWeightsError", "NumericalError", "ModelError"}
    catchers = {module_name(path) for path in MODULES for node in ast.walk(ast.parse(path.read_text()))
                if isinstance(node, ast.ExceptHandler) and node.type is not None
                and collapse & {n.id if isinstance(n, ast.Name) else getattr(n, "attr", "")
                                for n in ast.walk(node.type)}}
    assert catchers == COLLAPSE_CATCHERS, catchers


#: Hand-made statistics that pfcourse.evidence provides (issue 28): a slope with its interval is
#: evidence.log_slope or evidence.regression_slope, a resampled interval evidence.run_interval (one
#: resample count, N_RESAMPLES).
HAND_STATISTICS = ("np.polyfit", "stats.bootstrap", "linregress", "np.linalg.lstsq")


@pytest.mark.parametrize("chapter", sorted((ROOT / "book").glob("part*/*.py")), ids=lambda p: p.stem)
def test_chapters_compute_slopes_and_intervals_through_evidence(chapter):
    source = chapter.read_text()
    code = "\n".join(line.split("#")[0] for line in source.splitlines())  # comments may name them
    assert not [name for name in HAND_STATISTICS if name in code]
