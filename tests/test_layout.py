"""The package's layout: the library (core, scenarios, studies) and the book's machinery apart,
imports pointing one way: core <- scenarios <- studies <- book.

Every module of ``pfcourse`` belongs to one part (README, "The package"):

0. **core**: the top-level modules ``pfcourse/*.py``: the model protocol and the engine (filter,
   collectors, compiled kernels, resampling, results, filter settings), the algorithms (proposals,
   jitters, sample size, the Kalman family, smoothing, PMMH, the likelihood of a parameter),
   diagnostics, metrics, evidence (statistics of paired runs), seeding, and the plumbing
   (errors, checks, angles, the Gaussian density, numba settings, the pinned arithmetic);
1. **scenarios**: ``pfcourse.scenarios.landmarks``, ``.robot``, ``.terrain``, ``.maprobot``, each
   importing the core and itself only (scenarios do not know each other);
2. **studies**: ``pfcourse.studies`` (registry, runner, store, record, provenance, executor, the
   studies' row functions), importing the core and the scenarios;
3. **book**: ``pfcourse.book`` (style, narrow copies, legibility, figures, panels, report,
   exercises), importing anything and imported by nothing of the library.

A generic algorithm is defined in its core module only (``CORE_HOMES``).  ``pfcourse/__init__.py``
is the public facade: it re-exports core names only, so that ``import pfcourse`` is the library
without matplotlib (checked in a fresh interpreter).  Imports are read with ``ast`` (every
``import`` statement, including those inside functions), so nothing is executed.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pfcourse"
SCENARIOS = ("landmarks", "robot", "terrain", "maprobot")
RANK = {"core": 0, "scenarios": 1, "studies": 2, "book": 3}


def module_name(path: Path, package: Path = PACKAGE) -> str:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def group(module: str) -> str:
    """``core``, ``scenarios.<name>``, ``studies`` or ``book`` for a ``pfcourse...`` module name."""
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] == "scenarios":
        return f"scenarios.{parts[2]}" if len(parts) >= 3 else "scenarios"
    if len(parts) >= 2 and parts[1] in ("studies", "book"):
        return parts[1]
    return "core"


def rank(group_name: str) -> int:
    return RANK[group_name.split(".")[0]]


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
            # ``from pfcourse.scenarios import robot`` imports the subpackage ``pfcourse.scenarios.robot``
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
        if me == "pfcourse":  # the facade: the core only
            allowed = theirs == "core"
        elif mine.startswith("scenarios."):
            allowed = theirs in ("core", mine)
        else:
            allowed = rank(theirs) <= rank(mine)
        if not allowed:
            bad.append(f"{path.relative_to(package_dir.parent)}:{line}: {me} ({mine}) imports {target} ({theirs})")
    return bad


MODULES = sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_package_is_core_scenarios_studies_and_book():
    """The folders a newcomer sees (README, "The package")."""
    folders = {p.parent.relative_to(PACKAGE).as_posix() for p in MODULES if p.parent != PACKAGE}
    assert folders == {"scenarios", *(f"scenarios/{s}" for s in SCENARIOS), "studies", "book", "book/figures",
                       "book/exercises"}, folders


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path):
    assert violations(path) == []


def test_the_rule_catches_an_upward_import(tmp_path):
    """The checker itself: a core module importing a scenario, a scenario importing a study, another
    scenario or the book, and a study importing the book, are each reported; downward imports are not."""
    fake = tmp_path / "pfcourse"
    for folder in ("scenarios/robot", "scenarios/landmarks", "studies", "book"):
        (fake / folder).mkdir(parents=True)
    (fake / "filter.py").write_text("from pfcourse.scenarios.robot.scenario import RobotModel\n")
    (fake / "scenarios" / "robot" / "scenario.py").write_text(
        "from ...studies import study\nfrom pfcourse.scenarios.landmarks import simulate\nfrom ...filter import x\n"
        "from pfcourse.book import style\n")
    (fake / "studies" / "study.py").write_text("from pfcourse.scenarios.robot import scenario\nimport pfcourse.filter\n"
                                               "from pfcourse.book.style import COLORS\n")
    (fake / "book" / "style.py").write_text("from pfcourse.studies import study\nimport pfcourse.scenarios.robot\n")
    assert len(violations(fake / "filter.py", fake)) == 1
    assert len(violations(fake / "scenarios" / "robot" / "scenario.py", fake)) == 3
    assert len(violations(fake / "studies" / "study.py", fake)) == 1
    assert violations(fake / "book" / "style.py", fake) == []


def test_import_pfcourse_is_the_library_without_matplotlib():
    """``import pfcourse`` and every module of the library (core, scenarios, studies) load in a fresh
    interpreter without matplotlib (the book's machinery alone draws)."""
    library = [module_name(p) for p in MODULES if group(module_name(p)) != "book"]
    code = ("import sys, importlib\n"
            f"for name in {library!r}:\n"
            "    importlib.import_module(name)\n"
            "    assert 'matplotlib' not in sys.modules, name\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]


def test_version():
    import pfcourse

    assert pfcourse.__version__ == "0.4.0"


def test_rmse_is_written_once():
    """``sqrt(mean(e ** 2))`` is :func:`pfcourse.metrics.rmse`; no other module writes it out."""
    def is_rmse(node) -> bool:
        if not (isinstance(node, ast.Call) and ast.unparse(node.func).endswith("sqrt") and node.args):
            return False
        inner = node.args[0]
        # Any square under the mean: mean(e ** 2), mean(a ** 2 + b ** 2), mean(sum(e ** 2, axis=1)).
        return (isinstance(inner, ast.Call) and ast.unparse(inner.func).endswith("mean") and bool(inner.args)
                and any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Pow) for n in ast.walk(inner.args[0])))
    found = [f"{module_name(path)}:{node.lineno}" for path in MODULES
             for node in ast.walk(ast.parse(path.read_text())) if is_rmse(node)]
    assert {f.split(":")[0] for f in found} == {"pfcourse.metrics"}, found


#: Modules that may write a weighted circular mean beside pfcourse.angles, and why.
CIRCULAR_MEAN_EXCEPTIONS = {
    # the exact filter over a drive's twins: one weight vector per step (a (hypotheses, K) array), which
    # circular_mean (one weight vector) does not take; its stored map_global/exact_* tables were made with it
    "pfcourse.scenarios.maprobot.twins": 1,
    # the engine's compiled moments (weighted_moments, every FilterResult.mean): sin/cos sums accumulated in
    # one pass, relative to the first particle; circular_mean's complex resultant would move every stored
    # heading in its last bits (it differs by at most 1.0e-15 rad: tests/test_circular_mean_once.py)
    "pfcourse.kernels": 1,
}


def _weighted(node) -> bool:
    """Whether an expression weights or sums: ``@``, or a call of sum, mean, dot, einsum."""
    return any((isinstance(n, ast.BinOp) and isinstance(n.op, ast.MatMult)) or
               (isinstance(n, ast.Call) and ast.unparse(n.func).split(".")[-1] in ("sum", "mean", "dot", "einsum"))
               for n in ast.walk(node))


def _base_name(node) -> str | None:
    """``s`` for the expressions ``s`` and ``s[j]`` (an accumulator or its slot), else ``None``."""
    while isinstance(node, ast.Subscript):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def _assignments(scope) -> dict[str, list[tuple[ast.AST, bool]]]:
    """``{name: [(value, accumulated), ...]}``: what each name (or a slot of it) is given in ``scope``,
    ``accumulated`` for ``+=`` (a sum written as a loop); tuple assignments are paired element by element."""
    out: dict[str, list[tuple[ast.AST, bool]]] = {}
    for node in ast.walk(scope):
        pairs = []
        if isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple):
                    pairs += [(t, v, False) for t, v in zip(target.elts, node.value.elts)]
                else:
                    pairs.append((target, node.value, False))
        elif isinstance(node, ast.AugAssign):
            pairs.append((node.target, node.value, isinstance(node.op, ast.Add)))
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            pairs.append((node.target, node.value, False))
        for target, value, accumulated in pairs:
            name = _base_name(target)
            if name is not None:
                out.setdefault(name, []).append((value, accumulated))
    return out


def circular_means(source: str) -> int:
    """The weighted circular means written in ``source``: ``atan2(sum w sin, sum w cos)`` and
    ``angle(sum w exp(i a))`` written inline, and ``atan2(s, c)`` (or of their slots ``s[j], c[j]``) where
    ``s`` and ``c`` are given, in the same function, a weighted or accumulated (``+=``) sum of sines and of
    cosines (the compiled loop of :func:`pfcourse.kernels.weighted_moments`)."""
    tree = ast.parse(source)
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}

    def scope_of(node):
        while node in parents and not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            node = parents[node]
        return node

    def summed(arg, trig: str, given) -> bool:
        """``arg`` is (a slot of) a name given a weighted or accumulated sum containing ``trig``."""
        sources = given.get(_base_name(arg) or "", [])
        return (any(trig in ast.unparse(v) for v, _ in sources)
                and any(accumulated or _weighted(v) for v, accumulated in sources))

    found = 0
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and node.args):
            continue
        name, args = ast.unparse(node.func).split(".")[-1], [ast.unparse(a) for a in node.args]
        if name in ("arctan2", "atan2") and len(args) == 2:
            if "sin" in args[0] and "cos" in args[1] and _weighted(node.args[0]):
                found += 1
            elif _base_name(node.args[0]) and _base_name(node.args[1]):
                given = _assignments(scope_of(node))
                found += summed(node.args[0], "sin", given) and summed(node.args[1], "cos", given)
        elif name == "angle" and "exp" in args[0] and _weighted(node.args[0]):
            found += 1
    return found


def test_the_circular_mean_matcher_sees_inline_and_accumulated_means():
    """The matcher below finds each way a weighted circular mean is written, and not the bearings and
    headings that are not one (so that it can fail: a module that writes a mean of its own is seen)."""
    means = {
        "np.arctan2(w @ np.sin(a), w @ np.cos(a))": 1,
        "np.angle(np.sum(w * np.exp(1j * a)))": 1,
        "def f(a, w):\n    s, c = np.sum(w * np.sin(a)), np.sum(w * np.cos(a))\n    return np.arctan2(s, c)": 1,
        ("def f(x, w):\n    s = np.zeros(3); c = np.zeros(3)\n    for i in range(len(w)):\n"
         "        for j in range(3):\n            s[j] += w[i] * math.sin(x[i, j])\n"
         "            c[j] += w[i] * math.cos(x[i, j])\n    return [math.atan2(s[j], c[j]) for j in range(3)]"): 1,
        "np.arctan2(dy, dx) - theta": 0,
        "def f(a):\n    s, c = math.sin(a), math.cos(a)\n    return math.atan2(s, c)": 0,
        "def f(p, o):\n    d = p - o\n    return np.arctan2(d[:, 1], d[:, 0])": 0,
    }
    for source, count in means.items():
        assert circular_means(source) == count, source


def test_the_weighted_circular_mean_is_written_once():
    """``atan2(sum w sin, sum w cos)`` or ``angle(sum w exp(i a))``, inline or summed by a loop, is
    pfcourse.angles (``resultant``, ``circular_mean``, ``resultant_direction``); elsewhere only the listed
    exceptions."""
    found = Counter()
    for path in MODULES:
        count = circular_means(path.read_text())
        if count:
            found[module_name(path)] = count
    assert "pfcourse.angles" in found, "the matcher no longer sees pfcourse.angles' own mean"
    del found["pfcourse.angles"]
    assert dict(found) == CIRCULAR_MEAN_EXCEPTIONS


#: How a chapter must not read a stored study: the one reader is ``STUDIES[name].load()`` (the
#: table, its provenance in ``table.attrs["provenance"]``); the cross-checks against ``particles``
#: are read by ``registry.cross_check``.
OTHER_READERS = re.compile(r"read_csv\(|json\.loads?\(|np\.load\(|store import load|\.find\(|\bopen\(|read_text\(")
#: Raw data a chapter parses by hand (not a stored study): chapter -> the call that reads it.
RAW_DATA_READS = {"real_robot": "gzip.open(INTEL_LOG"}  # the Intel lab's CARMEN log, parsed line by line


@pytest.mark.parametrize("chapter", sorted((PACKAGE.parent / "book").glob("part*/*.py")), ids=lambda p: p.stem)
def test_chapters_read_stored_studies_one_way(chapter):
    code = "\n".join(line for line in chapter.read_text().splitlines() if not line.lstrip().startswith("#"))
    if chapter.stem in RAW_DATA_READS:
        assert RAW_DATA_READS[chapter.stem] in code, "a listed raw-data read is gone: remove it from the list"
        code = code.replace(RAW_DATA_READS[chapter.stem], "")
    assert not OTHER_READERS.findall(code)


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
    "run_tasks": "studies.executor",
    "SerialExecutor": "studies.executor",
    "StudyWarning": "studies.executor",
    "circular_mean": "angles",
    "resultant_direction": "angles",
    "pf_log_likelihood": "likelihood",
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
                     "pfcourse.scenarios.maprobot.drive")


@pytest.mark.parametrize("module", FILTER_REGISTRIES)
def test_a_scenario_names_its_filters_in_one_registry(module):
    """``FILTERS``: ``{name: FilterConfig}`` (pfcourse.filter_config), each filter built by its entry."""
    import importlib

    from pfcourse.filter_config import FilterConfig

    filters = importlib.import_module(module).FILTERS
    assert filters and all(isinstance(c, FilterConfig) and c.name == name for name, c in filters.items())
    # configurations as data (issue 44): each a FilterSettings record, its label derived from it and told
    # apart from the others', its provenance record plain data
    from pfcourse.filter_config import FilterSettings, records

    assert all(isinstance(c.settings, FilterSettings) for c in filters.values())
    assert all(c.label in (c.settings.label, c.settings.kind) or c.label.startswith(c.settings.label)
               for c in filters.values())
    assert len({c.label for c in filters.values()}) == len(filters)
    written = records(filters)
    assert json.loads(json.dumps(written)) == written


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
    """``python3 tasks.py study NAME`` runs a registered Study (the PMMH chains too, one chain a row); no
    study script is left in ``tools/studies/``, and no test loads one through ``sys.path``."""
    assert not list((ROOT / "tools" / "studies").glob("*.py"))
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
