//! Safe output for every command: a plan checked before any work, and
//! files that are written completely or not at all.
//!
//! 1. [`OutputPlan`]: every output of a command is compared with every
//!    input and every other output before anything is read or written.
//! 2. [`OutputFile`]: a regular destination is replaced atomically (a
//!    temporary renamed over it); special files are written through; `-` is
//!    standard output. [`commit_all`] puts several outputs in place only
//!    when all of them are complete, and says which were written if a
//!    rename fails half-way.
//! 3. [`install_cleanup`]: named temporaries are removed on SIGINT, SIGTERM
//!    and SIGHUP (on Linux temporaries are unnamed, so even SIGKILL leaves
//!    nothing).
//! 4. [`Staged`]: several outputs written and put in place together;
//!    [`Ledger`]: what a run declared and wrote, for its error message.

mod file;
mod plan;
mod signals;
mod staged;

pub use file::{commit_all, OutputError, OutputFile};
pub use plan::{canonical_absent, referenced_files, OutputPlan, PlanError, Role};
pub use signals::install_cleanup;
pub use staged::{Ledger, StageError, Staged};
