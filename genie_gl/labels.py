"""The label map: the paper's ten classes (Table 3), their colours and the names readers accept.

The one place class ids, names and colours are written; the exports (SemanticKITTI label-map
YAML, histograms), previews and USD labels all read them from here. A strategy may declare
more classes: ids above 9 are its own and are named ``class_<id>``.
"""

from __future__ import annotations

import numpy as np

# id -> name as the paper's Table 3 names the class (lower case)
CLASSES: dict[int, str] = {
    0: "background",
    1: "pallet",
    2: "rack",
    3: "car",
    4: "jack",
    5: "stillage",
    6: "storage cabinet",
    7: "dolly",
    8: "forklift",
    9: "small load carrier",
}
# id -> (r, g, b), 0..255
COLORS_RGB: dict[int, tuple[int, int, int]] = {
    0: (170, 170, 160),
    1: (141, 110, 99),
    2: (94, 53, 177),
    3: (229, 57, 53),
    4: (240, 98, 146),
    5: (67, 160, 71),
    6: (0, 137, 123),
    7: (253, 216, 53),
    8: (251, 140, 0),
    9: (30, 136, 229),
}
OTHER_RGB = (128, 128, 128)
# other spellings found in scene files (USD labels, older genie-gl outputs), lower case
ALIASES: dict[str, int] = {
    "cabinet": 6,
    "storage_cabinet": 6,
    "small_load_carrier": 9,
    "klt": 9,
    "floor": 0,
    "wall": 0,
    "unlabeled": 0,
    "unlabelled": 0,
}


def name(class_id: int) -> str:
    """The class's name (``class_<id>`` for an id the map does not know)."""
    return CLASSES.get(int(class_id), f"class_{int(class_id)}")


def color(class_id: int) -> tuple[int, int, int]:
    return COLORS_RGB.get(int(class_id), OTHER_RGB)


def class_id(label: str) -> int | None:
    """The id of a class name, spelt as the map or an alias has it (case-insensitive); None if
    unknown."""
    key = label.strip().lower()
    for k, v in CLASSES.items():
        if v == key or v.replace(" ", "_") == key:
            return k
    if key in ALIASES:
        return ALIASES[key]
    if key.startswith("class_") and key[6:].isdigit():
        return int(key[6:])
    return None


def palette(size: int = 65536, *, other: tuple[int, int, int] = (255, 255, 255)):
    """(size, 3) uint8 colour table indexed by class id."""
    table = np.empty((size, 3), np.uint8)
    table[:] = other
    for k, c in COLORS_RGB.items():
        table[k] = c
    return table
