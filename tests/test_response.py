import numpy as np

import rockjax as rj
from rockjax.response import e_exp, find_peaks


def test_find_peaks_refines_a_sampled_cosine():
    """Reference: the exact maxima of |cos(2 pi t)| at t = k/2."""
    t = np.arange(0.0, 3.0, 0.013)
    tp, yp = find_peaks(t, np.abs(np.cos(2 * np.pi * t)))
    np.testing.assert_allclose(tp, np.arange(1, tp.size + 1) * 0.5, atol=2e-4)
    np.testing.assert_allclose(yp, 1.0, atol=1e-4)


def test_e_exp_inverts_the_linearised_decay():
    """Reference: amplitude_after_impacts (docs/verification.md, Housner closed forms) fed back through Eq. 6."""
    eta, theta0, e = 0.2, 0.1, 0.94
    for n in (1, 2, 3):
        th_n = rj.relations.amplitude_after_impacts(theta0, eta, e, n)
        assert np.isclose(e_exp(th_n, theta0, eta, n), e, rtol=1e-12)


def test_public_names_have_docstrings():
    names = rj.__all__
    missing = [n for n in names if not getattr(getattr(rj, n), "__doc__", None)]
    assert not missing, missing
