"""rockjax: differentiable rocking of URM parapets and facades (DEM and Housner), on JAX.

Conventions: SI units, radians, float64. ``theta > 0`` when the block rotates about its +x
bottom corner; a positive ground acceleration drives ``theta`` negative; a facade
(``mode=rj.Facade(gap=...)``, or ``mode="one_sided"``) rotates only to ``theta >= 0``, its return
walls at its -x face; a parapet (``rj.Parapet()``, ``"two_sided"``) rocks both ways.
"""

import os as _os
import re as _re

# XLA:CPU compiles a while loop into a single kernel (no per-iteration dispatch) only when the
# loop touches fewer bytes than `xla_cpu_small_while_loop_byte_threshold`. Our time-stepping
# loops are a few hundred bytes per step but run tens of thousands of steps; above the default
# threshold each DEM step pays ~0.5-1 us of kernel dispatch, below it ~35-60 ns (docs/benchmarks.md).
# XLA reads XLA_FLAGS when its CPU backend starts, so this takes effect only if no JAX
# computation ran before `import rockjax`. Set ROCKJAX_NO_XLA_TUNING=1 to leave XLA_FLAGS alone.
_THRESHOLD = "xla_cpu_small_while_loop_byte_threshold=1000000"
if _os.environ.get("ROCKJAX_NO_XLA_TUNING", "0") != "1":
    _flags = _os.environ.get("XLA_FLAGS", "")
    if "xla_cpu_small_while_loop_byte_threshold" not in _flags:
        if "--xla_backend_extra_options=" in _flags:
            _flags = _re.sub(
                r"--xla_backend_extra_options=(\S*)",
                rf"--xla_backend_extra_options=\1,{_THRESHOLD}",
                _flags,
            )
        else:
            _flags = f"{_flags} --xla_backend_extra_options={_THRESHOLD}".strip()
        _os.environ["XLA_FLAGS"] = _flags

import jax as _jax  # noqa: E402

# The other import side effect: rocking impacts and penalty contacts need float64 (contact
# penetrations are ~1e-6 of the block size and energies are compared to 1e-6 relative).
_jax.config.update("jax_enable_x64", True)

from . import building as building  # noqa: E402
from . import calibration as calibration  # noqa: E402
from . import campaign as campaign  # noqa: E402  (dask is imported lazily inside)
from . import compilation as compilation  # noqa: E402
from . import jsonio as jsonio  # noqa: E402
from . import metrics as metrics  # noqa: E402
from . import openquake as openquake  # noqa: E402  (writes files; never imports the engine)
from . import plot as plot  # noqa: E402  (matplotlib is imported lazily inside)
from . import pulses as pulses  # noqa: E402
from . import records as records  # noqa: E402
from . import relations as relations  # noqa: E402
from . import spectra as spectra  # noqa: E402
from ._checks import PlausibilityWarning as PlausibilityWarning  # noqa: E402
from .assembly import Assembly as Assembly  # noqa: E402
from .assembly import LimitAnalysis as LimitAnalysis  # noqa: E402
from .assembly import collapse_multiplier as collapse_multiplier  # noqa: E402
from .assembly import limit_analysis as limit_analysis  # noqa: E402
from .block import Block as Block  # noqa: E402
from .building import ShearBuilding as ShearBuilding  # noqa: E402
from .building import floor_spectra as floor_spectra  # noqa: E402
from .calibration import Calibration as Calibration  # noqa: E402
from .calibration import fit_beta as fit_beta  # noqa: E402
from .calibration import fit_e as fit_e  # noqa: E402
from .calibration import fit_history as fit_history  # noqa: E402
from .compilation import enable_cache as enable_compilation_cache  # noqa: E402
from .contact import Joint as Joint  # noqa: E402
from .dem import AssemblyResponse as AssemblyResponse  # noqa: E402
from .dem import simulate_assembly as simulate_assembly  # noqa: E402
from .dem import simulate_dem as simulate_dem  # noqa: E402
from .dem import stable_dt as stable_dt  # noqa: E402
from .dem import stable_dt_assembly as stable_dt_assembly  # noqa: E402
from .fragility import Fragility as Fragility  # noqa: E402
from .fragility import fragility as fragility  # noqa: E402
from .housner import simulate_housner as simulate_housner  # noqa: E402
from .ida import collapse_intervals as collapse_intervals  # noqa: E402
from .ida import ida as ida  # noqa: E402
from .modes import Facade as Facade  # noqa: E402
from .modes import Parapet as Parapet  # noqa: E402
from .modes import as_mode as as_mode  # noqa: E402
from .motion import GroundMotion as GroundMotion  # noqa: E402
from .pulses import identify_pulse as identify_pulse  # noqa: E402
from .pushover import Capacity as Capacity  # noqa: E402
from .pushover import pushover as pushover  # noqa: E402
from .records import read_at2 as read_at2  # noqa: E402
from .records import read_csv as read_csv  # noqa: E402
from .records import write_at2 as write_at2  # noqa: E402
from .relations import beta_dejong as beta_dejong  # noqa: E402
from .relations import beta_hcrit as beta_hcrit  # noqa: E402
from .relations import beta_isr as beta_isr  # noqa: E402
from .relations import e_housner as e_housner  # noqa: E402
from .relations import e_isr as e_isr  # noqa: E402
from .relations import omega_crit as omega_crit  # noqa: E402
from .relations import omega_hcrit as omega_hcrit  # noqa: E402
from .response import Response as Response  # noqa: E402
from .spectra import response_spectrum as response_spectrum  # noqa: E402
from .spectra import rotd_spectrum as rotd_spectrum  # noqa: E402
from .supports import wall_top_motion as wall_top_motion  # noqa: E402
from .three_branch import ThreeBranchFit as ThreeBranchFit  # noqa: E402
from .three_branch import ThreeBranchLaw as ThreeBranchLaw  # noqa: E402
from .three_branch import fit_three_branch as fit_three_branch  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "Assembly",
    "AssemblyResponse",
    "Block",
    "Calibration",
    "Capacity",
    "Facade",
    "Fragility",
    "GroundMotion",
    "Joint",
    "LimitAnalysis",
    "Parapet",
    "PlausibilityWarning",
    "Response",
    "ShearBuilding",
    "ThreeBranchFit",
    "ThreeBranchLaw",
    "as_mode",
    "beta_dejong",
    "beta_hcrit",
    "beta_isr",
    "building",
    "calibration",
    "campaign",
    "collapse_intervals",
    "collapse_multiplier",
    "compilation",
    "e_housner",
    "e_isr",
    "enable_compilation_cache",
    "fit_beta",
    "fit_e",
    "fit_history",
    "fit_three_branch",
    "floor_spectra",
    "fragility",
    "ida",
    "identify_pulse",
    "jsonio",
    "limit_analysis",
    "metrics",
    "omega_crit",
    "omega_hcrit",
    "openquake",
    "plot",
    "pulses",
    "pushover",
    "read_at2",
    "read_csv",
    "records",
    "relations",
    "response_spectrum",
    "rotd_spectrum",
    "simulate_assembly",
    "simulate_dem",
    "simulate_housner",
    "spectra",
    "stable_dt",
    "stable_dt_assembly",
    "wall_top_motion",
    "write_at2",
]
