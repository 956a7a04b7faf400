"""A family of harder kitchens (issue 40, part 2): Cook- and Inspect-like task files with
``n`` movable objects, ``k`` of which may hide the target from the camera.

The objects (``ssr-compile tasks generate --kind cook --objects N --hiders K``):

* the target, ``block``, on the counter;
* ``k`` hiders on the counter, cracker boxes and sugar boxes in turn (``cracker_box``,
  ``sugar_box``, ``cracker_box_2``, ...): the episode's seed picks the one that stands between
  the camera and the block (the paper's Cook has two);
* ``n - 1 - k`` more blocks (``block_2``, ...), each on the counter or in a drawer as the seed
  draws it, with a prior uniform over the three.

``cook``: the block cooked and the stove off; prior of the block: the counter (as Cook).
``inspect``: the block in the bottom drawer and that drawer closed; prior of the block:
counter 1/2, each drawer 1/4 (so the robot may look in the drawers before behind the boxes).
The episode's seed draws everything else (``sim/tasks.py``: the order of the draws).
"""

from __future__ import annotations

KINDS = ("cook", "inspect")
MAX_OBJECTS = 12
MAX_HIDERS = 6
SPREAD = ("counter", "top_drawer", "bottom_drawer")


def family_name(kind: str, n: int, k: int) -> str:
    return f"{kind}_n{n}_k{k}"


def generate(kind: str, n: int, k: int) -> str:
    """The task file (TOML text) of the family member ``kind`` with ``n`` objects and ``k``
    hiders; ValueError when the numbers are out of range."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    if not 2 <= n <= MAX_OBJECTS:
        raise ValueError(f"objects must be from 2 to {MAX_OBJECTS}, got {n}")
    if not 1 <= k <= min(MAX_HIDERS, n - 1):
        raise ValueError(f"hiders must be from 1 to {min(MAX_HIDERS, n - 1)} (< objects), got {k}")
    kinds = {}  # hider -> its kind
    for i in range(k):
        box = ("cracker_box", "sugar_box")[i % 2]
        kinds[box if i < 2 else f"{box}_{i // 2 + 1}"] = box
    hiders = list(kinds)
    others = [f"block_{i + 2}" for i in range(n - 1 - k)]
    spread = "[" + ", ".join(f'"{s}"' for s in SPREAD) + "]"
    lines = [
        f"# generated: ssr-compile tasks generate --kind {kind} --objects {n} --hiders {k}",
        f'name = "{family_name(kind, n, k)}"',
    ]
    if kind == "cook":
        lines.append('goal = ["Cooked block", "StoveOff"]')
    else:
        lines.append('goal = ["On block bottom_drawer", "Closed bottom_drawer"]')
    lines += ["", "[objects]  # placed in this order; the hiders last", *(
        f'{o} = {{ kind = "block", on = {spread} }}' for o in others
    ), 'block = { kind = "block", on = "counter" }']  # fmt: skip
    lines += [f'{h} = {{ kind = "{kinds[h]}", on = "counter" }}' for h in hiders]
    lines += ["", "[hide]  # the seed picks the one in front of the block", 'target = "block"']
    lines.append("by = [" + ", ".join(f'"{h}"' for h in hiders) + "]")
    lines.append("reachable = true  # the one in front only where the robot can grasp it")
    lines += ["", "[prior]"]
    if kind == "cook":
        lines.append('block = ["counter"]')
    else:
        lines.append("block = { counter = 2, top_drawer = 1, bottom_drawer = 1 }")
    lines += [f'{h} = ["counter"]' for h in hiders]
    lines += [f"{o} = {spread}" for o in others]
    return "\n".join(lines) + "\n"
