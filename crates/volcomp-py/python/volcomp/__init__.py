"""volcomp: volumetric error compensation of 3-axis machine tools.

Error models (axis tables, the 21-component kinematic model, straightness),
the compensation and simulation of G-code programs, and identification
(ISO 230-2, straightness, thermal) and mirror compensation of
free-form surfaces, over the Rust library that the ``volcomp`` command uses.
Conventions: positions in mm in the machine's axis frame, errors in µm,
angles in µrad, the deviation ``e = actual − commanded`` (docs/design.md).

A ``str`` (or ``bytes``) argument that may be a file is its content; a
``pathlib.Path`` names a file. Walk-through: docs/python.md.
"""

from ._volcomp import (
    BadInputError,
    CompensateResult,
    Model,
    RefusedProgramError,
    SimulationResult,
    ThermalModel,
    VolcompError,
    VolcompIOError,
    VolcompWarning,
    __version__,
    compensate,
    iso230_2,
    iso230_2_csv,
    mirror,
    moves,
    simulate,
    straightness_fit,
    thermal_fit,
)

__all__ = [
    "BadInputError",
    "CompensateResult",
    "Model",
    "RefusedProgramError",
    "SimulationResult",
    "ThermalModel",
    "VolcompError",
    "VolcompIOError",
    "VolcompWarning",
    "__version__",
    "compensate",
    "iso230_2",
    "iso230_2_csv",
    "mirror",
    "moves",
    "simulate",
    "straightness_fit",
    "thermal_fit",
]
