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

/// A small benchmark: every condition runs, the tables are written, and two runs of the same
/// benchmark give the same tables.
#[test]
#[cfg_attr(not(feature = "slow-tests"), ignore = "slow: runs with `cargo test --features slow-tests`")]
fn a_small_benchmark_writes_its_tables_and_repeats() {
    let bench = Bench {
        tuning_fields: 1,
        held_out_fields: 1,
        duration_secs: 2.0,
        floors: vec![Floor::Isotropic],
        families: vec![Family::Random],
        passive_kp_nm_per_rad: vec![5.0],
        path_fields: 1,
        ..Bench::full()
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let mut tables = Vec::new();
    for _ in 0..2 {
        let dir = tempfile::tempdir().unwrap();
        let outcome = oal_bench::run_bench(&bench, &Config::default(), &pool, dir.path(), false).unwrap();
        assert_eq!(outcome.runs_planned, 2 * bench.conditions().len());
        let runs = std::fs::read_to_string(dir.path().join("oal_runs.csv")).unwrap();
        assert_eq!(runs.lines().count(), 1 + outcome.runs_planned);
        for name in ["oal_summary.csv", "oal_paired.csv", "plots/oal_success_isotropic_random.png"] {
            assert!(dir.path().join(name).exists(), "{name}");
        }
        tables.push(runs);
    }
    assert_eq!(tables[0], tables[1]);
}

/// `law_servo_kp_nm_per_rad` puts the contact laws on the passive baseline's soft servos: with
/// their feedback off each law's run is then the passive run, row for row. The report gives the
/// bare-floor speed of the gait on the passive servos beside the base gait's.
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
        true_contacts: false,
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
    let outcome = oal_bench::run_bench(&bench, &base, &pool, dir.path(), false).unwrap();
    let text = &outcome.section.text;
    assert!(text.contains("anisotropic: ") && text.contains(&format!("BL/cycle (passive_kp{kp} ")), "{text}");
    let runs = std::fs::read_to_string(dir.path().join("oal_runs.csv")).unwrap();
    // The scores (success, end, jams, speed, exit heading) of a condition's row.
    let scores = |condition: &str| -> String {
        let row = runs.lines().find(|l| l.split(',').nth(5) == Some(condition)).unwrap();
        row.split(',').skip(6).take(5).collect::<Vec<_>>().join(",")
    };
    let passive = scores(&format!("passive_kp{kp}"));
    assert_ne!(passive, scores("open_loop"), "the soft servos changed nothing");
    for law in ["follow_the_leader_reflex_est", "directional_admittance_est", "jam_resolution_est"] {
        assert_eq!(scores(law), passive, "{law}");
    }
}
