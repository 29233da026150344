//! What lies between the bytes of a program and the literal lines the
//! lexer and the interpreter read: LinuxCNC's parameters, expressions and
//! o-word control flow (RS274/NGC as LinuxCNC 2.9 extends it).
//!
//! | file | concern |
//! | --- | --- |
//! | `norm.rs` | a line as LinuxCNC's reader sees it (lower case, no blanks), with original columns |
//! | `expr.rs` | expressions: parsing, LinuxCNC's precedence and functions, evaluation |
//! | `line.rs` | a non-literal line: words with expressions, parameter settings, o-word statements; rendering to a literal line |
//! | `params.rs` | numbered and named parameters, call scopes, the interpreter's predefined ones |
//! | `source.rs` | the lines kept for control flow |
//! | `flow.rs` | o-word control flow, subroutines and their files, M98/M99, limits |
//!
//! A line with parameters or expressions is evaluated with the values from
//! before the line (settings on a line take effect after it) and rendered
//! as a literal line; that is what the interpreter and `compensate` see, so
//! a compensated program is the executed path, flat (docs/gcode.md).

pub mod expr;
pub mod flow;
pub mod line;
pub mod norm;
pub mod params;
pub mod source;

/// A hash map with a fast seeded hasher (foldhash): parameter names,
/// control labels and cached statements are looked up on every executed
/// line of a loop, where std's SipHash cost a tenth of the time; the
/// random seed keeps crafted names from colliding by design.
pub(crate) type Map<K, V> = std::collections::HashMap<K, V, foldhash::fast::RandomState>;

#[cfg(test)]
mod tests;
