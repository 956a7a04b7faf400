"""One colour per object, the same in every picture of the toolkit: the top view of
``ssr-compile render``, ``belief-plot`` and the frames of ``run --gif``.

The kitchen's objects have colours of their own (seen on the camera's image and on the light
surfaces of a belief plot alike); any other object takes the next colour of a palette that is
not already taken, in the order of the objects' names, so that two pictures of the same
objects colour them alike.
"""

from __future__ import annotations

from collections.abc import Iterable

#: The kitchen's objects (Table I's tasks).
NAMED_COLORS = {"block": "#00ff00", "sugar_box": "#ffd700", "cracker_box": "#ff0000"}
#: For other objects, in turn (matplotlib's tab10 without its red and green).
PALETTE = [
    "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f",
]  # fmt: skip


def object_colors(names: Iterable[str]) -> dict[str, str]:
    """Each object's colour (a ``#rrggbb`` string), by its name."""
    names = sorted(set(names))
    colors = {n: NAMED_COLORS[n] for n in names if n in NAMED_COLORS}
    free = [c for c in PALETTE if c not in colors.values()]
    others = [n for n in names if n not in colors]
    for k, name in enumerate(others):
        colors[name] = free[k % len(free)]
    return colors
