"""Modules loaded on first use.

xarray (and pandas under it) takes about a fifth of ``import rockjax`` and only the IDA,
campaign and fragility results need it; a command-line run that calibrates, or a script that
simulates, should not pay for it. diffrax (with optimistix and lineax; the Housner solver reads
its Tsit5 tableau and adjoint classes) and optax (the calibration's L-BFGS) took about a
quarter more: they load when a Housner run or a fit first needs them. The standard library's
``importlib.util.LazyLoader`` does the work: the module object exists at once and runs its
code on the first attribute access.
"""

import importlib.util
import sys
from types import ModuleType


def lazy_module(name: str) -> ModuleType:
    """The module ``name``, its code run on first attribute access (at once if already
    imported)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ImportError(f"{name} is not installed; pip install {name}")
    spec.loader = importlib.util.LazyLoader(spec.loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
