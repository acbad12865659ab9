"""The time-history result of a simulation, and its post-processing (peaks, Eq. 6)."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_UNSTABLE = 2
STATUS_UNRESOLVED = 3
STATUS_BAD_INPUT = 4
STATUS_MESSAGES = {
    STATUS_OK: "ok",
    STATUS_NONFINITE: "the state became non-finite (NaN/inf): reduce dt or check the inputs",
    STATUS_UNSTABLE: "dt exceeds the explicit stability limit: leave dt=None or use rj.stable_dt",
    STATUS_UNRESOLVED: (
        "Housner: a solver step needed more impacts than max_impacts_per_step (the block was "
        "stopped there): raise max_impacts_per_step or pass a smaller dt"
    ),
    STATUS_BAD_INPUT: (
        "an input traced through jit/vmap is out of range (beta or gap negative or not finite; "
        "block dimensions, E or rho not finite and positive; a non-finite ground acceleration): "
        "the run was not made; check that lane's inputs"
    ),
}


class Response(eqx.Module):
    """A simulated rocking history, sampled at ``t``.

    Attributes:
        t: Sample times [s].
        theta: Rotation [rad] (positive about the +x bottom corner).
        theta_dot: Angular velocity [rad/s].
        d: Horizontal displacement of the top centre relative to the base [m].
        overturned: True if ``|theta|`` passed ``eta`` while moving outward; the state is frozen
            from then on.
        status: 0 if the run is valid, else a code in ``rockjax.response.STATUS_MESSAGES``.
        theta_max: Largest ``|theta|`` reached over the run, including between samples [rad].
        eta: Slenderness angle of the block [rad], to normalise ``theta``.
        b: Block thickness [m], to normalise ``d``.
        energy: Total mechanical energy [J] (DEM: kinetic + potential + contact springs;
            Housner: kinetic + potential), or None when not requested.
        extras: Model-specific series, e.g. contact forces (DEM) or impact counts (Housner).
    """

    t: Float[Array, " time"]
    theta: Float[Array, " time"]
    theta_dot: Float[Array, " time"]
    d: Float[Array, " time"]
    overturned: Bool[Array, ""]
    status: Int[Array, ""]
    theta_max: Float[Array, ""]
    eta: Float[Array, ""]
    b: Float[Array, ""]
    energy: Float[Array, " time"] | None = None
    extras: dict = eqx.field(default_factory=dict)

    @property
    def d_over_b(self):
        """Top displacement over thickness, ``d/b`` [-]."""
        return self.d / self.b

    @property
    def theta_over_eta(self):
        """Normalised rotation ``theta/eta`` [-]."""
        return self.theta / self.eta

    @property
    def ok(self):
        """True where the run finished without a numerical failure."""
        return self.status == STATUS_OK

    def peaks(self, min_separation: float = 0.0):
        """Local maxima of ``|theta|`` (one per half-cycle), refined by a parabola through 3 samples.

        Runs on concrete (NumPy) values; not for use under jit.

        Returns:
            ``(t_peak, abs_theta_peak)`` as NumPy arrays [s], [rad].
        """
        return find_peaks(np.asarray(self.t), np.abs(np.asarray(self.theta)), min_separation)

    def e_exp(self, n_bounces: int = 3, theta0: float | None = None):
        """Experimental coefficient of restitution of bounces 1..n from peak rotations, Eq. (6).

        ``e_exp,n = [ (1 - (1 - |theta_n|/eta)^2) / (1 - (1 - |theta_0|/eta)^2) ]^(1/(2n))``

        Args:
            n_bounces: How many bounces to evaluate.
            theta0: Release rotation [rad]; default the first sample's ``|theta|``.

        Returns:
            NumPy array of ``e_exp`` for bounces 1..n (NaN where the peak does not exist).
        """
        _, amp = self.peaks()
        eta = float(self.eta)
        th0 = abs(float(self.theta[0])) if theta0 is None else abs(theta0)
        # the release itself is a maximum at t=0 that find_peaks does not return (edge sample)
        out = np.full(n_bounces, np.nan)
        for n in range(1, n_bounces + 1):
            if n <= amp.size:
                out[n - 1] = e_exp(amp[n - 1], th0, eta, n)
        return out


def e_exp(theta_n, theta0, eta, n):
    """Eq. (6): coefficient of restitution from the n-th bounce peak ``|theta_n|`` [rad].

    Args:
        theta_n: Peak rotation after the n-th impact [rad].
        theta0: Release rotation [rad].
        eta: Slenderness angle [rad].
        n: Bounce number (1, 2, ...).
    """
    num = 1.0 - (1.0 - jnp.abs(theta_n) / eta) ** 2
    den = 1.0 - (1.0 - jnp.abs(theta0) / eta) ** 2
    return (num / den) ** (1.0 / (2.0 * n))


def find_peaks(t: np.ndarray, y: np.ndarray, min_separation: float = 0.0):
    """Interior local maxima of ``y(t)`` (y >= 0), refined by a 3-point parabola; NumPy only."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if y.size < 3:
        return np.empty(0), np.empty(0)
    i = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    i = i[y[i] > 0]
    h = t[1] - t[0]
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    denom = y0 - 2 * y1 + y2
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom < 0, 0.5 * (y0 - y2) / denom, 0.0)
    s = np.clip(s, -1.0, 1.0)
    tp = t[i] + s * h
    yp = y1 - 0.25 * (y0 - y2) * s
    if min_separation > 0 and tp.size:
        keep = [0]
        for k in range(1, tp.size):
            if tp[k] - tp[keep[-1]] >= min_separation:
                keep.append(k)
            elif yp[k] > yp[keep[-1]]:
                keep[-1] = k
        tp, yp = tp[keep], yp[keep]
    return tp, yp
