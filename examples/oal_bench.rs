//! The obstacle-aided locomotion benchmark at a size of one's choosing, with a controller of
//! one's own plugged in beside the built-in contact laws (`simserpent experiment oal-bench` runs
//! the fixed quick and full sizes).
//!
//! ```text
//! cargo run --release --example oal_bench -- [--tune N] [--held N] [--first-seed S] [--duration S]
//!     [--threads N] [--out DIR] [--floors isotropic,anisotropic] [--families lattice,random,row]
//!     [--passive 10,5,2.5] [--law-gain-scales 0.5,1,2] [--no-matched] [--no-twins] [--no-laws]
//!     [--estimated-only] [--mine] [--law-servo-kp K] [--set KEY=VALUE]...
//! cargo run --release --example oal_bench -- cost     # per-step cost of each controller (µs)
//! cargo run --release --example oal_bench -- gait     # link–link contact of candidate base gaits
//! ```
//!
//! `--mine` adds [`PushAway`] (below): a force-feedback controller in ~30 lines, the template
//! for one's own. `--law-servo-kp K` runs the built-in contact laws on soft position servos of
//! kp K N·m/rad (kv K/100) instead of the stiff ones: with K a passive gain, each law's
//! feedback-off run is that passive baseline. The report goes to `<DIR>/oal-bench-<UTC time>/report.md`.

use simserpent::config::Config;
use simserpent::control::{Command, Controller, Observation, SineWave};
use simserpent::experiments::oal_bench::{self, Bench, Family, Floor, Plugged};
use std::sync::Arc;

/// The base wave plus, at every link the estimates say touches a peg, a bend of its two joints
/// away from the peg proportional to the contact force across the link (`GAIN_RAD_PER_N`).
struct PushAway {
    wave: SineWave,
    base_rad: Vec<f64>,
    base_velocity_rad_per_s: Vec<f64>,
}

const GAIN_RAD_PER_N: f64 = 0.01;

impl Controller for PushAway {
    fn update(&mut self, obs: &Observation, cmd: &mut Command) {
        use simserpent::control::JointTrajectory;
        self.wave.targets(obs.time_secs, &mut self.base_rad, &mut self.base_velocity_rad_per_s);
        cmd.position_rad.copy_from_slice(&self.base_rad);
        let c = &obs.contacts;
        if !c.active {
            return;
        }
        // The link's heading from the head's yaw and the encoders (a yaw-only snake).
        let mut heading = simserpent::state::yaw_rad(obs.head_quat);
        for i in 0..c.contact.len() {
            if i > 0 {
                heading += obs.joint_angle_rad[i - 1];
            }
            if !c.contact[i] {
                continue;
            }
            let f = c.obstacle_force_n[i];
            let across = -f[0] * heading.sin() + f[1] * heading.cos();
            for j in [i.wrapping_sub(1), i] {
                if let Some(q) = cmd.position_rad.get_mut(j) {
                    *q -= GAIN_RAD_PER_N * across;
                }
            }
        }
    }
}

fn push_away(config: &Config, n_joints: usize) -> Box<dyn Controller> {
    Box::new(PushAway {
        wave: SineWave::from_config(config),
        base_rad: vec![0.0; n_joints],
        base_velocity_rad_per_s: vec![0.0; n_joints],
    })
}

fn list<T>(value: &str, parse: impl Fn(&str) -> Option<T>) -> Result<Vec<T>, String> {
    value.split(',').map(|s| parse(s.trim()).ok_or_else(|| format!("cannot read `{s}` in `{value}`"))).collect()
}

/// The per-step cost (µs of the thread's CPU time) of each controller's update on a synthetic
/// observation with two contacts, `n_links` links (median of 5 rounds of 20 000 updates).
fn cost(n_links: usize) -> Vec<(String, f64)> {
    use simserpent::config::{ControllerKind, GaitKind};
    let mut out = Vec::new();
    let kinds = [
        ("gait (open loop)", ControllerKind::Gait),
        ("follow_the_leader_reflex", ControllerKind::FollowTheLeaderReflex),
        ("directional_admittance", ControllerKind::DirectionalAdmittance),
        ("jam_resolution", ControllerKind::JamResolution),
        ("push_away (this example)", ControllerKind::Gait),
    ];
    for (name, kind) in kinds {
        let mut c = Config::default();
        c.snake.n_links = n_links;
        c.control.controller = kind;
        c.gait.kind = GaitKind::SineWave;
        c.gait.sine_wave.amplitude_deg = oal_bench::BASE_AMPLITUDE_DEG;
        c.gait.sine_wave.phase_lag_deg = oal_bench::BASE_PHASE_LAG_DEG;
        c.estimation.enabled = true;
        let nj = n_links - 1;
        let mut ctl = if kind == ControllerKind::Gait && name == "push_away (this example)" {
            push_away(&c, nj)
        } else {
            simserpent::control::controller_from_config(&c, nj)
        };
        let mut obs = Observation::new(n_links, nj);
        obs.head_quat = [1.0, 0.0, 0.0, 0.0];
        obs.contacts = simserpent::estimation::ContactEstimates::new(n_links);
        obs.contacts.active = true;
        for (i, f) in [(2usize, [1.0, -4.0, 0.0]), (n_links / 2, [-1.5, 3.0, 0.0])] {
            obs.contacts.contact[i] = true;
            obs.contacts.obstacle_force_n[i] = f;
        }
        let mut cmd = Command::new(nj);
        let dt = c.general.timestep_secs;
        let mut rounds = Vec::new();
        let mut k = 0u64;
        for _ in 0..5 {
            let start = simserpent::cpu_time::thread_cpu_ns();
            for _ in 0..20_000 {
                obs.time_secs = k as f64 * dt;
                k += 1;
                ctl.update(&obs, &mut cmd);
            }
            rounds.push(simserpent::cpu_time::thread_cpu_ns().saturating_sub(start) as f64 / 20_000.0 * 1e-3);
        }
        rounds.sort_by(f64::total_cmp);
        std::hint::black_box(&cmd);
        out.push((name.to_string(), rounds[2]));
    }
    out
}

/// Link–link contact, reached amplitude and speed of candidate base gaits on the bare floors
/// (`gait [--kp K] [--duration S] [--amplitudes A,B,..] [--lags D,E,..]`): one row per floor,
/// amplitude and phase lag, on position servos of kp K (default: the default config's).
fn gait_table(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let defaults = Config::default();
    let (mut kp, mut duration) = (defaults.control.position_kp_nm_per_rad, 20.0);
    let (mut amplitudes, mut lags) = (vec![30.0, 45.0, 60.0, 80.0], vec![30.0, 45.0, 60.0]);
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let numbers = |v: &str| list(v, |s| s.parse::<f64>().ok().filter(|x| x.is_finite()));
        match args[i].as_str() {
            "--kp" => kp = numbers(&value)?[0],
            "--duration" => duration = numbers(&value)?[0],
            "--amplitudes" => amplitudes = numbers(&value)?,
            "--lags" => lags = numbers(&value)?,
            other => return Err(format!("gait: unknown argument `{other}`").into()),
        }
        i += 2;
    }
    println!(
        "| floor | amplitude ° | phase lag ° | kp N·m/rad | steps with link–link contact % | largest link–link force N | amplitude reached ° | speed BL/cycle |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for floor in [Floor::Anisotropic, Floor::Isotropic] {
        for &lag in &lags {
            for &amplitude in &amplitudes {
                let mut c = oal_bench::field_config(&defaults, floor, oal_bench::Layout::Bare, 0);
                c.gait.sine_wave.amplitude_deg = amplitude;
                c.gait.sine_wave.phase_lag_deg = lag;
                c.control.position_kp_nm_per_rad = kp;
                c.control.position_kv_nm_s_per_rad = kp / 100.0;
                c.estimation.enabled = false;
                let g = oal_bench::bare_gait(&c, duration)?;
                println!(
                    "| {} | {amplitude} | {lag} | {kp} | {:.1} | {:.1} | {:.0} | {:.3} |",
                    floor.name(),
                    100.0 * g.self_contact_share,
                    g.max_self_contact_n,
                    g.amplitude_reached_deg,
                    g.speed_bl_per_cycle
                );
            }
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("cost") {
        println!("| controller | µs per step, 10 links | µs per step, 30 links |\n|---|---|---|");
        let (ten, thirty) = (cost(10), cost(30));
        for ((name, a), (_, b)) in ten.iter().zip(&thirty) {
            println!("| {name} | {a:.3} | {b:.3} |");
        }
        return Ok(());
    }
    if args.first().map(String::as_str) == Some("gait") {
        return gait_table(&args[1..]);
    }
    let mut bench = Bench { tuning_fields: 5, held_out_fields: 30, duration_secs: 15.0, ..Bench::full() };
    let (mut threads, mut out) = (0usize, "runs".to_string());
    let mut overrides: Vec<String> = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let number = |v: &str| v.parse::<f64>().map_err(|_| format!("{}: not a number: `{v}`", args[i]));
        let count = |v: &str| v.parse::<u64>().map_err(|_| format!("{}: not a whole number: `{v}`", args[i]));
        match args[i].as_str() {
            "--tune" => bench.tuning_fields = count(&value)?,
            "--held" => bench.held_out_fields = count(&value)?,
            "--first-seed" => bench.first_held_out_seed = count(&value)?,
            "--law-gain-scales" => bench.law_gain_scales = list(&value, |s| s.parse().ok())?,
            "--duration" => bench.duration_secs = number(&value)?,
            "--threads" => threads = usize::try_from(count(&value)?).unwrap_or(usize::MAX),
            "--out" => out = value,
            "--floors" => bench.floors = list(&value, Floor::from_name)?,
            "--families" => bench.families = list(&value, Family::from_name)?,
            "--passive" => bench.passive_kp_nm_per_rad = list(&value, |s| s.parse().ok())?,
            "--law-servo-kp" => match number(&value)? {
                kp if kp > 0.0 && kp.is_finite() => bench.law_servo_kp_nm_per_rad = Some(kp),
                kp => return Err(format!("--law-servo-kp {kp}: must be a positive gain (N·m/rad)").into()),
            },
            "--set" => overrides.push(value),
            "--estimated-only" => {
                bench.true_contacts = false;
                i += 1;
                continue;
            }
            "--no-twins" | "--no-matched" => {
                if args[i] == "--no-twins" {
                    bench.twins = false;
                } else {
                    bench.speed_matched = false;
                }
                i += 1;
                continue;
            }
            "--no-laws" => {
                bench.laws = false;
                i += 1;
                continue;
            }
            "--mine" => {
                bench.plugged.push(Plugged { name: "push_away".into(), make: Arc::new(push_away), estimation: true });
                i += 1;
                continue;
            }
            other => return Err(format!("unknown argument `{other}` (see the example's documentation)").into()),
        }
        i += 2;
    }
    let base = simserpent::config::load_config_str("", simserpent::config::ConfigSource::Toml, &overrides)?;
    if let Some(message) = simserpent::threads_beyond_cap("--threads", threads) {
        return Err(message.into());
    }
    bench.check()?;
    simserpent::interrupt::install_handler()?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let start = std::time::Instant::now();
    let intro = format!("`cargo run --release --example oal_bench -- {}`", args.join(" "));
    let (folder, report) = oal_bench::run_into(&bench, &base, &pool, std::path::Path::new(&out), &intro, true)?;
    println!("{}", report.to_markdown());
    eprintln!("{}: {:.1} s on {} threads", folder.display(), start.elapsed().as_secs_f64(), pool.current_num_threads());
    Ok(())
}
