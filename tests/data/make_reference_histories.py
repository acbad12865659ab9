"""Writes tests/data/reference_histories.npz: DEM histories of the single block and of
assemblies, kept so that a change of the DEM's code (not of its physics) can be shown to
reproduce them (tests/test_dem_reference.py, to 1e-12 rad).

Run from the repository root: ``python tests/data/make_reference_histories.py``. The cases are
in :func:`cases` (tests/test_dem_reference.py imports them from here); each is short (1.5-3 s
of motion) so that the test stays within a few minutes on two cores.
"""

import os
from pathlib import Path

# The histories are compared like with like: written under the test suite's XLA flags
# (tests/conftest.py), since LLVM's optimisation level changes round-off (fused multiply-adds),
# which a three-block stack grows to 2e-12 rad in 2 s.
os.environ.setdefault(
    "XLA_FLAGS", "--xla_backend_optimization_level=0 --xla_llvm_disable_expensive_passes=true"
)

import numpy as np  # noqa: E402

import rockjax as rj  # noqa: E402

rj.compilation.configure_cpu()  # with the suite's flags, as tests/conftest.py does

OUT = Path(__file__).with_name("reference_histories.npz")


def cases():
    """``{name: (body, motion, keywords)}``: the stored histories' inputs."""
    parapet = rj.Block(b=0.25, h=3.0)
    facade = rj.Block(b=0.2, h=1.5)
    squat = rj.Block(b=0.6, h=0.5)
    ricker = rj.GroundMotion.ricker(pga=4.0, period=0.5)
    pulse = rj.GroundMotion.sine_cycle(pga=3.0, period=0.4, duration=2.0)
    beta_p = float(rj.beta_dejong(parapet))
    beta_f = float(rj.beta_isr(facade))
    n = int(np.asarray(pulse.ag).shape[0])
    t = np.arange(n) * pulse.dt
    u_top = 2e-3 * np.sin(2 * np.pi * t / 0.5)
    v_top = 2e-3 * 2 * np.pi / 0.5 * np.cos(2 * np.pi * t / 0.5)
    bldg = rj.ShearBuilding.uniform(2, 3.0, period=0.25)
    two = rj.Assembly.stack([rj.Block(b=0.23, h=1.2)] * 2)
    three = rj.Assembly.stack(
        [rj.Block(b=0.4, h=1.0), rj.Block(b=0.2, h=0.8), rj.Block(b=0.2, h=0.8)]
    )
    wall = rj.Assembly.stack([rj.Block(b=0.23, h=1.5)] * 2, top="restrained", gap=1e-3)
    loaded = rj.Assembly.stack([rj.Block(b=0.23, h=1.2)] * 2, overburden=5e3)
    return {
        "parapet_face_ricker": (parapet, ricker, dict(beta=beta_p)),
        "parapet_corners_ricker": (parapet, ricker, dict(beta=beta_p, joint=rj.Joint(n_sub=2))),
        "parapet_free_release": (
            parapet,
            None,
            dict(beta=0.0, theta0=0.5 * float(parapet.eta), duration=2.0),
        ),
        "facade_face_release": (
            facade,
            None,
            dict(
                beta=beta_f,
                mode="one_sided",
                gap=1e-3,
                theta0=0.5 * float(facade.eta),
                duration=2.0,
            ),
        ),
        "facade_corners_pulse": (
            facade,
            pulse,
            dict(beta=beta_f, mode="one_sided", gap=1e-3, joint=rj.Joint(n_sub=2)),
        ),
        "facade_moving_wall": (
            facade,
            pulse,
            dict(beta=beta_f, mode="one_sided", gap=1e-3, wall_motion=(u_top, v_top)),
        ),
        "facade_building_wall": (
            facade,
            pulse,
            dict(beta=beta_f, mode="one_sided", gap=1e-3, wall_motion=bldg),
        ),
        "squat_sliding_pulse": (
            squat,
            pulse.scaled(2.5),
            dict(beta=float(rj.beta_dejong(squat)), phi_deg=30.0),
        ),
        "stack2_ricker": (two, ricker, dict(beta=beta_p)),
        "stack3_pulse": (three, pulse, dict(beta=beta_p)),
        "stack2_restrained_building": (
            wall,
            pulse,
            dict(beta=beta_p, support_motion=bldg, storey=2),
        ),
        "stack2_overburden_pulse": (loaded, pulse, dict(beta=beta_p)),
        "stack2_facade_pulse": (two, pulse, dict(beta=beta_f, mode="one_sided", gap=1e-3)),
    }


def run(body, motion, kw):
    """The stored arrays of one case: ``t``, ``theta`` (and ``x``, ``y`` of each block)."""
    r = rj.simulate_dem(body, motion, **kw)
    out = {"t": np.asarray(r.t), "theta": np.asarray(r.theta)}
    for name in ("x", "y"):
        value = getattr(r, name, None)
        if value is None:
            value = r.extras.get(name)
        out[name] = np.asarray(value)
    return out


def main():
    arrays = {}
    for name, (body, motion, kw) in cases().items():
        for key, value in run(body, motion, kw).items():
            arrays[f"{name}/{key}"] = value
        print(name, arrays[f"{name}/theta"].shape, float(np.abs(arrays[f"{name}/theta"]).max()))
    np.savez_compressed(OUT, **arrays)
    print("wrote", OUT)


if __name__ == "__main__":
    main()
