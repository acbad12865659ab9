"""The Housner rocking model with impacts, solved in one JAX loop over the record.

Model (Housner 1963). A rigid rectangle of half-diagonal ``R`` and slenderness ``eta`` rocks
on one bottom corner, the pivot ``s = +1`` (the +x corner, ``theta > 0``) or ``s = -1``. With
``I_O = 4/3 m R^2`` and ``p^2 = 3 g / (4 R)`` the equation of motion on pivot ``s`` is

    theta_ddot = -(p^2 / g) [g_eff sin(s eta - theta) + a_g cos(s eta - theta)],

with ``g_eff = g + a_gv`` (base accelerating up adds to gravity). For ``theta > 0`` this reads
``I_O theta_ddot = -m g R sin(eta - theta) - m a_g R cos(eta - theta)``: gravity restores and a
positive ``a_g`` (base accelerating toward +x) drives ``theta`` negative. The pivot is carried in
the state, not taken as ``sign(theta)``, so the vector field stays smooth through ``theta = 0``
and the continuation past a crossing is smooth, which makes the crossing time a clean root.

* Two-sided (parapet): when ``s theta`` reaches 0 the block impacts and switches corner,
  ``theta_dot -> e theta_dot``, ``s -> -s``; default ``e = e_H = 1 - 1.5 sin^2 eta``, Eq. (2).
* One-sided (facade, ``theta >= 0``, return wall at -x): at ``theta = 0`` moving inward it
  rebounds about the same corner, ``theta_dot -> -|e| theta_dot``; default ``|e_1sr|``, Eq. (5).
* Rest (``s = 0``): rocking starts at the exact time ``|a_g|`` exceeds ``g_eff tan(eta)``
  (two-sided; pivot ``-sign(a_g)``) or ``a_g < -g_eff tan(eta)`` (one-sided). Chatter (Zeno):
  after an impact the block is put to rest only if the rest of its impact sequence provably
  ends with the forcing below the uplift threshold on both sides, or if its rebound is too
  small to matter (a hop below ``REST_HOP = 1e-6`` of ``eta``) (``rest_rule``; derivation in
  docs/theory.md, "Housner rest and chatter rule"); otherwise the impacts go on being
  resolved one by one.
* Overturning: ``|theta| > eta`` while moving outward flags ``overturned`` and freezes the state.
* Three-branch law (``law=``, docs/three_branch.md): the restoring moment follows a
  ``rockjax.ThreeBranchLaw`` (uplift threshold, rest rule and overturning rotation with it);
  its kinks are events like impacts, so steps are cut there.
* Moving return wall (``wall_motion=``, one-sided; docs/three_branch.md, "Moving return
  walls"): the stop is at ``max(theta_w(t), 0)``, ``theta_w = u_top / h`` (the wall, or the
  base where the wall has receded behind it), impacts restitute the velocity relative to it,
  and a block at rest rides on it until it would accelerate away faster than it. Where the
  rigid block would rock on its heel (room behind the base) the model leaves its validity:
  ``extras["t_heel"]`` reports when.

Layout, one job per private module: ``_field.py`` the vector field and restoring moment,
``_params.py`` the rules' numbers and a run's constants (three-branch terms),
``_tsit5.py`` the fixed-step Tsit5 tableau, step and dense output, ``_hermite.py`` the cubic
fits and roots on a step, ``_record.py`` the forcing and a moving wall's cubic, ``_impact.py``
the impact map, uplift and rest rule, ``_state.py`` the carried state, ``_pass.py`` one pass
of a step, ``_loop.py`` the while loop over the record (its docstring: the design),
``_wall.py`` moving return walls, ``_solve.py`` the compiled program and its in-graph checks,
``_simulate.py`` ``simulate_housner`` and its boundary checks (its docstring: the step-size
rule and the length buckets), ``_diffrax.py`` the same model through ``diffrax.diffeqsolve``
and ``diffrax.Event`` (``solver=``), ``_batch.py`` ``batch_runs``, ``_lax.py`` bare-lax helpers.

Accuracy (docs/verification.md, "Housner"): on 20 s broadband records (a Kanai-Tajimi record
and FEMA P695 components, two- and one-sided, up to overturning) the default step gives the
peaks of an independent event-driven solver within 1.3e-4 relative (peaks >= 0.05 eta) and
the same overturning flags; halving the step changes nothing at that level. Just above the
uplift threshold (50 cases of FEMA P695 far-field records at 1.05-1.3 g tan(eta), peaks of
8.6e-6 to 0.47 eta, flights often shorter than a step) ``theta_max`` is within 3.4e-5
relative of that solver's peaks, found by its own ``theta_dot = 0`` events (section "Peaks
between samples"; the former end-point parabola was up to 26 % low there).

Limitations: a step resolves at most ``max_impacts_per_step`` impacts (default 64); more are
reported, not resolved. A graze whose dip below zero the step's cubic fit does not show (a
dip of the order of Tsit5's local error) is missed; so is a step that crosses zero twice
after starting away from it.
"""

from ._batch import batch_runs as batch_runs
from ._params import P_DT_LIMIT as P_DT_LIMIT
from ._params import P_DT_TARGET as P_DT_TARGET
from ._params import REST_A_MARGIN as REST_A_MARGIN
from ._params import REST_HOP as REST_HOP
from ._params import REST_HORIZON as REST_HORIZON
from ._simulate import DEFAULT_DT as DEFAULT_DT
from ._simulate import DEFAULT_MAX_IMPACTS as DEFAULT_MAX_IMPACTS
from ._simulate import MODES as MODES
from ._simulate import check_restitution as check_restitution
from ._simulate import simulate_housner as simulate_housner
from ._tsit5 import tsit5_dense as tsit5_dense
from ._tsit5 import tsit5_tableau as tsit5_tableau
from ._wall import HEEL_TOL as HEEL_TOL
