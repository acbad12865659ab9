"""CLI: ``python -m calibrate parapets|facades|all [--quick] [--n-sub exact|N] [--out DIR]``."""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv=None) -> None:
    """Parse the arguments and run the chosen studies, printing the total wall time."""
    p = argparse.ArgumentParser(prog="python -m calibrate", description=__doc__)
    p.add_argument("study", choices=("parapets", "facades", "all"))
    p.add_argument("--quick", action="store_true", help="a 1-2 minute subset")
    p.add_argument("--out", type=Path, default=Path("calibrate/results"))
    p.add_argument(
        "--n-sub",
        default="exact",
        help="the DEM joint: 'exact' (default, the converged joint) or sub-contacts per face "
        "(2: the paper's corner contacts)",
    )
    a = p.parse_args(argv)
    n_sub = a.n_sub if a.n_sub == "exact" else int(a.n_sub)
    t0 = time.perf_counter()
    if a.study in ("parapets", "all"):
        from . import parapets

        parapets.run(a.out, a.quick, n_sub)
    if a.study in ("facades", "all"):
        from . import facades

        facades.run(a.out, a.quick, n_sub)
    print(f"done in {time.perf_counter() - t0:.0f} s; results in {a.out}", flush=True)


if __name__ == "__main__":
    main()
