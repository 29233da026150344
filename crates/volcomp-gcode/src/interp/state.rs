//! The interpreter's state as LinuxCNC's predefined parameters show it
//! (numbered: the RS274/NGC parameter table of the LinuxCNC manual,
//! "Numbered Parameters"; named: src/emc/rs274ngc/interp_namedparams.cc,
//! `lookup_named_param`). Offsets, reference points and tool offsets are in
//! the machine's units (LinuxCNC's `USER_TO_PROGRAM_LEN`, units.h), the
//! current position (#5420…, `#<_x>`) in the program's.

use super::options::MotionMode;
use super::{FeedMode, Interpreter};
use crate::geom::{Plane, Units, Vec3};

/// What a predefined parameter is when the interpreter cannot answer it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unanswerable {
    /// Not a predefined parameter: ordinary storage.
    NotPredefined,
    /// Its value comes from the machine at run time (probe results, M66
    /// inputs, overrides): volcomp cannot know it.
    RunTime,
}

impl Interpreter {
    fn prog_units(&self, mm: f64) -> f64 {
        mm / self.units.mm_per_unit()
    }

    /// A length of the machine's own parameters (offsets, reference
    /// points, tool): in the machine's units (`USER` units in LinuxCNC's
    /// units.h), whatever G20/G21 say.
    fn machine_vec(&self, v: Vec3, axis: usize) -> f64 {
        v[axis] / self.setup.machine_units.mm_per_unit()
    }

    /// The current position in program coordinates and units (LinuxCNC's
    /// `current_x…`: axis position minus work offset, G92 and tool offset).
    pub fn program_position(&self) -> Vec3 {
        let p = self.to_program_mm(self.position);
        Vec3::new(
            self.prog_units(p[0]),
            self.prog_units(p[1]),
            self.prog_units(p[2]),
        )
    }

    /// The value of numbered parameter `n` where the interpreter owns it
    /// (#5161–#5169 G28, #5181–#5189 G30, #5210–#5219 G92, #5220–#5390
    /// coordinate systems, #5400–#5409 tool, #5420–#5428 position), or why not.
    pub fn numbered_parameter(&self, n: usize) -> Result<f64, Unanswerable> {
        let xyz = |v: Vec3, k: usize| if k < 3 { self.machine_vec(v, k) } else { 0.0 };
        Ok(match n {
            5061..=5070 => return Err(Unanswerable::RunTime),
            5161..=5169 => xyz(self.setup.g28_mm, n - 5161),
            5181..=5189 => xyz(self.setup.g30_mm, n - 5181),
            5210 => f64::from(u8::from(self.g92 != Vec3::ZERO)),
            5211..=5219 => xyz(self.g92, n - 5211),
            5220 => (self.work + 1) as f64,
            5221..=5400 if n < 5221 + 20 * 9 => {
                let k = (n - 5221) / 20;
                let i = (n - 5221) % 20;
                if i < 9 {
                    xyz(self.work_offsets[k], i)
                } else if i == 9 {
                    // Rotation R of G10 L2 (degrees).
                    self.rotation_deg[k]
                } else {
                    return Err(Unanswerable::NotPredefined);
                }
            }
            5399 => return Err(Unanswerable::RunTime),
            // Tool changer fault and reason: LinuxCNC re-reads them from the
            // machine before every line (rs274ngc_pre.cc, `read`), whatever
            // the program set.
            5600 | 5601 => return Err(Unanswerable::RunTime),
            5400 => f64::from(self.loaded_tool),
            5401..=5409 => xyz(self.tlo, n - 5401),
            5410..=5413 => 0.0,
            5420..=5428 => {
                let p = self.program_position();
                if n - 5420 < 3 {
                    p[n - 5420]
                } else {
                    0.0
                }
            }
            _ => return Err(Unanswerable::NotPredefined),
        })
    }

    /// Whether numbered parameter `n` is one the interpreter owns (so a
    /// program cannot set it directly).
    pub fn owns_parameter(n: usize) -> bool {
        matches!(n, 5061..=5070 | 5161..=5169 | 5181..=5189 | 5210..=5428)
    }

    /// The value of a predefined named parameter (`_x`, `_metric`, …, the
    /// name without `#<>`), or why not.
    pub fn named_parameter(&self, name: &str, line: u64) -> Result<f64, Unanswerable> {
        let truth = |b: bool| f64::from(u8::from(b));
        let p = self.program_position();
        let abs = self.position;
        Ok(match name {
            "_vmajor" => 2.0,
            "_vminor" => 9.0,
            "_line" => line as f64,
            "_motion_mode" => match self.motion_mode {
                None => 800.0,
                Some(MotionMode::Rapid) => 0.0,
                Some(MotionMode::Feed) => 10.0,
                Some(MotionMode::Cw) => 20.0,
                Some(MotionMode::Ccw) => 30.0,
                Some(MotionMode::Cycle(code)) => f64::from(code),
                Some(MotionMode::Synced(code)) => f64::from(code),
                Some(MotionMode::Probe(code)) => f64::from(code),
                #[allow(unreachable_patterns)]
                _ => return Err(Unanswerable::NotPredefined),
            },
            "_plane" => match self.plane {
                Plane::Xy => 170.0,
                Plane::Zx => 180.0,
                Plane::Yz => 190.0,
            },
            "_ccomp" => self.comp_side_code().unwrap_or(400.0),
            "_metric" => truth(self.units == Units::Mm),
            "_imperial" => truth(self.units == Units::Inch),
            "_absolute" => truth(self.absolute),
            "_incremental" => truth(!self.absolute),
            "_inverse_time" => truth(self.feed_mode == FeedMode::InverseTime),
            "_units_per_minute" => truth(self.feed_mode == FeedMode::PerMinute),
            "_units_per_rev" => truth(self.feed_mode == FeedMode::PerRevolution),
            "_coord_system" => {
                if self.work < 6 {
                    540.0 + 10.0 * self.work as f64
                } else {
                    584.0 + (self.work + 1) as f64
                }
            }
            "_tool_offset" => truth(self.tlo != Vec3::ZERO),
            "_retract_r_plane" => truth(self.retract_to_r),
            "_retract_old_z" => truth(!self.retract_to_r),
            "_ijk_absolute_mode" => truth(self.arc_absolute),
            "_lathe_diameter_mode" => truth(self.diameter_mode),
            "_lathe_radius_mode" => 0.0,
            "_feed" => self.feed,
            "_rpm" => self.spindle_rpm,
            "_current_tool" => f64::from(self.loaded_tool),
            "_selected_tool" => f64::from(self.next_tool),
            "_x" => p[0],
            "_y" => p[1],
            "_z" => p[2],
            "_abs_x" => self.prog_units(abs[0]),
            "_abs_y" => self.prog_units(abs[1]),
            "_abs_z" => self.prog_units(abs[2]),
            "_a" | "_b" | "_c" | "_u" | "_v" | "_w" | "_abs_a" | "_abs_b" | "_abs_c" | "_abs_u"
            | "_abs_v" | "_abs_w" => 0.0,
            "_task" => 0.0,
            "_spindle_on" | "_spindle_cw" | "_mist" | "_flood" | "_speed_override"
            | "_feed_override" | "_adaptive_feed" | "_feed_hold" | "_spindle_rpm_mode"
            | "_spindle_css_mode" | "_current_pocket" | "_selected_pocket" | "_control_mode" => {
                return Err(Unanswerable::RunTime)
            }
            _ => return Err(Unanswerable::NotPredefined),
        })
    }
}
