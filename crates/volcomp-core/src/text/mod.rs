//! Text every file format shares, below the models that read and write
//! it: the one located CSV reader every table file goes through
//! ([`table`]) and how computed numbers are written ([`numfmt`]). `io`
//! re-exports both.

pub mod located;
pub mod numfmt;
pub mod table;
