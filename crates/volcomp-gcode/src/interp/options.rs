//! What the caller chooses ([`InterpOptions`]) and the modal modes a
//! program switches between (feed mode, motion mode).

/// Options that change interpretation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpOptions {
    /// Accept `K0` on G17 arcs (FreeCAD writes it; LinuxCNC refuses it, so
    /// the default refuses it too). A non-zero K on a G17 arc is refused
    /// either way.
    pub accept_k0_on_xy_arcs: bool,
    /// Interpret arc centres as absolute from the start, as if G90.1 began
    /// the program.
    pub absolute_arc_centers: bool,
    /// Hold the program to LinuxCNC's rule that it ends with M2 or M30 (or,
    /// if its first non-blank line is `%`, with a closing `%` line): a
    /// program that reaches the end of its file without one is read to its
    /// last line, as LinuxCNC runs it, with a warning that says what
    /// LinuxCNC then reports ("File ended with no percent sign or program
    /// end", `Interp::read_text`, interp_read.cc). Other controllers need
    /// no end, and a library caller may read a fragment, so the default
    /// does not warn; the `volcomp` command line does, unless told
    /// otherwise.
    pub require_program_end: bool,
    /// Largest distance (mm) between a G5/G5.1/G5.2 spline and the chords
    /// the interpreter linearises it into.
    pub spline_tolerance_mm: f64,
    /// Decimals of a computed value written into a rendered line (`F[1/3]`
    /// evaluated), in mm and in inch programs: `compensate` writes them
    /// like the program's numbers. `None`: the shortest number that reads
    /// back as the same double (up to 17 digits).
    pub computed_decimals: Option<[u8; 2]>,
    /// Most lines one run executes again — every pass of a loop after the
    /// first, every line of a called subroutine; a program past it is
    /// refused as a loop that never ends (default
    /// [`crate::ngc::flow::MAX_EXECUTED_LINES`]). Lines of the main program
    /// run once are not counted, so a long program without loops always runs.
    pub max_executed_lines: u64,
    /// Read the probing moves G38.2–G38.5 (off by default: after a probe
    /// move the machine is where the probe touched, which only the machine
    /// knows). When on, a probing move is read as a feed move to its end
    /// point — the path it takes when the probe never touches — so that a
    /// generated probing program (docs/probing.md) can be checked whole; the
    /// probed position (#5061–#5070) stays unknown to the interpreter.
    pub accept_probing: bool,
}

impl Default for InterpOptions {
    fn default() -> Self {
        Self {
            accept_k0_on_xy_arcs: false,
            absolute_arc_centers: false,
            require_program_end: false,
            spline_tolerance_mm: 1e-4,
            computed_decimals: None,
            max_executed_lines: crate::ngc::flow::MAX_EXECUTED_LINES,
            accept_probing: false,
        }
    }
}

/// Feed-rate mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedMode {
    /// G93: F is the inverse of the block's duration in minutes.
    InverseTime,
    /// G94: units per minute.
    PerMinute,
    /// G95: units per revolution.
    PerRevolution,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum MotionMode {
    Rapid,
    Feed,
    Cw,
    Ccw,
    /// Canned cycle: G81, G82, G85 or G89 (code × 10).
    Cycle(u16),
    /// Spline: G5 (50), G5.1 (51), G5.2 (52); G5.3 (53) only while its
    /// block runs.
    Spline(u16),
    /// Spindle-synchronised motion: G33 (330) or G33.1 rigid tapping (331).
    Synced(u16),
    /// Straight probe (read only with `InterpOptions::accept_probing`):
    /// G38.2 (382), G38.3 (383), G38.4 (384), G38.5 (385).
    Probe(u16),
}
