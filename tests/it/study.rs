//! The accuracy study (`simserpent study accuracy`) on a tiny case: one link dropped
//! at 5 m/s onto the floor for 50 ms, two settings against a 0.5 ms RK4 reference.

use simserpent::config::{Config, Integrator};
use simserpent::study::{self, Case, CaseKind, Setting, Status, StudyOptions};

fn tiny_impact() -> Case {
    let mut c = simserpent::experiments::collision_case_bodies(&Config::default(), 1);
    c.snake.head_position_m[2] = 0.02;
    c.general.duration_secs = 0.05;
    Case {
        name: "tiny-impact".into(),
        description: "one link at 5 m/s onto the floor, 50 ms".into(),
        config: c,
        kind: CaseKind::Impact { axis: 2, speed_m_per_s: 5.0 },
    }
}

#[test]
fn the_study_compares_settings_with_the_reference_and_writes_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let reference = Setting { integrator: Integrator::RK4, timestep_secs: 0.0005 };
    let rk4 = Setting { integrator: Integrator::RK4, timestep_secs: 0.001 };
    let euler = Setting { integrator: Integrator::Euler, timestep_secs: 0.001 };
    let options = StudyOptions { settings: vec![rk4, euler], reference, repeats: 1, out_dir: dir.path().join("study") };
    let result = study::run_study(vec![tiny_impact()], &options).unwrap();
    assert_eq!(result.rows.len(), 3);
    let reference_row = &result.rows[0];
    assert_eq!(reference_row.setting, reference);
    // The reference against itself: no error at all.
    assert_eq!(reference_row.status, Status::Ok);
    assert_eq!(reference_row.errors.worst().0, 0.0);
    for row in &result.rows {
        assert_eq!(row.status, Status::Ok, "{}", row.setting.label());
        assert!(row.steps_per_sec > 0.0 && row.realtime_factor > 0.0);
        // An impact compares the contact and the rebound, not a path.
        assert!(row.errors.com_path.is_none() && row.errors.joint_angles.is_none());
        assert!(row.errors.peak_force.is_some() && row.errors.rebound_speed.is_some());
    }
    // The link bounces back at less than it came in (the contact dissipates), but it does bounce.
    let t = study::trajectory(&result.cases[0], reference).unwrap();
    assert!(t.rebound_speed_m_per_s > 0.0 && t.rebound_speed_m_per_s < 5.0, "rebound {} m/s", t.rebound_speed_m_per_s);
    // Stopping 5 m/s takes a force well above the weight (0.3 kg · 9.81 m/s²).
    assert!(t.peak_force_n > 10.0 * 0.3 * 9.81, "peak {} N", t.peak_force_n);
    // The 10 ms peak is the impulse per 10 ms window: the momentum change m (v_in + v_out) falls in
    // at most two windows, so one of them carries at least half of it; and an average never
    // exceeds the instantaneous peak.
    let impulse_bound_n = 0.3 * (5.0 + t.rebound_speed_m_per_s) / (2.0 * study::FORCE_WINDOW_SECS);
    assert!(t.peak_window_force_n >= impulse_bound_n, "10 ms peak {} N < {impulse_bound_n} N", t.peak_window_force_n);
    assert!(
        t.peak_window_force_n <= t.peak_force_n,
        "10 ms peak {} N > peak {} N",
        t.peak_window_force_n,
        t.peak_force_n
    );
    for name in ["accuracy.md", "accuracy.csv", "work_precision_tiny-impact.png", "work_precision_tiny-impact.svg"] {
        assert!(dir.path().join("study").join(name).is_file(), "{name} missing");
    }
    let csv = std::fs::read_to_string(dir.path().join("study/accuracy.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
    assert!(result.report.contains("## Recommendation"));
}

#[test]
fn a_diverging_setting_is_reported_not_fatal() {
    // Euler at 10 ms cannot hold stiff servos of 1000 N·m/rad on 0.3 kg links of 0.2 m (ω·dt
    // far above 2): the run blows up. The study reports it and goes on.
    let mut case = tiny_impact();
    case.config.snake.n_links = 3;
    case.config.general.duration_secs = 0.5;
    let diverging = Setting { integrator: Integrator::Euler, timestep_secs: 0.01 };
    let status = study::trajectory(&case, diverging);
    match status {
        Err(Status::Diverged(what)) => assert!(!what.is_empty()),
        other => panic!("expected a divergence, got {other:?}"),
    }
}
