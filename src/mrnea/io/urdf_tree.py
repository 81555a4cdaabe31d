"""Walks over a URDF's tree for :mod:`mrnea.io.urdf`: the joints the tips keep, and the tip
links a refusal of a ``<mimic>`` joint suggests.

Each is one pass over the links in depth-first order (parents before children) or over the
paths to the tips, each link visited once: walking every leaf's or tip's path from the root
had made a file of a few thousand links take seconds, and a 16 MiB one minutes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from mrnea.errors import quote

MOVING_TYPES = ("revolute", "continuous", "prismatic")


def kept_joints(rd: Any, order: list[str], parent_joint: dict[str, Any],
                tips: Sequence[str]) -> set[str]:
    """The names of the moving joints kept: all without ``tips``, else those on the paths from
    the root (``order[0]``) to the tips. A tip that is no link, or whose path has no moving
    joint, is an error of ``rd`` (the reader, which names the file)."""
    if not tips:
        return {j.name for j in parent_joint.values() if j.type in MOVING_TYPES}
    base, moving_above = order[0], {order[0]: False}  # a moving joint on the link's path
    for name in order[1:]:
        j = parent_joint[name]
        moving_above[name] = moving_above[j.parent] or j.type in MOVING_TYPES
    kept: set[str] = set()
    seen = {base}
    for t in tips:
        if t not in moving_above:
            raise rd.error(f"tip link {quote(t)} does not exist")
        if not moving_above[t]:
            raise rd.error(f"the path from root link {quote(base)} to tip link {quote(t)} "
                           "has no moving joint")
        link = t
        while link not in seen:  # up to the first link a previous tip's path holds
            seen.add(link)
            j = parent_joint[link]
            if j.type in MOVING_TYPES:
                kept.add(j.name)
            link = j.parent
    return kept


def tip_candidates(links: dict[str, Any], order: list[str], parent_joint: dict[str, Any],
                   children: dict[str, list[Any]]) -> list[str]:
    """The leaves whose path from the root has a moving joint and no ``<mimic>`` joint, ordered
    by the mass the chain to them would move (the links after the path's first moving joint),
    heaviest first, then by name: real end effectors before the cameras and sensors hanging off
    a wrist with placeholder masses."""
    moved: dict[str, float | None] = {order[0]: None}  # None: no moving joint on the path yet
    clean = {order[0]: True}  # no <mimic> joint on the path
    for name in order[1:]:
        j = parent_joint[name]
        m = links[name].mass
        m = m if math.isfinite(m) and m > 0 else 0.0
        above = moved[j.parent]
        moved[name] = (above + m if above is not None
                       else m if j.type in MOVING_TYPES else None)
        clean[name] = clean[j.parent] and not j.mimic
    ranked = [(-mass, leaf) for leaf in order if not children[leaf] and clean[leaf]
              and (mass := moved[leaf]) is not None]
    return [leaf for _, leaf in sorted(ranked)]
