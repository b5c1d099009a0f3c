"""From a dataset's own labels to genie-gl's classes (``genie_gl.labels``, the paper's Table 3).

A genie-gl dataset's labels are its class ids. A foreign SemanticKITTI-layout set has its own
raw ids, named in its yaml's ``labels``; a label-map file says which of our classes each of
them is (or ``ignore``: left out of training and scoring)::

    # my-scans-to-genie.yaml: their raw id or name -> our class name or id, or ignore
    map:
      0: ignore            # unlabelled
      10: pallet
      11: pallet
      rack-upright: rack   # a name from their yaml's labels
      99: background
    default: error         # a raw id not listed: error (the default), ignore, or a class

A raw id found in the data that the map does not cover is refused with the file and the id,
as is a name the map gives that is neither ours nor theirs (with "did you mean").
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .. import labels as ours
from ..errors import ConfigError, did_you_mean

IGNORE = -1  # a point left out of training and scoring
UNMAPPED = -2  # a raw id the map does not cover (an error when it occurs)
IGNORE_NAMES = ("ignore", "unlabeled", "unlabelled", "none")
RAW_IDS = 1 << 16  # SemanticKITTI's semantic label is the lower 16 bits


@dataclass(frozen=True)
class LabelMap:
    """A look-up table from a dataset's raw semantic ids to genie-gl class ids.

    Attributes
    ----------
    lut : (65536,) int32
        ``lut[raw]`` = our class id, ``IGNORE`` (-1) or ``UNMAPPED`` (-2).
    source : str
        Where the map came from (a file, or "genie-gl's own classes"), for messages.
    names : dict[int, str]
        Our class ids the map produces -> their names.
    """

    lut: np.ndarray
    source: str
    names: dict[int, str]

    def apply(self, raw: np.ndarray, where: str) -> np.ndarray:
        """Raw ids (N,) to our ids (N,) int16 (-1 unlabelled); a raw id not in the map is a
        :class:`ConfigError` naming ``where``, the id and the map."""
        raw = np.asarray(raw)
        if raw.size and int(raw.max()) >= RAW_IDS:
            raise ConfigError(f"{where}: label {int(raw.max())} is beyond 16 bits")
        out = self.lut[raw.astype(np.int64)]
        bad = out == UNMAPPED
        if bad.any():
            ids, counts = np.unique(raw[bad], return_counts=True)
            others = (
                f" (and {len(ids) - 1} other unmapped ids: "
                f"{', '.join(str(int(i)) for i in ids[1:6])}"
                f"{' ...' if len(ids) > 6 else ''})"
                if len(ids) > 1
                else ""
            )
            raise ConfigError(
                f"{where}: label {int(ids[0])} (on {int(counts[0])} of {raw.size} points) is "
                "outside the "
                f"label map ({self.source}: ids {self.ids_text()}){others}; fix the labels, or "
                "give a "
                "--label-map file that maps it (their id: our class, or ignore)"
            )
        return out.astype(np.int16)

    def ids_text(self, most: int = 12) -> str:
        """The raw ids the map covers, shortened (``0-9, 12``), for messages."""
        ids = np.flatnonzero(self.lut != UNMAPPED)
        if len(ids) == RAW_IDS:
            return f"0-{RAW_IDS - 1}"
        runs, start = [], None
        for i, v in enumerate(ids):
            if start is None:
                start = v
            if i + 1 == len(ids) or ids[i + 1] != v + 1:
                runs.append(f"{start}" if start == v else f"{start}-{v}")
                start = None
        return ", ".join(runs[:most]) + (" ..." if len(runs) > most else "")

    def inverse(self) -> np.ndarray:
        """(C,) uint32: for each of our classes, the smallest raw id mapped to it (0 if none):
        what a prediction is written as in the dataset's own ids."""
        raw = np.flatnonzero(self.lut >= 0)  # increasing raw ids
        classes, first = np.unique(self.lut[raw], return_index=True)
        inv = np.zeros(int(classes.max()) + 1 if classes.size else 1, np.uint32)
        inv[classes] = raw[first]
        return inv


def identity(
    extra: Mapping[int, str] | None = None,
    *,
    only: Mapping[int, str] | None = None,
    source: str = "genie-gl's own classes",
) -> LabelMap:
    """genie-gl's own ids: every id maps to itself (ids above 9 are a strategy's own).

    ``only``: the ids a set's label-map yaml names (``labels``); every other raw id is then
    refused when it occurs (a stray id must never become a class of its own).
    """
    if only is None:
        lut = np.arange(RAW_IDS, dtype=np.int32)
    else:
        lut = np.full(RAW_IDS, UNMAPPED, np.int32)
        keep = np.array([int(k) for k in only if 0 <= int(k) < RAW_IDS], np.int64)
        lut[keep] = keep
    names = dict(ours.CLASSES)
    names.update({int(k): str(v) for k, v in (extra or {}).items()})
    if only is not None:
        names = {k: v for k, v in names.items() if lut[k] == k}
    return LabelMap(lut=lut, source=source, names=names)


def our_class(value: Any, where: str) -> int:
    """One of our classes from a name or an id; ``IGNORE`` for ``ignore``."""
    if isinstance(value, bool):
        raise ConfigError(f"{where}: {value!r} is not a class")
    if isinstance(value, int) or (isinstance(value, str) and value.strip().isdigit()):
        v = int(value)
        if v < 0 or v >= RAW_IDS:
            raise ConfigError(f"{where}: class id {v} outside 0..{RAW_IDS - 1}")
        return v
    text = str(value).strip().lower()
    if text in IGNORE_NAMES:
        return IGNORE
    cid = ours.class_id(text)
    if cid is None:
        names = [n.replace(" ", "_") for n in ours.CLASSES.values()] + list(IGNORE_NAMES[:1])
        raise ConfigError(
            f"{where}: unknown class {value!r}{did_you_mean(text.replace(' ', '_'), names)}; "
            f"expected one of {', '.join(names)} or a class id"
        )
    return cid


def load(path: str | os.PathLike, their_labels: Mapping[int, str] | None = None) -> LabelMap:
    """Read a label-map file (YAML or JSON: ``map`` and optional ``default``).

    Parameters
    ----------
    path : path
    their_labels : dict[int, str], optional
        The dataset's own ``labels`` (raw id -> name), so the map may name their classes.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(f"--label-map {path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"--label-map {path}: not a text file (byte {exc.start} is not UTF-8); expected a "
            "YAML/JSON "
            "label map {map: {their class: our class}}"
        ) from None
    except yaml.YAMLError as exc:
        raise ConfigError(
            f"--label-map {path}: not YAML/JSON ({str(exc).splitlines()[0]})"
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("map"), dict) or not data["map"]:
        raise ConfigError(
            f"--label-map {path}: expected a mapping with a non-empty 'map: {{their class: our "
            "class}'"
        )
    unknown = set(data) - {"map", "default"}
    if unknown:
        key = sorted(unknown)[0]
        raise ConfigError(
            f"--label-map {path}: unknown key {key!r}{did_you_mean(key, ['map', 'default'])}"
        )
    by_name = {str(v).strip().lower(): int(k) for k, v in (their_labels or {}).items()}
    default = data.get("default", "error")
    fill = (
        UNMAPPED
        if str(default).strip().lower() == "error"
        else our_class(default, f"--label-map {path}: default")
    )
    lut = np.full(RAW_IDS, fill, np.int32)
    names: dict[int, str] = {}
    for key, value in data["map"].items():
        where = f"--label-map {path}: map[{key!r}]"
        if isinstance(key, int) and not isinstance(key, bool):
            raw = key
        elif str(key).strip().isdigit():
            raw = int(str(key).strip())
        elif str(key).strip().lower() in by_name:
            raw = by_name[str(key).strip().lower()]
        else:
            raise ConfigError(
                f"{where}: {key!r} is neither a raw id nor a class of the dataset's yaml"
                f"{did_you_mean(str(key).lower(), by_name)}"
            )
        if not 0 <= raw < RAW_IDS:
            raise ConfigError(f"{where}: raw id {raw} outside 0..{RAW_IDS - 1}")
        c = our_class(value, where)
        lut[raw] = c
        if c >= 0:
            names[c] = ours.name(c)
    if fill >= 0:
        names[fill] = ours.name(fill)
    return LabelMap(lut=lut, source=str(path), names=names)


def check_same_classes(a: Mapping[int, str], a_src: str, b: Mapping[int, str], b_src: str) -> None:
    """Two label maps that name one id differently cannot be mixed: one line naming both."""
    for k in sorted(set(a) & set(b)):
        na, nb = str(a[k]).strip().lower(), str(b[k]).strip().lower()
        if na.replace("_", " ") != nb.replace("_", " "):
            raise ConfigError(
                f"mismatched label maps: {a_src} names class {k} {a[k]!r}, {b_src} names it "
                f"{b[k]!r}; give a --label-map file that maps one set's classes to the other's"
            )
