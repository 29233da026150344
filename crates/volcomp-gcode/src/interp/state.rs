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
    /// It holds what the set-up does not give (a work offset not in
    /// `[work_offsets]` and no var file, a tool's length or diameter not in
    /// the tool tables): [`Interpreter::not_in_setup`] says which.
    NotInSetup,
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

    /// Extra axis `k` (A, B, C, U, V, W) in the program frame: degrees, or
    /// program units for U, V, W (LinuxCNC's `AA_current` … `w_current`).
    fn extra_program(&self, k: usize) -> f64 {
        let v = self.extra[k] - self.extra_g92[k];
        if k < 3 {
            v
        } else {
            self.prog_units(v)
        }
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
    /// coordinate systems, #5400–#5413 the spindle tool's table entry,
    /// #5420–#5428 position), or why not.
    pub fn numbered_parameter(&self, n: usize) -> Result<f64, Unanswerable> {
        let xyz = |v: Vec3, k: usize| if k < 3 { self.machine_vec(v, k) } else { 0.0 };
        Ok(match n {
            5061..=5070 => return Err(Unanswerable::RunTime),
            5161..=5169 => xyz(self.setup.g28_mm, n - 5161),
            5181..=5189 => xyz(self.setup.g30_mm, n - 5181),
            // Set by G52/G92/G92.3, cleared by G92.1/G92.2
            // (`convert_axis_offsets`, interp_convert.cc).
            5210 => f64::from(u8::from(self.g92_applied)),
            // The G92 parameters: G92.2 clears the offset in effect but
            // keeps them (G92.3 restores from them); G92.1 clears both.
            5211..=5213 => xyz(self.g92_saved, n - 5211),
            // A, B, C (degrees), U, V, W (machine units).
            5214..=5216 => self.extra_g92_saved[n - 5214],
            5217..=5219 => self.extra_g92_saved[n - 5214] / self.setup.machine_units.mm_per_unit(),
            5220 => (self.work + 1) as f64,
            5221..=5390 => {
                let k = (n - 5221) / 20;
                let i = (n - 5221) % 20;
                if i > 9 {
                    return Err(Unanswerable::NotPredefined);
                }
                if !self.work_given[k] {
                    return Err(Unanswerable::NotInSetup);
                }
                if i < 9 {
                    xyz(self.work_offsets[k], i)
                } else {
                    // Rotation R of G10 L2 (degrees).
                    self.rotation_deg[k]
                }
            }
            5399 => return Err(Unanswerable::RunTime),
            // The spindle tool's entry of the tool table (`set_tool_parameters`,
            // rs274ngc_pre.cc, at M6, M61 and G10 L1/L10/L11): its number
            // (0: none), offsets, diameter, angles and orientation, in the
            // table's (the machine's) units — not the G43 offset in effect.
            5400 => f64::from(self.param_tool),
            5401..=5413 if self.param_tool == 0 => 0.0,
            5401 | 5402 => {
                let xy = self.tool_xy_mm.get(&self.param_tool).copied();
                self.machine_vec(
                    Vec3::new(xy.map_or(0.0, |v| v[0]), xy.map_or(0.0, |v| v[1]), 0.0),
                    n - 5401,
                )
            }
            5403 => match self.setup.tool_lengths_mm.get(&self.param_tool) {
                Some(l) => self.machine_vec(Vec3::new(0.0, 0.0, *l), 2),
                None => return Err(Unanswerable::NotInSetup),
            },
            5404..=5409 => 0.0,
            5410 => match self.setup.tool_diameters_mm.get(&self.param_tool) {
                Some(d) => self.machine_vec(Vec3::new(*d, 0.0, 0.0), 0),
                None => return Err(Unanswerable::NotInSetup),
            },
            5411..=5413 => {
                let lathe = self.tool_lathe.get(&self.param_tool).copied();
                lathe.map_or(0.0, |v| v[n - 5411])
            }
            5420..=5422 => self.program_position()[n - 5420],
            5423..=5428 => self.extra_program(n - 5423),
            // Tool changer fault and reason: LinuxCNC re-reads them from the
            // machine before every line (rs274ngc_pre.cc, `read_inputs`),
            // whatever the program set.
            5600 | 5601 => return Err(Unanswerable::RunTime),
            _ => return Err(Unanswerable::NotPredefined),
        })
    }

    /// Why numbered parameter `n` (one [`Interpreter::numbered_parameter`]
    /// answers with [`Unanswerable::NotInSetup`]) has no value.
    pub fn not_in_setup(&self, n: usize) -> (String, String) {
        if (5221..=5390).contains(&n) {
            let name = crate::setup::WORK_SYSTEMS[(n - 5221) / 20];
            return (
                format!("#{n} belongs to the {name} offset, which the set-up does not give"),
                format!("give it under [work_offsets] in the set-up file ({name} = [X, Y, Z]), or name LinuxCNC's var file (var_file = \"linuxcnc.var\")"),
            );
        }
        let t = self.param_tool;
        let (what, table) = if n == 5410 {
            ("diameter", "tool_diameters")
        } else {
            ("length", "tools")
        };
        (
            format!(
                "#{n} is the {what} of tool {t} (in the spindle), which the set-up does not give"
            ),
            format!("give it under [{table}] in the set-up file ({t} = …)"),
        )
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
            // `init_named_parameters` reads PACKAGE_VERSION "2.9.0~…" with
            // `sscanf("%lf%lf")`: 2.9, then ".0" (interp_namedparams.cc).
            "_vmajor" => 2.9,
            "_vminor" => 0.0,
            // 1 for a metric machine, 0 for an inch one (`inicheck`:
            // [TRAJ]LINEAR_UNITS); rs274 without an INI file gives -1.
            "_metric_machine" => truth(self.setup.machine_units == Units::Mm),
            "_line" => line as f64,
            "_motion_mode" => match self.motion_mode {
                None => 800.0,
                Some(MotionMode::Rapid) => 0.0,
                Some(MotionMode::Feed) => 10.0,
                Some(MotionMode::Cw) => 20.0,
                Some(MotionMode::Ccw) => 30.0,
                Some(MotionMode::Cycle(code)) => f64::from(code),
                Some(MotionMode::Synced(code)) => f64::from(code),
                // G5.2 (52) is modal; G5 and G5.1 do not change the mode.
                Some(MotionMode::Spline(code)) => f64::from(code),
                Some(MotionMode::Probe(code)) => f64::from(code),
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
            "_lathe_radius_mode" => truth(!self.diameter_mode),
            "_spindle_rpm_mode" => truth(!self.css_mode),
            "_spindle_css_mode" => truth(self.css_mode),
            // The spindle and coolant as M3/M4/M5 and M7/M8/M9 left them,
            // from a stopped spindle with coolant off at the start (as the
            // stand-alone interpreter starts; the canned cycles assume it
            // too).
            "_spindle_on" => truth(self.spindle_dir != 0),
            "_spindle_cw" => truth(self.spindle_dir == 1),
            "_mist" => truth(self.mist),
            "_flood" => truth(self.flood),
            "_feed" => self.feed,
            "_rpm" => self.spindle_rpm,
            // `lookup_named_param`: #5400.
            "_current_tool" => f64::from(self.param_tool),
            "_selected_tool" => f64::from(self.next_tool),
            "_x" => p[0],
            "_y" => p[1],
            "_z" => p[2],
            "_abs_x" => self.prog_units(abs[0]),
            "_abs_y" => self.prog_units(abs[1]),
            "_abs_z" => self.prog_units(abs[2]),
            "_a" => self.extra_program(0),
            "_b" => self.extra_program(1),
            "_c" => self.extra_program(2),
            "_u" => self.extra_program(3),
            "_v" => self.extra_program(4),
            "_w" => self.extra_program(5),
            // LinuxCNC 2.9 has `_abs_a` … `_abs_c`, no `_abs_u` … `_abs_w`.
            "_abs_a" => self.extra[0],
            "_abs_b" => self.extra[1],
            "_abs_c" => self.extra[2],
            // 1 in the machine's own interpreter (milltask), 0 in a preview
            // such as AXIS's or rs274: volcomp computes the path the
            // machine makes.
            "_task" => 1.0,
            "_speed_override" | "_feed_override" | "_adaptive_feed" | "_feed_hold"
            | "_current_pocket" | "_selected_pocket" | "_control_mode" => {
                return Err(Unanswerable::RunTime)
            }
            _ => return Err(Unanswerable::NotPredefined),
        })
    }
}
