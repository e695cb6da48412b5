//! Recording: the run folder, its manifest and the streaming tables.
//!
//! Layout of `runs/<run_name>-<UTC time>/`:
//! - `config.toml`: the resolved configuration (every key, after defaults and `--set`);
//! - `model.xml`: the generated MJCF (MuJoCo loads it unchanged);
//! - `manifest.json`: versions, seed, status (`incomplete` while running or after an
//!   interruption, then `complete` or `failed` with the reason), wall time, steps;
//! - `links.csv`, `joints.csv`, `sensors.csv`: one row per recorded step (wide);
//! - `contacts.csv`: one row per contact per recorded step (long format).
//!
//! With `recording.format = "parquet"` or `"both"` the tables are (also) written as
//! `<table>.parquet` with the same columns ([`Table`] fans every value out to both formats).

mod manifest;
#[cfg(feature = "parquet")]
mod parquet;
mod sink;
mod table;

pub use manifest::{Manifest, RunStatus};
#[cfg(feature = "parquet")]
pub use parquet::ParquetTable;
pub use sink::{ColumnKind, Table, TableSink};
pub use table::CsvTable;

use crate::config::Recording;
use crate::sim::{Index, Snapshot};
use std::path::{Path, PathBuf};

/// Errors of writing a run folder; they always name the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// An I/O failure on a file or folder.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RecordError + '_ {
    move |source| RecordError::Io { path: path.to_path_buf(), source }
}

/// UTC time as `YYYYMMDDTHHMMSSZ` from seconds since the Unix epoch (civil-from-days algorithm
/// of H. Hinnant, public domain).
pub fn utc_stamp(unix_secs: u64) -> String {
    let days = (unix_secs / 86_400) as i64;
    let rem = unix_secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// Creates `<output_dir>/<run_name>-<stamp>/` (with `-2`, `-3`, … if it exists already).
pub fn create_run_folder(output_dir: &Path, run_name: &str, stamp: &str) -> Result<PathBuf, RecordError> {
    std::fs::create_dir_all(output_dir).map_err(io_err(output_dir))?;
    let mut attempt = 1;
    loop {
        let name = if attempt == 1 { format!("{run_name}-{stamp}") } else { format!("{run_name}-{stamp}-{attempt}") };
        let path = output_dir.join(name);
        match std::fs::create_dir(&path) {
            Ok(()) => return Ok(path),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 1000 => attempt += 1,
            Err(e) => return Err(io_err(&path)(e)),
        }
    }
}

const XYZ: [&str; 3] = ["x", "y", "z"];

fn push3(header: &mut Vec<String>, prefix: &str, quantity: &str, unit: &str) {
    for axis in XYZ {
        header.push(format!("{prefix}_{quantity}_{axis}_{unit}"));
    }
}

/// The tables of one run, written as the run goes.
pub struct Recorder {
    flags: Recording,
    links: Table,
    joints: Table,
    sensors: Option<Table>,
    contacts: Option<Table>,
    contact_names: (Vec<String>, Vec<String>),
    step: u64,
    /// Whether `links` has the `link_ii_surface` columns.
    surfaces: bool,
}

impl Recorder {
    /// Creates the tables in `folder` with headers for the robot described by `index`.
    ///
    /// With `surfaces` (the config has floor surfaces) `links` gets one more column per link,
    /// `link_ii_surface`: the index of the surface under the link's centre in `ground.surfaces`,
    /// or −1 on the plain floor.
    pub fn create(folder: &Path, flags: &Recording, index: &Index, surfaces: bool) -> Result<Self, RecordError> {
        let f = flags;
        let mut h = vec!["time_s".to_string()];
        for link in &index.links {
            let n = &link.name;
            if f.link_position {
                push3(&mut h, n, "position", "m");
            }
            if f.link_orientation {
                h.extend(["qw", "qx", "qy", "qz"].map(|q| format!("{n}_orientation_{q}")));
            }
            if f.link_velocity {
                push3(&mut h, n, "velocity", "m_per_s");
            }
            if f.link_acceleration {
                push3(&mut h, n, "acceleration", "m_per_s2");
            }
            if f.link_angular_velocity {
                push3(&mut h, n, "angular_velocity", "rad_per_s");
            }
            if f.link_angular_acceleration {
                push3(&mut h, n, "angular_acceleration", "rad_per_s2");
            }
            if f.external_contact_forces {
                push3(&mut h, n, "contact_force", "n");
                push3(&mut h, n, "contact_torque", "nm");
                // Ground truth, split: floor (normal + friction), obstacles and where they push.
                push3(&mut h, n, "floor_force", "n");
                push3(&mut h, n, "obstacle_force", "n");
                push3(&mut h, n, "obstacle_point", "m");
            }
            if surfaces {
                h.push(format!("{n}_surface"));
            }
        }
        let links = Table::numeric(folder, "links", &h, f).map_err(io_err(&folder.join("links")))?;

        let mut h = vec!["time_s".to_string()];
        for joint in &index.joints {
            let n = &joint.name;
            if f.joint_angles {
                h.push(format!("{n}_angle_rad"));
            }
            if f.joint_velocities {
                h.push(format!("{n}_velocity_rad_per_s"));
            }
            for (on, kind) in [
                (f.torque_actuator_forces, "torque"),
                (f.position_actuator_forces, "position"),
                (f.velocity_actuator_forces, "velocity"),
                (f.intvelocity_actuator_forces, "intvelocity"),
            ] {
                if on {
                    h.push(format!("{n}_{kind}_actuator_force_nm"));
                }
            }
            if f.internal_joint_forces {
                push3(&mut h, n, "internal_force", "n");
                push3(&mut h, n, "internal_torque", "nm");
            }
        }
        let joints = Table::numeric(folder, "joints", &h, f).map_err(io_err(&folder.join("joints")))?;

        let sensors = if f.imu_sensors {
            let mut h = vec!["time_s".to_string(), "sensor_time_s".to_string()];
            for variant in ["true", "measured"] {
                for link in &index.links {
                    push3(&mut h, &link.name, &format!("accelerometer_{variant}"), "m_per_s2");
                    push3(&mut h, &link.name, &format!("gyro_{variant}"), "rad_per_s");
                }
                for joint in &index.joints {
                    h.push(format!("{}_encoder_{variant}_rad", joint.name));
                    h.push(format!("{}_encoder_velocity_{variant}_rad_per_s", joint.name));
                    h.push(format!("{}_actuator_torque_{variant}_nm", joint.name));
                    push3(&mut h, &joint.name, &format!("force_sensor_{variant}"), "n");
                    push3(&mut h, &joint.name, &format!("torque_sensor_{variant}"), "nm");
                }
            }
            for link in &index.links {
                push3(&mut h, &link.name, "velocimeter_true", "m_per_s");
            }
            Some(Table::numeric(folder, "sensors", &h, f).map_err(io_err(&folder.join("sensors")))?)
        } else {
            None
        };

        let contacts = if f.contacts {
            let h: Vec<String> = [
                "time_s",
                "step",
                "geom1",
                "geom2",
                "body1",
                "body2",
                "position_x_m",
                "position_y_m",
                "position_z_m",
                "normal_x",
                "normal_y",
                "normal_z",
                "distance_m",
                "penetration_m",
                "normal_force_n",
                "friction_force_1_n",
                "friction_force_2_n",
                "force_on_geom2_x_n",
                "force_on_geom2_y_n",
                "force_on_geom2_z_n",
            ]
            .iter()
            .map(|s| s.to_string())
            .collect();
            let mut kinds = vec![ColumnKind::Float; h.len()];
            kinds[1] = ColumnKind::Int;
            kinds[2..6].fill(ColumnKind::Text);
            Some(Table::typed(folder, "contacts", &h, &kinds, f).map_err(io_err(&folder.join("contacts")))?)
        } else {
            None
        };
        Ok(Self {
            flags: flags.clone(),
            links,
            joints,
            sensors,
            contacts,
            contact_names: (index.geom_names.clone(), index.body_names.clone()),
            step: 0,
            surfaces,
        })
    }

    /// Appends one snapshot (step number `step`).
    pub fn write(&mut self, step: u64, s: &Snapshot) -> Result<(), RecordError> {
        self.step = step;
        // Paths are only copied on error: a recorded step allocates nothing.
        self.write_links(s).map_err(|e| RecordError::Io { path: self.links.path().to_path_buf(), source: e })?;
        self.write_joints(s).map_err(|e| RecordError::Io { path: self.joints.path().to_path_buf(), source: e })?;
        if let Some(t) = self.sensors.as_mut() {
            write_sensors(t, s).map_err(|e| RecordError::Io { path: t.path().to_path_buf(), source: e })?;
        }
        if let Some(t) = self.contacts.as_mut() {
            write_contacts(t, step, s, &self.contact_names)
                .map_err(|e| RecordError::Io { path: t.path().to_path_buf(), source: e })?;
        }
        Ok(())
    }

    fn write_links(&mut self, s: &Snapshot) -> std::io::Result<()> {
        let (f, t) = (&self.flags, &mut self.links);
        t.num(s.time_secs)?;
        for i in 0..s.link_position_m.len() {
            if f.link_position {
                t.nums(&s.link_position_m[i])?;
            }
            if f.link_orientation {
                t.nums(&s.link_quat[i])?;
            }
            if f.link_velocity {
                t.nums(&s.link_velocity_m_per_s[i])?;
            }
            if f.link_acceleration {
                t.nums(&s.link_acceleration_m_per_s2[i])?;
            }
            if f.link_angular_velocity {
                t.nums(&s.link_angular_velocity_rad_per_s[i])?;
            }
            if f.link_angular_acceleration {
                t.nums(&s.link_angular_acceleration_rad_per_s2[i])?;
            }
            if f.external_contact_forces {
                t.nums(&s.link_contact_force_n[i])?;
                t.nums(&s.link_contact_torque_nm[i])?;
                t.nums(&s.link_floor_force_n[i])?;
                t.nums(&s.link_obstacle_force_n[i])?;
                // No obstacle contact: zeros (tables hold finite numbers only); obstacle_force is 0.
                t.nums(&s.link_obstacle_point_m[i].unwrap_or([0.0; 3]))?;
            }
            if self.surfaces {
                // Region 0 is the plain floor (-1), region k + 1 is surface k.
                t.num(s.link_region[i] as f64 - 1.0)?;
            }
        }
        t.end_row()
    }

    fn write_joints(&mut self, s: &Snapshot) -> std::io::Result<()> {
        let (f, t) = (&self.flags, &mut self.joints);
        t.num(s.time_secs)?;
        let kinds = [
            f.torque_actuator_forces,
            f.position_actuator_forces,
            f.velocity_actuator_forces,
            f.intvelocity_actuator_forces,
        ];
        for j in 0..s.joint_angle_rad.len() {
            if f.joint_angles {
                t.num(s.joint_angle_rad[j])?;
            }
            if f.joint_velocities {
                t.num(s.joint_velocity_rad_per_s[j])?;
            }
            for (k, on) in kinds.iter().enumerate() {
                if *on {
                    t.num(s.actuator_force_nm[j][k])?;
                }
            }
            if f.internal_joint_forces {
                t.nums(&s.joint_force_n[j])?;
                t.nums(&s.joint_torque_nm[j])?;
            }
        }
        t.end_row()
    }

    /// Flushes all tables (whole rows reach the files).
    pub fn flush(&mut self) -> Result<(), RecordError> {
        let mut tables: Vec<&mut Table> = vec![&mut self.links, &mut self.joints];
        tables.extend(self.sensors.as_mut());
        tables.extend(self.contacts.as_mut());
        for t in tables {
            t.flush().map_err(|(path, source)| RecordError::Io { path, source })?;
        }
        Ok(())
    }

    /// Flushes and closes all tables; returns (file name, rows) per table.
    pub fn finish(self) -> Result<Vec<(String, u64)>, RecordError> {
        let mut tables = vec![self.links, self.joints];
        tables.extend(self.sensors);
        tables.extend(self.contacts);
        let mut out = Vec::new();
        for t in tables {
            out.extend(t.finish().map_err(|(path, source)| RecordError::Io { path, source })?);
        }
        Ok(out)
    }
}

fn write_sensors(t: &mut Table, s: &Snapshot) -> std::io::Result<()> {
    t.num(s.time_secs)?;
    t.num(s.observation_true.sensor_time_secs)?;
    for o in [&s.observation_true, &s.observation_measured] {
        for i in 0..o.imu_accel_m_per_s2.len() {
            t.nums(&o.imu_accel_m_per_s2[i])?;
            t.nums(&o.imu_gyro_rad_per_s[i])?;
        }
        for j in 0..o.joint_angle_rad.len() {
            t.num(o.joint_angle_rad[j])?;
            t.num(o.joint_velocity_rad_per_s[j])?;
            t.num(o.actuator_torque_nm[j])?;
            t.nums(&o.joint_force_n[j])?;
            t.nums(&o.joint_torque_nm[j])?;
        }
    }
    for v in &s.link_velocimeter_m_per_s {
        t.nums(v)?;
    }
    t.end_row()
}

fn write_contacts(t: &mut Table, step: u64, s: &Snapshot, names: &(Vec<String>, Vec<String>)) -> std::io::Result<()> {
    fn name(list: &[String], id: usize) -> &str {
        list.get(id).map_or("?", String::as_str)
    }
    for c in &s.contacts {
        t.num(s.time_secs)?;
        t.int(step)?;
        t.text(name(&names.0, c.geom[0]))?;
        t.text(name(&names.0, c.geom[1]))?;
        t.text(name(&names.1, c.body[0]))?;
        t.text(name(&names.1, c.body[1]))?;
        t.nums(&c.position_m)?;
        t.nums(&c.normal)?;
        t.num(c.distance_m)?;
        t.num(c.penetration_m())?;
        t.num(c.normal_force_n)?;
        t.nums(&c.friction_force_n)?;
        t.nums(&c.force_on_geom2_n)?;
        t.end_row()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_stamp_matches_known_dates() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        assert_eq!(utc_stamp(951_782_400), "20000229T000000Z");
        assert_eq!(utc_stamp(1_795_373_261), "20261122T184741Z");
    }
}
