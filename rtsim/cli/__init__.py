"""The ``rtsim`` command line: the only place that parses options.

Each sub-command lives in its own module ``rtsim.cli.<name>`` with a function
``register(subparsers)`` that adds its parser and sets ``func(args) -> int``.
Input errors, and files that cannot be read or written, print one line,
``rtsim: <message>``, and exit 2; no traceback.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
from typing import Any, NoReturn

from rtsim._suggest import close_match, did_you_mean
from rtsim._version import __version__
from rtsim.errors import InputError

__all__ = ["main", "COMMANDS", "Parser", "plain"]

#: Sub-commands, in the order ``rtsim --help`` lists them.
COMMANDS: tuple[str, ...] = (
    "analyze",
    "bounds",
    "simulate",
    "generate",
    "scenario",
    "sweep",
    "validate",
    "histogram",
    "examples",
    "schema",
    "animate",
    "reproduce",
)


#: Metavariables of value options that do not name their own, by destination: one word per
#: kind of value, the same in every sub-command.
METAVARS: dict[str, str] = {
    "horizon": "MS",
    "overhead": "MS",
    "window": "MS",
    "granularity": "MS",
    "seed": "N",
    "followers": "N",
    "hough_radius": "CM",
    "tasks": "N",
    "count": "N",
    "windows": "N",
    "random_sets": "N",
    "bins": "N",
    "utilization": "U",
    "periods": "SPEC",
    "deadlines": "SPEC",
    "jobs": "FILE",
    "trace": "FILE",
    "gantt": "FILE",
    "gantt_range": "A..B",
    "histogram": "FILE",
    "out": "DIR",
    "scheduler": "NAME",
    "dpi": "N",
}
#: Help of options whose module gives none.
HELPS: dict[str, str] = {
    "exec_model": "execution times: wcet (default) or uniform in [bcet, wcet] (needs bcet)",
    "suspension": "the radio round trip as CPU time (cpu, default) or with the CPU free (idle)",
    "followers": "n, the number of followers, for a processing-window set",
    "hough_radius": "r_H in cm, for a processing-window set",
    "gantt_range": "time range of the Gantt chart, A..B in ms",
    "histogram": "response-time histograms (.png, .svg or .pdf), one panel per task",
    "utilization": "total utilization (UUniFast-Discard above 1)",
    "random_sets": "random task sets checked beside the paper's set",
    "allow_code": "let the input files load Python code they name as package.module:Name "
    "([scheduler] policy, [adjust] policy, a sweep's function); without it such "
    "a name is refused and its module never imported",
}

#: Sub-commands that read task-set, scenario or sweep files (they take ``--allow-code``).
READS_INPUT_FILES: tuple[str, ...] = (
    "analyze",
    "bounds",
    "simulate",
    "generate",
    "scenario",
    "sweep",
    "validate",
    "histogram",
)


def plain(text: str | None) -> str | None:
    """Docstring markup removed for the terminal: ``code``, `name` and a leading
    ``rtsim CMD ...``: synopsis (usage already shows it)."""
    if not text:
        return text
    text = re.sub(r"^``rtsim [^`]*``:?\s*", "", text)
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"\1", text)
    text = re.sub(r"\[`([^`]+)`\]\[[^\]]+\]", r"\1", text)  # an API page's cross-reference
    return text.replace("``", "").replace("`", "")


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose texts are plain (`plain`) and whose value options all
    have a metavariable (`METAVARS`) and a help text (`HELPS`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)  # --hor is not --horizon: say so instead
        desc = plain(kwargs.get("description"))
        kwargs["description"] = desc[:1].upper() + desc[1:] if desc else desc
        kwargs["epilog"] = plain(kwargs.get("epilog"))
        super().__init__(*args, **kwargs)

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action:  # type: ignore[override]
        action = super().add_argument(*args, **kwargs)
        takes_value = action.nargs != 0 and action.option_strings
        if takes_value and action.metavar is None and action.choices is None:
            action.metavar = METAVARS.get(action.dest)
        if not action.option_strings and action.metavar is None:
            action.metavar = action.dest.upper()  # positionals: FILE, DIR, ...
        if action.help is None:
            action.help = HELPS.get(action.dest)
        action.help = plain(action.help) if action.help else action.help
        return action

    def option_strings(self) -> list[str]:
        """Every option this parser knows (``--out``, ``-q``, ...)."""
        return [o for a in self._actions for o in a.option_strings]

    def error(self, message: str) -> NoReturn:
        """One line on stderr, exit 2: the problem, a did-you-mean where one fits, and where
        the options are listed (the usage is printed by ``--help`` only)."""
        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2))
            message += did_you_mean(m.group(1), choices)
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available sub-command registered."""
    parser = Parser(
        prog="rtsim",
        description="Real-time scheduling simulator for dynamic processing windows "
        "(Qadi, Goddard, Huang & Farritor).",
    )
    parser.add_argument("--version", action="version", version=f"rtsim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"rtsim.cli.{name}").register(sub)
        if name in READS_INPUT_FILES:
            sub.choices[name].add_argument("--allow-code", action="store_true")
    return parser


def numeric_options(parser: argparse.ArgumentParser, command: str) -> list[argparse.Action]:
    """The options of sub-command ``command`` that take an int or a float."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [a for a in sub.choices[command]._actions if a.option_strings and a.type in (int, float)]


def check_option_ranges(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse a numeric option outside its range (`rtsim.io.limits`), naming it."""
    from rtsim.io import limits  # lazy: `rtsim --version` start-up

    for action in numeric_options(parser, args.command):
        value = getattr(args, action.dest, None)
        if value is not None:
            name = max(action.option_strings, key=len)
            limits.check(f"option: {name}", value, name)


def suggest(token: str, options: list[str]) -> str | None:
    """The option ``token`` was probably meant as: one it abbreviates, else the closest."""
    name = token.split("=", 1)[0]
    longs = [o for o in options if o.startswith("--")]
    prefixed = [o for o in longs if o.startswith(name)] if name.startswith("--") else []
    if len(prefixed) == 1:
        return prefixed[0]
    return close_match(name, options)


def unknown_arguments(
    parser: argparse.ArgumentParser, command: str | None, extra: list[str]
) -> str:
    """The one-line error for arguments no option took: the first unknown option with a
    did-you-mean, else the first stray value."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    p = sub.choices.get(command) if command else parser
    prog = p.prog if p is not None else "rtsim"
    options = p.option_strings() if isinstance(p, Parser) else []
    for token in extra:
        if token.startswith("-") and len(token) > 1:
            hint = suggest(token, options)
            tail = f" (did you mean {hint}?)" if hint else ""
            return f"{prog}: unknown option {token.split('=', 1)[0]}{tail} (see {prog} --help)"
    return f"{prog}: unexpected argument {extra[0]!r} (see {prog} --help)"


def _unknown_before_parsing(parser: argparse.ArgumentParser, argv: list[str]) -> str | None:
    """An unknown option is reported before argparse's own checks (which would otherwise
    complain first about a required option that the misspelt one was meant to be)."""
    command = next((a for a in argv if a in COMMANDS), None)
    if command is None:
        return None
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    known = set(sub.choices[command].option_strings())
    after = argv[argv.index(command) + 1 :]
    if "--" in after:
        after = after[: after.index("--")]
    for token in after:
        name = token.split("=", 1)[0]
        if (
            token.startswith("-")
            and len(token) > 1
            and name not in known
            and not re.fullmatch(r"-[\d.].*", token)
        ):
            return unknown_arguments(parser, command, [token])
    return None


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so that every output being written
    is cleaned up the same way (staging directories and files removed)."""


def _terminate(signum: int, frame: Any) -> None:
    raise Terminated


def _signals() -> Any:
    """Route SIGTERM through `Terminated` (in the main thread); returns the previous
    handler (None when it could not be set)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _terminate)


def _streams() -> None:
    """Paths that are not UTF-8 (bytes the file system gave as surrogates) print as
    escapes instead of raising UnicodeEncodeError."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # pragma: no cover - a detached stream
                pass


def one_line(text: object) -> str:
    """A message as one line: line breaks and other control characters (in a task name,
    say) escaped, so that it can never split the error or fake a second ``rtsim:`` line."""
    s = str(text)
    if s.isprintable():
        return s
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)


def _quiet(_: Any) -> None:
    """An unraisable-exception hook that says nothing: after a signal, an object the signal
    cut short in its constructor (a progress bar) fails in its finaliser as the stack
    unwinds (or when the process exits), and Python would print that traceback under the
    one line the CLI promises. Left in place after a signal: the process is ending."""


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rtsim`` console script."""
    import signal

    from rtsim.registry import (  # lazy: `rtsim --version` start-up
        opted_in,
    )

    previous = None
    try:
        previous = _signals()
        _streams()
        argv = sys.argv[1:] if argv is None else list(argv)
        if argv == ["--version"]:  # what argparse prints, without importing every command
            print(f"rtsim {__version__}")
            return 0
        parser = build_parser()
        early = _unknown_before_parsing(parser, argv)
        if early:
            print(one_line(early), file=sys.stderr)
            return 2
        args, extra = parser.parse_known_args(argv)
        if extra:
            print(
                one_line(unknown_arguments(parser, getattr(args, "command", None), extra)),
                file=sys.stderr,
            )
            return 2
        check_option_ranges(parser, args)
        if getattr(args, "allow_code", False):
            with opted_in():
                return int(args.func(args) or 0)
        return int(args.func(args) or 0)
    except InputError as exc:  # one line per problem (a file may have several)
        for line in getattr(exc, "lines", None) or (str(exc),):
            print(f"rtsim: {one_line(line)}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into head, say
        return 0
    except OSError as exc:  # an output path that cannot be written, a full disk, ...
        from rtsim.io.outdir import (  # lazy: `rtsim --version` start-up
            shown,  # a staged file is named by its target
        )

        where = f"{shown(exc.filename)}: " if exc.filename else ""
        print(f"rtsim: {one_line(where)}{one_line(exc.strerror or exc)}", file=sys.stderr)
        return 2
    except RecursionError:  # a deeply nested input (TOML, JSON) read by a library
        print("rtsim: an input is nested too deeply to read", file=sys.stderr)
        return 2
    except Terminated:
        sys.unraisablehook = _quiet  # (`_quiet`: what the signal cut short, unwound)
        print("rtsim: terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        sys.unraisablehook = _quiet
        print("rtsim: interrupted", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
