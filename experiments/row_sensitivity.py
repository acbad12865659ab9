"""How much a row of two leaves amplifies a tiny change of its record, against a single block
and a stack of the same blocks: each is run under a Ricker pulse (0.12 g, T = 0.5 s, 3 s) and
under the same pulse scaled by 1 + 1e-12, at beta = 0 and at beta_DeJong, and the largest
difference of the rotations is printed over the peak (docs/assemblies.md, "Blocks side by
side"). About a minute:

    python experiments/row_sensitivity.py
"""

import jax.numpy as jnp

import rockjax as rj

SLENDER = rj.Block(b=0.12, h=1.5)
SHORT = rj.Block(b=0.12, h=1.0)
PULSE = rj.GroundMotion.ricker(pga_g=0.12, period=0.5, duration=3.0)
NUDGED = rj.GroundMotion(ag=PULSE.ag * (1.0 + 1e-12), dt=PULSE.dt)


def main():
    walls = {
        "single block": rj.Assembly.stack([SLENDER]),
        "stack of two": rj.Assembly.stack([SLENDER, SHORT]),
        "row of two leaves": rj.Assembly.row([SLENDER, SHORT]),
    }
    print("max |theta - theta_nudged| / max |theta| after a 1e-12 change of the record")
    for beta in (0.0, float(rj.beta_dejong(SHORT))):
        for name, wall in walls.items():
            a = rj.simulate_assembly(wall, PULSE, beta=beta)
            b = rj.simulate_assembly(wall, NUDGED, beta=beta, dt=float(a.dt))
            rel = float(jnp.max(jnp.abs(a.theta - b.theta)) / jnp.max(jnp.abs(a.theta)))
            print(f"  beta = {beta:.4g} s, {name:18s}: {rel:.2e}")


if __name__ == "__main__":
    main()
