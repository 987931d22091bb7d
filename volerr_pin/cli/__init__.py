# PYTHON_ARGCOMPLETE_OK (the mark by which argcomplete's global completion knows this command)
"""volerr: volumetric error of machine tools on Pinocchio - evaluate, rank, record, identify, diagnose, compensate.

Each command parses its arguments, calls the library and prints; every number comes from
the library.

Exit status 0 on success, 2 on bad input (one line on stderr naming the culprit); 130 on
Ctrl-C, 143 on SIGTERM and 129 on SIGHUP (one line; a run's outputs are written all or none,
so none is left half-written and no temporary file stays behind).
``--json`` prints exactly one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Iterable

import argcomplete

from .. import __version__
from ..base import COMMIT_CHECKS, VolerrError
from . import (_ballbar as ballbar, _compensate as compensate, _demo as demo, _dh as dh, _diagnose as diagnose,
               _errormap as errormap, _field as field, _gear as gear, _identify as identify, _info as info,
               _iso230 as iso230, _rank as rank, _thermal_fit as thermal_fit, _urdf as urdf)
from . import (_export as export, _plan as plan, _predict as predict, _testpiece as testpiece, _tolerance as tolerance,
               _uncertainty as uncertainty)
from ._common import check_out_name, in_cli_words

#: one module per command, in the order ``volerr --help`` lists them
COMMANDS = (demo, field, rank, iso230, identify, thermal_fit, diagnose, compensate, export, errormap, ballbar,
            gear, dh, info, urdf)
COMMANDS += (uncertainty, tolerance)
COMMANDS += (plan,)
COMMANDS += (predict, testpiece)

__all__ = ["build_parser", "main"]


class _Parser(argparse.ArgumentParser):
    """The top-level parser: a misspelt command gets "did you mean" (as Python 3.14's argparse
    says it; 3.11 does not)."""

    def error(self, message: str):
        choice = re.search(r"invalid choice: '([^']*)'", message)
        if choice:
            close = difflib.get_close_matches(choice.group(1), [c.COMMAND for c in COMMANDS], n=1, cutoff=0.6)
            if close:
                message += f"; did you mean {close[0]}?"
        super().error(message)


def build_parser(commands: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The ``volerr`` argument parser.

    Parameters
    ----------
    commands : iterable of str, optional
        The commands whose sub-parsers are built in full; the others are listed by name and
        help only, which ``volerr --help`` needs, without importing what their options need.
        Default: every command in full.
    """
    full = None if commands is None else set(commands)
    parser = _Parser(prog="volerr", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"volerr_pin {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        if full is None or command.COMMAND in full:
            command.add_parser(sub)
        else:
            sub.add_parser(command.COMMAND, help=command.HELP)
    return parser


def _command_of(argv: list[str]) -> set[str]:
    """The command ``argv`` names (its first word that is not an option), as a set of at most one:
    the one sub-parser :func:`main` builds in full. Under shell completion the words are those of
    the line being completed, and a command word still being typed names none."""
    if "_ARGCOMPLETE" in os.environ:
        line = os.environ.get("COMP_LINE", "")[:int(os.environ.get("COMP_POINT", "0") or 0)]
        words = line.split()[1:]
        if words and not line.endswith((" ", "\t")):
            words = words[:-1]   # the word under the cursor is not complete yet
        argv = words
    names = {c.COMMAND for c in COMMANDS}
    first = next((w for w in argv if not w.startswith("-")), None)
    return {first} if first in names else set()


def _note(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"volerr: note: {message}", file=sys.stderr)


class Stopped(BaseException):
    """A termination signal (SIGTERM, SIGHUP) raised where the run stands, so that its
    transaction removes its temporary files as on Ctrl-C."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: termination signals received in this run (a handler's exception can be swallowed: see
#: :data:`volerr_pin.base.COMMIT_CHECKS`)
_RECEIVED: list[int] = []


def _stop(signum, frame) -> None:
    _RECEIVED.append(signum)
    raise Stopped(signum)


def _refuse_after_stop() -> None:
    """A commit after a termination signal whose exception was swallowed: raise it again."""
    if _RECEIVED:
        raise Stopped(_RECEIVED[0])


def _quiet_stop(hook):
    """An unraisable-exception hook that stays silent about a swallowed :class:`Stopped`
    (it is raised again before anything is written, and at the end)."""
    def quiet(unraisable):
        if not isinstance(unraisable.exc_value, Stopped):
            hook(unraisable)
    return quiet


def main(argv: list[str] | None = None) -> int:
    """Run ``volerr`` with ``argv`` (default: the process arguments); returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_command_of(argv))
    argcomplete.autocomplete(parser)   # under shell completion: prints the candidates and exits
    args = parser.parse_args(argv)
    previous = {}
    hook = sys.unraisablehook
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGTERM, signal.SIGHUP):
            previous[signum] = signal.signal(signum, _stop)
        _RECEIVED.clear()
        COMMIT_CHECKS.append(_refuse_after_stop)
        sys.unraisablehook = _quiet_stop(hook)
    try:
        with warnings.catch_warnings():
            # the library's warnings are notes for the user: one line each, no source location
            warnings.showwarning = _note
            check_out_name(args)
            status = args.func(args)
        if _RECEIVED:   # a stop whose exception was swallowed after the last commit
            print(f"volerr: error: stopped by {signal.Signals(_RECEIVED[0]).name} as the run ended", file=sys.stderr)
            return 128 + _RECEIVED[0]
        return status
    except VolerrError as err:
        print(f"volerr: error: {in_cli_words(err)}", file=sys.stderr)
        return 2
    except OSError as err:
        # (an OSError of no file, a connection's, may have no strerror: its own words then)
        what = err.strerror or (str(err).splitlines() or [""])[0] or type(err).__name__
        print(f"volerr: error: {err.filename or 'writing the outputs'}: {what}; the outputs are left "
              "as they were", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("volerr: error: interrupted; the outputs are left as they were", file=sys.stderr)
        return 130
    except Stopped as stop:
        print(f"volerr: error: stopped by {signal.Signals(stop.signum).name}; the outputs are left as they were",
              file=sys.stderr)
        return 128 + stop.signum
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if previous:
            COMMIT_CHECKS.remove(_refuse_after_stop)
            sys.unraisablehook = hook
