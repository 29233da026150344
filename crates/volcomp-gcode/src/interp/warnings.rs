//! Warnings: what the program left unsaid and the interpreter assumed.

/// Something the program left unsaid and volcomp assumed, said once per
/// program so the user can check it (the program is still processed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Warning {
    /// 1-based line where the assumption was first needed.
    pub line: u64,
    /// 1-based column.
    pub column: usize,
    /// What was assumed and what to do if it is wrong.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}: warning: {}",
            self.line, self.column, self.message
        )
    }
}
