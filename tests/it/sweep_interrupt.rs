//! A sweep after SIGINT/SIGTERM (here: `interrupt::request`, which the signal handler calls):
//! no new run starts, the summary marks the runs `incomplete`, and the next invocation does them.
//! In a child process of the test binary (`common::in_child_process`), because the stop request
//! is process-wide: every run of the other tests in this binary would see it.

use crate::common::in_child_process;
use simserpent::sweep::{self, SampleMode, SummaryTable, SweepSpec, Variation};

#[test]
fn interrupted_sweep_marks_runs_incomplete_and_resumes() {
    in_child_process("sweep_interrupt::interrupted_sweep_marks_runs_incomplete_and_resumes", interrupted_sweep);
}

fn interrupted_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let spec = SweepSpec {
        config_path: None,
        overrides: ["general.duration_secs=0.2", "recording.every_n_steps=20", "terrain.kind=none"]
            .map(String::from)
            .to_vec(),
        variations: vec![Variation::parse("snake.n_links=3,4,5").unwrap()],
        mode: SampleMode::Grid,
        samples: 0,
        seed: 1,
        sweep_dir: Some(dir.path().to_path_buf()),
        threads: 2,
        shard: None,
        progress: false,
    };
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
