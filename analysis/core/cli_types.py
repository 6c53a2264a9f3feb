"""Command-line types: argparse's parser with one-line errors and exit code 2, and the `type`s that check an
option against its Field (or that a folder option names a writable folder) before anything runs."""
from __future__ import annotations

import argparse
from pathlib import Path

from analysis.core.schema import ConfigError, Field


class CommandLine(argparse.ArgumentParser):
    """argparse's parser, whose error is one line, `PROG: MESSAGE (--help lists the options)`, and exit code 2
    (argparse's own prints the whole usage first); an option is named in full (`--speed` is not taken for
    `--speed-kmh`), in every command and subcommand."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        self.exit(2, f"{self.prog}: {message} ({self.prog} --help lists the options)\n")


def option(name: str, field: Field, many: bool = False):
    """An argparse `type` for the option `name`: its text read as `field.kind` (a comma-separated list of them
    with `many`) and checked against `field`, so a bad value stops the command line with the option, its
    allowed range and exit code 2 before anything runs.

    >>> option("--threads", Field(1, 64, kind=int))("2")
    2
    >>> option("--seeds", Field(0, 10, kind=int), many=True)("1,2")
    [1, 2]
    """

    def parse(text: str):
        values = []
        for item in (text.split(",") if many else [text]):
            try:
                value = field.kind(item) if field.kind is int else float(item)
            except ValueError:
                raise argparse.ArgumentTypeError(f"{name} = {text!r}: allowed {'comma-separated ' if many else ''}"
                                                 f"{'whole ' if field.kind is int else ''}numbers in {field.allowed()}")
            try:
                values.append(field.check(name, value))
            except ConfigError as e:
                raise argparse.ArgumentTypeError(str(e))
        return values if many else values[0]
    parse.field = field                 # what the option takes, for the generated bad-input test
    return parse


def folder(name: str):
    """An argparse `type` for a folder option: a folder, or one that can be made (its nearest existing parent a
    writable folder), so a file or a read-only place stops the command line before anything runs.

    >>> folder("--out")("/proc/version")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: --out = '/proc/version': allowed a folder or one that can be made; this is a file
    """
    import os

    def parse(text: str) -> Path:
        path = Path(text)
        if path.exists() and not path.is_dir():
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: allowed a folder or one that can be made; this is a file")
        parent = path
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: allowed a folder or one that can be made; "
                                             f"{str(parent)!r} is a file")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: allowed a writable folder; {str(parent)!r} is not "
                                             "writable")
        return path
    return parse
