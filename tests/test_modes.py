"""Tests of rockjax.modes: the mode objects (rj.Parapet, rj.Facade), their conversion from the
names ``"two_sided"`` / ``"one_sided"`` (rj.as_mode), the errors that name the argument, and
every public entry point giving the same result to the bit for the object and the string."""

import math
import re
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj

ROOT = Path(__file__).resolve().parents[1]
BLOCK = rj.Block(b=0.2, h=1.5)  # eta ~ 0.133 rad, p ~ 2.2 rad/s
GAP = 1e-3  # [m]
BETA = 1e-3  # [s]


def _ricker():
    return rj.GroundMotion.ricker(pga=0.3 * 9.81, period=0.5, dt=0.01, duration=1.5, name="r")


def _same(a, b):
    """The two pytrees of results equal to the bit, leaf by leaf (NaN equal to NaN)."""
    la, lb = jax.tree.leaves(a), jax.tree.leaves(b)
    assert len(la) == len(lb)
    for x, y in zip(la, lb):
        assert np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True)


# --------------------------------------------------------------------------- conversion


def test_as_mode_converts_names_and_passes_objects():
    assert rj.as_mode("two_sided") == rj.Parapet()
    assert rj.as_mode("one_sided") == rj.Facade(gap=0.0)
    assert rj.as_mode("one_sided", GAP) == rj.Facade(gap=GAP)
    assert rj.as_mode("two_sided", 0.0) == rj.Parapet()  # a zero gap is no gap
    facade = rj.Facade(gap=GAP)
    assert rj.as_mode(facade) is facade
    assert rj.as_mode(facade, GAP) is facade  # the same gap given twice is one gap
    assert rj.as_mode(rj.Parapet()) == rj.Parapet()


def test_names_and_flags_are_the_strings_outputs_carry():
    assert (rj.Parapet().name, rj.Parapet().one_sided) == ("two_sided", False)
    assert (rj.Facade().name, rj.Facade().one_sided) == ("one_sided", True)
    assert rj.Parapet().gap == 0.0 and rj.Facade(gap=GAP).gap == GAP


@pytest.mark.parametrize(
    "call, pattern",
    [
        (lambda: rj.as_mode("facade"), r"\bmode\b.*one_sided.*got mode='facade'"),
        (lambda: rj.as_mode(1), r"\bmode\b.*rj\.Facade\(gap="),
        (lambda: rj.as_mode("two_sided", GAP), r"\bgap\b=0\.001 m would be ignored.*one_sided"),
        (lambda: rj.as_mode(rj.Parapet(), GAP), r"\bgap\b.*\bm\b.*ignored.*rj\.Facade"),
        (
            lambda: rj.as_mode(rj.Facade(gap=GAP), 2e-3),
            r"\bgap\b.*\bm\b.*given twice.*rj\.Facade\(gap=0\.002\)",
        ),
        (lambda: rj.Facade(gap=-GAP), r"\bgap\b must be finite and >= 0 in m.*e\.g\. 0\.001"),
        (lambda: rj.as_mode("one_sided", -GAP), r"\bgap\b must be finite and >= 0 in m"),
        (lambda: rj.Facade(gap=np.nan), r"\bgap\b.*\bm\b"),
    ],
)
def test_bad_modes_and_gaps_are_refused_with_the_argument_unit_and_fix(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()


def test_a_gap_in_millimetres_warns_once():
    with pytest.warns(rj.PlausibilityWarning, match=r"gap=1 m.*gap=0\.001 for 1 mm") as rec:
        rj.as_mode("one_sided", 1.0)
    assert len(rec) == 1


# --------------------------------------------------------------------------- the facts


def test_friction_angle_is_the_papers():
    # the paper (Section 2): phi = 50 deg for parapets, 30 deg for facades
    for mode, phi in ((rj.Parapet(), 50.0), (rj.Facade(gap=GAP), 30.0)):
        p = rj.dem.dem_params(BLOCK, BETA, mode=mode)
        assert float(p.tan_phi) == pytest.approx(math.tan(math.radians(phi)), rel=1e-15)


def test_step_accuracy_tables_are_the_modes():
    for mode in (rj.Parapet(), rj.Facade()):
        assert rj.dem.DT_ACCURACY[mode.name] == mode.dt_accuracy
        assert rj.dem.DT_ACCURACY_SUB[mode.name] == mode.dt_accuracy_sub
    # the default step is accuracy / omega_max at beta = 0 (below the stability cap): linear in
    # the accuracy, so the default is the mode's when it scales a step of known accuracy
    for mode, n_sub in ((rj.Parapet(), "exact"), (rj.Facade(), "exact"), (rj.Parapet(), 2)):
        joint = rj.Joint(n_sub=n_sub)
        own = mode.dt_accuracy if n_sub == "exact" else mode.dt_accuracy_sub
        ref = rj.stable_dt(BLOCK, mode=mode, joint=joint, accuracy=0.25)
        got = rj.stable_dt(BLOCK, mode=mode, joint=joint)
        assert got == pytest.approx(ref * own / 0.25, rel=1e-12)


def test_default_restitution_is_the_papers_eq2_and_eq5():
    s, c = math.sin(float(BLOCK.eta)), math.cos(float(BLOCK.eta))
    e_h = 1.0 - 1.5 * s**2  # Eq. (2)
    e_1sr = (1.0 - 1.5 * s**2) ** 2 * (1.0 - 1.5 * c**2)  # Eq. (5), negative for a wall
    assert float(rj.Parapet().default_e(BLOCK)) == pytest.approx(e_h, rel=1e-14)
    assert float(rj.Facade().default_e(BLOCK)) == pytest.approx(e_1sr, rel=1e-14)
    assert e_1sr < 0 and rj.Facade().e_magnitude(e_1sr) == -e_1sr
    assert rj.Parapet().e_magnitude(e_h) == e_h


def test_amplitude_and_calibration_target():
    theta = np.array([-0.02, 0.0, 0.03])
    np.testing.assert_array_equal(rj.Parapet().amplitude(theta), [0.02, 0.0, 0.03])
    np.testing.assert_array_equal(rj.Facade().amplitude(theta), [0.0, 0.0, 0.03])
    assert isinstance(rj.Facade().amplitude(theta), np.ndarray)  # NumPy in, NumPy out
    np.testing.assert_array_equal(rj.Facade().amplitude(jnp.asarray(theta)), [0.0, 0.0, 0.03])
    assert rj.calibration.default_target(rj.Parapet()) == "e"
    assert rj.calibration.default_target("one_sided") == "bounces"


def test_no_string_comparison_of_modes_outside_modes_py():
    # the mode's facts live on the object: no module branches on its name
    compare = re.compile(r"""(==|!=)\s*["'](one|two)_sided["']|["'](one|two)_sided["']\s*(==|!=)""")
    offenders = []
    for path in (ROOT / "rockjax").rglob("*.py"):
        if path.name == "modes.py":
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if compare.search(line):
                offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not offenders, "\n".join(offenders)


# --------------------------------------------------------------------------- entry points


def test_simulate_dem_facade_object_equals_the_string_to_the_bit():
    gm = _ricker()
    a = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=rj.Facade(gap=GAP), save=("energy",))
    b = rj.simulate_dem(BLOCK, gm, beta=BETA, mode="one_sided", gap=GAP, save=("energy",))
    c = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=rj.Facade(gap=GAP), gap=GAP, save=("energy",))
    _same(a, b)
    _same(a, c)
    p = rj.simulate_dem(BLOCK, gm, beta=BETA, mode=rj.Parapet())
    _same(p, rj.simulate_dem(BLOCK, gm, beta=BETA))
    assert rj.stable_dt(BLOCK, BETA, mode=rj.Facade(gap=GAP)) == rj.stable_dt(
        BLOCK, BETA, mode="one_sided", gap=GAP
    )


def test_simulate_dem_traced_gap_in_the_facade():
    # a Facade built inside a transform carries a traced gap, as gap= does
    dt = rj.stable_dt(BLOCK, 0.0, mode=rj.Facade())
    kw = dict(theta0=0.05, duration=0.3, dt=dt, throw=False)

    @jax.jit
    def both(g):
        a = rj.simulate_dem(BLOCK, mode=rj.Facade(gap=g), **kw).theta
        b = rj.simulate_dem(BLOCK, mode="one_sided", gap=g, **kw).theta
        return a, b

    a, b = both(jnp.asarray(GAP))
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_simulate_housner_takes_the_object_and_refuses_a_gap():
    gm = _ricker()
    for obj, name in ((rj.Parapet(), "two_sided"), (rj.Facade(), "one_sided")):
        _same(rj.simulate_housner(BLOCK, gm, mode=obj), rj.simulate_housner(BLOCK, gm, mode=name))
    with pytest.raises(ValueError, match=r"\bgap\b=0\.001 m would be ignored.*no facade gap"):
        rj.simulate_housner(BLOCK, gm, mode=rj.Facade(gap=GAP))


def test_ida_takes_the_object_and_keeps_the_names_in_its_attrs():
    recs, scales = [_ricker()], [0.5, 1.0]
    kw = dict(model=rj.DEM(beta=BETA), tail=0.2, progress=False)
    a = rj.ida(BLOCK, recs, scales, mode=rj.Facade(gap=GAP), **kw)
    # the name with the gap apart (rj.ida's former gap=): the same runs, with a warning
    with pytest.warns(DeprecationWarning, match=r"mode=rj\.Facade\(gap="):
        b = rj.ida(BLOCK, recs, scales, mode="one_sided", gap=GAP, **kw)
    for k in a.data_vars:
        assert np.array_equal(a[k].values, b[k].values, equal_nan=True)
    assert a.attrs["mode"] == "one_sided" and a.attrs["gap"] == GAP
    h = rj.ida(BLOCK, recs, scales, model=rj.Housner(), mode="one_sided", tail=0.2, progress=False)
    assert h.attrs["mode"] == "one_sided" and h.attrs["gap"] == 0.0
    with pytest.raises(ValueError, match="no facade gap"):
        rj.ida(BLOCK, recs, scales, model=rj.Housner(), mode=rj.Facade(gap=GAP), progress=False)


def test_pushover_takes_the_object():
    a = rj.pushover(BLOCK, rj.Facade(gap=GAP), n_out=50)
    b = rj.pushover(BLOCK, "one_sided", gap=GAP, n_out=50)
    _same(a, b)


def test_fit_beta_takes_the_object():
    e = float(rj.e_housner(BLOCK))
    kw = dict(max_iter=2, progress=False)
    a = rj.fit_beta(BLOCK, e, mode=rj.Parapet(), **kw)
    b = rj.fit_beta(BLOCK, e, mode="two_sided", **kw)
    assert a.beta == b.beta and a.loss == b.loss
    problem = rj.calibration.problem(BLOCK, mode=rj.Facade(gap=GAP))
    assert problem.mode.one_sided and float(problem.mode.gap) == GAP
    assert problem.kind == "bounces"  # the facade's default target


def test_campaign_case_keeps_the_name_and_gap():
    a = rj.campaign.Case("f", BLOCK, "s", model=rj.DEM(beta=BETA), mode=rj.Facade(gap=GAP))
    b = rj.campaign.Case("f", BLOCK, "s", model=rj.DEM(beta=BETA), mode="one_sided", gap=GAP)
    assert a == b and a.spec() == b.spec()
    assert a.mode == "one_sided" and a.gap == GAP
    cases = rj.campaign.grid(
        {"b": BLOCK}, ["s"], modes=(rj.Parapet(), rj.Facade(gap=GAP)),
        beta={("b", "two_sided"): BETA, ("b", "one_sided"): BETA},
    )  # fmt: skip
    got = {(c.mode, c.model.name): c.gap for c in cases}
    assert got == {
        ("two_sided", "dem"): 0.0,
        ("two_sided", "housner"): 0.0,
        ("one_sided", "dem"): GAP,
        ("one_sided", "housner"): 0.0,  # Housner's facade has no gap
    }


@pytest.mark.parametrize(
    "kwargs",
    [dict(mode="one_sided"), dict(mode=rj.Facade(gap=GAP)), dict(mode="two_sided", gap=GAP)],
)
def test_pushover_of_an_assembly_converts_the_mode_once_and_names_the_fix(kwargs):
    """An assembly stands on the ground with its own restraint: a facade mode, or a gap given
    apart, is refused before any run, with one fix (mode='two_sided', gap=0), not the facade
    fix that would be refused next."""
    wall = rj.Assembly.stack([BLOCK, BLOCK])
    with pytest.raises(ValueError, match=r"own top support; leave mode='two_sided' and gap=0"):
        rj.pushover(wall, **kwargs)


def test_calibration_target_is_checked_once_at_the_edge():
    """rj.calibration.check_target resolves None to the mode's default target and refuses a
    target that does not fit e and the mode; fit_beta and problem call it once."""
    check = rj.calibration.check_target
    assert check(None, 0.9, rj.Parapet()) == "e"
    assert check(None, None, rj.Facade()) == "bounces"
    assert check("e", 0.5, rj.Facade()) == "e"
    with pytest.raises(ValueError, match=r"\btarget\b must be one of \['bounces', 'e'\]"):
        check("E", 0.9, rj.Parapet())
    with pytest.raises(ValueError, match=r"target='bounces' is the facade.*one_sided"):
        check("bounces", None, rj.Parapet())
    with pytest.raises(ValueError, match=r"by default.*drop e, or pass target='e'"):
        check(None, 0.5, rj.Facade())
    with pytest.raises(ValueError, match=r"needs the target restitution e"):
        check("e", None, rj.Parapet())
    assert rj.calibration.TARGETS == ("e", "bounces")
