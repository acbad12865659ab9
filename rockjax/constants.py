"""Physical constants and unit factors. Inside rockjax everything is SI (m, s, kg, Pa, rad)."""

G = 9.80665
"""Standard gravity [m/s^2]; PEER and FEMA P695 records are in units of this g."""

MPA = 1.0e6
"""One megapascal in pascals (Eq. 7 takes E in MPa)."""
