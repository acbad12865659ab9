"""The model an IDA or a campaign runs, one small object with its own options: the DEM
(:class:`DEM`, ``beta`` and its joint), Housner's rigid block (:class:`Housner`, ``e``) or
Housner's block with a three-branch moment-rotation law (:class:`ThreeBranch`, the law).

The one home of what differs between the models where a batch of runs is set up: the name
the outputs carry, whether the block is rigid (no facade gap, no assembly), the step bound a
record's step is divided by, the simulator a run calls and the Dataset's attributes of the
model's options. :func:`rockjax.ida`, :class:`rockjax.campaign.Case` and the CLI's ``ida``
take a model object or its name (``"dem"`` / ``"housner"`` / ``"three_branch"``, its options
given apart) and convert it once, with :func:`as_model`; inside, only the object travels
(docs/conventions.md, "Models").
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx

from ._checks import check_nonnegative, check_positive, check_scalar
from ._types import ScalarLike
from .assembly import Assembly
from .contact import Joint
from .dem import simulate_dem, stable_dt
from .housner import P_DT_TARGET, check_restitution, simulate_housner
from .modes import Mode
from .three_branch import ThreeBranchFit, ThreeBranchLaw

BETA_HINT = "e.g. rj.DEM(beta=2e-3), or beta=float(rj.beta_dejong(block))."
"""The fix named for a missing or malformed ``beta``."""


class DEM(eqx.Module):
    """The discrete-element model, :func:`rockjax.simulate_dem` (a block or an
    :class:`rockjax.Assembly`), with its options.

    Attributes:
        beta: Stiffness-proportional Rayleigh coefficient [s], Eq. (1); one finite number
            >= 0 (required: e.g. ``rj.beta_dejong(block)``, or a calibrated value).
        joint: The contact joint (:class:`rockjax.Joint`); default ``rj.Joint()``, the
            converged joint; ``rj.Joint(n_sub=2)`` is the paper's corner contacts.
        accuracy: The step accuracy ``omega_max dt (1 + zeta)`` [-] of
            :func:`rockjax.stable_dt`; default None, the mode's (``mode.dt_accuracy``).
        name: ``"dem"``, the name outputs, file names and attributes carry.
        rigid: False: the DEM takes a facade's gap and runs assemblies.
        numbers: ``("beta",)``: its numeric option, static or data in a batch.
    """

    beta: ScalarLike
    joint: Joint = Joint()
    accuracy: float | None = None

    name: ClassVar[str] = "dem"
    rigid: ClassVar[bool] = False
    numbers: ClassVar[tuple[str, ...]] = ("beta",)

    def __check_init__(self):
        check_scalar("beta", self.beta, "s", BETA_HINT)
        check_nonnegative("beta", self.beta, "s", BETA_HINT)
        if not isinstance(self.joint, Joint):
            raise TypeError(
                f"joint must be a rockjax.Joint, e.g. rj.DEM(beta=..., joint=rj.Joint(n_sub=2)); "
                f"got {type(self.joint).__name__}."
            )
        if self.accuracy is not None:
            check_positive(
                "accuracy", self.accuracy, "[-]", "Leave accuracy=None for the mode's.", scalar=True
            )

    def step_bound(self, block, mode: Mode) -> float:
        """The largest solver step [s] of a run (a record's step is split into equal steps
        not above it): :func:`rockjax.stable_dt` at ``beta``, as a single run picks it."""
        return stable_dt(block, self.beta, mode=mode, joint=self.joint, accuracy=self.accuracy)

    def simulate(self, block, motion, *, mode: Mode, dt, **kw):
        """One run: :func:`rockjax.simulate_dem` with this model's options (``kw``: the
        simulator's other keywords, e.g. ``throw``, ``wall_motion``)."""
        return simulate_dem(block, motion, beta=self.beta, mode=mode, dt=dt, joint=self.joint, **kw)

    def attrs(self) -> dict:
        """The options as a Dataset's attributes: ``beta`` [s] and the joint's ``repr``."""
        out = {"beta": float(self.beta), "joint": repr(self.joint)}
        if self.accuracy is not None:
            out["accuracy"] = float(self.accuracy)
        return out


class Housner(eqx.Module):
    """Housner's rigid block, :func:`rockjax.simulate_housner`, with its restitution.

    Attributes:
        e: Coefficient of restitution [-]; default None, the paper's for the mode (``e_H``,
            Eq. (2), two-sided; ``|e_1SR|``, Eq. (5), one-sided: ``mode.default_e``).
        name: ``"housner"``.
        rigid: True: a rigid block, flush on a facade's return walls (no gap), one block.
        numbers: ``("e",)``: its numeric option.
    """

    e: ScalarLike | None = None

    name: ClassVar[str] = "housner"
    rigid: ClassVar[bool] = True
    numbers: ClassVar[tuple[str, ...]] = ("e",)

    def __check_init__(self):
        check_restitution_given(self.e)

    def step_bound(self, block, mode: Mode) -> float:
        """The largest solver step [s] :func:`rockjax.simulate_housner` takes for the block."""
        return rigid_step_bound(block)

    def simulate(self, block, motion, *, mode: Mode, dt, **kw):
        """One run: :func:`rockjax.simulate_housner` with this model's ``e``."""
        return simulate_housner(block, motion, e=self.e, mode=mode, dt=dt, **kw)

    def attrs(self) -> dict:
        """The options as a Dataset's attributes (the restitution used is the IDA's)."""
        return {}


class ThreeBranch(eqx.Module):
    """Housner's block with a three-branch moment-rotation law
    (:func:`rockjax.simulate_housner` with ``law=``; docs/three_branch.md).

    Attributes:
        law: The law (:class:`rockjax.ThreeBranchLaw`; a :class:`rockjax.ThreeBranchFit`,
            ``rj.fit_three_branch(rj.pushover(block))``, is taken as its ``law``).
        e: Coefficient of restitution [-]; default None, the paper's, as :class:`Housner`.
        name: ``"three_branch"``.
        rigid: True, as :class:`Housner`: no gap, one block.
        numbers: ``("e",)``.
    """

    law: ThreeBranchLaw
    e: ScalarLike | None = None

    name: ClassVar[str] = "three_branch"
    rigid: ClassVar[bool] = True
    numbers: ClassVar[tuple[str, ...]] = ("e",)

    def __init__(self, law: ThreeBranchLaw | ThreeBranchFit, e: ScalarLike | None = None):
        self.law = law.law if isinstance(law, ThreeBranchFit) else law
        self.e = e

    def __check_init__(self):
        if not isinstance(self.law, ThreeBranchLaw):
            raise ValueError(
                "rj.ThreeBranch needs law, a rockjax.ThreeBranchLaw, e.g. "
                "rj.ThreeBranch(rj.fit_three_branch(rj.pushover(block)).law); got "
                f"law={self.law!r}."
            )
        check_restitution_given(self.e)

    def step_bound(self, block, mode: Mode) -> float:
        """The largest solver step [s] :func:`rockjax.simulate_housner` takes for the block."""
        return rigid_step_bound(block)

    def simulate(self, block, motion, *, mode: Mode, dt, **kw):
        """One run: :func:`rockjax.simulate_housner` with this model's law and ``e``."""
        return simulate_housner(block, motion, e=self.e, mode=mode, dt=dt, law=self.law, **kw)

    def attrs(self) -> dict:
        """The law's parameters as a Dataset's attributes, ``law_<field>``."""
        return {
            f"law_{field}": float(getattr(self.law, field))
            for field in ("lambda_0", "Delta_1", "Delta_2", "Delta_u")
        }


Model = DEM | Housner | ThreeBranch
"""A model of a batch of runs: :class:`DEM`, :class:`Housner` or :class:`ThreeBranch`."""

MODEL_NAMES = (DEM.name, Housner.name, ThreeBranch.name)
"""The models' names, as the string form of ``model=`` takes them."""


def as_model(model, *, beta=None, e=None, joint=None, law=None) -> Model:
    """The model object of a ``model=`` argument: a :class:`DEM`, :class:`Housner` or
    :class:`ThreeBranch` as it is, or its name with the model's options given apart.

    Args:
        model: ``rj.DEM(beta=...)``, ``rj.Housner(e=...)``, ``rj.ThreeBranch(law)``, or
            ``"dem"`` (with ``beta``), ``"housner"``, ``"three_branch"`` (with ``law``).
        beta: The string form's DEM damping [s], Eq. (1); ``"dem"`` only, required there.
        e: The string form's restitution [-]; ``"housner"`` / ``"three_branch"`` only.
        joint: The string form's DEM joint (:class:`rockjax.Joint`); ``"dem"`` only.
        law: The string form's three-branch law; ``"three_branch"`` only, required there.

    Returns:
        The :class:`DEM`, :class:`Housner` or :class:`ThreeBranch`.

    Raises:
        ValueError: an unknown model; an option the model does not take; a model object
            with options also given apart (give them once, in the object); a missing
            ``beta`` (DEM) or ``law`` (three-branch); an option out of its range.
    """
    given = {k: v for k, v in dict(beta=beta, e=e, joint=joint, law=law).items() if v is not None}
    if isinstance(model, DEM | Housner | ThreeBranch):
        if given:
            apart = ", ".join(f"{k}={v!r}" for k, v in given.items())
            raise ValueError(
                f"model={model!r} and {apart}: a model's options are given once, in its "
                f"object; e.g. model=rj.DEM(beta=2e-3, joint=rj.Joint(n_sub=2)), "
                "model=rj.Housner(e=0.9) or model=rj.ThreeBranch(law, e=0.9)."
            )
        return model
    if not isinstance(model, str):
        raise ValueError(
            f"model must be rj.DEM(beta=<s>), rj.Housner(e=...), rj.ThreeBranch(law) or one of "
            f"{sorted(MODEL_NAMES)}; got model={model!r}."
        )
    if model not in MODEL_NAMES:
        raise ValueError(
            f"model must be one of {sorted(MODEL_NAMES)}, or rj.DEM(beta=<s>), rj.Housner(), "
            f"rj.ThreeBranch(law); got model={model!r}."
        )
    if model == DEM.name:
        if e is not None:
            raise ValueError(
                f"e (restitution) is a Housner parameter; model='dem' takes beta [s] "
                f"(model=rj.DEM(beta=...)). Got e={e}."
            )
        _refuse_law(model, law)
        if beta is None:
            raise ValueError(
                "model='dem' needs beta, the stiffness-proportional damping coefficient in s: "
                f"model=rj.DEM(beta=...), {BETA_HINT}"
            )
        return DEM(beta=beta, joint=Joint() if joint is None else joint)
    if beta is not None:
        raise ValueError(
            f"beta (DEM damping) is not a Housner parameter; model={model!r} takes e "
            f"(model=rj.Housner(e=...)). Got beta={beta}."
        )
    if joint is not None:
        raise ValueError(
            f"joint (the DEM's contact joint) is not a Housner parameter; got joint={joint!r}. "
            "Drop it, or use model=rj.DEM(beta=..., joint=...)."
        )
    if model == Housner.name:
        _refuse_law(model, law)
        return Housner(e=e)
    if law is None:
        raise ValueError(
            "model='three_branch' needs law=, a rockjax.ThreeBranchLaw: "
            "model=rj.ThreeBranch(rj.fit_three_branch(rj.pushover(block)).law)."
        )
    return ThreeBranch(law, e=e)


# ----------------------------------------------------------------------------- helpers


def _refuse_law(model: str, law) -> None:
    if law is not None:
        raise ValueError(
            f"law (a three-branch moment-rotation law) needs model='three_branch'; got "
            f"model={model!r}. Pass model=rj.ThreeBranch(law) or drop law."
        )


def check_restitution_given(e) -> None:
    """A given restitution [-]: one real number (its range for the mode is checked where the
    mode is known, :func:`rockjax.housner.check_restitution`)."""
    if e is not None:
        check_scalar("e", e, "[-]", "e.g. rj.Housner(e=0.9), or e=None for the default.")


def restitution_used(model: Housner | ThreeBranch, block, mode: Mode) -> float:
    """The restitution [-] a rigid model's runs use: the given ``e`` or the paper's default
    for the mode, checked (a squat block's ``e_H < 0`` is refused here, not run into failed
    runs), as its magnitude (``|e|`` one-sided, as :func:`rockjax.simulate_housner`)."""
    e_run = float(model.e) if model.e is not None else float(mode.default_e(block.eta))
    check_restitution(e_run, mode, default=model.e is None)
    return mode.e_magnitude(e_run)


def rigid_step_bound(block) -> float:
    """The step bound :func:`rockjax.simulate_housner` picks for a concrete block [s]."""
    return P_DT_TARGET / float(block.p)


def map_numbers(model: Model, fn) -> Model:
    """The model with each of its given numeric options (``model.numbers``: the DEM's
    ``beta``, a given ``e``) replaced by ``fn(value)``: Python floats (static under
    ``filter_jit``, a compile-cache key) or float64 NumPy scalars (data: one compiled program
    for every value, :func:`rockjax.compilation.strong_scalars`)."""
    for name in model.numbers:
        value = getattr(model, name)
        if value is not None:
            model = eqx.tree_at(lambda m, name=name: getattr(m, name), model, fn(value))
    return model


def takes_assembly(model: Model, block) -> None:
    """Refuse an :class:`rockjax.Assembly` for a rigid model (one block only)."""
    if isinstance(block, Assembly) and model.rigid:
        raise ValueError(
            f"an Assembly runs with the DEM only, model=rj.DEM(beta=...); got model={model.name!r}."
        )
