//! `simserpent estimate RUN_FOLDER`: runs the contact estimator on a recorded run.
//!
//! Reads the run's `config.toml` (its `[estimation]` and `[ground]` settings, the snake's
//! geometry), `sensors.csv` (the measured sensor columns: accelerometers, gyros, encoders, joint
//! force/torque sensors) and `links.csv` (the head's pose at the first row and its velocity —
//! what a tracking system gives —, every link's pose with `orientation = "true"`, and the ground
//! truth: obstacle and floor forces, obstacle contact points), feeds every recorded row to
//! [`MotionEstimator`] as the step loop would, and writes into `RUN_FOLDER/estimation/`:
//!
//! - `estimates.csv`: per row and link the estimates next to the truth of the instant their
//!   sensor values describe (`truth_time_s`: the previous row when every step is recorded — the
//!   sensors are those of the last complete model evaluation, one step old);
//! - `scores.md` and `scores.csv`: detection, false alarms, obstacle-force RMSE and contact-point
//!   errors per link and overall ([`MotionScore`]);
//! - `plots/estimate_link_ii.png/.svg`: estimated against true obstacle force per link.
//!
//! The rows must be consecutive steps (`recording.every_n_steps = 1`) for the head's attitude
//! filter to integrate its gyro as the step loop does; a run recorded more sparsely is refused
//! with that fix ([`EstimateError::SparseRows`]).

use crate::config::{Config, ConfigError, OrientationSource};
use crate::control::Observation;
use crate::estimation::{ContactEstimates, LinkPoses, LinkSample, MotionEstimator, MotionScore};
use crate::experiments::{ExperimentError, Table};
use crate::model::names;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Errors of `simserpent estimate`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EstimateError {
    /// The folder has no such file.
    #[error("{} is missing: {what}", path.display())]
    Missing { path: PathBuf, what: String },
    /// The run's config cannot be used.
    #[error("{}: {source}", path.display())]
    Config {
        path: PathBuf,
        #[source]
        source: ConfigError,
    },
    /// A table lacks a column or its rows do not match.
    #[error("{}: {problem}", path.display())]
    Table { path: PathBuf, problem: String },
    /// A file cannot be read or written.
    #[error("cannot {what} {}", path.display())]
    Io {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A plot failed.
    #[error("plot {}: {message}", path.display())]
    Plot { path: PathBuf, message: String },
    /// A file that is not one SimSerpent reads or writes ([`crate::files`]: a link out of the run
    /// folder, a FIFO or device, too large, a link where the estimates go).
    #[error(transparent)]
    File(#[from] crate::files::FileError),
    /// The run recorded only every k-th step: the estimator's filters need consecutive steps.
    #[error(
        "{}: recording.every_n_steps = {every_n_steps}: the tables hold one row per {every_n_steps} steps, and the \
         estimator needs every step (its head-attitude filter integrates the gyro and differentiates the head's \
         velocity from one row to the next); on sparser rows its estimates degrade (the peg-field \
         tutorial's 10-s run scored on every 10th row: a force error of 63 % of the force's RMS and 93 % of the \
         contact points within 1 cm, against 1.1 % and 98 % on every row). Record every step: \
         `simserpent run CONFIG --set recording.every_n_steps=1`, or estimate during the run with \
         `--set estimation.enabled=true` (estimates.csv)",
        path.display()
    )]
    SparseRows { path: PathBuf, every_n_steps: u64 },
    /// SIGINT/SIGTERM stopped the estimation (exit code 130); what was written is incomplete.
    #[error("interrupted by a signal (SIGINT or SIGTERM) at row {row}; nothing was written")]
    Interrupted { row: usize },
}

/// What the tool produced.
#[derive(Debug, Clone)]
pub struct EstimateOutcome {
    /// `RUN_FOLDER/estimation`.
    pub folder: PathBuf,
    /// Rows estimated.
    pub rows: usize,
    /// All links together, and per link.
    pub total: MotionScore,
    pub per_link: Vec<MotionScore>,
}

fn table(path: &Path) -> Result<Table, EstimateError> {
    Table::read(path).map_err(|e| match e {
        ExperimentError::File(crate::files::FileError::Missing { .. }) => EstimateError::Missing {
            path: path.to_path_buf(),
            what:
                "the run must be recorded as CSV (recording.format = \"csv\" or \"both\") with recording.imu_sensors \
                   (sensors.csv) and the link columns (links.csv)"
                    .into(),
        },
        ExperimentError::File(e) => EstimateError::File(e),
        ExperimentError::Io { path, source, .. } => EstimateError::Io { what: "read", path, source },
        ExperimentError::Data(problem) => EstimateError::Table { path: path.to_path_buf(), problem },
        other => EstimateError::Table { path: path.to_path_buf(), problem: other.to_string() },
    })
}

/// A numeric column whose every field is a finite number (at most 1e15 in magnitude), or an
/// error naming the file, the row and the column (or the switch that records a missing column).
fn col<'a>(t: &'a Table, path: &Path, name: &str, switch: &str) -> Result<&'a [f64], EstimateError> {
    match t.finite_col(name) {
        Ok(Some(c)) => Ok(c),
        Ok(None) => Err(EstimateError::Table {
            path: path.to_path_buf(),
            problem: format!("no column `{name}` (recorded with {switch})"),
        }),
        Err(problem) => Err(EstimateError::Table { path: path.to_path_buf(), problem }),
    }
}

/// Checks the tables against the run's config: both start with `time_s`, hold the same instants,
/// strictly increasing, and links.csv has no columns of a link beyond `n_links`.
fn check_tables(
    links: &Table,
    links_path: &Path,
    sensors: &Table,
    sensors_path: &Path,
    n_links: usize,
) -> Result<(), EstimateError> {
    let bad = |path: &Path, problem: String| EstimateError::Table { path: path.to_path_buf(), problem };
    for (t, path) in [(links, links_path), (sensors, sensors_path)] {
        if t.header.first().map(String::as_str) != Some("time_s") {
            return Err(bad(path, "the first column must be `time_s`, as the run wrote it".into()));
        }
        if t.rows() == 0 {
            return Err(bad(path, "no rows".into()));
        }
    }
    let time = col(links, links_path, "time_s", "always")?;
    let sensor_rows = col(sensors, sensors_path, "time_s", "always")?;
    if let Some(k) = (1..time.len()).find(|&k| time[k] <= time[k - 1]) {
        return Err(bad(
            links_path,
            format!("row {}: time_s {} does not increase (row {} has {})", k + 1, time[k], k, time[k - 1]),
        ));
    }
    if let Some(k) = (0..time.len()).find(|&k| time[k] != sensor_rows[k]) {
        return Err(bad(
            sensors_path,
            format!(
                "row {}: time_s {} differs from links.csv's {}: both must come from the same run",
                k + 1,
                sensor_rows[k],
                time[k]
            ),
        ));
    }
    // Every link (and joint) has the columns of the first: a dropped or renamed column of one
    // link is a table of another recording.
    for (t, path) in [(links, links_path), (sensors, sensors_path)] {
        let names: std::collections::HashSet<&str> = t.header.iter().map(String::as_str).collect();
        let families = [
            (
                format!("{}_", names::link_body(0)),
                (0..n_links).map(|i| format!("{}_", names::link_body(i))).collect::<Vec<_>>(),
            ),
            (format!("{}_", names::joint(1)), (1..n_links).map(|j| format!("{}_", names::joint(j))).collect()),
        ];
        for (first, all) in &families {
            for h in t.header.iter().filter_map(|h| h.strip_prefix(first.as_str())) {
                if let Some(missing) = all.iter().map(|p| format!("{p}{h}")).find(|n| !names.contains(n.as_str())) {
                    return Err(bad(
                        path,
                        format!("no column `{missing}` although `{first}{h}` is there: not a whole table of this run"),
                    ));
                }
            }
        }
    }
    let beyond = format!("{}_", names::link_body(n_links));
    if let Some(h) = links.header.iter().find(|h| h.starts_with(&beyond)) {
        return Err(bad(
            links_path,
            format!(
                "has the column `{h}` of link {n_links}, but config.toml says snake.n_links = {n_links}: the config is not this run's"
            ),
        ));
    }
    Ok(())
}

fn xyz<'a>(t: &'a Table, path: &Path, stem: &str, unit: &str, switch: &str) -> Result<[&'a [f64]; 3], EstimateError> {
    Ok([
        col(t, path, &format!("{stem}_x_{unit}"), switch)?,
        col(t, path, &format!("{stem}_y_{unit}"), switch)?,
        col(t, path, &format!("{stem}_z_{unit}"), switch)?,
    ])
}

fn at(c: &[&[f64]; 3], k: usize) -> [f64; 3] {
    [c[0][k], c[1][k], c[2][k]]
}

/// Per-link columns of links.csv.
struct LinkCols<'a> {
    position: [&'a [f64]; 3],
    quat: [&'a [f64]; 4],
    velocity: [&'a [f64]; 3],
    angular_velocity: [&'a [f64]; 3],
    obstacle: [&'a [f64]; 3],
    floor: [&'a [f64]; 3],
    external: [&'a [f64]; 3],
    obstacle_point: [&'a [f64]; 3],
}

/// Per-link columns of sensors.csv (measured).
struct SensorCols<'a> {
    accel: [&'a [f64]; 3],
    gyro: [&'a [f64]; 3],
}

struct JointCols<'a> {
    angle: &'a [f64],
    velocity: &'a [f64],
    force: [&'a [f64]; 3],
    torque: [&'a [f64]; 3],
}

/// Runs the estimator of the run's config (with `overrides`, e.g. `estimation.orientation="true"`)
/// on the recorded run in `run_folder`.
pub fn estimate_run_folder(run_folder: &Path, overrides: &[String]) -> Result<EstimateOutcome, EstimateError> {
    let config_path = run_folder.join("config.toml");
    // The reader's rule first: a regular file inside the run folder.
    match crate::files::read_in(run_folder, &config_path, crate::files::SMALL_FILE_CAP_BYTES) {
        Err(crate::files::FileError::Missing { .. }) => {
            return Err(EstimateError::Missing {
                path: config_path,
                what: "not a run folder (every run folder has its resolved config.toml)".into(),
            });
        }
        Err(e) => return Err(e.into()),
        Ok(_) => {}
    }
    let config = crate::config::load_config(&config_path, overrides)
        .and_then(|c| c.validate().map(|()| c))
        .map_err(|source| EstimateError::Config { path: config_path.clone(), source })?;
    // How the run recorded, as its config.toml says (an override cannot make sparse rows dense).
    let recorded = crate::config::load_config(&config_path, &[])
        .map_err(|source| EstimateError::Config { path: config_path.clone(), source })?;
    let every_n_steps = recorded.recording.every_n_steps.max(config.recording.every_n_steps);
    if every_n_steps != 1 {
        return Err(EstimateError::SparseRows { path: config_path, every_n_steps });
    }
    let manifest = run_folder.join("manifest.json");
    if let Ok(text) = crate::files::read_text_in(run_folder, &manifest, crate::files::SMALL_FILE_CAP_BYTES)
        && text.contains("\"robot_file\": \"")
    {
        return Err(EstimateError::Table {
            path: manifest,
            problem: "the run simulated a robot file (--robot); the estimator knows only the generated snake's chain"
                .into(),
        });
    }
    let sensors_path = run_folder.join("sensors.csv");
    let links_path = run_folder.join("links.csv");
    let sensors = table(&sensors_path)?;
    let links = table(&links_path)?;
    let rows = sensors.rows();
    if links.rows() != rows {
        return Err(EstimateError::Table {
            path: links_path,
            problem: format!("{} rows, sensors.csv has {rows}: both must come from the same run", links.rows()),
        });
    }
    let nl = config.snake.n_links;
    let nj = nl.saturating_sub(1);
    check_tables(&links, &links_path, &sensors, &sensors_path, nl)?;
    let time = col(&links, &links_path, "time_s", "always")?;
    let sensor_time = col(&sensors, &sensors_path, "sensor_time_s", "recording.imu_sensors")?;
    let mut link_cols = Vec::with_capacity(nl);
    let mut sensor_cols = Vec::with_capacity(nl);
    for i in 0..nl {
        let p = names::link_body(i);
        let q = |n: &str| col(&links, &links_path, &format!("{p}_orientation_{n}"), "recording.link_orientation");
        link_cols.push(LinkCols {
            position: xyz(&links, &links_path, &format!("{p}_position"), "m", "recording.link_position")?,
            quat: [q("qw")?, q("qx")?, q("qy")?, q("qz")?],
            velocity: xyz(&links, &links_path, &format!("{p}_velocity"), "m_per_s", "recording.link_velocity")?,
            angular_velocity: xyz(
                &links,
                &links_path,
                &format!("{p}_angular_velocity"),
                "rad_per_s",
                "recording.link_angular_velocity",
            )?,
            obstacle: xyz(
                &links,
                &links_path,
                &format!("{p}_obstacle_force"),
                "n",
                "recording.external_contact_forces",
            )?,
            floor: xyz(&links, &links_path, &format!("{p}_floor_force"), "n", "recording.external_contact_forces")?,
            external: xyz(
                &links,
                &links_path,
                &format!("{p}_contact_force"),
                "n",
                "recording.external_contact_forces",
            )?,
            obstacle_point: xyz(
                &links,
                &links_path,
                &format!("{p}_obstacle_point"),
                "m",
                "recording.external_contact_forces",
            )?,
        });
        sensor_cols.push(SensorCols {
            accel: xyz(
                &sensors,
                &sensors_path,
                &format!("{p}_accelerometer_measured"),
                "m_per_s2",
                "recording.imu_sensors",
            )?,
            gyro: xyz(&sensors, &sensors_path, &format!("{p}_gyro_measured"), "rad_per_s", "recording.imu_sensors")?,
        });
    }
    let mut joint_cols = Vec::with_capacity(nj);
    for j in 0..nj {
        let p = names::joint(j + 1);
        let s = "recording.imu_sensors";
        joint_cols.push(JointCols {
            angle: col(&sensors, &sensors_path, &format!("{p}_encoder_measured_rad"), s)?,
            velocity: col(&sensors, &sensors_path, &format!("{p}_encoder_velocity_measured_rad_per_s"), s)?,
            force: xyz(&sensors, &sensors_path, &format!("{p}_force_sensor_measured"), "n", s)?,
            torque: xyz(&sensors, &sensors_path, &format!("{p}_torque_sensor_measured"), "nm", s)?,
        });
    }

    let masses = vec![config.snake.link_mass_kg; nl];
    let mut estimator = MotionEstimator::from_config(&config, &masses);
    let mut obs = Observation::new(nl, nj);
    let mut est = ContactEstimates::new(nl);
    let mut poses = LinkPoses::new(nl);
    let mut total = MotionScore::for_targets(&config);
    let mut per_link = vec![total.clone(); nl];
    // Written only inside the run folder, never through a link ([`crate::files`]).
    let out_dir = crate::files::create_dir_in(run_folder, Path::new("estimation"))?;
    let mut csv = header(nl);
    let mut series: Vec<[Vec<f64>; 4]> = vec![Default::default(); nl];
    let l = config.snake.link_length_m;
    for k in 0..rows {
        if k % 1024 == 0 && crate::interrupt::requested() {
            return Err(EstimateError::Interrupted { row: k });
        }
        obs.time_secs = time[k];
        obs.sensor_time_secs = sensor_time[k];
        for (i, (lc, sc)) in link_cols.iter().zip(&sensor_cols).enumerate() {
            obs.imu_accel_m_per_s2[i] = at(&sc.accel, k);
            obs.imu_gyro_rad_per_s[i] = at(&sc.gyro, k);
            poses.quat[i] = [lc.quat[0][k], lc.quat[1][k], lc.quat[2][k], lc.quat[3][k]];
            poses.com_m[i] = at(&lc.position, k);
            poses.com_velocity_m_per_s[i] = at(&lc.velocity, k);
            poses.angular_velocity_rad_per_s[i] = at(&lc.angular_velocity, k);
            let r = crate::estimation::quat_to_matrix(poses.quat[i]);
            // The frame origin is half a link ahead of the centre of mass along +x.
            poses.origin_m[i] = [0, 1, 2].map(|a| poses.com_m[i][a] + 0.5 * l * r[a][0]);
        }
        for (j, jc) in joint_cols.iter().enumerate() {
            obs.joint_angle_rad[j] = jc.angle[k];
            obs.joint_velocity_rad_per_s[j] = jc.velocity[k];
            obs.joint_force_n[j] = at(&jc.force, k);
            obs.joint_torque_nm[j] = at(&jc.torque, k);
        }
        // The head: its pose (the attitude filter starts from the first row's) and its
        // centre-of-mass velocity, as a tracking system gives them.
        obs.head_quat = poses.quat[0];
        obs.head_position_m = poses.origin_m[0];
        obs.head_velocity_m_per_s = poses.com_velocity_m_per_s[0];
        let true_poses = (config.estimation.orientation == OrientationSource::True).then_some(&poses);
        estimator.update(&obs, true_poses, &mut est);
        // The estimate describes the sensors' sample time: score it against the truth of that
        // row (the previous one when every step is recorded), else of this row.
        let m =
            if k > 0 && (time[k - 1] - sensor_time[k]).abs() < (time[k] - sensor_time[k]).abs() { k - 1 } else { k };
        let _ = write!(csv, "{},{}", time[k], time[m]);
        for (i, lc) in link_cols.iter().enumerate() {
            let r = crate::estimation::quat_to_matrix([lc.quat[0][m], lc.quat[1][m], lc.quat[2][m], lc.quat[3][m]]);
            let axis3 = [r[0][0], r[1][0], r[2][0]];
            let h = axis3[0].hypot(axis3[1]).max(1e-12);
            let c = at(&lc.position, m);
            let obstacle = at(&lc.obstacle, m);
            let touching = obstacle.iter().any(|v| *v != 0.0);
            let point = at(&lc.obstacle_point, m);
            let true_point = touching.then(|| (0..3).map(|a| (point[a] - c[a]) * axis3[a]).sum::<f64>());
            let sample = LinkSample {
                true_obstacle_n: obstacle,
                true_point_along_m: true_point,
                axis: [axis3[0] / h, axis3[1] / h, 0.0],
                estimated_obstacle_n: est.obstacle_force_n[i],
                detected: est.contact[i],
                estimated_point_along_m: est.contact_point_along_m[i],
            };
            total.add(&sample);
            per_link[i].add(&sample);
            let p = est.contact_point_along_m[i];
            for v in est.external_force_n[i].iter().chain(&est.floor_force_n[i]).chain(&est.obstacle_force_n[i]) {
                let _ = write!(csv, ",{v}");
            }
            let _ = write!(csv, ",{},{}", u8::from(est.contact[i]), p.unwrap_or(f64::NAN));
            for v in at(&lc.external, m).iter().chain(&at(&lc.floor, m)).chain(&obstacle) {
                let _ = write!(csv, ",{v}");
            }
            let _ = write!(csv, ",{}", true_point.unwrap_or(f64::NAN));
            let s = &mut series[i];
            s[0].push(est.obstacle_force_n[i][0]);
            s[1].push(obstacle[0]); // truth at the sensors' time, as plotted
            s[2].push(est.obstacle_force_n[i][1]);
            s[3].push(obstacle[1]);
        }
        csv.push('\n');
    }
    let write = |name: &str, text: &str| -> Result<(), EstimateError> {
        crate::files::write_in(&out_dir, Path::new(name), text.as_bytes())?;
        Ok(())
    };
    write("estimates.csv", &csv)?;
    write("scores.csv", &scores_csv(&total, &per_link))?;
    write("scores.md", &scores_markdown(run_folder, &config, rows, &total, &per_link, est.floor_friction))?;
    let plots = crate::files::create_dir_in(&out_dir, Path::new("plots"))?;
    for (i, s) in series.into_iter().enumerate() {
        let [ex, tx, ey, ty] = s;
        let named = vec![
            ("estimated obstacle x".to_string(), ex),
            ("true obstacle x".to_string(), tx),
            ("estimated obstacle y".to_string(), ey),
            ("true obstacle y".to_string(), ty),
        ];
        crate::plot::plot_time_series(
            &plots,
            &format!("estimate_link_{i:02}"),
            &format!("link {i}: obstacle force, estimated (from measured sensors) and true"),
            "force (N)",
            sensor_time,
            &named,
        )
        .map_err(|e| EstimateError::Plot { path: plots.clone(), message: e.to_string() })?;
    }
    Ok(EstimateOutcome { folder: out_dir, rows, total, per_link })
}

fn header(nl: usize) -> String {
    // truth_time_s: the row whose truth the estimate is compared with (its sensors' sample time).
    let mut h = String::from("time_s,truth_time_s");
    for i in 0..nl {
        let p = names::link_body(i);
        for stem in ["estimated_external_force", "estimated_floor_force", "estimated_obstacle_force"] {
            for a in ["x", "y", "z"] {
                let _ = write!(h, ",{p}_{stem}_{a}_n");
            }
        }
        let _ = write!(h, ",{p}_estimated_contact,{p}_estimated_point_along_m");
        for stem in ["true_external_force", "true_floor_force", "true_obstacle_force"] {
            for a in ["x", "y", "z"] {
                let _ = write!(h, ",{p}_{stem}_{a}_n");
            }
        }
        let _ = write!(h, ",{p}_true_point_along_m");
    }
    h.push('\n');
    h
}

fn score_fields(s: &MotionScore) -> String {
    format!(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
        s.hits,
        s.misses,
        s.false_alarms,
        s.correct_rejections,
        s.detection_rate(),
        s.false_alarm_rate(),
        s.relative_force_rmse(),
        s.points,
        s.point_within_rate(),
        s.mean_point_error_m(),
        s.free_link_steps,
        s.false_forces,
        s.false_force_rate(),
        s.false_force_max_n,
        s.false_force_rms_n()
    )
}

fn scores_csv(total: &MotionScore, per_link: &[MotionScore]) -> String {
    let mut out = String::from(
        "link,hits,misses,false_alarms,correct_rejections,detection_rate,false_alarm_rate,relative_force_rmse,points,points_within_1cm_rate,mean_point_error_m,free_link_steps,false_forces,false_force_rate,false_force_max_n,false_force_rms_n\n",
    );
    for (i, s) in per_link.iter().enumerate() {
        let _ = writeln!(out, "{i},{}", score_fields(s));
    }
    let _ = writeln!(out, "all,{}", score_fields(total));
    out
}

fn pct(x: f64) -> String {
    if x.is_nan() { "n/a".into() } else { format!("{:.1} %", 100.0 * x) }
}

fn scores_markdown(
    run: &Path,
    config: &Config,
    rows: usize,
    total: &MotionScore,
    per_link: &[MotionScore],
    floor_friction: [f64; 3],
) -> String {
    let e = &config.estimation;
    let friction = match e.friction {
        crate::config::FloorFrictionSource::Config => "the [ground] coefficients".to_string(),
        crate::config::FloorFrictionSource::Identify => format!(
            "coefficients identified online (prior {}; at the end forward {:.4}, backward {:.4}, lateral {:.4})",
            e.friction_prior, floor_friction[0], floor_friction[1], floor_friction[2]
        ),
    };
    let mut out = format!(
        "# Contact estimation of {}\n\n{rows} recorded rows; estimator: Newton–Euler on the measured sensors, link \
         orientations from {:?}, floor share with {friction} ({:?} floor), detection threshold {} N. A link-step \
         counts as an obstacle contact when the true horizontal obstacle force reaches the threshold; contact points are \
         scored where the true lateral force exceeds 1 N (tolerance 1 cm). False force: on the link-steps without any \
         true obstacle force (free), the share with more than {:.3} N of estimated obstacle force (one link's weight: \
         more than the floor could hold the link sideways with, at μ ≤ 1), and the largest.\n\n",
        run.display(),
        e.orientation,
        config.ground.model,
        e.detection_threshold_n,
        total.false_force_threshold_n
    );
    out.push_str("| link | contact link-steps | detected | false alarms | force RMSE / RMS | points | within 1 cm | mean point error (cm) | free link-steps | false force | largest false force (N) |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    let row = |name: String, s: &MotionScore| {
        format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {} | {:.2} |\n",
            s.hits + s.misses,
            pct(s.detection_rate()),
            pct(s.false_alarm_rate()),
            pct(s.relative_force_rmse()),
            s.points,
            pct(s.point_within_rate()),
            100.0 * s.mean_point_error_m(),
            s.free_link_steps,
            pct(s.false_force_rate()),
            s.false_force_max_n
        )
    };
    for (i, s) in per_link.iter().enumerate() {
        out.push_str(&row(i.to_string(), s));
    }
    out.push_str(&row("**all**".into(), total));
    out
}
