"""Regional risk with the OpenQuake engine: rockjax fragilities as the engine's input files.

* :func:`fragility_model` writes an NRML 0.5 fragility model (continuous ``logncdf`` or
  discrete) from :class:`rockjax.Fragility` s, one function per class, one or several limit
  states (:func:`limit_state_fragilities`);
* :func:`exposure` writes the exposure (XML header and CSV assets) and the taxonomy mapping
  from a CSV inventory of buildings; :func:`ground_motion_fields` the scenario's fields;
  :func:`scenario_job` the ``scenario_damage`` job;
* :class:`Catalogue` holds the classes (parapet and facade geometry bins, restraint, host
  building, position) and computes each class's IDA and fragility in a ground IM;
* :func:`run_job` runs ``oq run job.ini`` (the engine as a separate program: it is AGPL-3 and
  rockjax does not import it) and reads the per-asset damage back.

See docs/openquake.md ("Regional risk with OpenQuake").
"""

from ._catalogue import BuildingClass as BuildingClass
from ._catalogue import Catalogue as Catalogue
from ._engine import engine_available as engine_available
from ._engine import read_damages as read_damages
from ._engine import run_job as run_job
from ._files import exposure as exposure
from ._files import ground_motion_fields as ground_motion_fields
from ._files import scenario_job as scenario_job
from ._limit_states import limit_state_fragilities as limit_state_fragilities
from ._limit_states import limit_state_name as limit_state_name
from ._limit_states import ordinal_probit as ordinal_probit
from ._nrml import engine_imt as engine_imt
from ._nrml import fragility_model as fragility_model
from ._nrml import lognormal_moments as lognormal_moments

__all__ = [
    "BuildingClass",
    "Catalogue",
    "engine_available",
    "engine_imt",
    "exposure",
    "fragility_model",
    "ground_motion_fields",
    "limit_state_fragilities",
    "limit_state_name",
    "lognormal_moments",
    "ordinal_probit",
    "read_damages",
    "run_job",
    "scenario_job",
]
