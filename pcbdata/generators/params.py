"""What every typed parameter set of a generator family shares: its names, reading it from a
preset's or the user's (`--set`) values, and its plain form for the manifest."""
from __future__ import annotations

from dataclasses import MISSING, asdict, fields
from difflib import SequenceMatcher, get_close_matches
from typing import Any

from pcbdata.core.errors import UserError


def closest_name(key: str, known: list[str]) -> str | None:
    """The known name closest to `key`: difflib's closest match, else the one sharing the most
    words with it (`nets_max` -> `net_counts`), ties by similarity; None when nothing is near."""
    close = get_close_matches(key, known, n=1)
    if close:
        return close[0]
    words = key.lower().split("_")

    def score(name: str) -> tuple[int, float]:
        parts = name.split("_")
        shared = sum(1 for w in words if get_close_matches(w, parts, n=1, cutoff=0.75))
        return shared, SequenceMatcher(None, key, name).ratio()

    best = max(known, key=score, default=None)
    return best if best is not None and score(best)[0] else None


class GeneratorParams:
    """Base of a family's frozen parameter dataclass. A subclass names its family in errors
    (`LABEL`) and checks one value against its annotation (`coerce`)."""

    LABEL = ""
    #: Parameters added after sets were released, which draw nothing at their default: the
    #: manifest records them only when set, so the earlier levels' records (and the pinned
    #: releases of them) stay as they were. A left-out one is at its default, so the record
    #: still gives the boards.
    RECORDED_WHEN_SET: tuple[str, ...] = ()

    @staticmethod
    def coerce(key: str, value: Any, annotation: str, where: str) -> Any:
        raise NotImplementedError

    @classmethod
    def keys(cls) -> list[str]:
        return [f.name for f in fields(cls)]  # type: ignore[arg-type]

    @classmethod
    def from_dict(cls, values: dict, where: str):
        """Typed parameters from preset/override values; `where` names their origin in errors."""
        known = {f.name: f for f in fields(cls)}  # type: ignore[arg-type]
        kwargs = {}
        for key, value in values.items():
            if key not in known:
                close = closest_name(key, list(known))
                hint = f"; did you mean {close!r}?" if close else ""
                raise UserError(f"{where}: unknown {cls.LABEL} parameter {key!r}{hint} "
                                f"(known: {', '.join(sorted(known))})")
            kwargs[key] = cls.coerce(key, value, str(known[key].type), where)
        return cls(**kwargs)

    def as_dict(self) -> dict:
        """The full parameter set, but `RECORDED_WHEN_SET` parameters at their default."""
        data = asdict(self)  # type: ignore[call-overload]
        defaults = {f.name: (f.default_factory() if f.default_factory is not MISSING
                             else f.default)
                    for f in fields(self)  # type: ignore[arg-type]
                    if f.name in self.RECORDED_WHEN_SET}
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in data.items()
                if not (k in defaults and v == defaults[k])}
