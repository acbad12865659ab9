import jax.numpy as jnp
import numpy as np

from rockjax.contact import normal_force, shear_force


def test_normal_force_conventions():
    k, beta = 1e8, 0.01
    # separating corner still penetrated: the 'closed' dashpot pulls, the 'clipped' one cannot
    f, f_el, _ = normal_force(jnp.array(1e-6), jnp.array(-1.0), k, beta, "closed")
    assert np.isclose(f_el, 100.0) and np.isclose(f, 100.0 - 1e6)
    f, _, _ = normal_force(jnp.array(1e-6), jnp.array(-1.0), k, beta, "clipped")
    assert f == 0.0
    f, f_el, _ = normal_force(jnp.array(-1e-6), jnp.array(-1.0), k, beta, "closed")
    assert f == 0.0 and f_el == 0.0  # open contacts carry nothing


def test_shear_force_is_capped_by_mohr_coulomb():
    """Reference: |F_s| <= tan(phi) N with zero cohesion; an open contact resets the spring."""
    fs_total, fs, _ = shear_force(0.0, 1.0, 1e-3, 1e8, 1000.0, np.tan(np.radians(30)), 0.0)
    assert np.isclose(abs(fs), 1000.0 * np.tan(np.radians(30)))
    _, fs, _ = shear_force(500.0, 0.0, 1e-3, 1e8, 0.0, 1.0, 0.0)
    assert fs == 0.0


def test_sliding_contact_carries_the_coulomb_force_alone():
    """Reference: Coulomb friction, |F_s| = tan(phi) N on a sliding contact whatever its slip
    rate; the dashpot beta k_s (tangent stiffness k_s) acts on a sticking contact only."""
    k_s, n, tan_phi, beta, dt = 1e8, 1000.0, 0.5, 1e-3, 1e-5
    # sliding: the trial 100 - 1e8 * 1.0 * 1e-5 = -999 N is beyond the cap 500 N
    f, fs, w = shear_force(100.0, 1.0, dt, k_s, n, tan_phi, beta)
    assert f == fs == -tan_phi * n and w == 0.0
    # sticking: trial 100 - 1e8 * 1e-4 * 1e-5 = 99.9 N, and the dashpot beta k_s v = 10 N
    f, fs, w = shear_force(100.0, 1e-4, dt, k_s, n, tan_phi, beta)
    assert np.isclose(fs, 99.9) and np.isclose(f, 99.9 - 10.0) and w == 1.0
