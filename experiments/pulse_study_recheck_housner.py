"""Re-run the Housner half of the pulse study with the current code and compare its
capacities with the committed ``results/pulse_study/capacities.csv``.

    python experiments/pulse_study_recheck_housner.py [--parts /tmp/housner_recheck]

Same records, scales and block/mode cases as ``pulse_study.py`` (its functions are reused),
Housner only (the DEM half takes over an hour on 2 cores); prints the failed-run counts and
every record whose capacity or number of collapse intervals differs.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np
import pandas as pd

import rockjax as rj

sys.path.insert(0, str(pathlib.Path(__file__).parent))
import pulse_study as ps  # noqa: E402

RESULTS = pathlib.Path(__file__).parent / "results" / "pulse_study"


def main(argv=None) -> pd.DataFrame:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", default="/tmp/rockjax_housner_recheck")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    sets = ps.load_records(False)
    shapes = ps.identify(sets)
    blocks = {k: rj.Block(b=b, h=h) for k, (h, b) in ps.GEOMETRIES.items()}
    cases = rj.campaign.grid(blocks, ps.SETS, modes=ps.MODES, models=("housner",))
    results = rj.campaign.run(cases, sets, pathlib.Path(args.parts), scales=ps.SCALES)
    new = pd.DataFrame(ps.capacities(results, cases, shapes))
    old = pd.read_csv(RESULTS / "capacities.csv")
    both = old[old.model == "housner"].merge(
        new, on=["geometry", "mode", "model", "record"], suffixes=("_old", "_new")
    )
    changed = both[
        ~np.isclose(both.capacity_g_old, both.capacity_g_new)
        | (both.n_collapse_intervals_old != both.n_collapse_intervals_new)
    ]
    print(
        f"{len(both)} record x case rows; failed runs: committed "
        f"{int(both.n_failed_runs_old.sum())}, now {int(both.n_failed_runs_new.sum())}; "
        f"{len(changed)} rows differ ({time.perf_counter() - t0:.0f} s)"
    )
    if len(changed):
        print(changed.to_string())
    return changed


if __name__ == "__main__":
    main()
