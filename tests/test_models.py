"""Tests of rockjax.models: the model objects of an IDA or a campaign (rj.DEM, rj.Housner,
rj.ThreeBranch), their conversion from the names "dem" / "housner" / "three_branch" with the
options apart (rj.as_model), the errors that name the argument and the fix, and the former
keywords of rj.ida and rj.campaign.Case giving the same runs to the bit, with a
DeprecationWarning."""

import inspect

import numpy as np
import pytest

import rockjax as rj

BLOCK = rj.Block(b=0.2, h=1.5)  # eta ~ 0.133 rad, p ~ 2.2 rad/s
BETA = 1e-3  # [s]
GAP = 1e-3  # [m]
LAW = rj.ThreeBranchLaw(lambda_0=0.2 / 1.5, Delta_1=0.05, Delta_2=0.2, Delta_u=0.8)


def _records():
    return [rj.GroundMotion.ricker(pga=3.0, period=0.5, dt=0.01, duration=1.0, name="r")]


def _same_dataset(a, b):
    """Every variable equal to the bit (NaN equal to NaN) and the same attributes but the
    creation time."""
    assert set(a.data_vars) == set(b.data_vars)
    for k in a.data_vars:
        assert np.array_equal(a[k].values, b[k].values, equal_nan=True), k
    skip = {"created"}
    assert {k for k in a.attrs if k not in skip} == {k for k in b.attrs if k not in skip}
    for k in a.attrs:
        if k not in skip:
            assert np.array_equal(np.asarray(a.attrs[k]), np.asarray(b.attrs[k])), k


# --------------------------------------------------------------------------- conversion


def test_as_model_converts_names_and_passes_objects():
    assert rj.as_model("dem", beta=BETA) == rj.DEM(beta=BETA)
    assert rj.as_model("dem", beta=BETA).joint == rj.Joint()
    corners = rj.Joint(n_sub=2)
    assert rj.as_model("dem", beta=BETA, joint=corners) == rj.DEM(beta=BETA, joint=corners)
    assert rj.as_model("housner") == rj.Housner()
    assert rj.as_model("housner", e=0.9) == rj.Housner(e=0.9)
    assert rj.as_model("three_branch", law=LAW) == rj.ThreeBranch(LAW)
    dem = rj.DEM(beta=BETA)
    assert rj.as_model(dem) is dem
    # a fit of the law is taken as its law
    fit = rj.ThreeBranchFit(law=LAW, rmse=0.0, max_error=0.0)
    assert rj.ThreeBranch(fit).law is LAW


def test_names_and_flags_are_the_strings_outputs_carry():
    assert [m.name for m in (rj.DEM, rj.Housner, rj.ThreeBranch)] == [
        "dem",
        "housner",
        "three_branch",
    ]
    assert not rj.DEM.rigid and rj.Housner.rigid and rj.ThreeBranch.rigid


@pytest.mark.parametrize(
    "call, pattern",
    [
        (lambda: rj.as_model("fem"), r"\bmodel\b must be one of.*got model='fem'"),
        (lambda: rj.as_model(1), r"\bmodel\b must be rj\.DEM\(beta="),
        (lambda: rj.as_model("dem"), r"model='dem' needs \bbeta\b.*rj\.DEM\(beta="),
        (lambda: rj.as_model("dem", beta=BETA, e=0.9), r"\be\b .*Housner parameter.*rj\.DEM"),
        (lambda: rj.as_model("housner", beta=BETA), r"\bbeta\b .*not a Housner.*takes e"),
        (lambda: rj.as_model("housner", law=LAW), r"\blaw\b.*rj\.ThreeBranch\(law\)"),
        (lambda: rj.as_model("three_branch"), r"needs law.*rj\.ThreeBranch\("),
        (lambda: rj.as_model(rj.DEM(beta=BETA), beta=BETA), r"given once.*rj\.DEM\(beta="),
        (lambda: rj.DEM(beta=-1e-3), r"\bbeta\b must be finite and >= 0 in s.*rj\.DEM"),
        (lambda: rj.DEM(beta=[1e-3, 2e-3]), r"\bbeta\b must be one number in s"),
        (lambda: rj.DEM(beta=BETA, accuracy=0.0), r"\baccuracy\b"),
        (lambda: rj.Housner(e="0.9"), r"\be\b.*quotes"),
        (lambda: rj.ThreeBranch(None), r"needs law.*fit_three_branch"),
    ],
)
def test_bad_models_are_refused_with_the_fix(call, pattern, user_view):
    with pytest.raises(ValueError, match=pattern):
        call()


def test_ida_signature_is_short():
    """The model's options travel in its object: ida's own keywords stay few."""
    params = inspect.signature(rj.ida).parameters
    named = [p for p in params.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    assert not {"beta", "e", "joint", "law", "gap"} & set(params)
    assert len(named) <= 15


# --------------------------------------------------------------------------- the same runs


def test_ida_former_keywords_give_the_object_runs_to_the_bit():
    """Reference: the object form; the former keywords (beta=, joint=, gap=, e=, law=) warn
    and run the same chunks, so the Datasets are equal to the bit."""
    kw = dict(tail=0.2, progress=False)
    corners = rj.Joint(n_sub=2)
    new = rj.ida(
        BLOCK,
        _records(),
        [0.5, 1.5],
        model=rj.DEM(beta=BETA, joint=corners),
        mode=rj.Facade(gap=GAP),
        **kw,
    )
    with pytest.warns(DeprecationWarning, match=r"rj\.DEM\(beta=.*rj\.Facade\(gap="):
        old = rj.ida(
            BLOCK,
            _records(),
            [0.5, 1.5],
            model="dem",
            beta=BETA,
            joint=corners,
            mode="one_sided",
            gap=GAP,
            **kw,
        )
    _same_dataset(new, old)
    assert new.attrs["model"] == "dem" and new.attrs["beta"] == BETA
    assert new.attrs["joint"] == repr(corners) and new.attrs["gap"] == GAP
    assert np.all(new["status"].values == 0)

    new = rj.ida(BLOCK, _records(), [0.5, 1.5], model=rj.Housner(e=0.8), **kw)
    with pytest.warns(DeprecationWarning, match=r"rj\.Housner\(e="):
        old = rj.ida(BLOCK, _records(), [0.5, 1.5], model="housner", e=0.8, **kw)
    _same_dataset(new, old)
    assert new.attrs["e"] == 0.8 and new.attrs["e_source"] == "given"
    alias = rj.ida(BLOCK, _records(), [0.5, 1.5], model="housner", **kw)
    _same_dataset(alias, rj.ida(BLOCK, _records(), [0.5, 1.5], model=rj.Housner(), **kw))

    new = rj.ida(BLOCK, _records(), [0.5, 1.5], model=rj.ThreeBranch(LAW), **kw)
    with pytest.warns(DeprecationWarning, match=r"rj\.ThreeBranch\(law"):
        old = rj.ida(BLOCK, _records(), [0.5, 1.5], model="three_branch", law=LAW, **kw)
    _same_dataset(new, old)
    assert new.attrs["model"] == "three_branch" and new.attrs["law_Delta_u"] == 0.8


def test_ida_refuses_unknown_keywords():
    with pytest.raises(TypeError, match="unexpected keyword argument 'betta'"):
        rj.ida(BLOCK, _records(), [1.0], model=rj.DEM(beta=BETA), betta=1e-3)


def test_campaign_case_keeps_the_object_and_its_spec():
    a = rj.campaign.Case("c", BLOCK, "s", model=rj.DEM(beta=BETA), mode=rj.Facade(gap=GAP))
    with pytest.warns(DeprecationWarning, match=r"model=rj\.DEM\(beta="):
        b = rj.campaign.Case("c", BLOCK, "s", model="dem", beta=BETA, mode="one_sided", gap=GAP)
    assert a == b and a.spec() == b.spec()
    assert a.model == rj.DEM(beta=BETA) and a.beta is None and a.mode == "one_sided"
    # the spec (hence the parts' fingerprints) of a default case keeps its former keys
    assert set(a.spec()) == {"name", "block", "records", "model", "mode", "beta", "e", "gap"}
    assert a.spec()["beta"] == BETA and a.spec()["model"] == "dem"
    corners = rj.campaign.Case("c", BLOCK, "s", model=rj.DEM(beta=BETA, joint=rj.Joint(n_sub=2)))
    assert corners.spec()["joint"] == repr(rj.Joint(n_sub=2))
    tb = rj.campaign.Case("t", BLOCK, "s", model=rj.ThreeBranch(LAW))
    assert tb.spec()["law_Delta_u"] == 0.8 and tb.spec()["model"] == "three_branch"
    cases = rj.campaign.grid(
        {"b": BLOCK}, ["s"], modes=("two_sided",), models=(rj.Housner(e=0.9), rj.ThreeBranch(LAW))
    )
    assert [c.name for c in cases] == ["b_two_sided_housner_s", "b_two_sided_three_branch_s"]
    assert cases[0].spec()["e"] == 0.9
