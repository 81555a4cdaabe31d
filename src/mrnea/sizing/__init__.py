"""Drive sizing from motor and gearbox catalogues (issue 27; docs/sizing.md): per joint, every
motor x gearbox combination judged exactly on the programs' own requirement, the best by an
objective, then the whole robot verified by simulation."""

from mrnea.sizing.catalogue import Catalogue, Gearbox, Motor, Train, load_catalogue
from mrnea.sizing.core import JointSizing, SizingResult, apply_trains, size_drives

__all__ = ["Catalogue", "Gearbox", "JointSizing", "Motor", "SizingResult", "Train",
           "apply_trains", "load_catalogue", "size_drives"]
