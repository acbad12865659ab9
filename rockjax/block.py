"""The rigid block: geometry, material, and derived rocking quantities."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._checks import check_above, check_below, check_positive, check_scalar, concrete
from ._types import ScalarLike
from .constants import G

MAX_DIMENSION = 50.0
"""Largest block dimension ``b``, ``h`` or ``length`` accepted [m]: above it the input is
taken for a unit slip (millimetres for metres)."""

MIN_DIMENSION = 1e-3
"""Smallest block dimension ``b``, ``h`` or ``length`` accepted [m] (a millimetre, below any
masonry unit or laboratory specimen): below it the input is taken for a unit slip (metres
divided by 1000 twice, or kilometres for metres), and the rocking frequency ``p`` and the DEM
step would leave floating-point range (a block of 1e-300 m)."""

MIN_RHO = 100.0
"""Smallest density accepted [kg/m^3] (below any masonry, timber or aerated concrete): below it
the input is taken for a unit slip (t/m^3 or g/cm^3 for kg/m^3)."""

MIN_E = 1e7
"""Smallest Young's modulus accepted [Pa] (10 MPa, below any masonry): below it the input is
taken for a unit slip (MPa for Pa)."""


class Block(eqx.Module):
    """A rectangular rigid block (a parapet or a facade panel), in SI units.

    Sign convention (used throughout rockjax): x is horizontal, in the rocking plane, y is up.
    ``theta > 0`` when the block rotates about its +x bottom corner (the top moves toward +x).
    A positive ground acceleration (base accelerating toward +x) drives ``theta`` negative.
    A facade (``mode="one_sided"``) may rotate only to ``theta >= 0``; its return walls stand
    at its -x face.

    Each field is one number: a Python float, or a JAX scalar, so a ``Block`` can be built
    inside ``vmap`` (``jax.vmap(lambda b: rj.Block(b=b, h=3.0))``) or differentiated. A
    concrete array of several values is refused: vmap over the values instead.

    Args:
        b: Full thickness in the rocking direction [m].
        h: Full height [m].
        length: Out-of-plane length [m] (does not change rocking, only mass and stiffness).
        rho: Density [kg/m^3].
        E: Young's modulus [Pa], used for the joint stiffness ``j_kn = E/h``.
        nu: Poisson ratio [-], used for ``j_ks = j_kn / (2 (1 + nu))``.
    """

    FIELDS: ClassVar[tuple[str, ...]] = ("b", "h", "length", "rho", "E", "nu")
    """The names of the fields, in order (for serialising a block)."""

    b: ScalarLike
    h: ScalarLike
    length: ScalarLike = 1.0
    rho: ScalarLike = 1800.0
    E: ScalarLike = 1.8e9
    nu: ScalarLike = 0.25

    def __check_init__(self):
        check_positive("b", self.b, "m", "Give the full wall thickness, e.g. b=0.25.", scalar=True)
        check_positive("h", self.h, "m", "Give the full wall height, e.g. h=3.0.", scalar=True)
        check_positive(
            "length", self.length, "m", "Use the out-of-plane length, e.g. 1.0.", scalar=True
        )
        check_positive("rho", self.rho, "kg/m^3", "Masonry is about 1800-2400 kg/m^3.", scalar=True)
        check_positive(
            "E", self.E, "Pa", "Give E in pascals, e.g. 1.8e9 for 1800 MPa.", scalar=True
        )
        for name in ("b", "h", "length"):
            check_below(
                name,
                getattr(self, name),
                MAX_DIMENSION,
                "m",
                f"rockjax works in metres: did you give millimetres? Divide by 1000 "
                f"(e.g. {name}=0.25 for 250 mm).",
            )
            check_above(
                name,
                getattr(self, name),
                MIN_DIMENSION,
                "m",
                f"rockjax works in metres (a brick is 0.1-0.25 m): give {name} in metres, "
                f"e.g. {name}=0.25 for 250 mm.",
            )
        check_above(
            "rho",
            self.rho,
            MIN_RHO,
            "kg/m^3",
            "Masonry is about 1800-2400 kg/m^3: did you give t/m^3 or g/cm^3? Multiply by "
            "1000 (e.g. rho=1800 for 1.8 t/m^3).",
        )
        check_above(
            "E",
            self.E,
            MIN_E,
            "Pa",
            "Masonry is about 1e8-1e10 Pa: did you give MPa? Multiply by 1e6 (e.g. E=1.8e9 "
            "for 1800 MPa).",
        )
        check_scalar("nu", self.nu, "[-]", "Masonry is about nu=0.15-0.25.")
        nu = concrete(self.nu)
        # NumPy, not jnp: inside jit every jnp operation is staged, even on a Python float
        if nu is not None and not (np.all(np.isfinite(nu)) and np.all((nu > -1) & (nu < 0.5))):
            raise ValueError(
                f"nu (Poisson ratio, dimensionless) must lie in (-1, 0.5); got nu={self.nu}."
            )

    @property
    def m(self):
        """Mass [kg]."""
        return self.rho * self.b * self.h * self.length

    @property
    def m_per_length(self):
        """Mass per unit out-of-plane length [kg/m] (the ``m`` of DeJong's omega_crit)."""
        return self.rho * self.b * self.h

    @property
    def R(self):
        """Half-diagonal, centroid to a corner [m]."""
        return 0.5 * jnp.hypot(self.b, self.h)

    @property
    def eta(self):
        """Slenderness angle ``atan(b/h)`` [rad] (the paper's eta; Housner's alpha)."""
        return jnp.arctan2(self.b, self.h)

    @property
    def p(self):
        """Housner frequency parameter ``sqrt(3 g / (4 R))`` [rad/s]."""
        return jnp.sqrt(3.0 * G / (4.0 * self.R))

    @property
    def I_c(self):
        """Moment of inertia about the centroid, in the rocking plane [kg m^2]."""
        return self.m * (self.b**2 + self.h**2) / 12.0

    @property
    def I_O(self):
        """Moment of inertia about a bottom corner, ``4/3 m R^2`` [kg m^2]."""
        return 4.0 / 3.0 * self.m * self.R**2

    @property
    def j_kn(self):
        """Joint normal stiffness per unit area ``E/h`` [Pa/m]."""
        return self.E / self.h

    @property
    def j_ks(self):
        """Joint shear stiffness per unit area ``j_kn / (2 (1 + nu))`` [Pa/m]."""
        return self.j_kn / (2.0 * (1.0 + self.nu))

    def top_displacement(self, theta):
        """Horizontal displacement [m] of the top centre relative to the base, rigid rotation
        ``theta`` [rad] about the pivot corner on the side of its sign:
        ``sign(theta) b/2 (1 - cos theta) + h sin theta``.

        ``|d|`` grows with ``|theta|`` on ``[0, pi/2]``, so the peak displacement of a run is
        ``top_displacement(theta_max)``.
        """
        return jnp.sign(theta) * 0.5 * self.b * (1.0 - jnp.cos(theta)) + self.h * jnp.sin(theta)
