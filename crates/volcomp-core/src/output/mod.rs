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
//! 4. [`check_standard_streams`]: a process started with standard output
//!    closed is refused rather than losing its output.

mod file;
mod plan;
mod signals;

pub use file::{commit_all, OutputError, OutputFile};
pub use plan::{canonical_absent, referenced_files, OutputPlan, PlanError, Role};
pub use signals::install_cleanup;

/// Whether the standard streams (descriptors 0, 1, 2) are open.
///
/// A closed descriptor is dangerous beyond lost output: the next file the
/// process opens takes its number, so text meant for standard output would
/// land in that file. Closed standard input and error are re-opened on
/// `/dev/null` (reading `-` then sees an empty program; messages are lost,
/// the exit status still tells). A closed standard output is an error the
/// caller should report: output written there would be lost with exit 0.
pub fn check_standard_streams() -> Result<(), &'static str> {
    #[cfg(target_os = "linux")]
    {
        use rustix::fd::BorrowedFd;
        let closed = |fd: i32| {
            // SAFETY: only queried, never closed or kept.
            let b = unsafe { BorrowedFd::borrow_raw(fd) };
            rustix::io::fcntl_getfd(b).is_err()
        };
        // In order: each re-opened descriptor takes the lowest free number,
        // which is its own when the lower ones are open.
        let stdout_closed = closed(1);
        for fd in 0..3 {
            if closed(fd) {
                let f = std::fs::OpenOptions::new()
                    .read(fd == 0)
                    .write(fd != 0)
                    .open("/dev/null");
                if let Ok(f) = f {
                    // Keep it open for good: it now holds descriptor `fd`.
                    std::mem::forget(f);
                }
            }
        }
        if stdout_closed {
            return Err("standard output is closed (`>&-`): volcomp writes results there; redirect it to a file or to /dev/null");
        }
    }
    Ok(())
}
