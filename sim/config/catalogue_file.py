"""The item catalogue an episode config names (`catalogue`), read by the loaders at the edge
and held by the config as a `CatalogueFile`: compared by the key it was read for and its
content digest, so a config pickles whole to a sweep's worker (which reads no file) and two
configs compare equal by what they run with."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

from sim.checks import check
from sim.errors import InvalidInput
from sim.flow.catalogue import DEFAULT_CATALOGUE, Catalogue, load_catalogue


@functools.lru_cache(maxsize=16)
def _catalogue_at(path: str, mtime_ns: int, size: int) -> Catalogue:
    return load_catalogue(path)


def episode_catalogue(path: str) -> Catalogue:
    """The item catalogue of a config's `catalogue` key (a TOML file; "": the built-in
    `sim/data/items.toml`), read once per file version; refused in one line naming `catalogue`
    (and the file) when it cannot be used."""
    file = Path(path) if path else DEFAULT_CATALOGUE
    try:
        stat = file.stat()
    except OSError as exc:
        allowed = "an item catalogue TOML file"
        raise InvalidInput("catalogue", allowed, f"{path}: {exc.strerror}") from None
    if not file.is_file():
        raise InvalidInput("catalogue", "an item catalogue TOML file", f"{path}: not a file")
    try:
        return _catalogue_at(str(file), stat.st_mtime_ns, stat.st_size)
    except InvalidInput as exc:
        field = exc.field if exc.field.startswith("catalogue") else f"catalogue: {exc.field}"
        raise InvalidInput(field, exc.allowed, exc.got, exc.where or str(file)) from None


@dataclass(frozen=True)
class CatalogueFile:
    """An item catalogue as an episode config holds it: read from its file by the loaders
    (`read`), compared by the config key it was read for and its content.

    Attributes:
        path: The config's `catalogue` key it was read for ("": the built-in one).
        digest: The catalogue's content digest (`Catalogue.digest`).
        catalogue: The catalogue itself (left out of comparisons and reprs: its digest
            stands for it).
    """

    path: str
    digest: str
    catalogue: Catalogue = field(compare=False, repr=False)

    @classmethod
    def read(cls, path: object, where: str | None = None) -> CatalogueFile:
        """The catalogue of a config's `catalogue` key (from config file `where`), read now
        (`episode_catalogue`); refused naming `catalogue` and the file when the key is not a
        path or its file cannot be used."""
        ok = isinstance(path, str) and "\0" not in path
        check(ok, "catalogue", "a path to an item catalogue TOML file", path, where)
        assert isinstance(path, str)
        try:
            catalogue = episode_catalogue(path)
        except InvalidInput as exc:
            raise InvalidInput(exc.field, exc.allowed, exc.got, exc.where or where) from None
        return cls(path, catalogue.digest, catalogue)


@functools.cache
def builtin_catalogue() -> CatalogueFile:
    """The built-in catalogue (`sim/data/items.toml`: the thesis's paper, plastic and
    aluminium), read once per process: what `EpisodeConfig()` runs with.

    Returns:
        The catalogue of the key "".
    """
    return CatalogueFile.read("")
