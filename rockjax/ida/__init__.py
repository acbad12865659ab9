"""Incremental dynamic analysis (IDA): one block under records x scale factors, batched.

Every (record, scale) pair is one run of the model, an object with its own options
(:class:`rockjax.DEM`: :func:`rockjax.simulate_dem`; :class:`rockjax.Housner`:
:func:`rockjax.simulate_housner`; :class:`rockjax.ThreeBranch`: ``simulate_housner`` with a
three-branch law) with ``throw=False``. A facade in a building (``wall_motion=`` a :class:`rockjax.ShearBuilding`)
has its return walls driven by the building's response to each scaled record; a wall of
several blocks in a building (an :class:`rockjax.Assembly` with ``support_motion=`` a building
and ``storey=``) stands on its floor and is held by the floor above. The building is linear:
its response is solved once per record and scaled with the record in every run. The pairs are
flattened and run in chunks of ``chunk_size`` (default :data:`CHUNK_PER_DEVICE` per device): one compiled batch per chunk from a Python
loop, which bounds the memory and lets a progress bar advance between chunks (DEM parapets and
walls of several blocks are vmapped; Housner runs and DEM facades of one block go through
:func:`rockjax.housner.batch_runs`, one after another on CPU). By default, on a host CPU, the
chunks run in :func:`host_threads` threads at once, each on its own core. The runs are
chunked in the order of their scaled records' PGV (``scale * pgv``, lowest first): a batch
steps until its last run ends, so runs that collapse early go together. The last chunk is
padded (with repeats of its last run, dropped afterwards) to the same shape, so the batch
compiles once.

Records. Every run lasts ``t_end`` = the longest record plus a free-vibration ``tail`` [s]
(records are zero-padded), so the block can finish its last excursion (or overturn) after the
strongest record ends. Each record runs on its own ``dt``: records are grouped by ``dt`` and
each group is batched separately (one compilation per group), so a set that mixes steps (the
FEMA near-field set has 0.0024 to 0.02 s) does not run every record on the finest one. Each
run sees ``scale * ag`` (and ``scale * ag_v``, if any record of its group has a vertical
component; the others get zeros).

Engineering demand parameters, per run:

* ``max_d_over_b``: peak ``|d|/b`` of the top centre relative to the base. DEM: the running
  maximum over every step, ``extras["d_max"] / b``. Housner: from the peak rotation with the
  rigid-block formula ``|d| = b/2 (1 - cos theta_max) + h sin theta_max``, which is the same
  as ``max|Response.d|`` over the run because ``|d|`` grows with ``|theta|`` on
  ``[0, pi/2]``, but also includes the peaks between samples (``theta_max`` is the maximum
  of each solver step's dense output).
* ``max_theta_over_eta``: ``theta_max / eta``.
* ``collapse``: overturned (``|theta| > eta`` moving outward; the state is frozen from then
  on, so the two EDPs above are then the values where the run stopped, just past ``eta``).
* ``status``: 0 if the run is valid, else a code of ``rockjax.response.STATUS_MESSAGES``; a
  failed run has NaN EDPs and ``collapse = False`` and does not stop the batch.
* ``t_heel`` (Housner with ``wall_motion`` only): ``extras["t_heel"]`` of the run [s], the
  first time the rigid block, its return wall receded behind its base, would rock on its heel
  (``inf``: never); the run is the rigid block's up to that time only (docs/three_branch.md,
  "Moving return walls").
* ``pga_scaled``: ``scale * pga`` [m/s^2], with ``pga`` the peak of the record as run.
* ``im``: the intensity measure of the run, ``scale * IM(record)``, for ``im="pga"``
  (default; equal to ``pga_scaled``), ``"pgv"`` [m/s] or ``"sa(T)"`` (5 %-damped
  pseudo-spectral acceleration at ``T`` seconds, :mod:`rockjax.spectra`) [m/s^2]; all three
  are proportional to the record's amplitude. ``im_g`` is the same in g where the IM is an
  acceleration. Per record, ``pgv`` [m/s] and ``im_record`` (the IM at scale 1) are
  coordinates, so :func:`rockjax.fragility` can fit against PGA, PGV or the IDA's IM.
"""

from ..batching import host_threads as host_threads
from ._api import ida as ida
from ._config import DEFAULT_SCALES as DEFAULT_SCALES
from ._config import MODELS as MODELS
from ._config import MODES as MODES
from ._config import run_config as run_config
from ._intervals import CollapseIntervals as CollapseIntervals
from ._intervals import collapse_intervals as collapse_intervals
from ._plan import CHUNK_PER_DEVICE as CHUNK_PER_DEVICE
