"""Motor and gearbox catalogues for drive sizing (issue 27; the format: docs/sizing.md).

``load_catalogue(path) -> Catalogue`` reads a TOML file of ``[[motor]]``, ``[[gearbox]]`` and
``[[drive]]`` entries (a drive: a motor and a gearbox sold as one unit), checked by the
project's TOML checker (:class:`mrnea.io.tomlcheck.TomlCheck`): an error names the file, the
entry (``motor 'M-120'`` or ``motor #3`` without a usable name) and the field.
:meth:`Catalogue.combinations` gives every drive train to judge: each motor with each gearbox,
and each drive unit.

Units, SI: torques [N m], speeds [rad/s], inertias [kg m^2], masses [kg]; a motor's figures at
its shaft, a gearbox's ratings at its output and its inertia and speed limit at its input.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrnea.actuator_fields import EFFICIENCY_MIN, GEAR_RANGE
from mrnea.errors import ModelError, SizingError, quote
from mrnea.frozen import MAGNITUDES, check_name
from mrnea.io.tomlcheck import TomlCheck, read_text

__all__ = ["Catalogue", "Gearbox", "Motor", "Train", "load_catalogue", "loads_catalogue"]


@dataclass(frozen=True)
class Motor:
    """A motor: ``rated_torque`` (continuous, thermal) and ``peak_torque`` [N m], ``max_speed``
    [rad/s], ``rotor_inertia`` [kg m^2], all at its shaft; ``torque_speed`` (peak, corner_speed,
    no_load_speed) or None (the peak up to ``max_speed``); ``mass`` [kg], ``price`` (None: not
    given)."""

    name: str
    rated_torque: float
    peak_torque: float
    max_speed: float
    rotor_inertia: float
    torque_speed: tuple[float, float, float] | None = None
    mass: float = 0.0
    price: float | None = None


@dataclass(frozen=True)
class Gearbox:
    """A gearbox: ``ratio`` G (input turns per output turn), ``efficiency`` (driving,
    back-driven), ``inertia`` [kg m^2] at the input, ``rated_torque`` (compared with the
    cubic mean) and ``peak_torque`` [N m] at the output (inf: not rated), ``max_input_speed``
    [rad/s] (inf: not rated), ``mass`` [kg], ``price`` (None: not given)."""

    name: str
    ratio: float
    efficiency: tuple[float, float] = (1.0, 1.0)
    inertia: float = 0.0
    rated_torque: float = float("inf")
    peak_torque: float = float("inf")
    max_input_speed: float = float("inf")
    mass: float = 0.0
    price: float | None = None


@dataclass(frozen=True)
class Train:
    """One drive train to judge: a motor and a gearbox (``unit``: sold as one ``[[drive]]``,
    whose mass and price are the motor's, the gearbox's being 0 and None)."""

    motor: Motor
    gearbox: Gearbox
    unit: bool = False

    @property
    def name(self) -> str:
        return self.motor.name if self.unit else f"{self.motor.name} + {self.gearbox.name}"

    @property
    def mass(self) -> float:
        return self.motor.mass + self.gearbox.mass

    @property
    def price(self) -> float | None:
        """The motor's and the gearbox's price (a unit's: its own); None if one is not given."""
        if self.unit:
            return self.motor.price
        if self.motor.price is None or self.gearbox.price is None:
            return None
        return self.motor.price + self.gearbox.price


@dataclass(frozen=True)
class Catalogue:
    """What one catalogue file offers: motors, gearboxes and drive units (each a Train)."""

    motors: tuple[Motor, ...]
    gearboxes: tuple[Gearbox, ...]
    drives: tuple[Train, ...]
    source: str = "catalogue"

    def combinations(self) -> list[Train]:
        """Every motor with every gearbox, then every drive unit."""
        return ([Train(m, g) for m in self.motors for g in self.gearboxes]
                + list(self.drives))


#: The largest number a catalogue entry may give (docs/sizing.md): a mass and an inertia as a
#: robot file's (:data:`mrnea.frozen.MAGNITUDES`), any other (torques [N m], speeds [rad/s],
#: prices) :data:`BOUND`; beyond, the sums of the judging and the plot lose every digit.
BOUND = 1e9
_BOUNDS = {"mass": MAGNITUDES["mass"], "rotor_inertia": MAGNITUDES["rotor_inertia"],
           "inertia": MAGNITUDES["rotor_inertia"]}

#: The most combinations one catalogue may give: each is judged over every cycle of the programs
#: (about 80 bytes a cycle), so beyond this even a short program needs more memory than a
#: machine has, and :meth:`Catalogue.combinations` alone took 25 s and 3 GB to list 25 million
#: (5000 motors x 5000 gearboxes) before the memory check could refuse them; a 16 MiB file could
#: ask for 6e10.
MAX_COMBINATIONS = 1_000_000

_MOTOR_KEYS = ("name", "rated_torque", "peak_torque", "max_speed", "rotor_inertia",
               "torque_speed", "mass", "price")
_GEARBOX_KEYS = ("name", "ratio", "efficiency", "inertia", "rated_torque", "peak_torque",
                 "max_input_speed", "mass", "price")
#: a drive unit: the motor's keys, the gearbox's ratio, efficiency, inertia and input speed,
#: and its output ratings under their own names (the motor's ratings keep theirs)
_DRIVE_KEYS = (*_MOTOR_KEYS, "ratio", "efficiency", "inertia", "max_input_speed",
               "output_rated_torque", "output_peak_torque")


def loads_catalogue(text: str, source: str = "catalogue") -> Catalogue:
    """A catalogue from TOML text (:func:`load_catalogue`); ``source`` names it in errors."""
    check = TomlCheck(source, SizingError)
    doc = check.parse(text)
    check.check_keys(doc, ("motor", "gearbox", "drive"), "")
    entries: dict[str, list[Mapping[str, Any]]] = {}
    for kind in ("motor", "gearbox", "drive"):
        value = doc.get(kind, [])
        if not isinstance(value, list) or not all(isinstance(e, dict) for e in value):
            raise check.error("", f"'{kind}' must be an array of tables, [[{kind}]]")
        entries[kind] = value
    if not any(entries.values()):
        raise check.error("", "no [[motor]], [[gearbox]] or [[drive]] entry")
    names: set[str] = set()
    motors = tuple(_motor(check, e, f"motor #{k}", names)
                   for k, e in enumerate(entries["motor"], start=1))
    gearboxes = tuple(_gearbox(check, e, f"gearbox #{k}", names)
                      for k, e in enumerate(entries["gearbox"], start=1))
    drives = tuple(_drive(check, e, f"drive #{k}", names)
                   for k, e in enumerate(entries["drive"], start=1))
    if not drives and not (motors and gearboxes):
        raise check.error("", "nothing to combine: give [[motor]] and [[gearbox]] entries, or "
                              "[[drive]] units")
    count = len(motors) * len(gearboxes) + len(drives)
    if count > MAX_COMBINATIONS:
        raise check.error("", f"{len(motors)} motors x {len(gearboxes)} gearboxes + "
                              f"{len(drives)} drives make {count} combinations, more than "
                              f"{MAX_COMBINATIONS} mrnea judges (split the catalogue)")
    _unit_names(check, motors, gearboxes, drives)  # after the cap: it may visit every pair
    return Catalogue(motors, gearboxes, drives, source)


def load_catalogue(path: str | Path) -> Catalogue:
    """Read a catalogue file (docs/sizing.md). Raises :class:`SizingError` naming the file,
    the entry and the field at fault."""
    return loads_catalogue(read_text(path, "catalogue", SizingError), str(path))


def _name(check: TomlCheck, e: Mapping[str, Any], where: str, names: set[str]) -> str:
    """The entry's unique name, held to a robot's joint names' rule (no control characters):
    it is written into chosen_drives.toml and sized_robot.toml, where a newline in a comment
    or a table header made the file invalid TOML."""
    name = check.string(check.require(e, "name", where), where, "name")
    try:
        check_name(name, "drive")
    except ModelError:
        raise check.error(where, f"'name' {quote(name)} holds a control character (a newline, "
                                 f"a tab...)") from None
    if name in names:
        raise check.error(where, f"duplicate name {quote(name)}")
    names.add(name)
    return name


def _unit_names(check: TomlCheck, motors: tuple[Motor, ...], gearboxes: tuple[Gearbox, ...],
                drives: tuple[Train, ...]) -> None:
    """Every train's name is its own: a drive unit named like a motor-and-gearbox combination
    (``'A + B'`` with a motor 'A' and a gearbox 'B'), or two combinations of one name (motors
    'A' and 'A + B', gearboxes 'B + C' and 'C'), had one name in every table, plot and the
    summary, so the chosen one could not be told from the other. Only names holding
    ``' + '`` are looked at, so this costs nothing for usual catalogues."""
    motor_names, gear_names = {m.name for m in motors}, {g.name for g in gearboxes}
    sep = " + "

    def splits(name: str) -> list[tuple[str, str]]:
        """The (motor, gearbox) pairs of the file whose combination is named ``name``."""
        out, k = [], name.find(sep)
        while k >= 0:
            if name[:k] in motor_names and name[k + len(sep):] in gear_names:
                out.append((name[:k], name[k + len(sep):]))
            k = name.find(sep, k + 1)
        return out

    for d in drives:
        if pair := next(iter(splits(d.name)), None):
            raise check.error(f"drive {quote(d.name)}", f"its name is also that of motor "
                                                        f"{quote(pair[0])} with gearbox "
                                                        f"{quote(pair[1])}: rename it")
    for m in (m for m in motors if sep in m.name):
        for g in gearboxes:
            if len(pair := splits(f"{m.name}{sep}{g.name}")) > 1:
                raise check.error(f"motor {quote(m.name)}", f"with gearbox {quote(g.name)} it "
                                  f"is named as motor {quote(pair[0][0])} with gearbox "
                                  f"{quote(pair[0][1])}: rename one")


def _positive(check: TomlCheck, e: Mapping[str, Any], key: str, where: str,
              default: float | None = None, *, zero: bool = False, inf: bool = False) -> float:
    """``e[key]`` > 0 (>= 0 with ``zero``; inf allowed with ``inf``); ``default`` if absent
    (None: required)."""
    if key not in e and default is not None:
        return default
    v = check.number(check.require(e, key, where), where, key, allow_inf=inf)
    if v < 0 or (v == 0 and not zero):
        raise check.error(where, f"'{key}' must be {'>= 0' if zero else '> 0'}, got {v}")
    bound = _BOUNDS.get(key, BOUND)
    if bound < v < float("inf"):
        raise check.error(where, f"'{key}' {v:.3g} is beyond {bound:g}, the largest mrnea "
                                 "accepts (check its units)")
    return v


def _price(check: TomlCheck, e: Mapping[str, Any], where: str) -> float | None:
    return _positive(check, e, "price", where, zero=True) if "price" in e else None


def _motor(check: TomlCheck, e: Mapping[str, Any], where: str, names: set[str],
           keys: tuple[str, ...] = _MOTOR_KEYS) -> Motor:
    where = f"{where.split(' ')[0]} {quote(_name(check, e, where, names))}"
    check.check_keys(e, keys, where)
    rated = _positive(check, e, "rated_torque", where)
    peak = _positive(check, e, "peak_torque", where)
    if rated > peak:
        raise check.error(where, f"'rated_torque' {rated} is above 'peak_torque' {peak}")
    vmax = _positive(check, e, "max_speed", where)
    curve = None
    if "torque_speed" in e:
        c = check.vector(e["torque_speed"], where, "torque_speed", 3, allow_inf=True)
        if not (c[0] == peak and 0 < c[1] <= c[2]) or c[1] > BOUND:
            raise check.error(where, f"'torque_speed' must be [peak_torque, corner_speed, "
                                     f"no_load_speed] with peak {peak} and 0 < corner_speed <= "
                                     f"no_load_speed, corner at most {BOUND:g}; got {c.tolist()}")
        curve = (float(c[0]), float(c[1]), float(c[2]))
    return Motor(e["name"], rated, peak, vmax,
                 _positive(check, e, "rotor_inertia", where, zero=True), curve,
                 _positive(check, e, "mass", where, 0.0, zero=True), _price(check, e, where))


def _efficiency(check: TomlCheck, e: Mapping[str, Any], where: str) -> tuple[float, float]:
    if "efficiency" not in e:
        return (1.0, 1.0)
    v = e["efficiency"]
    pair = (check.vector(v, where, "efficiency", 2).tolist() if isinstance(v, list)
            else [check.number(v, where, "efficiency")] * 2)
    if not all(EFFICIENCY_MIN <= x <= 1.0 for x in pair):
        raise check.error(where, f"'efficiency' must be in [{EFFICIENCY_MIN:g}, 1] (one value, "
                                 f"or [driving, back-driven]), got {quote(v)}")
    return (float(pair[0]), float(pair[1]))


def _ratio(check: TomlCheck, e: Mapping[str, Any], where: str) -> float:
    g = _positive(check, e, "ratio", where)
    if not GEAR_RANGE[0] <= g <= GEAR_RANGE[1]:
        raise check.error(where, f"'ratio' {g} is outside {list(GEAR_RANGE)}")
    return g


def _gearbox(check: TomlCheck, e: Mapping[str, Any], where: str, names: set[str]) -> Gearbox:
    where = f"gearbox {quote(_name(check, e, where, names))}"
    check.check_keys(e, _GEARBOX_KEYS, where)
    inf = float("inf")
    return Gearbox(e["name"], _ratio(check, e, where), _efficiency(check, e, where),
                   _positive(check, e, "inertia", where, 0.0, zero=True),
                   _positive(check, e, "rated_torque", where, inf, inf=True),
                   _positive(check, e, "peak_torque", where, inf, inf=True),
                   _positive(check, e, "max_input_speed", where, inf, inf=True),
                   _positive(check, e, "mass", where, 0.0, zero=True), _price(check, e, where))


def _drive(check: TomlCheck, e: Mapping[str, Any], where: str, names: set[str]) -> Train:
    motor = _motor(check, e, where, names, _DRIVE_KEYS)
    where = f"drive {quote(motor.name)}"
    inf = float("inf")
    box = Gearbox(motor.name, _ratio(check, e, where), _efficiency(check, e, where),
                  _positive(check, e, "inertia", where, 0.0, zero=True),
                  _positive(check, e, "output_rated_torque", where, inf, inf=True),
                  _positive(check, e, "output_peak_torque", where, inf, inf=True),
                  _positive(check, e, "max_input_speed", where, inf, inf=True))
    return Train(motor, box, unit=True)
