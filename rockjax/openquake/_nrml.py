"""NRML 0.5 fragility models for the OpenQuake engine, from rockjax fragilities.

The engine's continuous ``logncdf`` fragility function is given by the mean and standard
deviation of the IM itself (in g for PGA and SA, cm/s for PGV), not of its logarithm: for a
lognormal with median ``theta`` and dispersion ``sigma`` these are
``mean = theta exp(sigma^2 / 2)`` and ``stddev = mean sqrt(exp(sigma^2) - 1)``
(:func:`lognormal_moments`). The engine turns them back into ``theta`` and ``sigma``, holds the
probability constant outside ``[minIML, maxIML]`` (the IM is clipped to that range) and sets it
to 0 at and below ``noDamageLimit``.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from .. import jsonio
from ..constants import G
from ..fragility import Fragility
from ..spectra import is_im_name, parse_im

NRML_NS = "http://openquake.org/xmlns/nrml/0.5"
MODEL_ID = "rockjax"
DESCRIPTION = "URM parapet and facade collapse fragilities computed by rockjax"
LOSS_CATEGORIES = ("structural", "nonstructural", "contents", "business_interruption")
ID_PATTERN = re.compile(r"^[A-Za-z0-9_-]{1,75}$")
"""Class ids and limit-state names the engine reads as identifiers (its ``source_id`` rule, the
stricter of the two it applies): letters, digits, ``_`` and ``-``, at most 75 characters."""

# IM units rockjax writes -> factor to the engine's unit for that IM type
_TO_ENGINE = {"PGA": {"m/s^2": 1.0 / G, "g": 1.0}, "SA": {"m/s^2": 1.0 / G, "g": 1.0}}
_TO_ENGINE["PGV"] = {"m/s": 100.0, "cm/s": 1.0}


def lognormal_moments(median: float, beta_log: float) -> tuple[float, float]:
    """Mean and standard deviation of a lognormal variable from its median and dispersion.

    Args:
        median: Median ``theta`` [IM units].
        beta_log: Standard deviation of ``ln IM`` [-].

    Returns:
        ``(mean, stddev)`` of the IM, in the units of ``median``: what the engine's continuous
        ``logncdf`` function reads as ``mean`` and ``stddev``.
    """
    mean = median * math.exp(0.5 * beta_log**2)
    return mean, mean * math.sqrt(math.expm1(beta_log**2))


def engine_imt(im: str) -> str:
    """The engine's name of a rockjax IM: ``"pga"`` -> ``"PGA"``, ``"sa(0.3)"`` ->
    ``"SA(0.3)"``, ``"pgv"`` -> ``"PGV"``.

    Raises:
        ValueError: for an IM the engine has no name for (a Dataset variable such as
            ``"scale"``), with the fix.
    """
    if not isinstance(im, str) or not is_im_name(im):
        raise ValueError(
            f"im={im!r} is no intensity measure the OpenQuake engine has; fit the fragility in "
            "'pga', 'pgv' or 'sa(T)': rj.fragility(ds, im='pga')."
        )
    spec = parse_im(im)
    return spec.name.upper()


def check_id(what: str, value) -> str:
    if not isinstance(value, str) or not ID_PATTERN.match(value):
        raise ValueError(
            f"{what} must be 1 to 75 letters, digits, '_' or '-' (the engine's identifiers); "
            f"got {value!r}. Rename it, e.g. {re.sub(r'[^A-Za-z0-9_-]', '_', str(value))[:75]!r}."
        )
    return value


def _as_limit_states(fragilities, limit_states) -> tuple[tuple[str, ...], dict]:
    """``{class id: {limit state: Fragility}}`` and the limit states in increasing severity."""
    if not isinstance(fragilities, Mapping) or not fragilities:
        raise ValueError(
            "fragilities must be a non-empty dict from class id to rj.Fragility (or to a dict "
            f"from limit state to rj.Fragility); got {type(fragilities).__name__}."
        )
    per_class = {}
    for cid, value in fragilities.items():
        check_id("each class id", cid)
        if isinstance(value, Fragility):
            value = {"collapse" if limit_states is None else None: value}
        if not isinstance(value, Mapping) or not value:
            raise ValueError(
                f"fragilities[{cid!r}] must be an rj.Fragility or a dict from limit state to "
                f"rj.Fragility; got {type(value).__name__}."
            )
        for ls, f in value.items():
            if not isinstance(f, Fragility):
                raise ValueError(
                    f"fragilities[{cid!r}][{ls!r}] must be an rj.Fragility; got {type(f).__name__}."
                )
        per_class[cid] = dict(value)
    if limit_states is None:
        names = tuple(next(iter(per_class.values())))
    else:
        names = (limit_states,) if isinstance(limit_states, str) else tuple(limit_states)
        for cid, value in per_class.items():  # a bare Fragility is the one limit state
            if list(value) == [None]:
                if len(names) != 1:
                    raise ValueError(
                        f"fragilities[{cid!r}] is one rj.Fragility but limit_states={names} "
                        "names several: give a dict from limit state to rj.Fragility."
                    )
                per_class[cid] = {names[0]: value[None]}
    if not names:
        raise ValueError("limit_states must name at least one limit state, e.g. ('collapse',).")
    for ls in names:
        check_id("each limit state", ls)
    if len(set(names)) != len(names):
        raise ValueError(f"limit_states must be distinct; got {names}.")
    for cid, value in per_class.items():
        if set(value) != set(names):
            raise ValueError(
                f"fragilities[{cid!r}] has limit states {sorted(value)}, the model "
                f"{list(names)}: every class needs one fragility per limit state."
            )
    return names, per_class


def _class_range(cid, funcs, iml_range, factor) -> tuple[float, float]:
    """``(minIML, maxIML)`` of a class in the engine's units."""
    if iml_range is not None:
        rng = iml_range[cid] if isinstance(iml_range, Mapping) else iml_range
        try:
            lo, hi = (float(v) for v in rng)
        except (TypeError, ValueError):
            raise ValueError(
                f"iml_range must be (lo, hi) in the engine's units (g for PGA and SA, cm/s for "
                f"PGV), or a dict from class id to one; got {rng!r} for class {cid!r}."
            ) from None
    else:
        los = [f.im_range[0] for f in funcs]
        his = [f.im_range[1] for f in funcs]
        if not all(math.isfinite(v) for v in los + his):
            raise ValueError(
                f"the fragilities of class {cid!r} carry no IM range (built by hand, not by "
                "rj.fragility): give iml_range=(lo, hi) in the engine's units (g for PGA and "
                "SA, cm/s for PGV)."
            )
        lo, hi = min(los) * factor, max(his) * factor
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        raise ValueError(
            f"the IM range of class {cid!r} must satisfy 0 < lo < hi (engine units: g for PGA "
            f"and SA, cm/s for PGV); got ({lo}, {hi}). Run the IDA over a wider range of "
            "positive scale factors, or give iml_range."
        )
    return lo, hi


def fragility_model(
    fragilities: Mapping[str, Fragility | Mapping[str, Fragility]],
    path: str | os.PathLike,
    *,
    limit_states: str | tuple[str, ...] | None = None,
    loss_category: str = "nonstructural",
    form: str = "continuous",
    n_levels: int = 40,
    iml_range: tuple[float, float] | Mapping[str, tuple[float, float]] | None = None,
    no_damage_limit: bool = True,
) -> str:
    """Write an NRML 0.5 ``fragilityModel`` that the OpenQuake engine reads.

    One ``fragilityFunction`` per class, its id the class id (the engine's taxonomy, or the
    ``risk_id`` of a ``taxonomy_mapping.csv``). The IM range of each class is that of the IDA
    its fragilities were fitted on (:attr:`rockjax.Fragility.im_range`, widest over its limit
    states), converted to the engine's units: ``minIML`` and ``maxIML``, and the
    ``noDamageLimit`` (the lowest IM that was run): the engine gives probability 0 at and below
    it and holds the probability at ``maxIML`` above ``maxIML``, so outside the range that was
    run the model claims nothing it did not compute.

    Args:
        fragilities: Class id -> :class:`rockjax.Fragility` (one limit state), or class id ->
            ``{limit state: Fragility}`` (several, e.g. from :func:`limit_state_fragilities`).
            Every fragility of the model must be in the same IM (``"pga"``, ``"sa(T)"`` or
            ``"pgv"``).
        path: The XML file to write.
        limit_states: Limit-state names in increasing severity; default the dict's order, or
            ``("collapse",)`` for bare fragilities. The curves of a class must not cross over
            its IM range (the engine's damage-state fractions are their differences).
        loss_category: ``"nonstructural"`` (default: parapets and facades), ``"structural"``,
            ``"contents"`` or ``"business_interruption"``; the job's key is
            ``<loss_category>_fragility_file``.
        form: ``"continuous"`` (``logncdf``, exact) or ``"discrete"`` (``n_levels`` IM levels,
            geometric over the range, which the engine interpolates linearly).
        n_levels: Levels of the discrete form (>= 2).
        iml_range: ``(lo, hi)`` in the engine's units (g for PGA and SA, cm/s for PGV), for every
            class or as a dict per class, instead of the IDA's range.
        no_damage_limit: Write ``noDamageLimit`` (the range's low end): probability 0 at and
            below the lowest IM that was run. False leaves it out: the engine then holds the
            probability at its ``minIML`` value (continuous) or its first level's (discrete)
            down to IM 0.

    Returns:
        The IM type written (e.g. ``"PGA"``): the job's ``intensity_measure_types``.

    Raises:
        ValueError: on ids the engine refuses, mixed IMs, unknown units, missing IM ranges,
            crossing limit-state curves or bad options, naming the fix.
    """
    names, per_class = _as_limit_states(fragilities, limit_states)
    if loss_category not in LOSS_CATEGORIES:
        raise ValueError(
            f"loss_category must be one of {LOSS_CATEGORIES}; got {loss_category!r}. Parapets "
            "and facades are 'nonstructural'."
        )
    if form not in ("continuous", "discrete"):
        raise ValueError(f"form must be 'continuous' or 'discrete'; got {form!r}.")
    if isinstance(n_levels, bool) or not (isinstance(n_levels, int) and n_levels >= 2):
        raise ValueError(f"n_levels must be an int >= 2; got {n_levels!r}. Use 40.")
    every = [f for value in per_class.values() for f in value.values()]
    ims = {f.im for f in every}
    if len(ims) != 1:
        raise ValueError(
            f"every fragility of one model must be in the same IM; got {sorted(ims)}. Fit them "
            "all with rj.fragility(ds, im=...) of one IM, or write one model per IM."
        )
    imt = engine_imt(every[0].im)
    kind = imt.split("(")[0]  # PGA, PGV or SA
    units = {f.im_units for f in every}
    if len(units) != 1 or next(iter(units)) not in _TO_ENGINE[kind]:
        raise ValueError(
            f"the fragilities are in {sorted(units)}, which rockjax cannot convert to the "
            f"engine's unit of {imt} ({'cm/s' if kind == 'PGV' else 'g'}); fit them in "
            f"{sorted(_TO_ENGINE[kind])}."
        )
    factor = _TO_ENGINE[kind][next(iter(units))]

    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<nrml xmlns="{NRML_NS}">',
        f'<fragilityModel id="{MODEL_ID}" assetCategory="buildings" '
        f'lossCategory="{loss_category}">',
        f"  <description>{escape(DESCRIPTION)}</description>",
        f"  <limitStates>{' '.join(names)}</limitStates>",
    ]
    for cid, value in per_class.items():
        funcs = [value[ls] for ls in names]
        lo, hi = _class_range(cid, funcs, iml_range, factor)
        _check_order(cid, names, funcs, lo / factor, hi / factor)
        ndl = f' noDamageLimit="{lo!r}"' if no_damage_limit else ""
        if form == "continuous":
            lines.append(f'  <fragilityFunction id="{cid}" format="continuous" shape="logncdf">')
            lines.append(f'    <imls imt="{imt}"{ndl} minIML="{lo!r}" maxIML="{hi!r}"/>')
            for ls, f in zip(names, funcs, strict=True):
                mean, std = lognormal_moments(f.median * factor, f.beta_log)
                lines.append(f'    <params ls="{ls}" mean="{mean!r}" stddev="{std!r}"/>')
        else:
            levels = discrete_levels(lo, hi, n_levels)
            lines.append(f'  <fragilityFunction id="{cid}" format="discrete">')
            text = " ".join(repr(float(v)) for v in levels)
            lines.append(f'    <imls imt="{imt}"{ndl}>{text}</imls>')
            for ls, f in zip(names, funcs, strict=True):
                poes = " ".join(repr(float(p)) for p in f.prob(levels / factor))
                lines.append(f"    <poes ls={quoteattr(ls)}>{poes}</poes>")
        lines.append("  </fragilityFunction>")
    lines += ["</fragilityModel>", "</nrml>", ""]
    jsonio.write_text(path, "\n".join(lines))
    return imt


def discrete_levels(lo: float, hi: float, n_levels: int) -> np.ndarray:
    """The IM levels of the discrete form: ``n_levels`` geometric from ``lo`` to ``hi``."""
    return np.geomspace(lo, hi, n_levels)


_ORDER_TOL = 1e-9
"""Probability by which a more severe limit state may exceed a milder one (round-off)."""


def _check_order(cid, names, funcs, lo, hi) -> None:
    """Refuse limit-state curves that cross over ``[lo, hi]`` (the IM's own units)."""
    if len(funcs) < 2:
        return
    grid = np.geomspace(lo, hi, 200)
    probs = np.stack([f.prob(grid) for f in funcs])
    for i in range(len(funcs) - 1):
        bad = probs[i + 1] > probs[i] + _ORDER_TOL
        if np.any(bad):
            at = grid[np.argmax(bad)]
            raise ValueError(
                f"class {cid!r}: limit state {names[i + 1]!r} is more probable than the milder "
                f"{names[i]!r} at IM = {at:.4g} {funcs[0].im_units}; the engine's damage-state "
                "fractions would be negative. Fit both from the same IDA "
                "(rockjax.openquake.limit_state_fragilities), or order limit_states by severity."
            )
