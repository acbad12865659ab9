"""Rebound peaks of lightly damped facades (beta = 0, 0.1, 0.25 beta_Hcrit) at the default
DEM step and at 1/2 and 1/4 of it, against 1/16 of it (docs/verification.md, "DEM time
step: convergence").

    python experiments/facade_light_damping.py [--open ACCURACY]

One-sided free rocking from 0.5 eta, gap 0, E 4.05 GPa, phi 30 deg, the default joint; prints
the peaks / eta at dt_d/16 and the error in % of each step. The third undamped bounce of
0.2 x 1.5 m moves erratically with the step (a phase effect of the undamped contact modes).
``--open`` sets ``rj.Facade.dt_accuracy_open`` (the steps while the return wall is out of
reach) for this process, e.g. to the value before the current default.
"""

from __future__ import annotations

import argparse

import numpy as np

import rockjax as rj
from rockjax import metrics

DURATION = 8.0
"""Free rocking [s]: three rebounds of every facade here (in 2.5 s the slender 0.11 x 2.4 m
one completed only its first, and 0.3 x 2.4 m at beta <= 0.1 beta_Hcrit its first two)."""


def peaks(block, beta, dt):
    r = rj.simulate_dem(
        block,
        beta=beta,
        mode="one_sided",
        theta0=0.5 * block.eta,
        duration=DURATION,
        save_dt=2.5e-4,
        dt=dt,
    )
    pk = metrics.peaks(r.t, r.theta, block.eta, 3, mode="one_sided")
    # a bounce not completed within the run is NaN, not the finder's upper bound
    amp = np.where(np.asarray(pk.valid), np.asarray(pk.amplitude), np.nan)
    return amp[1:] / float(block.eta)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--open", type=float, default=None, help="rj.Facade.dt_accuracy_open")
    args = ap.parse_args()
    if args.open is not None:
        # read by each run's set-up and passed to its program as data
        rj.Facade.dt_accuracy_open = args.open
    print(f"open steps at {rj.Facade.dt_accuracy_open}")
    print("b x h [m], beta/beta_Hcrit, step/dt_d, peaks/eta at dt_d/16, error [%]")
    for b, h in ((0.2, 1.5), (0.11, 2.4), (0.3, 2.4)):
        block = rj.Block(b=b, h=h, E=4.05e9)
        for frac in (0.0, 0.1, 0.25):
            beta = frac * float(rj.beta_hcrit(block))
            dt_d = rj.stable_dt(block, beta, mode="one_sided")
            ref = peaks(block, beta, dt_d / 16)
            for f in (1.0, 0.5, 0.25):
                err = 100 * (peaks(block, beta, dt_d * f) - ref) / ref
                print(f"{b} x {h}, {frac}, {f}, {np.round(ref, 4)}, {np.round(err, 2)}")


if __name__ == "__main__":
    main()
