"""URDF ``<transmission>`` elements: the gear ratio of each joint a transmission drives.

A single-joint, single-actuator transmission gives its joint the gear ratio
``abs(mechanicalReduction)`` (ros_control's ``<actuator><mechanicalReduction>`` or the old
format's direct child); a coupled one (a differential, several actuators) gives ``None``, which
:func:`load_urdf <mrnea.io.urdf.load_urdf>` turns into gear ratio 1 and a warning when it drives
the chain.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

from mrnea.errors import quote

if TYPE_CHECKING:
    from mrnea.io.urdf import _Reader

__all__ = ["transmissions"]


def transmissions(rd: _Reader, root: ET.Element) -> dict[str, tuple[str, float | None]]:
    """Joint name -> (transmission name, abs(mechanical reduction), or None if coupled).

    Transmissions of joints the file does not have are ignored (cut-down robot files often
    keep the full list).
    """
    out: dict[str, tuple[str, float | None]] = {}
    for k, tr in enumerate(root.findall("transmission")):
        tname = tr.get("name") or f"#{k + 1}"
        what = f"transmission {quote(tname)}"
        jnames = [rd.required(je, "name", f"{what} <joint>") for je in tr.findall("joint")]
        # ros_control format: <actuator><mechanicalReduction>; old format: a direct child
        red_elems = [*tr.findall("actuator/mechanicalReduction"),
                     *tr.findall("mechanicalReduction")]
        reductions = [rd.text_number(r, f"{what} <mechanicalReduction>") for r in red_elems]
        for jn in jnames:
            if jn in out:
                raise rd.error(f"{what}: joint {quote(jn)} is already driven by transmission "
                               f"{quote(out[jn][0])}")
        if len(jnames) == 1 and len(reductions) <= 1:
            red = reductions[0] if reductions else 1.0
            if red == 0 or not math.isfinite(red):
                raise rd.error(
                    f"{what} <mechanicalReduction>: must be finite and non-zero, got {red}"
                )
            out[jnames[0]] = (tname, abs(red))
        else:  # differential or multi-actuator: load_urdf warns if it drives the chain
            for jn in jnames:
                out[jn] = (tname, None)
    return out
