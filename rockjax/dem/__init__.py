"""The DEM model: rigid blocks (3 DOF each) on penalty joints, stepped by explicit central
differences with centred dashpots inside ``jax.lax.scan``. A single block is the assembly of
one; the same kernel runs both.

Model (paper Section 2): the joint under each face (:class:`rockjax.Joint`), by default the
contact law integrated over the face (the ``n_sub -> infinity`` limit of the sub-contacts: a
continuous Winkler joint with one resultant shear spring per face; docs/theory.md,
"Integrated face contact"), or ``n_sub`` >= 2 sub-contact points (``Joint(n_sub=2)``: the
paper's corners); normal stiffness ``j_kn = E/h`` and shear stiffness
``j_ks = j_kn / (2 (1 + nu))`` per unit area, Mohr-Coulomb with zero tension and cohesion,
stiffness-proportional Rayleigh damping ``beta`` as a dashpot ``c = beta k`` on the closed
joint (the shear dashpot only while the joint sticks; :mod:`rockjax.contact`). A facade
(``mode="one_sided"``) leans on return walls, a distance ``gap`` behind its back faces,
fixed or moving (:mod:`rockjax.supports`). Assemblies: blocks stacked (top free or restrained,
with an overburden) or side by side (docs/assemblies.md).

Integration: central differences with centred dashpots, one (block-tridiagonal) solve per
step; stable for ``dt <= 2 / omega_max`` whatever ``beta``. The default step is chosen for
accuracy, ``dt = accuracy / (omega_max (1 + zeta))``, ``zeta = beta omega_max / 2``
(docs/theory.md "Time stepping", docs/verification.md), capped at ``DT_SAFETY`` times the
stability limit and rounded down to divide the record step.

Layout: ``_params`` (parameters, state, the step rule), ``_algebra`` (3 x 3 algebra, the
solves), ``_faces`` (the joints' forces), ``_step`` (one step, energy, collapse), ``_state``
(initial states), ``_run`` (the scan driver), ``_response`` (what a run returns),
``_simulate`` (the public entry points and their checks); ``_stacked`` (the step, energy and
collapse rule of a tall stack as array operations over its blocks, from
``STACKED_MIN_BLOCKS`` blocks up, ``STACKED_MIN_BLOCKS_ONE`` in one history: a program that
does not grow with the stack).
"""

from ._params import DT_ACCURACY as DT_ACCURACY
from ._params import DT_ACCURACY_SUB as DT_ACCURACY_SUB
from ._params import DT_SAFETY as DT_SAFETY
from ._params import MODES as MODES
from ._params import SOLVE_UNROLLED_MAX_BLOCKS as SOLVE_UNROLLED_MAX_BLOCKS
from ._params import STACKED_MIN_BLOCKS as STACKED_MIN_BLOCKS
from ._params import STACKED_MIN_BLOCKS_ONE as STACKED_MIN_BLOCKS_ONE
from ._params import DemParams as DemParams
from ._params import DemState as DemState
from ._params import critical_dt as critical_dt
from ._params import default_step as default_step
from ._params import dem_params as dem_params
from ._params import omega_max as omega_max
from ._response import AssemblyResponse as AssemblyResponse
from ._response import block_response as block_response
from ._run import REACH_SAMPLES as REACH_SAMPLES
from ._run import REACH_STEPS as REACH_STEPS
from ._run import SCAN_CHUNK as SCAN_CHUNK
from ._run import padded_length as padded_length
from ._run import run as run
from ._simulate import DEFAULT_SAVE_DT as DEFAULT_SAVE_DT
from ._simulate import SAVE_OPTIONS as SAVE_OPTIONS
from ._simulate import prepare_motion as prepare_motion
from ._simulate import simulate_assembly as simulate_assembly
from ._simulate import simulate_dem as simulate_dem
from ._simulate import stable_dt as stable_dt
from ._simulate import stable_dt_assembly as stable_dt_assembly
from ._state import initial_state as initial_state
from ._step import step as step
