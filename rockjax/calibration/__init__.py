"""Calibrate the DEM damping ``beta`` to a coefficient of restitution, by gradient descent.

The paper matched DEM and Housner free-rocking histories by trial; here the match is a
differentiable loss minimised with L-BFGS (``optax.lbfgs``, backtracking line search):

1. **Reference**: Housner's free rocking with the target ``e`` (or, for facades, the measured
   bounce ratios of ``e_ISR``), released from rest at ``theta0`` (one or several amplitudes).
2. **Loss** (:func:`rockjax.metrics.peak_loss`): the mean square gap of the bounce
   log-energies ``log U_k - log U_0`` between the DEM and Housner, bounce by bounce, over the
   first ``n_bounces`` impacts that keep at least 2 % of the release energy (weights 1, else 0).
   It is insensitive to phase, and equals ``(log e_DEM - log e)^2`` for a DEM with a constant
   restitution. The paper's pointwise weighted-mean history error
   (:func:`rockjax.metrics.history_error`) is reported beside it.
3. **Smoothness**: the DEM locates contact onsets inside the step (``Joint(onset="sub_step")``,
   :mod:`rockjax.contact`), so the loss is continuous in ``beta``; with onsets on the step grid
   it jumps ~1e-4 at ~1e-5 ``beta_DeJong`` intervals and the local derivative misses the trend.
4. **Scaling and bounds**: two DEM runs at ``beta = 0`` and ``beta_max`` (vmapped) give the
   reachable range (a target outside it raises) and the slope used to scale the variable
   ``u = S beta`` so that the loss is ``~ (u - u*)^2``; ``beta = beta_cap tanh(|u| / (S beta_cap))``
   keeps it in ``[0, beta_cap]`` (``beta_cap = 1.25 beta_max``, the step is sized for it).
5. **Derivatives** in forward mode (``jax.jvp`` through the ``lax.scan``; one tangent per
   parameter), wrapped as a ``custom_vjp`` for optax.

Baselines (``method=``): ``"grid"`` (dense vmapped grid, parabola through the best three
points) and ``"root"`` (Illinois false position on the signed log-energy gap, monotone in
``beta``).

**What a result promises.** Before any optimisation, a target whose Housner reference has no
bounce keeping :data:`MIN_ENERGY_RATIO` of its release energy (the loss would be identically
zero), ``n_bounces < 1``, a DEM that keeps no such bounce at ``beta = 0`` and an unreachable
target raise ``ValueError`` with the fix (``target="e"`` cuts its bracket where the DEM stops
bouncing, so the reachable range is always defined). After it, every method (``lbfgs``, its
false-position finish, ``grid``, ``root``; and :func:`fit_e`) reports ``converged=True`` only
if its promise is kept, with every number finite: ``target="e"``, the DEM's own ``e`` within
:data:`E_TOL` of the target; ``target="bounces"`` (the facade default, a best match as in the
paper), the loss's minimum found; ``loss="history"``, the history error's minimum found from
the bounce-loss optimum. ``target_met`` says whether the target itself is met (for facades:
each ``e_exp`` in its band of :data:`BOUNCE_BANDS`), measured on the DEM's saved history by a
NumPy peak finder independent of the loss (:func:`rockjax.response.bounce_peaks`, also behind
``Response.e_exp``); ``reason`` and ``target_missed`` say what was missed.

**Layout.** :mod:`~rockjax.calibration.problems` (the public problem objects,
:func:`problem`, :func:`stats`, :func:`dem_run`, :func:`housner_reference`),
:mod:`~rockjax.calibration.derivatives` (the forward-mode ``custom_vjp``),
:mod:`~rockjax.calibration.solvers` (L-BFGS, grid, Illinois false position),
:mod:`~rockjax.calibration.result` (:class:`Calibration`, :class:`HistoryFit`, the tolerances and
the verdict), :mod:`~rockjax.calibration.fit` (:func:`fit_beta`),
:mod:`~rockjax.calibration.fit_e` (:func:`fit_e`, :func:`e_effective`) and
:mod:`~rockjax.calibration.fit_history` (:func:`fit_history`).
"""

from .fit import GAP_TOL as GAP_TOL
from .fit import HISTORY_SPAN as HISTORY_SPAN
from .fit import HISTORY_STEP as HISTORY_STEP
from .fit import LOSSES as LOSSES
from .fit import METHODS as METHODS
from .fit import fit_beta as fit_beta
from .fit_e import e_effective as e_effective
from .fit_e import fit_e as fit_e
from .fit_history import fit_history as fit_history
from .problems import FACADE_BETA_MAX_HCRIT as FACADE_BETA_MAX_HCRIT
from .problems import MODES as MODES
from .problems import SAVE_DT as SAVE_DT
from .problems import TARGETS as TARGETS
from .problems import CalibrationProblem as CalibrationProblem
from .problems import EProblem as EProblem
from .problems import HistoryProblem as HistoryProblem
from .problems import check_target as check_target
from .problems import default_target as default_target
from .problems import dem_run as dem_run
from .problems import history_loss as history_loss
from .problems import history_problem as history_problem
from .problems import history_stat as history_stat
from .problems import history_stat_batch as history_stat_batch
from .problems import housner_reference as housner_reference
from .problems import last_compared_time as last_compared_time
from .problems import problem as problem
from .problems import stats as stats
from .problems import stats_batch as stats_batch
from .problems import window_error as window_error
from .result import BOUNCE_BANDS as BOUNCE_BANDS
from .result import BOUNCE_FRACTIONS as BOUNCE_FRACTIONS
from .result import E_TOL as E_TOL
from .result import HISTORY_TOL as HISTORY_TOL
from .result import MIN_ENERGY_RATIO as MIN_ENERGY_RATIO
from .result import Calibration as Calibration
from .result import HistoryFit as HistoryFit
from .result import bounce_peaks as bounce_peaks
from .result import bounces_missed as bounces_missed
from .result import e_missed as e_missed
from .result import history_missed as history_missed
from .result import history_peak_gap as history_peak_gap
from .result import minimum_missed as minimum_missed
from .result import verdict as verdict

__all__ = [
    "BOUNCE_BANDS",
    "BOUNCE_FRACTIONS",
    "Calibration",
    "CalibrationProblem",
    "E_TOL",
    "EProblem",
    "FACADE_BETA_MAX_HCRIT",
    "GAP_TOL",
    "HISTORY_SPAN",
    "HISTORY_STEP",
    "HISTORY_TOL",
    "HistoryFit",
    "HistoryProblem",
    "LOSSES",
    "METHODS",
    "MIN_ENERGY_RATIO",
    "MODES",
    "SAVE_DT",
    "TARGETS",
    "bounce_peaks",
    "bounces_missed",
    "check_target",
    "default_target",
    "dem_run",
    "e_effective",
    "e_missed",
    "fit_beta",
    "fit_e",
    "fit_history",
    "history_loss",
    "history_missed",
    "history_peak_gap",
    "history_problem",
    "history_stat",
    "history_stat_batch",
    "housner_reference",
    "last_compared_time",
    "minimum_missed",
    "problem",
    "stats",
    "stats_batch",
    "verdict",
    "window_error",
]
