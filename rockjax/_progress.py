"""Progress bars (tqdm, on stderr) for the long loops: IDA chunks, fit iterations.

One rule for every bar: ``progress=None`` (the default of the functions that take it) shows a
bar only in interactive use, when stderr is a terminal; ``True`` always shows one (logs, or a
notebook, whose stderr is no terminal); ``False`` never does. A bar costs one host-side update
per chunk or iteration, which the loops already synchronise on, so it does not slow them.
"""

from __future__ import annotations

import sys

from tqdm import tqdm


def enabled(progress: bool | None) -> bool:
    """Whether to show a bar: ``progress`` if given, else whether stderr is a terminal."""
    if progress is not None and not isinstance(progress, bool):
        raise ValueError(
            f"progress must be True, False or None (a bar when stderr is a terminal); got "
            f"progress={progress!r}."
        )
    if progress is None:
        isatty = getattr(sys.stderr, "isatty", None)
        return bool(isatty is not None and isatty())
    return progress


def bar(progress: bool | None, *, total: int, desc: str, unit: str) -> tqdm:
    """A tqdm bar on stderr, disabled unless :func:`enabled` ``(progress)``."""
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        disable=not enabled(progress),
        dynamic_ncols=True,
        leave=True,
    )
