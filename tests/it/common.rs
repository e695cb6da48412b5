//! Helpers shared by the test modules: one implementation each.

use std::process::{Command, Output};

/// Standard output and standard error of a finished process, as one text.
pub fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// Runs `body` in a child process of this test binary that runs only the test `test_name` (its
/// full name, module included: `"robustness::accepted_configs_compile_and_step"`), with a
/// temporary folder as working directory; the calling test passes when the child's test passes.
///
/// For tests that change process-wide state other tests must not see (the interrupt flag), and
/// for in-process runs: MuJoCo warnings (no log hook is installed in tests) go to `MUJOCO_LOG.TXT`
/// in the working directory, and runs go to `runs/` there, not into the repository.
pub fn in_child_process(test_name: &str, body: impl FnOnce()) {
    const CHILD: &str = "SIMSERPENT_TEST_CHILD";
    if std::env::var(CHILD).is_ok_and(|name| name == test_name) {
        body();
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", test_name, "--nocapture", "--test-threads=1"])
        .env(CHILD, test_name)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success() && text(&out).contains("1 passed"), "{}", text(&out));
}
