//! The LinuxCNC program of a probing plan, and its check by volcomp's own
//! interpreter before it is written (docs/probing.md, "The probing
//! program").
//!
//! The program runs in mm (G21), absolute (G90), in the coordinate system
//! chosen (G54 by default), with the probe's tool length offset (G43 H) or
//! none (G49). It first refuses to run where the machine's offsets are not
//! those it was made for (the work offset and tool length of the set-up,
//! G92 off): `(ABORT,…)` inside an `o-if`, which LinuxCNC 2.9 turns into an
//! error that stops the program (`Interp::convert_comment`,
//! src/emc/rs274ngc/interp_convert.cc). Every touch is
//!
//! ```text
//! G38.2 Z-3.5 F300          (fast, until the probe trips)
//! G91 G1 Z0.5               (back off)
//! G90 G38.2 Z-3.5 F20       (slow: the recorded touch)
//! (LOG,touch n=1 p=r f=s1 d=-Z st=ffr at=… q=%.6f#5061,#5062,#5063 ok=#5070)
//! G0 Z…                     (back to the start point)
//! ```
//!
//! and the log's header records the offsets in effect (see
//! [`crate::io::probe_log`]).

use super::plan::{NoContact, Plan, PlanOptions, Step};
use super::ProbeError;
use crate::io::numfmt;
use crate::io::probe_log::{states_label, LOG_VERSION};
use crate::model::setup::MachineSetup;
use std::fmt::Write as _;
use volcomp_gcode::{InterpOptions, MotionKind, Vec3};

/// The coordinate systems in P order.
const SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// The offsets the program is written for: work offset and tool length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The work offset of the chosen coordinate system (mm).
    pub work_offset_mm: Vec3,
    /// The probe's tool length offset (mm), 0 without a probe tool.
    pub tool_length_mm: f64,
    /// Millimetres per machine unit: LinuxCNC keeps offsets and tool
    /// lengths (#5221…, #5401…) in the machine's units (`[TRAJ]
    /// LINEAR_UNITS`), 1 for a metric machine, 25.4 for an inch one.
    pub mm_per_machine_unit: f64,
}

impl Frame {
    /// The offsets of `setup` for the options' coordinate system and probe tool.
    pub fn of(setup: &MachineSetup, o: &PlanOptions) -> Result<Self, ProbeError> {
        let tool_length_mm = match o.probe_tool {
            None => 0.0,
            Some(t) => *setup.setup.tool_lengths_mm.get(&t).ok_or_else(|| {
                ProbeError::Invalid(format!(
                    "probe tool {t} has no length in the set-up's [tools] table: give it there (the length LinuxCNC's tool table has)"
                ))
            })?,
        };
        Ok(Self {
            work_offset_mm: setup.setup.work_offsets_mm[o.work_system],
            tool_length_mm,
            mm_per_machine_unit: setup.setup.machine_units.mm_per_unit(),
        })
    }

    /// Program coordinates of axis position `q`.
    pub fn program(&self, q: Vec3) -> Vec3 {
        q - self.work_offset_mm - Vec3::new(0.0, 0.0, self.tool_length_mm)
    }
}

fn xyz(p: Vec3) -> String {
    let [x, y, z] = p.to_array().map(numfmt::mm);
    format!("X{x} Y{y} Z{z}")
}

fn coord(letter: char, v: f64) -> String {
    format!("{letter}{}", numfmt::mm(v))
}

/// Seconds as `12 min 5 s`.
pub fn duration(s: f64) -> String {
    let s = s.round() as u64;
    if s >= 3600 {
        format!("{} h {} min", s / 3600, (s % 3600) / 60)
    } else if s >= 60 {
        format!("{} min {} s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}

/// Writes the program of `plan` (`title`: a line saying what made it).
pub fn write_program(plan: &Plan, o: &PlanOptions, frame: &Frame, title: &str) -> String {
    let mut g = String::with_capacity(256 * plan.touches.len() + 4096);
    let probe = match o.no_contact {
        NoContact::Stop => "G38.2",
        NoContact::Skip => "G38.3",
    };
    let sys = SYSTEMS[o.work_system];
    let k = o.work_system;
    let _ = writeln!(g, "({})", title.replace(['(', ')'], ""));
    let _ = writeln!(
        g,
        "(artifact {}: {} touches; time on the machine about {} at F{} / F{}, rapids {} mm/min, {} mm/s2)",
        plan.artifact,
        plan.touches.len(),
        duration(plan.time_s),
        numfmt::mm(o.fast_feed_mm_min),
        numfmt::mm(o.slow_feed_mm_min),
        numfmt::mm(o.rapid_mm_min),
        numfmt::mm(o.accel_mm_s2)
    );
    let _ = writeln!(
        g,
        "(made for {sys} = {} and a probe tip of {} mm)",
        xyz(frame.work_offset_mm),
        numfmt::mm(o.tip_diameter_mm)
    );
    g.push_str("G17 G21 G40 G80 G90 G94\nM5 M9\n");
    let _ = writeln!(g, "{sys}");
    match o.probe_tool {
        Some(t) => {
            let _ = writeln!(g, "G43 H{t}");
        }
        None => g.push_str("G49\n"),
    }
    // Refuse to run with offsets other than those the program was made for
    // (compared in the machine's units, in which LinuxCNC keeps them).
    let base = 5221 + 20 * k;
    let w = frame.work_offset_mm * (1.0 / frame.mm_per_machine_unit);
    let _ = writeln!(
        g,
        "o100 if [ABS[#{} - {}] GT 0.0005 OR ABS[#{} - {}] GT 0.0005 OR ABS[#{} - {}] GT 0.0005]",
        base,
        numfmt::mm(w.x),
        base + 1,
        numfmt::mm(w.y),
        base + 2,
        numfmt::mm(w.z)
    );
    let _ = writeln!(
        g,
        "  (ABORT,{sys} is not the work offset this program was made for: regenerate it with the machine's offsets)"
    );
    g.push_str("o100 endif\n");
    g.push_str("o101 if [#5210 NE 0]\n  (ABORT,G92 offsets are in effect: cancel them with G92.1 and run again)\no101 endif\n");
    // #5400–#5403 are the spindle tool's table entry (`set_tool_parameters`,
    // rs274ngc_pre.cc), which the log records as the tool offset: the probe
    // must be the tool in the spindle, not only the G43 offset in effect.
    if let Some(t) = o.probe_tool {
        let _ = writeln!(g, "o103 if [#5400 NE {t}]");
        let _ = writeln!(
            g,
            "  (ABORT,the probe tool {t} is not in the spindle: load it with T{t} M6 and run again)"
        );
        g.push_str("o103 endif\n");
    }
    let _ = writeln!(
        g,
        "o102 if [ABS[#5403 - {}] GT 0.0005]",
        numfmt::mm(frame.tool_length_mm / frame.mm_per_machine_unit)
    );
    g.push_str("  (ABORT,the tool length offset is not the probe's: load the probe and its offset as the set-up says)\no102 endif\n");
    let _ = writeln!(g, "(LOGOPEN,{})", o.log_file);
    let _ = writeln!(
        g,
        "(LOG,volcomp-probe {LOG_VERSION} artifact={})",
        plan.artifact
    );
    let _ = writeln!(
        g,
        "(LOG,frame g5x=%.6f#{},#{},#{} r=#{} g92on=#5210 g92=#5211,#5212,#5213 tlo=#5401,#5402,#5403 metric=#<_metric> mm=#<_metric_machine>)",
        base,
        base + 1,
        base + 2,
        base + 9
    );
    let slow = numfmt::mm(o.slow_feed_mm_min);
    let fast = numfmt::mm(o.fast_feed_mm_min);
    for step in &plan.steps {
        match step {
            Step::SafeZ(z) => {
                let _ = writeln!(g, "G53 G0 Z{}", numfmt::mm(*z));
            }
            Step::Pause(text) => {
                let _ = writeln!(g, "(MSG,{})\nM0", text.replace(['(', ')'], ""));
            }
            Step::Rapid(q) => {
                let _ = writeln!(g, "G0 {}", xyz(frame.program(*q)));
            }
            Step::Touch(n) => {
                let t = &plan.touches[n - 1];
                let a = t.direction.axis;
                let letter = ['X', 'Y', 'Z'][a];
                let target = frame.program(t.target_mm);
                let start = frame.program(t.start_mm);
                let back = -t.direction.sign() * o.backoff_mm;
                let _ = writeln!(g, "{probe} {} F{fast}", coord(letter, target[a]));
                let _ = writeln!(g, "G91 G1 {} F{fast}", coord(letter, back));
                let _ = writeln!(g, "G90 {probe} {} F{slow}", coord(letter, target[a]));
                let _ = writeln!(
                    g,
                    "(LOG,touch n={} p={} f={} d={} st={} at={},{},{} q=%.6f#5061,#5062,#5063 ok=#5070)",
                    t.n,
                    t.placement,
                    t.feature,
                    t.direction.label(),
                    states_label(&t.states),
                    numfmt::fixed(target.x, 6),
                    numfmt::fixed(target.y, 6),
                    numfmt::fixed(target.z, 6)
                );
                let _ = writeln!(g, "G0 {}", coord(letter, start[a]));
            }
        }
    }
    g.push_str("(LOGCLOSE)\nM2\n");
    g
}

/// Reads the program back with volcomp's interpreter (probing moves read
/// as feed moves to their end points) and checks that it makes exactly the
/// moves of the plan: every probe move ends at its touch's target, every
/// rapid where the plan put it.
pub fn check_program(
    text: &str,
    plan: &Plan,
    setup: &MachineSetup,
    frame: &Frame,
    probe_tool: Option<u32>,
) -> Result<(), ProbeError> {
    let mut ms = setup.clone();
    ms.interp = InterpOptions {
        accept_probing: true,
        require_program_end: true,
        ..ms.interp
    };
    // The program selects its own offsets; the tool length it applies is
    // the set-up's (G43 H reads the tool table).
    // The operator has loaded the probe (T M6) before the run: the check
    // starts with it in the spindle, written on the first line so that
    // line numbers stay the program's.
    let checked = match probe_tool {
        Some(t) => format!("T{t} M6 {text}"),
        None => text.to_string(),
    };
    let mut walker = ms.walker(checked.as_bytes(), "probe.ngc");
    let mut motions = Vec::new();
    loop {
        match walker.next_line() {
            Ok(Some(ev)) => motions.extend_from_slice(ev.motions),
            Ok(None) => break,
            Err(e) => return Err(ProbeError::Program(e.to_string())),
        }
    }
    // Expected: every step's end point in order (a probe move: fast, back
    // off, slow, return). The back-off is relative to where the probe
    // tripped, which the interpreter cannot know: it is not compared. NaN
    // coordinates (after G53 Z alone) are not compared either.
    let nan = f64::NAN;
    let mut want: Vec<(Vec3, bool)> = Vec::new();
    let mut last = Vec3::new(nan, nan, nan);
    for step in &plan.steps {
        match step {
            Step::SafeZ(z) => {
                last.z = *z;
                want.push((last, false));
            }
            Step::Pause(_) => {}
            Step::Rapid(q) => {
                last = *q;
                want.push((*q, false));
            }
            Step::Touch(n) => {
                let t = &plan.touches[n - 1];
                want.push((t.target_mm, true));
                want.push((Vec3::new(nan, nan, nan), true));
                want.push((t.target_mm, true));
                want.push((t.start_mm, false));
                last = t.start_mm;
            }
        }
    }
    let _ = frame;
    if motions.len() != want.len() {
        return Err(ProbeError::Program(format!(
            "{} motions read, {} planned",
            motions.len(),
            want.len()
        )));
    }
    for (m, (w, probe_move)) in motions.iter().zip(&want) {
        let e = m.end;
        for a in 0..3 {
            if w[a].is_finite() && (e[a] - w[a]).abs() > 1e-5 {
                return Err(ProbeError::Program(format!(
                    "line {}: the interpreter ends this move at {} {}, the plan at {}",
                    m.line,
                    ['X', 'Y', 'Z'][a],
                    e[a],
                    w[a]
                )));
            }
        }
        if *probe_move && m.kind != MotionKind::Feed {
            return Err(ProbeError::Program(format!(
                "line {}: a probe move read as a rapid",
                m.line
            )));
        }
    }
    Ok(())
}
