//! The contact laws of `control` (follow-the-leader reflex, directional admittance, jam
//! resolution) in the step loop, and the obstacle-aided locomotion benchmark.

use simserpent::config::{Config, ContactSource, ControllerKind};
use simserpent::experiments::oal_bench::{self, Bench, Family, Floor, Layout};
use simserpent::sim::{LoopPlan, Observer, SimError, Simulation, StepView, World};
use simserpent::state::Snapshot;

/// The centre of mass every 50 steps.
#[derive(Default)]
struct Path(Vec<[f64; 3]>);

impl Observer<SimError> for Path {
    fn on_record(&mut self, _: &StepView<'_>, snap: &Snapshot) -> Result<(), SimError> {
        self.0.push(snap.centre_of_mass_m());
        Ok(())
    }
}

fn run(config: &Config, secs: f64) -> Vec<[f64; 3]> {
    config.validate().unwrap();
    let world = World::from_config(config).unwrap();
    let mut sim = Simulation::new(config, world);
    let mut path = Path::default();
    let steps = (secs / config.general.timestep_secs).round() as u64;
    sim.run(LoopPlan { steps, record_every_n_steps: 50 }, &mut [&mut path]).unwrap();
    path.0
}

/// A medium random field of the benchmark on the isotropic floor, base gait, open loop.
fn field() -> Config {
    oal_bench::field_config(&Config::default(), Floor::Isotropic, Layout::Random(3.0), 1000)
}

fn with_law(kind: ControllerKind, source: ContactSource, feedback: bool) -> Config {
    let mut c = field();
    c.control.controller = kind;
    c.estimation.enabled = true;
    c.follow_the_leader_reflex.contacts = source;
    c.follow_the_leader_reflex.feedback = feedback;
    c.directional_admittance.contacts = source;
    c.directional_admittance.feedback = feedback;
    c.jam_resolution.contacts = source;
    c.jam_resolution.feedback = feedback;
    c
}

const LAWS: [ControllerKind; 3] =
    [ControllerKind::FollowTheLeaderReflex, ControllerKind::DirectionalAdmittance, ControllerKind::JamResolution];

/// With `feedback = false` each law sends the open-loop gait's set-points, so the run is the
/// open-loop run bit for bit (sensing and estimation do not touch the physics): the benchmark's
/// "feedback off" condition is the open loop.
#[test]
fn each_law_without_feedback_is_the_open_loop_run_bit_for_bit() {
    let secs = 3.0;
    let open = run(&field(), secs);
    for kind in LAWS {
        let off = run(&with_law(kind, ContactSource::Estimated, false), secs);
        assert_eq!(off, open, "{kind:?}");
    }
}

/// With feedback each law, fed the estimates or the true contacts, runs on a peg field and
/// changes the run (the pegs are felt), and the run is repeatable. (The jam resolution acts
/// only on a jam: a jam rule asking for 1 m of progress every 2 s makes it act here.)
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn each_law_feels_the_pegs_with_estimated_and_true_contacts() {
    let secs = 8.0;
    let open = run(&field(), secs);
    for kind in LAWS {
        for source in [ContactSource::Estimated, ContactSource::True] {
            let mut config = with_law(kind, source, true);
            config.jam_resolution.jam_min_progress_m = 1.0;
            let path = run(&config, secs);
            assert!(path.iter().flatten().all(|x| x.is_finite()), "{kind:?} {source:?}");
            assert_ne!(path, open, "{kind:?} {source:?}: the law changed nothing");
            assert_eq!(run(&config, secs), path, "{kind:?} {source:?}: not repeatable");
        }
    }
}

/// A small benchmark: every condition runs (the tuning sweep, the held-out fields and their
/// bare-floor twins), the tables are written, two runs of the same benchmark give the same
/// tables, and two shards merged give the unsharded tables byte for byte.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_small_benchmark_writes_its_tables_repeats_and_shards() {
    let bench = Bench {
        tuning_fields: 1,
        held_out_fields: 2,
        duration_secs: 3.0,
        floors: vec![Floor::Anisotropic],
        families: vec![Family::Random],
        passive_kp_nm_per_rad: vec![5.0, 2.5],
        law_gain_scales: vec![1.0, 2.0],
        true_contacts: false,
        path_fields: 1,
        ..Bench::full()
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let tables = ["oal_runs.csv", "oal_summary.csv", "oal_paired.csv", "oal_heading.csv", "oal_bare.csv"];
    let read = |dir: &std::path::Path| -> Vec<String> {
        tables.iter().map(|t| std::fs::read_to_string(dir.join(t)).unwrap()).collect()
    };
    let mut runs = Vec::new();
    for _ in 0..2 {
        let dir = tempfile::tempdir().unwrap();
        let outcome = oal_bench::run_bench(&bench, &Config::default(), &pool, dir.path(), false).unwrap();
        let t = read(dir.path());
        // Tuning: 2 passive gains and 3 laws × 2 scales on one field; held out: open loop, the
        // chosen passive gain, its matched open loop and 3 laws, on 2 fields and their twins.
        assert_eq!(outcome.runs_planned, 8 + 2 * 2 * 6, "{}", t[0]);
        assert_eq!(t[0].lines().count(), 1 + outcome.runs_planned);
        assert!(t[0].lines().any(|l| l.contains(",twin,")), "{}", t[0]);
        assert!(dir.path().join("plots/oal_success_anisotropic_random.png").exists());
        runs.push(t);
    }
    assert_eq!(runs[0], runs[1]);
    let dir = tempfile::tempdir().unwrap();
    for i in 0..2 {
        let shard = Bench { shard: Some((i, 2)), ..bench.clone() };
        oal_bench::run_bench(&shard, &Config::default(), &pool, dir.path(), false).unwrap();
        assert!(dir.path().join(format!("oal_runs-shard-{i}-of-2.csv")).exists());
    }
    oal_bench::merge_shards(&bench, &Config::default(), &pool, dir.path()).unwrap();
    assert_eq!(read(dir.path()), runs[0], "shards merged differ from the unsharded run");
    // A missing shard is named.
    std::fs::remove_file(dir.path().join("oal_runs-shard-1-of-2.csv")).unwrap();
    let err = oal_bench::merge_shards(&bench, &Config::default(), &pool, dir.path()).unwrap_err();
    assert!(err.to_string().contains("0/2"), "{err}");
}

/// `law_servo_kp_nm_per_rad` puts the contact laws on the passive baseline's soft servos: with
/// their feedback off each law's run is then the passive run, row for row.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn laws_on_soft_servos_without_feedback_are_the_passive_runs() {
    let kp = 5.0;
    let bench = Bench {
        tuning_fields: 0,
        held_out_fields: 1,
        duration_secs: 2.0,
        floors: vec![Floor::Anisotropic],
        families: vec![Family::Random],
        passive_kp_nm_per_rad: vec![kp],
        law_gain_scales: vec![1.0],
        true_contacts: false,
        twins: false,
        path_fields: 0,
        law_servo_kp_nm_per_rad: Some(kp),
        ..Bench::full()
    };
    let mut base = Config::default();
    base.follow_the_leader_reflex.feedback = false;
    base.directional_admittance.feedback = false;
    base.jam_resolution.feedback = false;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let dir = tempfile::tempdir().unwrap();
    oal_bench::run_bench(&bench, &base, &pool, dir.path(), false).unwrap();
    let runs = std::fs::read_to_string(dir.path().join("oal_runs.csv")).unwrap();
    // The scores (success … exit heading) of a condition's held-out row.
    let scores = |condition: &str| -> String {
        let row = runs.lines().find(|l| l.split(',').nth(5) == Some(condition)).unwrap();
        row.split(',').skip(6).take(8).collect::<Vec<_>>().join(",")
    };
    let passive = scores(&format!("passive_kp{kp}"));
    assert_ne!(passive, scores("open_loop"), "the soft servos changed nothing");
    for law in ["follow_the_leader_reflex_est", "directional_admittance_est", "jam_resolution_est"] {
        assert_eq!(scores(law), passive, "{law}");
    }
}

/// The benchmark's base gait on the default servos never brings two links into contact on
/// either bare floor, over the whole run from t = 0: every contact force of a benchmark run is a
/// peg's or a wall's (a wider wave, 80°, does touch itself: the measurement can fail).
#[test]
fn the_base_gait_clears_itself_on_both_bare_floors() {
    let defaults = Config::default();
    for floor in [Floor::Anisotropic, Floor::Isotropic] {
        let mut c = oal_bench::field_config(&defaults, floor, Layout::Bare, 0);
        assert_eq!(c.control.position_kp_nm_per_rad, defaults.control.position_kp_nm_per_rad);
        assert_eq!(c.control.position_kv_nm_s_per_rad, defaults.control.position_kv_nm_s_per_rad);
        c.estimation.enabled = false;
        let g = oal_bench::bare_gait(&c, 15.0).unwrap();
        assert_eq!(g.self_contact_share, 0.0, "{floor:?}: {g:?}");
        assert_eq!(g.max_self_contact_n, 0.0, "{floor:?}: {g:?}");
        assert!((g.amplitude_reached_deg - oal_bench::BASE_AMPLITUDE_DEG).abs() < 5.0, "{floor:?}: {g:?}");
    }
    let mut wide = oal_bench::field_config(&defaults, Floor::Anisotropic, Layout::Bare, 0);
    wide.gait.sine_wave.amplitude_deg = 80.0;
    wide.gait.sine_wave.phase_lag_deg = 30.0;
    wide.estimation.enabled = false;
    let g = oal_bench::bare_gait(&wide, 15.0).unwrap();
    assert!(g.self_contact_share > 0.1, "{g:?}");
}

/// On the bare floor there is nothing to feel: each contact law fed the step loop's estimates
/// should go as fast as its open loop, within 1 % of the open loop's speed (anisotropic floor; on
/// the isotropic floor, where the open loop does not move forward, within 1 % of the anisotropic
/// speed). With the base gait clear of itself (the test above) what is left are the estimator's
/// false obstacle forces on the bare floor; the failure message lists every law and floor.
#[test]
#[ignore = "fails: the estimator's false obstacle forces on the bare floor move the reflex (0.576 against the open loop's 0.604 BL/cycle on the anisotropic floor)"]
fn each_law_with_estimated_contacts_equals_its_open_loop_on_the_bare_floor() {
    let defaults = Config::default();
    let mut scale = None;
    let mut misses = Vec::new();
    for floor in [Floor::Anisotropic, Floor::Isotropic] {
        let mut open = oal_bench::field_config(&defaults, floor, Layout::Bare, 1000);
        open.estimation.enabled = false;
        let v_open = oal_bench::bare_gait(&open, 15.0).unwrap().speed_bl_per_cycle;
        let reference = *scale.get_or_insert(v_open.abs());
        for kind in LAWS {
            let mut c = open.clone();
            c.control.controller = kind;
            c.estimation.enabled = true;
            c.follow_the_leader_reflex.contacts = ContactSource::Estimated;
            c.directional_admittance.contacts = ContactSource::Estimated;
            c.jam_resolution.contacts = ContactSource::Estimated;
            let g = oal_bench::bare_gait(&c, 15.0).unwrap();
            if (g.speed_bl_per_cycle - v_open).abs() > 0.01 * reference {
                misses.push(format!(
                    "{floor:?} {kind:?}: {} BL/cycle against the open loop's {v_open} ({} % of link-steps flagged)",
                    g.speed_bl_per_cycle,
                    100.0 * g.estimate_flag_share
                ));
            }
        }
    }
    assert!(misses.is_empty(), "{}", misses.join("; "));
}
