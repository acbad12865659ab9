"""The public-API rule: no module of the repository (rockjax, its tests, experiments, benchmarks,
the calibrate package) imports another module's private names (``_name``), neither by
``from x import _name`` nor by attribute access ``module._name`` on an imported repository
module. A private module of a package (``rockjax._checks``) serves its own package only.
Private names inside their own module are fine. Checked on the source with ``ast``."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("rockjax", "tests", "experiments", "benchmarks", "calibrate")

# Uses in files outside this change, to be made public by their modules' owners; the list may
# only shrink.
KNOWN: set[tuple[str, str]] = set()


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[0] in ("tests", "experiments", "benchmarks"):
        parts = parts[1:]  # run with their folder on sys.path: `import helpers`, `_timing`
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _local_modules() -> dict[str, Path]:
    out = {}
    for top in SCANNED:
        for path in (ROOT / top).rglob("*.py"):
            out[_module_name(path)] = path
    return out


MODULES = _local_modules()


def _is_local(name: str) -> bool:
    return name in MODULES


def _absolute(path: Path, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    here = _module_name(path).split(".")
    is_pkg = path.name == "__init__.py"
    base = here if is_pkg else here[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


def _package(module: str) -> str:
    return module.rsplit(".", 1)[0] if "." in module else ""


def _violations(path: Path, source: str | None = None) -> list[str]:
    """``module.private_name`` strings that ``path`` (or ``source`` as if it were there)
    reaches into."""
    me = _module_name(path)
    tree = ast.parse(path.read_text() if source is None else source, filename=str(path))
    bound: dict[str, str] = {}  # local name -> repository module it is bound to
    found = []

    def reach(module: str, name: str, lineno: int) -> None:
        if not _private(name) or module == me:
            return
        target = f"{module}.{name}"
        if target in MODULES and _package(target) == _package(me):
            return  # a private module of my own package (rockjax._checks in rockjax)
        if target in MODULES and me.startswith(_package(target) + "."):
            return  # ... or of a package I am inside
        found.append(f"{target} (line {lineno})")

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _is_local(alias.name):
                    for i, part in enumerate(alias.name.split(".")[1:], start=1):
                        reach(".".join(alias.name.split(".")[:i]), part, node.lineno)
                    if alias.asname:
                        bound[alias.asname] = alias.name
                    else:
                        top = alias.name.split(".")[0]
                        bound[top] = top
        elif isinstance(node, ast.ImportFrom):
            module = _absolute(path, node)
            if not _is_local(module):
                continue
            parts = module.split(".")
            for i in range(1, len(parts)):
                reach(".".join(parts[:i]), parts[i], node.lineno)
            for alias in node.names:
                reach(module, alias.name, node.lineno)
                sub = f"{module}.{alias.name}"
                if _is_local(sub):
                    bound[alias.asname or alias.name] = sub
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            chain = []
            base = node
            while isinstance(base, ast.Attribute):
                chain.append(base.attr)
                base = base.value
            if not (isinstance(base, ast.Name) and base.id in bound):
                continue
            module = bound[base.id]
            for attr in reversed(chain):
                reach(module, attr, node.lineno)
                if not _is_local(f"{module}.{attr}"):
                    break
                module = f"{module}.{attr}"
    return sorted(set(found))


def test_rule_sees_the_three_kinds_of_reach():
    """The checker itself: it flags ``from x import _y``, ``module._y`` and a chain
    ``rj.metrics._y``, and lets ``module.public`` and a module's own private names pass."""
    probe = ROOT / "tests" / "_probe_private_imports.py"
    source = (
        "import rockjax as rj\n"
        "from rockjax import metrics\n"
        "from rockjax.cli import _load\n"
        "from rockjax._checks import check_choice\n"
        "def _mine(): pass\n"
        "_mine(); metrics.peaks; metrics._hidden; rj.metrics._deep\n"
    )
    got = _violations(probe, source)
    assert got == [
        "rockjax._checks (line 4)",
        "rockjax.cli._load (line 3)",
        "rockjax.metrics._deep (line 6)",
        "rockjax.metrics._hidden (line 6)",
    ]


def test_no_module_imports_another_modules_private_names():
    bad = []
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            for v in _violations(path):
                if (rel, v.split(" ")[0]) not in KNOWN:
                    bad.append(f"{rel}: {v}")
    assert not bad, "private names used outside their module:\n" + "\n".join(bad)


# ----------------------------------------------------------------------------- parameter counts

MAX_PARAMETERS = 8
"""The most parameters a public function or method of rockjax may take (``self``/``cls`` not
counted; ``*args`` and ``**kwargs`` count one each). Past that a call reads better with an
option object, as the mode (``mode=rj.Facade(gap=)``) and the joint (``joint=rj.Joint()``) are."""

# Public functions over the limit, with their counts. The list may only shrink and a count only
# fall: the test fails on a new function over the limit, a count that grew, and an entry that
# is no longer over it (remove it then).
WIDE: dict[str, int] = {
    # options being gathered into model objects in other changes; to shrink there
    "ida": 19,
    "fit_beta": 17,
    "fit_e": 9,
    "simulate_dem": 18,  # rockjax/dem/
    "calibration.problem": 9,
    "campaign.run": 9,
    # a simulator's and a reader's keywords, each one documented choice of the run or the file
    # (initial state, step, law, moving wall, diffrax solver; columns, units, delimiter)
    "simulate_housner": 15,
    "read_csv": 13,
    # the pull (d_over_b, duration, n_out) and the DEM's own keywords (beta, joint, phi_deg, gap)
    "pushover": 10,
}


def _parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs]
    bound = 1 if names and names[0] in ("self", "cls") else 0
    return len(names) - bound + (a.vararg is not None) + (a.kwarg is not None)


def _definition(module: str, name: str, depth: int = 0):
    """The ``def`` or ``class`` node of ``module.name``, following ``from .x import name``."""
    path = MODULES[module]
    tree = ast.parse(path.read_text())
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            if node.name == name:
                return node
        elif isinstance(node, ast.ImportFrom) and node.level and depth < 5:
            for alias in node.names:
                if (alias.asname or alias.name) == name:
                    return _definition(_absolute(path, node), alias.name, depth + 1)
    return None


def _module_functions(module: str) -> dict[str, ast.FunctionDef]:
    """The public functions of a public module: its own and those it re-exports
    (``from .x import f as f``)."""
    path = MODULES[module]
    found = {}
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
            found[node.name] = node
        elif isinstance(node, ast.ImportFrom) and node.level:
            for alias in node.names:
                if alias.asname == alias.name and not _private(alias.name):  # the re-export form
                    target = _absolute(path, node)
                    if target in MODULES:
                        definition = _definition(target, alias.name)
                        if isinstance(definition, ast.FunctionDef):
                            found[alias.name] = definition
    return found


def _public_counts() -> dict[str, int]:
    """``{name: parameters}`` of every function that rockjax/__init__.py re-exports, of the
    public methods of every class it re-exports (``Class.method``), and of the public functions
    of the modules it re-exports (``module.function``, unless also re-exported by name)."""
    counts = {}
    modules = []
    tree = ast.parse(MODULES["rockjax"].read_text())
    for node in tree.body:
        if not (isinstance(node, ast.ImportFrom) and node.level == 1):
            continue
        if node.module is None:  # from . import records as records
            modules += [alias.name for alias in node.names]
            continue
        for alias in node.names:
            found = _definition(f"rockjax.{node.module}", alias.name)
            if isinstance(found, (ast.FunctionDef, ast.AsyncFunctionDef)):
                counts[alias.asname or alias.name] = _parameters(found)
            elif isinstance(found, ast.ClassDef):
                for item in found.body:
                    if isinstance(item, ast.FunctionDef) and not _private(item.name):
                        if not item.name.startswith("__"):
                            counts[f"{alias.asname or alias.name}.{item.name}"] = _parameters(item)
    for module in modules:
        for name, fn in _module_functions(f"rockjax.{module}").items():
            if name not in counts:
                counts[f"{module}.{name}"] = _parameters(fn)
    return counts


def test_parameter_counting():
    source = "def f(a, /, b=1, *rest, c, **options): pass\nclass K:\n    def m(self, x): pass\n"
    f, k = ast.parse(source).body
    assert _parameters(f) == 5 and _parameters(k.body[0]) == 1


def test_public_functions_take_few_parameters():
    counts = _public_counts()
    resolved = {
        "simulate_housner",
        "GroundMotion.ricker",
        "pushover",
        "spectra.intensity",
        "records.load",
    }
    assert resolved <= counts.keys()
    wide = {name: n for name, n in counts.items() if n > MAX_PARAMETERS}
    new = {name: n for name, n in wide.items() if name not in WIDE}
    grown = {name: (WIDE[name], n) for name, n in wide.items() if name in WIDE and n > WIDE[name]}
    stale = {name: counts.get(name) for name in WIDE if name not in wide}
    assert not new, (
        f"public functions over {MAX_PARAMETERS} parameters (use an option object): {new}"
    )
    assert not grown, f"allowed wide functions that grew (allowed, now): {grown}"
    assert not stale, f"no longer over {MAX_PARAMETERS}, remove from WIDE: {stale}"
