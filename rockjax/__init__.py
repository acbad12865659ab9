"""rockjax: differentiable rocking of URM parapets and facades (DEM and Housner), on JAX.

Conventions: SI units, radians, float64. ``theta > 0`` when the block rotates about its +x
bottom corner; a positive ground acceleration drives ``theta`` negative; a facade
(``mode=rj.Facade(gap=...)``, or ``mode="one_sided"``) rotates only to ``theta >= 0``, its return
walls at its -x face; a parapet (``rj.Parapet()``, ``"two_sided"``) rocks both ways.
"""

import jax as _jax

# The one import side effect on JAX's configuration: rocking impacts and penalty contacts need
# float64 (contact penetrations are ~1e-6 of the block size and energies are compared to 1e-6
# relative).
_jax.config.update("jax_enable_x64", True)

from . import batching as batching  # noqa: E402
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
from .batching import vmap_chunks as vmap_chunks  # noqa: E402
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
from .models import DEM as DEM  # noqa: E402
from .models import Housner as Housner  # noqa: E402
from .models import ThreeBranch as ThreeBranch  # noqa: E402
from .models import as_model as as_model  # noqa: E402
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

# XLA:CPU's option for rockjax's time loops (one history 3-30x faster), added to
# XLA_FLAGS only where it overrides no choice of the user's: XLA_FLAGS unset, JAX's backend not
# started (XLA reads the variable then), ROCKJAX_NO_XLA_TUNING not 1. Otherwise the first
# compile says once how to add it (docs/conventions.md, "XLA flags").
compilation.configure_cpu(keep_user_flags=True)

__version__ = "0.1.0"

__all__ = [
    "Assembly",
    "AssemblyResponse",
    "Block",
    "Calibration",
    "Capacity",
    "DEM",
    "Facade",
    "Fragility",
    "GroundMotion",
    "Housner",
    "Joint",
    "LimitAnalysis",
    "Parapet",
    "PlausibilityWarning",
    "Response",
    "ShearBuilding",
    "ThreeBranch",
    "ThreeBranchFit",
    "ThreeBranchLaw",
    "as_mode",
    "as_model",
    "batching",
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
    "vmap_chunks",
    "wall_top_motion",
    "write_at2",
]
