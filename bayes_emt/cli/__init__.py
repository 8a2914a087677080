"""The ``bayes-emt`` command line.

Sub-commands live one per module in :mod:`bayes_emt.cli.commands`; each module defines
``register(subparsers)`` which adds its parser and sets ``func=run``. Errors the user can fix
(bad files, bad options, output paths that cannot be written, :mod:`bayes_emt.cli.paths`) print
one line ``bayes-emt: error: ...`` and exit with code 2, option errors found by the parser
included (``bayes-emt: error: argument --seed: ...``); never a traceback.

SIGINT and SIGTERM raise :class:`~bayes_emt.errors.Interrupted` (the sampler holds them until the
end of the step in progress, :mod:`bayes_emt.inference.sampling`); the command prints one line
(``bayes-emt: interrupted; checkpoint FILE is intact (N steps stored), continue with --resume``)
and exits with 130 (SIGINT) or 143 (SIGTERM). Both signals are ignored while that line is printed.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import signal
import sys
import threading
import time
import warnings

from .._procs import process_age
from ..errors import BayesEMTError, Interrupted
from . import commands

__all__ = ["main", "build_parser"]


class UsageError(Exception):
    """An option the parser refuses (raised instead of argparse's usage dump and exit)."""


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are one line: ``bayes-emt: error: argument --seed: ...``."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} -h')")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayes-emt",
        description="Parameters, uncertainty, evidence and shunt design for electromagnetic "
                    "transducers from their electrical admittance alone.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{commands.__name__}.{info.name}")
        mod.register(sub)
    return parser


def _showwarning(message, category, filename, lineno, file=None, line=None):
    print(f"bayes-emt: warning: {message}", file=sys.stderr)


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


def main(argv: list[str] | None = None) -> int:
    in_main = threading.current_thread() is threading.main_thread()
    old = {}
    if in_main:
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, _raise_interrupted)
    try:
        return _main(argv)
    except KeyboardInterrupt as exc:
        if in_main:
            for sig in old:
                signal.signal(sig, signal.SIG_IGN)
        text = str(exc) if isinstance(exc, Interrupted) else ""
        print(f"bayes-emt: {text or 'interrupted'}", file=sys.stderr)
        return exc.exit_code if isinstance(exc, Interrupted) else 130
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        print(f"bayes-emt: error: {exc}", file=sys.stderr)
        return 2
    warnings.showwarning = _showwarning
    t0 = time.perf_counter()
    # where a command's wall-clock budget counts from: the process's start when this is the program
    # (the interpreter's start and the imports are part of the user's wait), the call otherwise (a
    # notebook, a test session or a script calling main() many times: its age is not this command's)
    args.started_at = time.monotonic() - (process_age() if argv is None else 0.0)
    try:
        rc = args.func(args)
        if getattr(args, "verbose", False):
            print(f"bayes-emt {args.command}: finished in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    except (BayesEMTError, ValueError, KeyError, OSError) as exc:
        # OSError: FileNotFoundError, FileExistsError, IsADirectoryError, NotADirectoryError,
        # PermissionError, a full disk...: the user can act on each; say it in one line
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"bayes-emt: error: {msg}", file=sys.stderr)
        return 2
    return int(rc or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
