"""The ``rockjax`` command: its parser (one subcommand per module) and :func:`main`, which
turns errors into one ``error: ...`` line and an exit status."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from .. import __version__
from ..compilation import configure_cpu, enable_cache
from ._calibrate import add_calibrate_parser
from ._demo import add_demo_parser
from ._ida import add_ida_parser
from ._pushover import add_pushover_parser
from ._simulate import add_simulate_parser
from ._spectrum import add_spectrum_parser


def main(argv: Sequence[str | os.PathLike] | None = None) -> int:
    """Entry point of the ``rockjax`` command.

    Args:
        argv: Command-line arguments without the program name; default ``sys.argv[1:]``.

    Returns:
        The exit status: 0 on success, 1 when a calibration misses its target or every run of
        an IDA failed (the reason on stderr; the files are still written), 2 on invalid input
        or a file that cannot be read or written (after printing ``error: ...``), 130 when
        interrupted, 1 when the reader of the output goes away (a broken pipe).
    """
    parser = _parser()
    args = parser.parse_args(None if argv is None else [os.fspath(a) for a in argv])
    if argv is None:  # run as the command (not called from Python): reuse compiled programs
        enable_cache()
        configure_cpu()  # XLA:CPU's option for the time loops, with the user's XLA_FLAGS too
    try:
        return args.run(args)
    except ValueError as err:
        message = " ".join(str(err).split("\n"))
        print(f"error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader (e.g. `| head`) went away: stop quietly, as Unix tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as err:  # after BrokenPipeError, one of them: a path the checks before the runs could not foresee (disk full)
        where = f": {err.filename}" if err.filename else ""
        print(f"error: {err.strerror or err}{where}", file=sys.stderr)
        return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rockjax",
        description="Differentiable rocking of URM parapets and facades (DEM and Housner), on JAX.",
        allow_abbrev=False,
    )
    parser.add_argument("--version", action="version", version=f"rockjax {__version__}")
    sub = parser.add_subparsers(title="commands", dest="command", required=True)
    add_demo_parser(sub)
    add_ida_parser(sub)
    add_calibrate_parser(sub)
    add_simulate_parser(sub)
    add_spectrum_parser(sub)
    add_pushover_parser(sub)
    return parser
