"""The command line's options of an episode config, made from the schema: each top-level key
whose `Setting` names an option (and the belt's speed and the feed of `[belt]` and `[infeed]`)
becomes one, its type, choices and help (with the range filled in) read from the field.
Imports nothing heavy, so `sortsim --help` answers at once."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from sim.config.fields import Setting, settings_of
from sim.config.sections import Belt, InfeedRate
from sim.config.settings import EpisodeSettings


def episode_options() -> list[tuple[dataclasses.Field, Setting]]:
    """The fields that have a command-line option, in the order `--help` lists them."""
    fields = [*settings_of(EpisodeSettings), *settings_of(Belt), *settings_of(InfeedRate)]
    return [(f, spec) for f, spec in fields if spec.option]


def _dest(spec: Setting) -> str:
    return spec.option[2:].replace("-", "_")


def _help(field: dataclasses.Field, spec: Setting) -> str:
    r = spec.range
    ends = {"lo": r.lo, "hi": r.hi} if r is not None else {}
    return spec.help.format(allowed=spec.allowed, default=field.default, **ends)


def add_options(parser: argparse.ArgumentParser) -> None:
    """Add every option of `episode_options` to `parser` (each None unless given)."""
    for field, spec in episode_options():
        kwargs: dict[str, Any] = {"default": None, "help": _help(field, spec)}
        if spec.choices is not None:
            kwargs["choices"] = list(spec.choices)
        elif spec.range is not None:
            kwargs["type"] = int if spec.range.integer else float
        if spec.metavar is not None:
            kwargs["metavar"] = spec.metavar
        parser.add_argument(spec.option, **kwargs)


def load_keywords(args: argparse.Namespace) -> dict[str, Any]:
    """`sim.config.load`'s keywords of the parsed options (None where not given)."""
    return {spec.keyword or f.name: getattr(args, _dest(spec)) for f, spec in episode_options()}
