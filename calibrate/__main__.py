"""CLI: ``python -m calibrate parapets|facades|all [--quick] [--out calibrate/results]``."""

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
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    if a.study in ("parapets", "all"):
        from . import parapets

        parapets.run(a.out, a.quick)
    if a.study in ("facades", "all"):
        from . import facades

        facades.run(a.out, a.quick)
    print(f"done in {time.perf_counter() - t0:.0f} s; results in {a.out}", flush=True)


if __name__ == "__main__":
    main()
