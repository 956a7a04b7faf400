"""Table I of the paper (§VIII) as published: what a sweep's table is compared with."""

from __future__ import annotations

# Table I of the paper: task -> variant -> (success %, mean planning time of successes, s).
PAPER_TABLE1: dict[str, dict[str, tuple[float, float]]] = {
    "inspect": {
        "neither": (96, 41),
        "constraints": (100, 45),
        "deferred": (100, 32),
        "both": (100, 26),
    },
    "stow": {
        "neither": (80, 124),
        "constraints": (88, 226),
        "deferred": (88, 92),
        "both": (88, 108),
    },
    "swap": {
        "neither": (52, 190),
        "constraints": (40, 484),
        "deferred": (60, 105),
        "both": (80, 232),
    },
    "cook": {
        "neither": (20, 375),
        "constraints": (40, 406),
        "deferred": (56, 249),
        "both": (100, 203),
    },
}
PAPER_EPISODES = 25  # problems per task in the paper
