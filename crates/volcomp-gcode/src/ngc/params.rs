//! Parameter storage as LinuxCNC 2.9 keeps it (interp_read.cc,
//! interp_namedparams.cc, interp_o_word.cc `enter_context`/`leave_context`):
//!
//! * numbered #1–#5601: global storage, except that #1–#30 belong to the
//!   call level — a call saves the caller's #1–#30, passes its arguments in
//!   them (the rest 0) and the return restores them; unset ones read 0;
//! * named `#<_name>` (leading underscore): global; `#<name>`: local to the
//!   call level (a subroutine does not see its caller's); reading one that
//!   was never set is an error;
//! * the interpreter's own (#5161–#5428, `#<_x>`, `#<_metric>` …) are read
//!   from its state ([`crate::Interpreter::numbered_parameter`]); a program
//!   cannot set them directly (use G10, G28.1, G30.1, G92).
//!
//! `#<_value>` and `#<_value_returned>` hold the value of the last
//! subroutine return; `#<_call_level>` the depth of calls.

use super::expr::{ExprError, Lookup, MAX_PARAMETERS};
use super::Map;
use crate::interp::Unanswerable;
use crate::Interpreter;

/// The parameters of a running program.
#[derive(Debug, Clone)]
pub struct Params {
    numbered: Vec<f64>,
    globals: Map<String, f64>,
    /// One frame per call level: the caller's #1–#30 and the locals.
    frames: Vec<Frame>,
    /// `#<_value>`.
    pub value: f64,
    /// `#<_value_returned>`.
    pub value_returned: bool,
}

#[derive(Debug, Clone, Default)]
struct Frame {
    saved: [f64; 30],
    locals: Map<String, f64>,
}

impl Default for Params {
    fn default() -> Self {
        let mut numbered = vec![0.0; MAX_PARAMETERS + 1];
        // The (DEBUG, …) flag, 1 at start (`Interp::init`, rs274ngc_pre.cc).
        numbered[5599] = 1.0;
        Self {
            numbered,
            globals: Map::default(),
            frames: vec![Frame::default()],
            value: 0.0,
            value_returned: false,
        }
    }
}

impl Params {
    /// Sets numbered parameter `n` (1–5601) from outside the program (a
    /// `.var` file).
    pub fn preset(&mut self, n: usize, v: f64) {
        if let Some(p) = self.numbered.get_mut(n) {
            *p = v;
        }
    }

    /// Sets a parameter the program set (checked: not one the interpreter owns).
    pub fn set_numbered(&mut self, n: usize, v: f64, col: usize) -> Result<(), ExprError> {
        if Interpreter::owns_parameter(n) {
            return Err(ExprError::new(
                col,
                format!("#{n} belongs to the interpreter (offsets, reference points, tool, position) and is not set by assignment in volcomp"),
                "set offsets with G10 L2/L20, reference points with G28.1/G30.1, G92 with G92",
            ));
        }
        self.numbered[n] = v;
        Ok(())
    }

    /// Sets a named parameter (global when it starts with `_`).
    pub fn set_named(&mut self, name: &str, v: f64, col: usize) -> Result<(), ExprError> {
        if name.starts_with('_') {
            if matches!(
                name,
                "_value" | "_value_returned" | "_call_level" | "_remap_level"
            ) || is_interp_named(name)
            {
                return Err(ExprError::new(
                    col,
                    format!("#<{name}> is read-only"),
                    "choose another name",
                ));
            }
            self.globals.insert(name.to_string(), v);
        } else if let Some(f) = self.frames.last_mut() {
            f.locals.insert(name.to_string(), v);
        }
        Ok(())
    }

    /// The call depth (0 in the main program).
    pub fn call_level(&self) -> usize {
        self.frames.len() - 1
    }

    /// Enters a subroutine with `args` in #1–#30.
    pub fn push_call(&mut self, args: &[f64]) {
        let mut saved = [0.0; 30];
        saved.copy_from_slice(&self.numbered[1..=30]);
        for (i, p) in self.numbered[1..=30].iter_mut().enumerate() {
            *p = args.get(i).copied().unwrap_or(0.0);
        }
        self.frames.push(Frame {
            saved,
            locals: Map::default(),
        });
    }

    /// Leaves a subroutine, restoring the caller's #1–#30 and locals.
    pub fn pop_call(&mut self, value: Option<f64>) {
        if self.frames.len() > 1 {
            if let Some(f) = self.frames.pop() {
                self.numbered[1..=30].copy_from_slice(&f.saved);
            }
        }
        self.value = value.unwrap_or(0.0);
        self.value_returned = value.is_some();
    }
}

fn is_interp_named(name: &str) -> bool {
    Interpreter::new(Default::default(), Default::default())
        .named_parameter(name, 0)
        .is_ok()
        || matches!(
            name,
            "_spindle_on"
                | "_spindle_cw"
                | "_mist"
                | "_flood"
                | "_speed_override"
                | "_feed_override"
                | "_adaptive_feed"
                | "_feed_hold"
                | "_spindle_rpm_mode"
                | "_spindle_css_mode"
                | "_current_pocket"
                | "_selected_pocket"
                | "_control_mode"
        )
}

/// Parameters and the interpreter's state together, as expressions read them.
pub struct Scope<'a> {
    /// Stored parameters.
    pub params: &'a Params,
    /// The interpreter (predefined parameters).
    pub interp: &'a Interpreter,
    /// The current source line number (`#<_line>`).
    pub line: u64,
}

impl Lookup for Scope<'_> {
    fn numbered(&self, n: usize, col: usize) -> Result<f64, ExprError> {
        if (5420..=5428).contains(&n) && self.interp.cutter_comp_on() {
            // interp_read.cc, `read_parameter`: the programmed and the
            // tool's position differ while compensation is on.
            return Err(ExprError::new(
                col,
                format!("#{n} (current position) read with cutter radius compensation on; LinuxCNC refuses it (\"Cannot read current position with cutter radius compensation on\")"),
                "read the position before G41/G42 or after G40",
            ));
        }
        match self.interp.numbered_parameter(n) {
            Ok(v) => Ok(v),
            Err(Unanswerable::RunTime) => Err(ExprError::new(
                col,
                format!("#{n} holds a result of the machine at run time (probing, digital inputs, tool changer fault): volcomp cannot know it"),
                "give the value in the program, or compensate the program after it has been run",
            )),
            Err(Unanswerable::NotInSetup) => {
                let (message, help) = self.interp.not_in_setup(n);
                Err(ExprError::new(col, message, help))
            }
            Err(Unanswerable::NotPredefined) => Ok(self.params.numbered[n]),
        }
    }

    fn named(&self, name: &str, col: usize) -> Result<f64, ExprError> {
        match name {
            "_value" => return Ok(self.params.value),
            "_value_returned" => return Ok(f64::from(u8::from(self.params.value_returned))),
            "_call_level" => return Ok(self.params.call_level() as f64),
            "_remap_level" => return Ok(0.0),
            _ => {}
        }
        if name.starts_with('_') {
            if let Some(v) = self.params.globals.get(name) {
                return Ok(*v);
            }
            match self.interp.named_parameter(name, self.line) {
                Ok(v) => return Ok(v),
                Err(Unanswerable::RunTime) => {
                    return Err(ExprError::new(
                        col,
                        format!("#<{name}> is a state of the machine at run time (spindle, coolant, overrides) that volcomp does not follow"),
                        "give the value in the program instead",
                    ))
                }
                Err(Unanswerable::NotPredefined | Unanswerable::NotInSetup) => {}
            }
        } else if let Some(v) = self.params.frames.last().and_then(|f| f.locals.get(name)) {
            return Ok(*v);
        }
        Err(ExprError::new(
            col,
            format!("named parameter #<{name}> is not defined"),
            "set it before reading it (e.g. #<name> = 0 on an earlier line); a subroutine does not see its caller's local parameters",
        ))
    }

    fn exists(&self, name: &str) -> bool {
        self.named(name, 0).is_ok()
    }
}
