//! The report section of a program's machining time on the planner model
//! (`crate::plan`, docs/planner.md).

use super::{Block, Section, Table};
use crate::plan::{ProgramEstimate, TimeComparison};

fn s3(v: f64) -> String {
    format!("{v:.3}")
}

/// The rows of one program's estimate.
fn column(p: &ProgramEstimate) -> [String; 6] {
    let c = &p.motion.counts;
    [
        s3(p.motion.total_s),
        s3(p.motion.cutting_s),
        s3(p.motion.rapid_s),
        s3(p.dwell_s),
        c.segments.to_string(),
        format!(
            "{} / {} / {}",
            c.blend_arcs, c.parabolic_blends, c.tangent_joints
        ),
    ]
}

/// "Machining time": the program's (and its original's) time on the
/// planner model, with the limits it ran with.
pub fn machining_time_section(t: &TimeComparison) -> Section {
    let labels = [
        "whole program (first motion to the end of the last), s",
        "cutting (a G1/G2/G3 active), s",
        "rapids, s",
        "dwells (G4, not in the whole program), s",
        "planner segments",
        "joints: blend arcs / parabolic blends / tangent",
    ];
    let prog = column(&t.program);
    let mut table = match &t.original {
        Some(o) => {
            let orig = column(o);
            let change = |new: f64, old: f64| {
                if old > 0.0 {
                    format!("{:+.1} %", (new / old - 1.0) * 100.0)
                } else {
                    String::new()
                }
            };
            let changes = [
                change(t.program.motion.total_s, o.motion.total_s),
                change(t.program.motion.cutting_s, o.motion.cutting_s),
                change(t.program.motion.rapid_s, o.motion.rapid_s),
                String::new(),
                String::new(),
                String::new(),
            ];
            Table {
                headers: vec![
                    String::new(),
                    "original".into(),
                    "compensated".into(),
                    "change".into(),
                ],
                rows: (0..labels.len())
                    .map(|i| {
                        vec![
                            labels[i].to_string(),
                            orig[i].clone(),
                            prog[i].clone(),
                            changes[i].clone(),
                        ]
                    })
                    .collect(),
                numeric: vec![false, true, true, true],
            }
        }
        None => Table {
            headers: vec![String::new(), "program".into()],
            rows: (0..labels.len())
                .map(|i| vec![labels[i].to_string(), prog[i].clone()])
                .collect(),
            numeric: vec![false, true],
        },
    };
    table
        .rows
        .retain(|r| r[1] != "0.000" || (r.len() > 2 && r[2] != "0.000"));
    Section {
        id: "machining-time".into(),
        title: "Machining time".into(),
        blocks: vec![
            Block::Table(table),
            Block::Text(format!(
                "Estimated on a servo-period model of LinuxCNC 2.9's trajectory planner (its blend arcs, parabolic blends, tangent joints, look-ahead and path modes G61, G61.1, G64 P Q; docs/planner.md), which agrees with LinuxCNC's own planner within 5 ms on the programs it was checked on. Limits: {}.",
                t.limits_note()
            )),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::MachineSetup;

    #[test]
    fn the_section_shows_both_programs_and_the_change() {
        let slow = "G21 G90\nG1 X100 F3000\nM2\n";
        let fast = "G21 G90\nG1 X100 F6000\nM2\n";
        let t = crate::plan::compare_programs(
            (slow.as_bytes(), "c.ngc"),
            Some((Box::new(fast.as_bytes()), "o.ngc")),
            &MachineSetup::default(),
        )
        .unwrap();
        let s = machining_time_section(&t);
        let Block::Table(table) = &s.blocks[0] else {
            panic!("no table")
        };
        assert_eq!(table.rows[0][1], "1.200");
        assert_eq!(table.rows[0][2], "2.100");
        assert_eq!(table.rows[0][3], "+75.0 %");
        // No rapids, no dwells: those rows are left out.
        assert!(table.rows.iter().all(|r| !r[0].starts_with("rapids")));
    }
}
