"""volcomp: volumetric error compensation of 3-axis machine tools.

Error models (axis tables, the 21-component kinematic model, straightness),
the compensation and simulation of G-code programs, and identification
(ISO 230-2, straightness, thermal, a touch probe's artifacts) and mirror compensation of
free-form surfaces, over the Rust library that the ``volcomp`` command uses.
Conventions: positions in mm in the machine's axis frame, errors in µm,
angles in µrad, the deviation ``e = actual − commanded`` (docs/design.md).

An input file is a path (``str`` or ``pathlib.Path``), or a file object
(``io.StringIO(text)``, ``open(...)``) for content already in memory.
Walk-through: docs/python.md.
"""

import functools as _functools
import inspect as _inspect
from typing import Callable, TypeVar

from . import _volcomp

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
    ballbar_fit,
    ballbar_predict,
    compensate,
    export,
    iso230_2,
    iso230_2_csv,
    machining_time,
    mirror,
    moves,
    probe_fit,
    probe_plan,
    simulate,
    straightness_fit,
    thermal_fit,
)

_F = TypeVar("_F", bound=Callable[..., object])


def _with_options(fn: _F) -> _F:
    """``fn`` with the library's options of its job (the job is the
    function's name) as keyword parameters: its signature and docstring list
    them, from the library's one table (the CLI's flags are built from the
    same table)."""
    options = _volcomp._options(fn.__name__)
    signature = _inspect.signature(fn)
    params = [p for p in signature.parameters.values() if p.kind != p.VAR_KEYWORD]
    # Options the function takes as its own parameters (mirror's nominal
    # and measured) stay where they are.
    options = [o for o in options if o["name"] not in signature.parameters]
    params += [
        _inspect.Parameter(o["name"], _inspect.Parameter.KEYWORD_ONLY, default=o["default"])
        for o in options
    ]

    @_functools.wraps(fn)
    def call(*args, **kwargs):
        return fn(*args, **kwargs)

    lines = [(fn.__doc__ or "").rstrip(), "", "Options:"]
    for o in options:
        choices = f" (one of {', '.join(o['choices'])})" if o["choices"] else ""
        lines.append(f"    {o['name']}: {o['type']} = {o['default']!r}{choices}")
        # A switch's help says what turning it from its default does.
        turn = {True: "False: ", False: "True: "}.get(o["default"], "") if o["type"] == "bool" else ""
        lines.append(f"        {turn}{o['help']}")
    call.__doc__ = "\n".join(lines)
    call.__signature__ = signature.replace(parameters=params)  # type: ignore[attr-defined]
    return call  # type: ignore[return-value]


# Each job's function, with its options as keyword parameters.
for _job in (
    compensate, simulate, moves, machining_time, mirror, thermal_fit, straightness_fit, export,
    ballbar_predict, ballbar_fit, probe_fit, probe_plan,
):
    globals()[_job.__name__] = _with_options(_job)
del _job

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
    "ballbar_fit",
    "ballbar_predict",
    "compensate",
    "export",
    "iso230_2",
    "iso230_2_csv",
    "machining_time",
    "mirror",
    "moves",
    "probe_fit",
    "probe_plan",
    "simulate",
    "straightness_fit",
    "thermal_fit",
]
