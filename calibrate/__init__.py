"""Calibration campaign of the DEM damping ``beta`` against the paper (Figs 1-3 and 5-7).

Run from the repository root: ``python -m calibrate parapets|facades|all [--quick]``.
Not part of the installed ``rockjax`` wheel.
"""
