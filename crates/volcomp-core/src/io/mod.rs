//! File formats: the readers and writers of every file volcomp takes or
//! writes live here (the G-code program itself is read by `volcomp-gcode`).

pub mod table;
