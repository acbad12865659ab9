"""Campaigns: many IDAs (geometries x modes x models x record sets) on Dask, resumable.

A campaign is a list of :class:`Case` s, each one :func:`rockjax.ida` of one block, mode and
model over one named record set. :func:`run` splits every case into *parts* (a few records of
one ``dt``, all scale factors), runs the parts as tasks on a Dask ``distributed`` cluster (a
``LocalCluster`` of one single-threaded worker process per core by default, or the scheduler
at an address), and each task writes its finished part to ``out/<case>/part-NNNN.nc``
(NetCDF, written to a temporary name and renamed, so a part file is whole or absent). When
every part of a case is on disk, the case is assembled into ``out/<case>.nc``.

Resuming: run the same campaign with the same ``out`` again. Parts already on disk are not
recomputed; a part whose fingerprint (a hash of the case, the scale factors, the run length
and the record data) differs from the campaign's raises an error instead of mixing two
campaigns. The manifest records the SHA-256 checksum of every finished part and assembled case:
a part whose file no longer matches its checksum, or that cannot be read back (a truncated or
empty file), is reported by name (a ``RuntimeWarning``), kept aside as ``*.damaged`` and
recomputed; a damaged assembled case is rebuilt from its parts. A finished campaign is read
without writing anything, so it can be re-loaded through :func:`run` from a read-only folder. Every part runs with the whole record set's run length ``t_end``, so a part's runs
equal those of one :func:`rockjax.ida` call on the whole set, and an interrupted and resumed
campaign gives the same datasets as an uninterrupted one (tests/test_campaign.py kills one).

Dask and tqdm come with the optional extra ``campaign`` (``pip install -e ".[campaign]"``).
Workers on other machines need rockjax installed and ``out`` on a file system they share with
the client (the usual setup on a cluster).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import re
import time
import uuid
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import jax
import numpy as np

from . import jsonio
from ._checks import check_nonnegative, check_scales
from ._lazy import lazy_module
from .block import Block
from .contact import Joint
from .ida import DEFAULT_SCALES, MODELS, host_threads, ida, run_config
from .models import DEM, Housner, Model, as_model
from .modes import Mode, as_mode
from .motion import GroundMotion

xr = lazy_module("xarray")  # loaded on first use (rockjax/_lazy.py)

MANIFEST = "campaign.json"
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclasses.dataclass(frozen=True)
class Case:
    """One IDA of a campaign: a block, a mode and a model over one named record set.

    Attributes:
        name: Label, also the file name of the result: letters, digits, ``_``, ``.``, ``-``.
        block: The block (scalar fields).
        records: Key of the record set in the ``records`` mapping given to :func:`run`.
        model: The model with its options, as :func:`rockjax.ida` takes it:
            ``rj.DEM(beta=...)``, ``rj.Housner(e=...)`` or ``rj.ThreeBranch(law)``, or a name
            (``"housner"``); kept as the object (:func:`rockjax.as_model`, converted once).
            Its ``name`` labels the manifest and the results.
        mode: ``"two_sided"`` (parapet) or ``"one_sided"`` (facade): given as a name or as
            :class:`rockjax.Parapet` / :class:`rockjax.Facade`, kept as its name (the
            manifest's and the results' label).
        beta: Deprecated (a ``DeprecationWarning``): the DEM's damping [s], now
            ``model=rj.DEM(beta=...)``; folded into ``model`` and kept as None.
        e: Deprecated, as ``beta``: the Housner restitution [-], now
            ``model=rj.Housner(e=...)``.
        gap: The facade's gap [m] given apart (with ``mode="one_sided"``) or in the Facade
            (the DEM's only); kept as a float (0 for a parapet).
    """

    name: str
    block: Block
    records: str
    model: Model | str = "dem"
    mode: Mode | str = "two_sided"
    beta: float | None = None
    e: float | None = None
    gap: float | None = None

    def __post_init__(self):
        # converted once (rockjax.as_model, rockjax.as_mode): the model kept as its object,
        # the mode as the name and the float gap of the spec
        options = {k: v for k, v in (("beta", self.beta), ("e", self.e)) if v is not None}
        if options:
            given = ", ".join(f"{k}=" for k in options)
            warnings.warn(
                f"rj.campaign.Case({given}...) is deprecated: give the model's options in its "
                "object, model=rj.DEM(beta=...) or model=rj.Housner(e=...). The runs are the same.",
                DeprecationWarning,
                stacklevel=3,
            )
        model = as_model(self.model, **options)
        mode = as_mode(self.mode, self.gap)
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "beta", None)
        object.__setattr__(self, "e", None)
        object.__setattr__(self, "mode", mode.name)
        object.__setattr__(self, "gap", float(mode.gap))

    def rocking(self) -> Mode:
        """The mode object of the case (:class:`rockjax.Parapet` or :class:`rockjax.Facade`
        with its gap)."""
        return as_mode(self.mode, self.gap)

    def spec(self) -> dict:
        """The case as JSON-ready values (the block as its fields, the model as its name and
        options)."""
        block = {f: float(getattr(self.block, f)) for f in Block.FIELDS}
        model = self.model
        out = dict(
            name=self.name,
            block=block,
            records=self.records,
            model=model.name,
            mode=self.mode,
            beta=float(model.beta) if isinstance(model, DEM) else None,
            e=float(model.e) if model.rigid and model.e is not None else None,
            gap=float(self.gap),
        )
        # the options beyond beta and e, only where given (a default case's spec, hence its
        # fingerprint, is the same as before they existed)
        extra = {k: v for k, v in model.attrs().items() if k not in ("beta", "joint")}
        if isinstance(model, DEM) and model.joint != Joint():
            extra["joint"] = repr(model.joint)
        return out | extra


def grid(
    blocks: Mapping[str, Block],
    record_sets: Sequence[str],
    *,
    modes: Sequence[Mode | str] = ("two_sided", "one_sided"),
    models: Sequence[Model | str] = ("dem", "housner"),
    beta: Mapping[tuple[str, str], float] | None = None,
    e: Mapping[tuple[str, str], float] | None = None,
    gap: float | None = None,
) -> list[Case]:
    """Every combination of block x mode x model x record set, as :class:`Case` s.

    Args:
        blocks: Label -> block, e.g. ``{"h3.00": rj.Block(b=0.25, h=3.0)}``.
        record_sets: Keys of the record sets (as in the mapping given to :func:`run`).
        modes: Modes to run: names, or :class:`rockjax.Parapet` / :class:`rockjax.Facade`
            (a Facade's gap is that of its DEM cases).
        models: Models to run: objects (``rj.Housner(e=0.9)``, ``rj.ThreeBranch(law)``,
            ``rj.DEM(beta=...)``: the same for every block and mode) or the names ``"dem"``
            (its ``beta`` per block and mode from ``beta``) and ``"housner"`` (its ``e`` from
            ``e``, where given).
        beta: ``(block label, mode name) -> beta`` [s] for the ``"dem"`` cases (required with
            ``"dem"``).
        e: ``(block label, mode name) -> e`` for the ``"housner"`` cases (default: Eq. 2 /
            Eq. 5).
        gap: Facade gap of the DEM one-sided cases [m]; default None (0, or the Facade's own).

    Returns:
        Cases named ``"<block>_<mode>_<model name>_<record set>"``.
    """
    cases = []
    for label, block in blocks.items():
        for given in modes:
            rocking = as_mode(given)
            mode = rocking.name
            for model in models:
                if model == DEM.name:
                    if beta is None or (label, mode) not in beta:
                        raise ValueError(
                            f"the DEM case of block {label!r}, mode {mode!r} needs beta: "
                            f"give beta={{({label!r}, {mode!r}): value in s, ...}}."
                        )
                    model = DEM(beta=float(beta[(label, mode)]))
                elif model == Housner.name and e is not None and (label, mode) in e:
                    model = Housner(e=float(e[(label, mode)]))
                model = as_model(model)
                # Housner's facade has no gap
                kw = {"mode": rocking.without_gap()}
                if not model.rigid:
                    kw["mode"] = as_mode(given, gap) if rocking.one_sided else rocking
                for rs in record_sets:
                    name = f"{label}_{mode}_{model.name}_{rs}"
                    cases.append(Case(name, block, rs, model=model, **kw))
    return cases


def run(
    cases: Sequence[Case],
    records: Mapping[str, Sequence[GroundMotion]],
    out: str | os.PathLike,
    *,
    scales=DEFAULT_SCALES,
    tail: float = 2.0,
    records_per_task: int | Mapping[str, int] = 8,
    scheduler=None,
    n_workers: int | None = None,
    progress: bool = True,
) -> dict[str, xr.Dataset]:
    """Run (or resume) a campaign on Dask and return its datasets.

    Args:
        cases: The IDAs to run, with distinct names.
        records: Record-set name -> ground motions (distinct names within a set).
        out: Directory of the campaign: ``campaign.json`` (the manifest), ``<case>/part-*.nc``
            (finished parts) and ``<case>.nc`` (assembled cases). Created if missing.
        scales: Scale factors [-], as :func:`rockjax.ida`.
        tail: Free vibration after the longest record of each set [s].
        records_per_task: Records per part (all scale factors of each), or a mapping model ->
            count (e.g. ``{"dem": 4, "housner": 16}``: a Housner part costs mostly its
            compilation, a DEM part its steps). A ``dt`` group is split into parts of equal
            size (the last padded with repeats of its first record, dropped from the result),
            so each group compiles one shape. Smaller parts lose less to an interruption and
            balance better; larger ones compile less often.
        scheduler: ``None`` for a ``LocalCluster`` started here (closed at the end), a
            scheduler address (``"tcp://host:8786"``), or a ``distributed.Client``.
        n_workers: Worker processes of the LocalCluster (default: one per core this process
            may use, :func:`rockjax.ida.host_threads`, so a batch scheduler's CPU set or
            ``taskset`` is respected; at most one per pending part); each runs one task at a
            time.
        progress: Show a progress bar (tqdm, on stderr) over the parts.

    Returns:
        Case name -> ``xarray.Dataset`` with dims ``("record", "scale")``, the records in the
        order of their set, as :func:`rockjax.ida` returns for the whole set (plus attrs
        ``campaign_case`` and ``campaign_fingerprint``).

    Raises:
        ValueError: on invalid cases or records, or if ``out`` holds parts of a different
            campaign under the same case name.
        RuntimeError: if some parts failed; the finished ones stay on disk (run again to
            retry the rest).
    """
    out = Path(out)
    scales = check_scales(scales)
    parts = plan(cases, records, scales=scales, tail=tail, records_per_task=records_per_task)
    out.mkdir(parents=True, exist_ok=True)
    manifest = _Manifest.open(out)
    manifest.register(cases, parts, scales, float(tail))
    pending = [p for p in parts if not _part_ok(out, p, manifest)]
    manifest.save()
    if pending:
        _compute(pending, records, scales, out, scheduler, n_workers, progress, manifest)
    return {case.name: _assemble(out, case, parts, records, manifest) for case in cases}


def load(out: str | os.PathLike) -> dict[str, xr.Dataset]:
    """The assembled datasets of a finished campaign directory (case name -> Dataset).

    Raises:
        ValueError: if ``out`` has no manifest or a case is not finished (run it again with
            :func:`run` to complete it).
    """
    out = Path(out)
    manifest = out / MANIFEST
    if not manifest.exists():
        raise ValueError(
            f"out={os.fspath(out)!r} has no {MANIFEST}, so it is not a campaign directory: give "
            "the folder that rockjax.campaign.run wrote, or run the campaign there first."
        )
    cases = json.loads(manifest.read_text())["cases"]
    result = {}
    for name, entry in cases.items():
        path = out / f"{name}.nc"
        if not path.exists():
            raise ValueError(
                f"case {name!r} of {out} is not finished ({path.name} is missing); run the "
                "campaign again with rockjax.campaign.run to complete it."
            )
        recorded = entry.get("assembled")
        if recorded is not None and _sha256(path) != recorded:
            raise ValueError(
                f"{path} does not match the checksum in {MANIFEST} (changed or damaged since it "
                "was written); run the campaign again with rockjax.campaign.run and the same "
                "arguments to rebuild it from its parts."
            )
        ds, err = _read(path)
        if ds is None:
            raise ValueError(
                f"{path} cannot be read ({err}); run the campaign again with "
                "rockjax.campaign.run and the same arguments to rebuild it from its parts."
            )
        result[name] = ds
    return result


# ----------------------------------------------------------------------------- planning


@dataclasses.dataclass(frozen=True)
class Part:
    """One task of a campaign: a few records of one case (one ``dt``), all scale factors.

    Attributes:
        case: The case it belongs to.
        part: Its number within the case.
        index: Indices of its records in the case's record set.
        size: Records run (``index`` padded with repeats of its first record to the size of
            every part of its ``dt`` group, so the group compiles one shape).
        group: The case and ``dt`` it shares a compiled shape with.
        t_end: Run length [s] (the whole set's longest record plus the tail).
        fingerprint: Hash of the case, scale factors, run length and record data.
        cost: Relative cost (runs x steps), for scheduling.
    """

    case: Case
    part: int
    index: tuple[int, ...]
    size: int
    group: str
    t_end: float
    fingerprint: str
    cost: float

    @property
    def key(self) -> str:
        """``"<case>/part-NNNN"``."""
        return f"{self.case.name}/part-{self.part:04d}"

    @property
    def filename(self) -> str:
        """``"<case>/part-NNNN-<fingerprint>.nc"``, relative to the campaign directory: the name
        says which campaign wrote it."""
        return f"{self.case.name}/part-{self.part:04d}-{self.fingerprint}.nc"


def plan(
    cases: Sequence[Case],
    records: Mapping[str, Sequence[GroundMotion]],
    *,
    scales=DEFAULT_SCALES,
    tail: float = 2.0,
    records_per_task: int | Mapping[str, int] = 8,
) -> list[Part]:
    """The parts :func:`run` computes, without running anything (arguments as there).

    Raises:
        ValueError: on invalid cases, records or part sizes, naming the fix.
    """
    scales = check_scales(scales)
    check_nonnegative(
        "tail", tail, "s", "tail is the free vibration after the records, e.g. 2.0.", scalar=True
    )
    tail = float(tail)
    per = records_per_task
    per = dict.fromkeys(MODELS, per) if not isinstance(per, Mapping) else dict(per)
    for model in MODELS:
        n = per.get(model, 8)
        if isinstance(n, bool) or not (isinstance(n, int) and n >= 1):
            raise ValueError(
                f"records_per_task must be an int >= 1 per model; got {records_per_task!r}."
            )
        per[model] = n
    if isinstance(cases, Case) or not cases:
        raise ValueError("cases must be a non-empty sequence of rockjax.campaign.Case.")
    names = [c.name for c in cases]
    for c in cases:
        if not isinstance(c, Case):
            raise ValueError(f"cases must hold rockjax.campaign.Case; got {type(c)}.")
        if not _NAME.match(c.name):
            raise ValueError(
                f"case name {c.name!r} is not a safe file name; use letters, digits, _ . -"
            )
        if c.records not in records:
            raise ValueError(
                f"case {c.name!r} asks for record set {c.records!r}, which is not among the "
                f"records given ({sorted(records)})."
            )
    if len(set(names)) != len(names):
        raise ValueError(
            f"case names must be distinct; {sorted({n for n in names if names.count(n) > 1})} repeat."
        )
    set_hash = {}
    for key, recs in records.items():
        if isinstance(recs, GroundMotion) or not recs:
            raise ValueError(f"record set {key!r} must be a non-empty sequence of GroundMotion.")
        rnames = [r.name for r in recs]
        if len(set(rnames)) != len(rnames):
            raise ValueError(f"record names repeat within set {key!r}; they label the datasets.")
        set_hash[key] = [_record_hash(r) for r in recs]
    parts = []
    for c in cases:
        _, config, _ = run_config(c.block, model=c.model, mode=c.rocking())
        recs = records[c.records]
        t_end = max(r.duration for r in recs) + tail
        spec = json.dumps(
            dict(case=c.spec(), scales=scales.tolist(), t_end=t_end, records=set_hash[c.records]),
            sort_keys=True,
        )
        # group by dt (one compiled shape per group), in the set's order
        steps: list[float] = []
        for r in recs:
            if not any(math.isclose(r.dt, d, rel_tol=1e-9) for d in steps):
                steps.append(r.dt)
        number = 0
        size_max = per[c.model.name]
        for d in steps:
            idx = [i for i, r in enumerate(recs) if math.isclose(r.dt, d, rel_tol=1e-9)]
            n_sub = max(1, math.ceil(d / config["dt_bound"] - 1e-9))
            n_parts = math.ceil(len(idx) / size_max)
            size = math.ceil(len(idx) / n_parts)
            for k in range(n_parts):
                chunk = tuple(idx[k * size : (k + 1) * size])
                fp = hashlib.sha256(f"{spec}|{chunk}".encode()).hexdigest()[:16]
                cost = size * scales.size * (t_end / d) * n_sub
                group = f"{c.name}@{d:g}"
                parts.append(Part(c, number, chunk, size, group, t_end, fp, cost))
                number += 1
    return parts


def _record_hash(r: GroundMotion) -> str:
    h = hashlib.sha256()
    h.update(r.name.encode())
    h.update(np.float64(r.dt).tobytes())
    h.update(np.ascontiguousarray(np.asarray(r.ag, np.float64)).tobytes())
    if r.ag_v is not None:
        h.update(np.ascontiguousarray(np.asarray(r.ag_v, np.float64)).tobytes())
    return h.hexdigest()[:16]


class _Manifest:
    """``campaign.json``: per case its spec, its parts' fingerprints and the checksums of the
    finished files. Written atomically, and only when its content changes."""

    def __init__(self, out: Path, data: dict, text: str | None):
        self.out, self.data, self._text = out, data, text

    @classmethod
    def open(cls, out: Path) -> _Manifest:
        path = out / MANIFEST
        text = path.read_text() if path.exists() else None
        return cls(out, json.loads(text) if text else {"cases": {}}, text)

    def register(self, cases, parts, scales, tail) -> None:
        """Add the cases; a case already there with other parts raises (another campaign)."""
        fps: dict[str, dict[str, str]] = {}
        for p in parts:
            fps.setdefault(p.case.name, {})[p.key] = p.fingerprint
        for c in cases:
            prev = self.data["cases"].get(c.name)
            if prev is not None and prev["parts"] != fps[c.name]:
                raise ValueError(
                    f"{self.out} already holds case {c.name!r} run with other parameters, scales, "
                    f"tail, records or records_per_task. Use another output directory, or delete "
                    f"{self.out / c.name} and {self.out / (c.name + '.nc')} to recompute it."
                )
            if prev is None:
                self.data["cases"][c.name] = dict(spec=c.spec(), parts=fps[c.name], checksums={})
        self.data["scales"] = scales.tolist()
        self.data["tail"] = tail

    def checksum(self, part: Part) -> str | None:
        return self.data["cases"][part.case.name].get("checksums", {}).get(part.key)

    def set_checksum(self, part: Part, digest: str | None) -> None:
        sums = self.data["cases"][part.case.name].setdefault("checksums", {})
        if digest is None:
            sums.pop(part.key, None)
        else:
            sums[part.key] = digest

    def assembled(self, name: str) -> str | None:
        return self.data["cases"][name].get("assembled")

    def set_assembled(self, name: str, digest: str) -> None:
        self.data["cases"][name]["assembled"] = digest

    def save(self) -> None:
        text = jsonio.dumps(self.data, indent=1, sort_keys=True)
        if text != self._text:
            jsonio.write_text(self.out / MANIFEST, text)
            self._text = text


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _read(path: Path) -> tuple[xr.Dataset | None, str]:
    """The dataset in ``path`` loaded into memory, or ``(None, why)`` if it cannot be read."""
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load(), ""
    except (OSError, ValueError, KeyError, RuntimeError) as err:  # h5py/xarray on a bad file
        return None, f"{type(err).__name__}: {err}"


def _set_aside(path: Path, why: str) -> None:
    """Report a damaged file by name and move it to ``*.damaged`` (kept for inspection)."""
    aside = path.with_name(path.name + ".damaged")
    warnings.warn(
        f"campaign file {path} is damaged ({why}); moved to {aside.name} and recomputed.",
        RuntimeWarning,
        stacklevel=3,
    )
    os.replace(path, aside)


def _part_ok(out: Path, part: Part, manifest: _Manifest) -> bool:
    """Whether ``part`` is on disk and whole. A damaged part is set aside (to recompute); a
    finished part not yet in the manifest (the client was stopped before recording it) is
    accepted if it reads back as this part; a part of the same number from another campaign
    raises."""
    path = out / part.filename
    if not path.exists():
        others = list((out / part.case.name).glob(f"part-{part.part:04d}-*.nc"))
        if others:
            raise ValueError(
                f"{others[0]} was written by a different campaign (expected fingerprint "
                f"{part.fingerprint}); use another output directory or delete {others[0].parent}."
            )
        manifest.set_checksum(part, None)
        return False
    digest, recorded = _sha256(path), manifest.checksum(part)
    if recorded is not None:
        if digest == recorded:
            return True
        why = f"checksum {digest[:12]}... differs from the manifest's {recorded[:12]}..."
    else:
        ds, why = _read(path)
        if ds is not None:
            n = ds.sizes.get("record")
            if ds.attrs.get("campaign_fingerprint") == part.fingerprint and n == len(part.index):
                manifest.set_checksum(part, digest)
                return True
            why = "it is not this part's dataset"
    _set_aside(path, why)
    manifest.set_checksum(part, None)
    return False


# ----------------------------------------------------------------------------- running


def _run_part(case: Case, recs, size, scales, t_end, fingerprint, key, path):
    """A Dask task: one part's IDA, written atomically to ``path``. Returns (key, seconds,
    SHA-256 of the file).

    The part's records are padded to ``size`` with renamed repeats of the first (so every part
    of a ``dt`` group compiles the same shape); the repeats are dropped from the result.
    """
    start = time.perf_counter()
    n_real = len(recs)
    pad = [
        GroundMotion(ag=recs[0].ag, dt=recs[0].dt, name=f"{recs[0].name}#pad{k}", ag_v=recs[0].ag_v)
        for k in range(size - n_real)
    ]
    ds = ida(
        case.block,
        list(recs) + pad,
        scales,
        model=case.model,
        mode=case.rocking(),
        t_end=t_end,
        progress=False,
        devices=jax.local_devices()[:1],  # one worker per core: its part on one device
    )
    ds = ds.isel(record=slice(0, n_real))
    ds.attrs.update(
        campaign_case=case.name,
        campaign_fingerprint=fingerprint,
        campaign_part=key,
        campaign_seconds=time.perf_counter() - start,  # this part's IDA, compilation included
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    digest = _atomic_to_netcdf(ds, path)
    return key, time.perf_counter() - start, digest


def _compute(pending, records, scales, out, scheduler, n_workers, progress, manifest) -> None:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
        from tqdm import tqdm
    except ImportError as err:  # pragma: no cover - the extra is installed in CI
        raise ImportError(
            "rockjax.campaign needs Dask distributed and tqdm: pip install -e '.[campaign]' "
            f"(missing: {err.name})."
        ) from err
    for tmp in out.glob("*/.part-*.tmp"):  # left by a killed writer
        tmp.unlink(missing_ok=True)
    cluster = None
    if scheduler is None:
        # one worker per core this process may use (a batch scheduler's cpuset, taskset)
        n = n_workers or min(host_threads(), len(pending))
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        client = Client(cluster)
    elif isinstance(scheduler, str):
        client = Client(scheduler)
    else:
        client = scheduler
    failed = []
    try:
        pending = sorted(pending, key=lambda t: -t.cost)  # longest first: balanced ends
        home = _assign_groups(pending, list(client.scheduler_info().get("workers", {})))
        futures = {}
        for t in pending:
            recs = [records[t.case.records][i] for i in t.index]
            worker = home.get(t.group)
            # a preference: an idle worker may take it (distributed refuses the flag with no
            # worker named, e.g. before any worker has registered)
            placement = {} if worker is None else dict(workers=worker, allow_other_workers=True)
            fut = client.submit(
                _run_part,
                t.case,
                recs,
                t.size,
                scales,
                t.t_end,
                t.fingerprint,
                t.key,
                str(out / t.filename),
                key=f"rockjax-{t.fingerprint}",
                pure=False,
                **placement,
            )
            futures[fut] = t
        bar = tqdm(total=len(pending), desc="campaign", unit="part", disable=not progress)
        for fut in as_completed(futures):
            t = futures[fut]
            if fut.status == "error":
                failed.append((t.key, repr(fut.exception())))
            else:  # recorded as each part lands, so a stopped client loses no checksum
                manifest.set_checksum(t, fut.result()[2])
                manifest.save()
            bar.set_postfix_str(t.key, refresh=False)
            bar.update(1)
        bar.close()
    finally:
        if client is not scheduler:
            client.close()
        if cluster is not None:
            cluster.close()
    if failed:
        lines = "\n".join(f"  {k}: {msg}" for k, msg in failed)
        raise RuntimeError(
            f"{len(failed)} of {len(pending)} parts failed (the others are saved in {out}; "
            f"run again to retry):\n{lines}"
        )


def _assign_groups(tasks, workers: list[str]) -> dict[str, list[str]]:
    """A preferred worker per ``dt`` group (longest processing time first, to the least loaded
    worker), so that a group's parts reuse one worker's compilation instead of compiling the
    same shape on every worker."""
    if not workers:
        return {}
    cost: dict[str, float] = {}
    for t in tasks:
        cost[t.group] = cost.get(t.group, 0.0) + t.cost
    load = dict.fromkeys(workers, 0.0)
    home = {}
    for group in sorted(cost, key=lambda g: -cost[g]):
        w = min(load, key=load.get)
        home[group] = [w]
        load[w] += cost[group]
    return home


# ----------------------------------------------------------------------------- assembling


def _assemble(out: Path, case: Case, parts, records, manifest: _Manifest) -> xr.Dataset:
    """The case's parts joined in the record set's order, also written to ``out/<case>.nc``."""
    parts = [p for p in parts if p.case.name == case.name]
    fingerprint = hashlib.sha256("|".join(p.fingerprint for p in parts).encode()).hexdigest()[:16]
    path = out / f"{case.name}.nc"
    expected = [records[case.records][i].name for i in sorted(i for p in parts for i in p.index)]
    if path.exists():  # assembled before: reuse it if it is this campaign's and whole
        digest, recorded = _sha256(path), manifest.assembled(case.name)
        ds, why = _read(path)
        if ds is not None and recorded not in (None, digest):
            ds, why = None, f"checksum {digest[:12]}... differs from the manifest's"
        if ds is not None:
            names = [str(r) for r in ds["record"].values]
            if ds.attrs.get("campaign_fingerprint") == fingerprint and names == expected:
                if recorded is None:
                    manifest.set_assembled(case.name, digest)
                    manifest.save()
                return ds
        else:
            _set_aside(path, why)
    order = np.argsort(np.concatenate([np.asarray(p.index) for p in parts]), kind="stable")
    datasets = []
    for p in parts:
        ds, why = _read(out / p.filename)
        if ds is None:  # pragma: no cover - checked before computing; a change in between
            raise RuntimeError(f"{out / p.filename} cannot be read ({why}); run again.")
        datasets.append(ds)
    # strings as objects: concat would cut every name to the first part's fixed width
    datasets = [
        d.assign_coords({k: d[k].astype(object) for k in d.coords if d[k].dtype.kind == "U"})
        for d in datasets
    ]
    meta = sorted({k for d in datasets for k in d.coords if str(k).startswith("meta_")})
    for i, d in enumerate(datasets):  # a metadata key some parts lack: "" there, as in rj.ida
        missing = {k: ("record", [""] * d.sizes["record"]) for k in meta if k not in d.coords}
        datasets[i] = d.assign_coords(missing)
    ds = xr.concat(
        datasets,
        dim="record",
        data_vars="all",
        coords="different",
        compat="equals",
        combine_attrs="drop_conflicts",
        join="outer",
    )
    ds = ds.isel(record=order)
    if [str(r) for r in ds["record"].values] != expected:  # pragma: no cover - a safeguard
        raise RuntimeError(f"case {case.name!r}: the parts' records do not match the record set.")
    ds.attrs.pop("campaign_part", None)
    ds.attrs["campaign_seconds"] = float(
        sum(d.attrs.get("campaign_seconds", np.nan) for d in datasets)
    )
    ds.attrs["campaign_case"] = case.name
    ds.attrs["campaign_fingerprint"] = fingerprint
    ds.attrs["created"] = min(d.attrs["created"] for d in datasets)
    manifest.set_assembled(case.name, _atomic_to_netcdf(ds, path))
    manifest.save()
    return ds


def _atomic_to_netcdf(ds: xr.Dataset, path: Path) -> str:
    """Write ``ds`` to ``path`` through a temporary name and a rename (the file is whole or
    absent); returns its SHA-256."""
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    ds.to_netcdf(tmp, engine="h5netcdf")
    digest = _sha256(tmp)
    os.replace(tmp, path)
    return digest
