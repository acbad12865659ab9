"""A catalogue of building classes for regional risk: each class's IDA and fragility in a
ground IM the engine has, the building's amplification inside the class.

A class is one element (a free parapet on the roof, or a facade on return walls with its gap,
in a storey) of one geometry bin ``(b, h)`` on one host building (storeys, fundamental period,
damping; a uniform :class:`rockjax.ShearBuilding`). Its IDA runs the element on the motion of
the floor it stands on (the roof for a parapet, floor ``storey - 1`` for a facade, 0 the
ground): the building's floor accelerations under each ground record, which the linear
building scales with the record, so the run at scale ``s`` is the element under the building's
response to the ground record at scale ``s``. The IM of each run is then the ground record's IM
times ``s`` (PGA or SA(T) at the site), and the fragility is fitted in it: the engine's ground
motion fields enter directly, the amplification lives inside the class.

The IDAs run as one :func:`rockjax.campaign.run` (Dask, resumable: a stopped catalogue restarts
where it stopped): one record set per host building and floor, one case per class.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
from collections.abc import Mapping, Sequence

import numpy as np

from .. import campaign
from .._lazy import lazy_module
from ..block import Block
from ..building import ShearBuilding
from ..constants import G
from ..fragility import Fragility, fragility
from ..ida import DEFAULT_SCALES
from ..models import DEM, Model, as_model
from ..modes import Facade, Parapet
from ..motion import GroundMotion
from ..spectra import intensity, parse_im
from ._limit_states import limit_state_fragilities

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)

ELEMENTS = ("parapet", "facade")
DEFAULT_STOREY_HEIGHT = 3.0  # [m], a URM storey
PERIOD_PER_STOREY = 0.1
"""Default fundamental period per storey [s] of the host building (T1 ~ 0.1 n for low-rise URM,
the rule of thumb of rockjax.ShearBuilding.uniform's check)."""


def _tag(x, scale: int) -> str:
    return f"{round(float(x) * scale):d}"


@dataclasses.dataclass(frozen=True)
class BuildingClass:
    """One class of the catalogue: an element, its geometry bin, restraint, host and position.

    Attributes:
        element: ``"parapet"`` (free, rocking both ways on the roof) or ``"facade"`` (one-sided,
            on return walls ``gap`` behind it, in storey ``storey``).
        b: Thickness of the bin's representative block [m].
        h: Height of the bin's representative block [m].
        storeys: Storeys of the host building.
        period: Fundamental period of the host building [s]; default 0.1 s per storey.
        damping: Damping ratio of the host building [-].
        storey: Facades only: the storey the facade stands in (1 = ground storey, its base on
            the ground); parapets stand on the roof (``storeys + 1``).
        gap: Facades only: gap to the return walls [m] (the DEM's; Housner's facade has none).
        storey_height: Storey height of the host building [m].
    """

    element: str
    b: float
    h: float
    storeys: int
    period: float | None = None
    damping: float = 0.05
    storey: int | None = None
    gap: float = 0.0
    storey_height: float = DEFAULT_STOREY_HEIGHT

    def __post_init__(self):
        if self.element not in ELEMENTS:
            raise ValueError(f"element must be one of {ELEMENTS}; got {self.element!r}.")
        for name in ("b", "h", "storey_height"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number in m; got {name}={v!r}.")
        n = self.storeys
        if isinstance(n, bool) or not (isinstance(n, int | np.integer) and n >= 1):
            raise ValueError(f"storeys must be an int >= 1; got storeys={n!r}.")
        if self.period is None:
            object.__setattr__(self, "period", PERIOD_PER_STOREY * int(n))
        if not (math.isfinite(self.period) and self.period > 0):
            raise ValueError(f"period must be positive, in s; got period={self.period!r}.")
        if self.element == "parapet":
            if self.storey not in (None, n + 1):
                raise ValueError(
                    f"a parapet stands on the roof (storey={n + 1} of a {n}-storey building); "
                    f"got storey={self.storey!r}. Leave storey out."
                )
            if self.gap:
                raise ValueError(f"a parapet has no return walls; got gap={self.gap!r}.")
            object.__setattr__(self, "storey", int(n) + 1)
        else:
            s = 1 if self.storey is None else self.storey
            if isinstance(s, bool) or not (isinstance(s, int | np.integer) and 1 <= s <= n):
                raise ValueError(
                    f"a facade's storey must be an int from 1 to storeys={n}; got storey={s!r}."
                )
            object.__setattr__(self, "storey", int(s))
            if not (math.isfinite(self.gap) and self.gap >= 0):
                raise ValueError(f"gap must be >= 0, in m; got gap={self.gap!r}.")

    @property
    def floor(self) -> int:
        """The floor whose motion drives the element's base (0 the ground, ``storeys`` the roof)."""
        return self.storey - 1

    @property
    def id(self) -> str:
        """The class id (the engine's ``risk_id``), e.g. ``"P-b25-h100-n2-T20-roof"``: b and h
        in cm, the period in hundredths of a second, the damping in %, the gap in mm."""
        head = "P" if self.element == "parapet" else "F"
        where = "roof" if self.element == "parapet" else f"s{self.storey}"
        gap = f"-g{_tag(self.gap, 1000)}" if self.element == "facade" else ""
        return (
            f"{head}-b{_tag(self.b, 100)}-h{_tag(self.h, 100)}{gap}-n{self.storeys}"
            f"-T{_tag(self.period, 100)}-z{_tag(self.damping, 100)}-{where}"
        )

    def block(self) -> Block:
        """The bin's representative block."""
        return Block(b=self.b, h=self.h)

    def mode(self) -> Parapet | Facade:
        """:class:`rockjax.Parapet` or :class:`rockjax.Facade` (with the gap)."""
        return Parapet() if self.element == "parapet" else Facade(gap=self.gap)

    def building(self) -> ShearBuilding:
        """The host building (uniform, :meth:`rockjax.ShearBuilding.uniform`)."""
        return ShearBuilding.uniform(self.storeys, self.storey_height, self.period, self.damping)

    def host_key(self) -> str:
        """Name of the record set this class runs on (its building and floor)."""
        return (
            f"n{self.storeys}-T{_tag(self.period, 1000)}-z{_tag(self.damping, 1000)}"
            f"-H{_tag(self.storey_height, 100)}-f{self.floor}"
        )


def _centre(value, centres: Sequence[float], what: str, log: bool) -> float:
    """The nearest bin centre; refuses values beyond half a spacing outside the range."""
    c = np.asarray(centres, float)
    if c.size == 1:
        return float(c[0])
    f = np.log if log else (lambda x: x)
    x, fc = f(float(value)), f(c)
    half_lo, half_hi = 0.5 * (fc[1] - fc[0]), 0.5 * (fc[-1] - fc[-2])
    if not (fc[0] - half_lo <= x <= fc[-1] + half_hi):
        raise ValueError(
            f"{what}={value!r} lies outside the catalogue's bins (centres {c.tolist()}); add a "
            "bin for it, or leave the building out of the exposure."
        )
    return float(c[int(np.argmin(np.abs(fc - x)))])


@dataclasses.dataclass(frozen=True)
class Catalogue:
    """Classes over geometry bins, restraint, host building and position.

    Build with :meth:`grid`; :meth:`class_of` bins a building of an inventory; :meth:`run`
    computes every class's IDA and fragility.

    Attributes:
        classes: The classes, distinct ids.
        b: Bin centres of the thickness per element [m].
        h: Bin centres of the height per element [m].
        periods: Host period per storey count [s].
    """

    classes: tuple[BuildingClass, ...]
    b: Mapping[str, tuple[float, ...]]
    h: Mapping[str, tuple[float, ...]]
    periods: Mapping[int, float]
    gap: float = 0.0
    damping: float = 0.05

    @classmethod
    def grid(
        cls,
        *,
        parapet_b: Sequence[float] = (0.12, 0.25, 0.38),
        parapet_h: Sequence[float] = (0.6, 1.0, 1.5),
        facade_b: Sequence[float] = (0.25, 0.38, 0.5),
        facade_h: Sequence[float] = (3.0,),
        storeys: Sequence[int] = (1, 2, 3),
        periods: Mapping[int, float] | None = None,
        damping: float = 0.05,
        gap: float = 0.0,
        facade_storeys: str = "top",
    ) -> Catalogue:
        """Every combination of element x (b, h) bin x host building x position.

        Args:
            parapet_b: Parapet thickness bins (centres) [m].
            parapet_h: Parapet height bins [m].
            facade_b: Facade thickness bins [m].
            facade_h: Facade height bins [m] (a storey's facade: about the storey height).
            storeys: Host buildings' storey counts.
            periods: Storey count -> fundamental period [s]; default 0.1 s per storey.
            damping: The buildings' damping ratio [-].
            gap: Facades' gap to the return walls [m].
            facade_storeys: ``"top"`` (the facade of the top storey, the one that fails
                first), or ``"all"`` (every storey).

        Returns:
            The :class:`Catalogue`.
        """
        periods = {n: PERIOD_PER_STOREY * n for n in storeys} if periods is None else periods
        classes = []
        for n in storeys:
            common = dict(storeys=n, period=float(periods[n]), damping=damping)
            for b, h in itertools.product(parapet_b, parapet_h):
                classes.append(BuildingClass("parapet", b, h, **common))
            where = [n] if facade_storeys == "top" else range(1, n + 1)
            for b, h, s in itertools.product(facade_b, facade_h, where):
                classes.append(BuildingClass("facade", b, h, storey=s, gap=gap, **common))
        return cls(
            classes=tuple(classes),
            b={"parapet": tuple(parapet_b), "facade": tuple(facade_b)},
            h={"parapet": tuple(parapet_h), "facade": tuple(facade_h)},
            periods=dict(periods),
            gap=gap,
            damping=damping,
        )

    def __post_init__(self):
        ids = [c.id for c in self.classes]
        if len(set(ids)) != len(ids):
            raise ValueError("the catalogue's class ids repeat; its bins must be distinct.")

    def class_of(self, building) -> str:
        """The class id of one building (a row of an inventory).

        Args:
            building: With ``element`` (``"parapet"`` or ``"facade"``), ``b`` and ``h`` [m],
                ``storeys``, and for a facade ``storey`` (default the top one).

        Returns:
            The id of the class whose bins hold it (nearest bin centre, in log b and log h).

        Raises:
            ValueError: for a building outside the catalogue (an element, storey count or
                geometry it has no class for).
        """
        element = str(building["element"])
        if element not in ELEMENTS:
            raise ValueError(f"element must be one of {ELEMENTS}; got {element!r}.")
        n = int(building["storeys"])
        if n not in self.periods:
            raise ValueError(
                f"the catalogue has no {n}-storey host building (it has {sorted(self.periods)})."
            )
        b = _centre(building["b"], self.b[element], f"{element} b [m]", log=True)
        h = _centre(building["h"], self.h[element], f"{element} h [m]", log=True)
        storey = None
        if element == "facade":
            given = building.get("storey", None)
            storey = (
                n
                if given is None or (isinstance(given, float) and math.isnan(given))
                else int(given)
            )
        probe = BuildingClass(
            element,
            b,
            h,
            n,
            period=float(self.periods[n]),
            damping=self.damping,
            storey=storey,
            gap=self.gap if element == "facade" else 0.0,
        )
        ids = {c.id for c in self.classes}
        if probe.id not in ids:
            raise ValueError(f"the catalogue has no class {probe.id!r} for this building.")
        return probe.id

    def record_sets(self, records: Sequence[GroundMotion]) -> dict[str, list[GroundMotion]]:
        """The records each class runs on: every host building's floor motions under the ground
        records (key :meth:`BuildingClass.host_key`), in the records' order."""
        n_max = max(r.n for r in records)
        sets = {}
        for c in self.classes:
            key = c.host_key()
            if key in sets:
                continue
            if c.floor == 0:
                sets[key] = list(records)
                continue
            bldg = c.building()
            floors = []
            for r in records:  # one length: the building's program compiles once
                padded = GroundMotion(
                    ag=np.pad(np.asarray(r.ag), (0, n_max - r.n)),
                    dt=r.dt,
                    name=r.name,
                    meta=r.meta,
                )
                floors.append(bldg.floor_motions(padded)[c.floor - 1])
            sets[key] = [
                f.with_metadata(ground=r.name) for f, r in zip(floors, records, strict=True)
            ]
        return sets

    def run(
        self,
        records: Sequence[GroundMotion],
        out: str | os.PathLike,
        *,
        im: str = "pga",
        scales=DEFAULT_SCALES,
        model: str | Model = "housner",
        beta: Mapping[str, float] | None = None,
        d_over_b: Sequence[float] = (),
        tail: float = 2.0,
        records_per_task: int = 22,
        scheduler=None,
        n_workers: int | None = None,
        progress: bool = True,
    ) -> tuple[dict[str, xr.Dataset], dict[str, Fragility | dict[str, Fragility]]]:
        """Every class's IDA (a resumable Dask campaign) and fragility in a ground IM.

        Args:
            records: The ground records (distinct names), e.g. ``rj.records.fema_p695()``.
            out: The campaign's folder (:func:`rockjax.campaign.run`; resumable).
            im: The ground IM of the fragilities: ``"pga"`` or ``"sa(T)"`` (5 % damped, at the
                site), as the engine's ``PGA`` / ``SA(T)``.
            scales: Scale factors of the records [-] (wide enough that every class both
                survives and collapses).
            model: ``"housner"`` (default, its default restitution), ``"dem"`` (then ``beta``
                per class id, [s]), or one model object for every class
                (``rj.Housner(e=...)``, ``rj.DEM(beta=...)``; :func:`rockjax.as_model`).
            beta: DEM damping per class id [s].
            d_over_b: Thresholds of milder limit states (``d/b >= x``), fitted with collapse
                by :func:`rockjax.openquake.limit_state_fragilities`; empty: collapse only.
            tail: Free vibration after the records [s].
            records_per_task: Records per campaign part (:func:`rockjax.campaign.run`); the
                default, 22, makes two parts of a 44-record set: a Housner part costs mostly
                its fixed overhead, so fewer parts finish sooner.
            scheduler: As :func:`rockjax.campaign.run` (None: a LocalCluster here).
            n_workers: Worker processes of the LocalCluster.
            progress: A progress bar over the campaign's parts.

        Returns:
            ``(datasets, fragilities)``: class id -> IDA Dataset, whose ``im`` is the ground
            IM (``attrs["im"]``; the floor's PGA stays in ``pga_scaled``), and class id ->
            :class:`rockjax.Fragility` (or ``{limit state: Fragility}`` with ``d_over_b``),
            ready for :func:`rockjax.openquake.fragility_model`.

        Raises:
            ValueError: if a class's fragility is undefined (no collapse or no survival in the
                scale range), naming the class.
        """
        spec = parse_im(im)
        if spec.kind == "pgv":
            raise ValueError("im must be 'pga' or 'sa(T)' (the catalogue's ground IMs).")
        sets = self.record_sets(records)
        cases = []
        for c in self.classes:
            if isinstance(model, str) and model == "dem":
                if beta is None or c.id not in beta:
                    raise ValueError(
                        f"model='dem' needs beta per class id [s] (beta={{class id: beta}}); "
                        f"none for {c.id!r}."
                    )
                run_model, mode = DEM(beta=float(beta[c.id])), c.mode()
            else:
                run_model = as_model(model)
                mode = c.mode() if isinstance(run_model, DEM) else c.mode().without_gap()
            cases.append(campaign.Case(c.id, c.block(), c.host_key(), model=run_model, mode=mode))
        raw = campaign.run(
            cases,
            sets,
            out,
            scales=scales,
            tail=tail,
            scheduler=scheduler,
            records_per_task=records_per_task,
            n_workers=n_workers,
            progress=progress,
        )
        ground = np.array([float(intensity(r, spec.name)) for r in records])
        datasets, fragilities = {}, {}
        for c in self.classes:
            ds = raw[c.id]
            grid = ground[:, None] * ds["scale"].values[None, :]
            attrs = {"units": spec.units, "long_name": f"ground {spec.long_name}"}
            ds = ds.assign(im=(("record", "scale"), grid, attrs))
            if "im_g" in ds:  # the floor's, as rj.ida wrote it: now the ground's in g
                ds = ds.assign(im_g=(("record", "scale"), grid / G, {"units": "g"}))
            ds.attrs.update(im=spec.name, im_where="ground", rockjax_class=c.id)
            datasets[c.id] = ds
            try:
                if d_over_b:
                    fragilities[c.id] = limit_state_fragilities(ds, d_over_b, im=spec.name)
                else:
                    fragilities[c.id] = fragility(ds, spec.name, n_boot=0)
            except ValueError as err:
                raise ValueError(f"class {c.id!r}: {err}") from err
        return datasets, fragilities
