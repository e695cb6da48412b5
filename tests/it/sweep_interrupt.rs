//! A sweep after SIGINT/SIGTERM (here: `interrupt::request`, which the signal handler calls):
//! no new run starts, the summary marks the runs `incomplete`, and the next invocation does them.
//! In a child process of the test binary (`common::in_child_process`), because the stop request
//! is process-wide: every run of the other tests in this binary would see it.

use crate::common::in_child_process;
use crate::sweep::spec;
use simserpent::sweep::{self, SummaryTable};

#[test]
fn interrupted_sweep_marks_runs_incomplete_and_resumes() {
    in_child_process("sweep_interrupt::interrupted_sweep_marks_runs_incomplete_and_resumes", interrupted_sweep);
}

fn interrupted_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path(), &["snake.n_links=3,4,5"]);
    simserpent::interrupt::request();
    let report = sweep::run_sweep(&spec).unwrap();
    simserpent::interrupt::clear();
    assert_eq!(report.interrupted(), 3);
    assert_eq!(report.counts(), (0, 0, 0));
    let table = SummaryTable::read_csv(&dir.path().join("summary.csv")).unwrap();
    let status = table.header.iter().position(|h| h == "status").unwrap();
    assert!(table.rows.iter().all(|r| r[status] == "incomplete"), "{:?}", table.rows);
    let again = sweep::run_sweep(&spec).unwrap();
    assert_eq!(again.counts(), (3, 0, 0));
    assert_eq!(again.interrupted(), 0);
}
