"""The ``rockjax`` command line.

``rockjax demo [--out DIR] [--quick]`` runs the main job on built-in examples from the paper
(Galvez et al., Sect. 2): free rocking of a parapet with DEM and Housner, a one-sided facade,
a Ricker pulse, the DEM ``e(beta)`` sweep behind Eq. (3), a calibration of ``beta`` to ``e_H``
by gradient descent, and a small IDA under analytic pulses with both models. It writes figures
(PNG), time histories (CSV), IDA Datasets (NetCDF) and ``results.json`` into ``DIR`` and prints
a summary.

``rockjax ida --records nearfield|farfield|...|FILE.AT2... --out ida.nc`` runs an incremental
dynamic analysis (:func:`rockjax.ida`) of one block under FEMA P695 record sets
(:func:`rockjax.records.fema_p695`) or PEER ``.AT2`` files, writes the Dataset to NetCDF and,
next to it, the IDA table as CSV (``ida.csv``: one row per run), the IDA curves and the
fitted collapse fragility as figures (``ida_curves.png``, ``ida_fragility.png``; PDF or SVG with
``--figure-format``) and the fragility summary (``ida_fragility.json``: median in the IM's
units and in g, dispersion, bootstrap intervals; or why it cannot be fitted), and prints a
summary.

``rockjax calibrate --b 0.25 --h 3 [--e 0.975]`` fits the DEM damping ``beta`` of one block so
that its free rocking matches Housner's with restitution ``e`` (:func:`rockjax.fit_beta`; default
``e = e_H``, Eq. 2), or, with ``--mode one_sided`` (target ``bounces`` by default), a facade's
measured bounce ratios. It prints ``beta``, the DEM's effective ``e`` and the reachable range,
and writes ``calibration.png`` (DEM at the fitted ``beta`` vs Housner, and the loss history) and
``calibration.json``; a fit that does not meet its target within the stated tolerance is
reported with the reason on stderr and exit status 1 (the files are still written).

``rockjax simulate --b 0.2 --h 1.5 --pulse MH --pga-g 0.3 --pulse-period 0.4`` runs one block
under a record (``--record``: a PEER ``.AT2`` file, or a CSV file whose units its header states
or ``--units`` gives), an analytic pulse (``--pulse``) or a free release (``--theta0``), with the
DEM, Housner or Housner with a three-branch law (``--model``), on the ground or in a host shear
building (``--storeys``, ``--building-period``, ``--storey``); it prints the peak
``|theta|/eta``, whether the block overturned and the time step, and writes ``simulate.csv``
(:meth:`rockjax.Response.to_dataframe`), ``simulate.png`` and ``simulate.json``.

``rockjax spectrum --record FILE`` writes the elastic response spectrum of a record or a pulse
(:func:`rockjax.response_spectrum`), and with a host building its floor spectra
(:func:`rockjax.floor_spectra`), as ``spectrum.csv``, ``spectrum.png`` and ``spectrum.json``.

``rockjax pushover --b 0.17 --h 1.5`` runs the DEM pushover of a block or a stack
(:func:`rockjax.pushover`), fits the three-branch law (:func:`rockjax.fit_three_branch`) and
writes ``pushover.csv``, ``pushover.png`` and ``pushover.json`` (the law, which
``rockjax simulate --model three-branch --law pushover.json`` reads).

Errors in the input, and an output file that cannot be written (every file a command writes is
checked before its first run), are reported as one ``error: ...`` line on stderr with exit
status 2. An IDA whose runs all fail writes its files and exits with status 1 and one
``error: ...`` line naming the runs' status.

**Layout.** One private module per command, re-exported here: ``_main`` (:func:`main` and the
parser), ``_demo`` (the main job, one function per step) with ``_demo_inputs`` (its examples and
files) and ``_demo_files`` (its figures and CSV files), ``_ida``, ``_calibrate``, ``_simulate``,
``_spectrum``, ``_pushover``, ``_options`` (the options of the last three: block, record or
pulse, mode, joint, building, outputs) and ``_common`` (the output checks and summaries the
commands share). ``python -m rockjax.cli`` runs
:func:`main` too.
"""

from ._calibrate import CALIBRATE_FILES as CALIBRATE_FILES
from ._demo_inputs import BETA_MAX_RATIO as BETA_MAX_RATIO
from ._demo_inputs import DEMO_FILES as DEMO_FILES
from ._demo_inputs import DT_OUT as DT_OUT
from ._demo_inputs import FACADE_B as FACADE_B
from ._demo_inputs import FACADE_DT_OUT as FACADE_DT_OUT
from ._demo_inputs import FACADE_DURATION as FACADE_DURATION
from ._demo_inputs import FACADE_GAP as FACADE_GAP
from ._demo_inputs import FACADE_H as FACADE_H
from ._demo_inputs import N_BETA as N_BETA
from ._demo_inputs import N_BETA_QUICK as N_BETA_QUICK
from ._demo_inputs import N_BOUNCES as N_BOUNCES
from ._demo_inputs import PARAPET_B as PARAPET_B
from ._demo_inputs import PARAPET_DURATION as PARAPET_DURATION
from ._demo_inputs import PARAPET_H as PARAPET_H
from ._demo_inputs import RELEASE as RELEASE
from ._demo_inputs import RICKER_PERIOD as RICKER_PERIOD
from ._demo_inputs import RICKER_PGA as RICKER_PGA
from ._ida import FIGURE_FORMATS as FIGURE_FORMATS
from ._main import main as main

__all__ = [
    "BETA_MAX_RATIO",
    "CALIBRATE_FILES",
    "DEMO_FILES",
    "DT_OUT",
    "FACADE_B",
    "FACADE_DT_OUT",
    "FACADE_DURATION",
    "FACADE_GAP",
    "FACADE_H",
    "FIGURE_FORMATS",
    "N_BETA",
    "N_BETA_QUICK",
    "N_BOUNCES",
    "PARAPET_B",
    "PARAPET_DURATION",
    "PARAPET_H",
    "RELEASE",
    "RICKER_PERIOD",
    "RICKER_PGA",
    "main",
]
