"""Type stubs of volcomp's compiled module (see the docstrings of each
function for units and conventions; walk-through in docs/python.md)."""

import os
from typing import IO, Any, Literal, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

Input = Union[str, os.PathLike[str], IO[str], IO[bytes]]
"""A file: its path (str or pathlib.Path), or a file object for content in
memory (io.StringIO(text))."""
Text = Input
ArrayLike = npt.ArrayLike
F64 = npt.NDArray[np.float64]

class VolcompError(Exception):
    """Any error of volcomp."""

    file: Optional[str]
    """The file (or program name) the error is in, when known."""
    line: Optional[int]
    """1-based line of a program or row of a table."""
    column: Optional[int]
    """1-based column (byte of a program line, field of a table)."""
    message: str
    """What is wrong and what to do."""

class BadInputError(VolcompError):
    """An input file, array or option is malformed or inconsistent."""

class RefusedProgramError(VolcompError):
    """The interpreter or the compensation refused the program."""

class VolcompIOError(VolcompError):
    """A file could not be read or written."""

class VolcompWarning(UserWarning):
    """What the G-code interpreter assumed."""

class Model:
    """An error model: e(q, s) = actual − commanded (µm) at axis positions
    q (mm) with motion directions s (docs/design.md)."""

    @staticmethod
    def load(path: Union[str, os.PathLike[str]], *, clamp: bool = False) -> Model:
        """Loads an axis-table CSV, a 21-component model or a straightness
        model (TOML); clamp=True holds positions outside a table at its end."""
    @staticmethod
    def from_csv(
        text: Union[str, bytes, os.PathLike[str], IO[str], IO[bytes]],
        *,
        name: str = "<map>",
        clamp: bool = False,
    ) -> Model:
        """An axis-table map from its CSV text (or a path or file object)."""
    @staticmethod
    def from_axis_tables(
        x: Any, y: Any, z: Any, *, clamp: bool = False
    ) -> Model:
        """An axis-table map from arrays: per axis (positions_mm (n,),
        errors_um (n, 3)) or {"forward": (p, e), "reverse": (p, e)}."""
    @staticmethod
    def from_components(
        x: Any,
        y: Any,
        z: Any,
        *,
        chain: str = "w X' Y' b Z t",
        squareness_urad: tuple[float, float, float] = (0.0, 0.0, 0.0),
        measuring_point_mm: tuple[float, float, float] = (0.0, 0.0, 0.0),
        measuring_tool_length_mm: float = 0.0,
        angles: Literal["relative", "moving-part"] = "relative",
        clamp: bool = False,
    ) -> Model:
        """A 21-component model from arrays: per axis (positions_mm (n,),
        linear_um (n, 3), angular_urad (n, 3)) or {"forward": ..., "reverse": ...}."""
    @property
    def kind(self) -> Literal["axis-table", "kinematic-21", "straightness"]:
        """The kind of model."""
    @property
    def path(self) -> Optional[str]:
        """The file the model was loaded from."""
    @property
    def uses_tool_offset(self) -> bool:
        """Whether the deviation depends on the tool offset (Abbe arms)."""
    @property
    def range_mm(self) -> F64:
        """(3, 2): [min, max] per axis X, Y, Z (mm)."""
    def deviation_um(
        self,
        positions_mm: ArrayLike,
        *,
        directions: Optional[ArrayLike] = None,
        tool_offset_mm: Optional[ArrayLike] = None,
        positioning_only: bool = False,
        outside: Literal["raise", "nan"] = "raise",
    ) -> F64:
        """e (µm, shape (N, 3)) at positions (N, 3) mm; directions ±1 of
        shape (3,) or (N, 3); tool offset (3,) or (N, 3) mm."""
    def components(self) -> dict[str, Any]:
        """The components as arrays per axis and direction."""
    def component(self, name: str) -> tuple[F64, F64, F64]:
        """One ISO 230-1 component ("EXX", "EBY", ...) as (position_mm,
        forward, reverse)."""
    def to_csv(self) -> str:
        """An axis-table map as CSV text."""

class CompensateResult:
    """The compensated program and what was done."""

    data: bytes
    """The compensated program."""
    lines_in: int
    lines_out: int
    points: int
    max_residual_um: float
    max_correction_um: float
    take_ups: int
    take_ups_folded: int
    max_fold_excursion_um: float
    held: list[tuple[int, str]]
    held_count: int
    uncompensated_moves: int
    uncompensated: Optional[str]
    """Feed moves written without compensation (an axis never set, with
    allow_uncompensated_axes=True): how many, why, what to do; else None."""
    warnings: list[dict[str, Any]]
    """Dicts with file, line, column, message."""
    point_records: Optional[dict[str, Any]]
    """With point_records=True: line, target_mm (N, 3), command_mm (N, 3),
    iterations, residual_um, reversed, held, take_up, rapid."""
    machining_time: dict[str, Any]
    """The original's ("original") and the compensated program's
    ("program") time on the planner model, the limits used: the keys of
    `volcomp time --json` (docs/planner.md)."""
    @property
    def text(self) -> str:
        """The compensated program as text."""
    def summary(self) -> dict[str, Any]:
        """The summary as a dict."""

class SimulationResult:
    """Metrics of a simulated program (µm)."""

    point_rms_um: float
    point_max_um: float
    contour_rms_um: float
    contour_max_um: float
    blocks: int
    points: int
    samples: int
    feed_length_mm: float
    nominal: str
    point_definition: str
    contour_definition: str
    warnings: list[dict[str, Any]]
    segments: Optional[dict[str, Any]]
    """With segments=True: line, nominal_line, command_mm, actual_mm,
    target_mm (N, 3; NaN where none), point_um, contour_max_um."""
    machining_time: dict[str, Any]
    """The program's (and the reference's) time on the planner model: the
    keys of `volcomp time --json` (docs/planner.md)."""
    def as_dict(self) -> dict[str, Any]:
        """The metrics as a dict (the CLI's simulate --json keys)."""

def compensate(
    program: Input,
    model: Model,
    *,
    point_records: bool = False,
    name: Optional[str] = None,
    date_utc: Optional[str] = None,
    setup: Optional[Input] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
    absolute_arc_centers: bool = False,
    accept_k0: bool = False,
    allow_no_program_end: bool = False,
    max_repeated_lines: int = 5000000,
    method: Literal["exact", "ilc", "direct", "pitch"] = "exact",
    segment_length_mm: Optional[float] = None,
    segments: Optional[int] = None,
    no_split: bool = False,
    contour_tolerance_um: Optional[float] = None,
    min_segment_length_mm: float = 0.01,
    gain: float = 0.5,
    max_iterations: int = 20,
    max_residual_um: float = 1.0,
    max_output_bytes: Optional[int] = 268435456,
    chord_tolerance_mm: float = 0.0001,
    arcs_as_lines: bool = False,
    decimals: Optional[int] = None,
    max_correction_mm: float = 0.1,
    nominal_directions: bool = False,
    take_up: bool = True,
    separate_take_ups: bool = False,
    take_up_tolerance_um: Optional[float] = None,
    drill_tolerance_um: float = 5.0,
    trace: bool = True,
    allow_recompensate: bool = False,
    allow_uncompensated_axes: bool = False,
) -> CompensateResult:
    """Compensates a program for the model's errors (the options of
    `volcomp compensate`, from the library's one table: help(volcomp.compensate))."""

def simulate(
    program: Input,
    model: Model,
    *,
    segments: bool = False,
    name: Optional[str] = None,
    setup: Optional[Input] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
    absolute_arc_centers: bool = False,
    accept_k0: bool = False,
    allow_no_program_end: bool = False,
    max_repeated_lines: int = 5000000,
    reference: Optional[Input] = None,
    chord_tolerance_mm: float = 1e-05,
) -> SimulationResult:
    """Simulates a program and measures it against its nominal path."""

def moves(
    program: Input,
    *,
    extra_axes: bool = False,
    name: Optional[str] = None,
    setup: Optional[Input] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
    absolute_arc_centers: bool = False,
    accept_k0: bool = False,
    allow_no_program_end: bool = False,
    max_repeated_lines: int = 5000000,
) -> dict[str, npt.NDArray[Any]]:
    """One row per motion as a dict of columns (the `volcomp moves` CSV)."""

def machining_time(
    program: Input,
    *,
    name: Optional[str] = None,
    setup: Optional[Input] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
    absolute_arc_centers: bool = False,
    accept_k0: bool = False,
    allow_no_program_end: bool = False,
    max_repeated_lines: int = 10000000,
    reference: Optional[Input] = None,
) -> dict[str, Any]:
    """The program's (and the reference's) time on a model of LinuxCNC
    2.9's trajectory planner: the dict of `volcomp time --json`
    (docs/planner.md)."""

def iso230_2(
    target_mm: ArrayLike, up_um: ArrayLike, down_um: ArrayLike
) -> dict[str, Any]:
    """ISO 230-2 figures from deviations (µm) of shape (m targets, n runs)."""

def export(
    model: Model,
    *,
    to: Optional[
        Literal[
            "linuxcnc", "siemens-eec", "siemens-cec", "heidenhain", "isg-ssfk", "isg-csv",
            "fanuc", "klipper", "marlin", "rrf", "grblhal",
        ]
    ] = None,
    step_mm: Optional[float] = None,
    at: Optional[Sequence[float]] = None,
    max_table_error_um: float = 1.0,
    backlash_only: bool = False,
    axis_names: str = "X1,Y1,Z1",
    resolution_um: float = 1.0,
    max_points: Optional[int] = None,
    detection_unit_um: float = 1.0,
    fanuc_sign: Literal["correction", "error"] = "correction",
    fanuc_data_offset: int = 10000,
    fanuc_bidirectional: Literal["auto", "on", "off"] = "auto",
    fanuc_reference_return: Literal["positive", "negative"] = "positive",
    reference_direction: Literal["positive", "negative"] = "positive",
    cec_sign: Literal["error", "correction"] = "error",
    homing_dir_mask: int = 0,
    profile: str = "volcomp",
    comp_type: Optional[int] = None,
    units: Optional[Literal["mm", "inch"]] = None,
    tool_length_mm: Optional[float] = None,
    tool_offset_mm: Optional[Sequence[float]] = None,
    form: Literal["htm", "first-order"] = "htm",
) -> dict[str, Any]:
    """A model's controller tables (``volcomp map export``): ``files`` (name
    → text), the controller's ``notes``, ``table_error_um``."""

def iso230_2_csv(runs: Text, *, name: Optional[str] = None) -> dict[str, Any]:
    """ISO 230-2 figures from a test CSV (a path or a file object)."""

def straightness_fit(
    runs: Sequence[Union[Input, dict[str, Any]]],
    *,
    axis: Optional[Literal["X", "Y"]] = None,
    sigma_t: float = 0.05,
    p_t: float = 0.01,
    taper_fraction: float = 0.1,
    normalisation: Literal["common", "per-run"] = "common",
    cutoff: Literal["cross-validation", "thresholds"] = "cross-validation",
    harmonics: Optional[int] = None,
    negate: bool = False,
) -> tuple[Model, dict[str, dict[str, Any]]]:
    """A straightness model from runs at several feed rates (CSV files as
    paths or file objects, or dicts of positions_mm, displacement_um,
    feed_mm_per_min, axis); returns (model, report per axis)."""

class ThermalModel:
    """The regression of the 21-component model on temperatures
    (docs/thermal.md)."""

    @staticmethod
    def load(path: Union[str, os.PathLike[str]]) -> ThermalModel:
        """Loads a thermal model file (TOML)."""
    @property
    def sensors(self) -> list[str]:
        """The sensors, in column order."""
    @property
    def unidentifiable(self) -> list[str]:
        """Parameters the placements could not identify."""
    @property
    def sigma0_um(self) -> F64:
        """Probing noise per training cycle (µm)."""
    def to_toml(self) -> str:
        """The model file's text."""
    def predict(
        self, temperatures: Input, *, cycle: Optional[int] = None, extrapolate: bool = False
    ) -> Model:
        """The 21-component model at a row of a temperature CSV."""

def thermal_fit(
    measurements: Input,
    temperatures: Input,
    artifact: Input,
    *,
    ranges_mm: Optional[Sequence[Sequence[float]]] = None,
    chain: str = "w X' Y' b Z t",
    order: int = 2,
    probe_length_mm: float = 0.0,
    lags: int = 0,
    threshold: float = 0.001,
    table_samples: int = 61,
    bands_samples: Optional[int] = None,
) -> tuple[ThermalModel, dict[str, Any]]:
    """Fits a thermal model from artifact cycles and temperatures (CSV files
    as paths or file objects; ranges_mm is required); with bands_samples, the
    95 % Monte Carlo bands (the options of `volcomp thermal fit`)."""

def ballbar_predict(
    map: Input,
    *,
    centre_mm: Optional[Sequence[float]] = None,
    plane: Literal["XY", "YZ", "ZX"] = "XY",
    radius_mm: float = 100.0,
    feed_mm_per_min: float = 1000.0,
    direction: Literal["both", "ccw", "cw"] = "both",
    start_deg: float = 0.0,
    overshoot_deg: float = 180.0,
    step_deg: float = 0.1,
    program: Optional[Input] = None,
    clamp: bool = False,
) -> dict[str, Any]:
    """The ballbar trace of the machine of `map` (a path; centre_mm is
    required), its ISO 230-4 figures and the test's LinuxCNC program
    (the options of `volcomp ballbar predict`)."""

def ballbar_fit(
    trace: Input,
    *,
    pitch_mm: Optional[Sequence[float]] = None,
    spike_width_deg: float = 2.0,
    trace_plane: Optional[Literal["XY", "YZ", "ZX"]] = None,
    trace_radius_mm: Optional[float] = None,
    trace_centre_mm: Optional[Sequence[float]] = None,
    trace_feed_mm_per_min: Optional[float] = None,
) -> dict[str, Any]:
    """The ISO 230-4 figures of a trace file and the causes fitted to it
    (the options of `volcomp ballbar fit`)."""

def probe_plan(
    artifact: Input,
    setup: Optional[Input] = None,
    *,
    tip_diameter_mm: Optional[float] = None,
    probe_tool: Optional[int] = None,
    work_system: str = "G54",
    placement: Optional[str] = None,
    fast_feed_mm_min: float = 300.0,
    slow_feed_mm_min: float = 20.0,
    approach_mm: float = 2.0,
    overtravel_mm: float = 2.0,
    backoff_mm: float = 0.5,
    clearance_mm: float = 5.0,
    take_up_mm: float = 1.0,
    sphere_touches: Literal["5", "9"] = "5",
    repeats: int = 1,
    reference_repeats: int = 3,
    edge_points: int = 7,
    edge_margin_mm: float = 10.0,
    no_contact: Literal["stop", "skip"] = "stop",
    log_file: str = "probe.log",
    safe_z_mm: Optional[float] = None,
    rapid_mm_min: float = 3000.0,
    accel_mm_s2: float = 500.0,
) -> tuple[str, dict[str, Any]]:
    """The probing program of an artifact (a path or file object; setup: the
    set-up file with the work offset and the probe's tool length), checked
    by volcomp's interpreter, and a dict of touches, time_s (on the machine)
    and placements (the options of `volcomp probe plan`; tip_diameter_mm
    is required)."""

def probe_fit(
    artifacts: Sequence[Input],
    logs: Sequence[Input],
    *,
    ranges_mm: Optional[Sequence[Sequence[float]]] = None,
    chain: str = "w X' Y' b Z t",
    order: int = 2,
    model: Literal["auto", "full", "reduced"] = "auto",
    threshold: float = 0.001,
    leave_one_out: bool = False,
    monte_carlo: int = 0,
) -> tuple[Model, dict[str, Any]]:
    """The machine identified from probing logs (artifact descriptions and
    LinuxCNC logs or CSV points as paths or file objects; ranges_mm is
    required): the model with the axes' reversal, and a dict of params,
    reversal_um, sigma0_um, notes, warnings, held_out, summary (the options
    of `volcomp probe fit`)."""

def mirror(
    nominal: Input,
    measured: Input,
    *,
    date_utc: Optional[str] = None,
    stock_mm: Optional[float] = None,
    nominal_format: Optional[Literal["bspline", "grid"]] = None,
    material: Literal["below", "above", "normal-out", "normal-in"] = "below",
    probe_radius_mm: Optional[float] = None,
    max_error_mm: float = 0.1,
    fit: Literal["least-squares", "interpolate"] = "least-squares",
    tolerance_um: Optional[float] = None,
    refuse_worse: bool = False,
    grid_params: Literal["chord-length", "centripetal", "uniform"] = "chord-length",
    grid_size: int = 41,
    finishing: Optional[Input] = None,
    tool_radius_mm: Optional[float] = None,
    cl_point: Literal["tip", "center"] = "tip",
    contact_tolerance_mm: float = 0.02,
    segment_length_mm: float = 2.0,
    no_split: bool = False,
    decimals: Optional[int] = None,
    trace: bool = True,
    allow_recompensate: bool = False,
    setup: Optional[Input] = None,
    work_offset_mm: Optional[Sequence[float]] = None,
    absolute_arc_centers: bool = False,
    accept_k0: bool = False,
    allow_no_program_end: bool = False,
    max_repeated_lines: int = 5000000,
) -> dict[str, Any]:
    """Mirror compensation of a free-form surface from probe points (stock_mm
    is required); with finishing and tool_radius_mm, the compensated
    finishing program (the options of `volcomp surface mirror`)."""
