//! The columns of every table, written down once. Each [`Group`] says when it is recorded (a
//! `[recording]` switch), what its columns are called and typed, and how its values are read
//! from a [`Snapshot`]; the [`Recorder`](super::Recorder) builds both the header and every row
//! from these lists, so a new recorded quantity is one entry here.
//!
//! [`Layout::new`] resolves a [`TableSpec`] once, when the run starts: names are formatted and
//! the switched-off groups dropped there. Writing a row then only walks the resolved list of
//! writers: no names, no flags, no allocation.

use super::format::ColumnKind;
use super::sink::Table;
use crate::config::Recording;
use crate::sim::Snapshot;
use std::io;

/// What a run records: the `[recording]` switches and whether the floor has surfaces.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wanted<'a> {
    /// The `[recording]` section.
    pub flags: &'a Recording,
    /// The config has floor surfaces (`links` gets `link_ii_surface`).
    pub surfaces: bool,
    /// Contact estimation runs in the loop (`[estimation] enabled`): the `estimates` table.
    pub estimation: bool,
}

/// What a group of columns repeats over within a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Per {
    /// Once per row; the names have no prefix.
    Row,
    /// Once per link, each name prefixed with `<link>_`.
    Link,
    /// Once per joint, each name prefixed with `<joint>_`.
    Joint,
}

/// How many rows one recorded step adds to a table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Rows {
    /// One (the wide tables).
    One,
    /// One per contact (long format).
    PerContact,
}

/// The column names of a group, after the `<link>_` or `<joint>_` prefix if any. Units are part
/// of the names (`_m`, `_rad_per_s`, …).
#[derive(Debug, Clone, Copy)]
pub(super) enum Names {
    /// One column.
    One(&'static str),
    /// Three columns, `<quantity>_x_<unit>`, `<quantity>_y_<unit>` and `<quantity>_z_<unit>`.
    Xyz(&'static str, &'static str),
    /// The columns listed.
    List(&'static [&'static str]),
}

impl Names {
    /// The names, each with `prefix` (and `_`) in front unless it is empty.
    pub(super) fn push_to(self, prefix: &str, out: &mut Vec<String>) {
        let join = |name: &str| if prefix.is_empty() { name.to_string() } else { format!("{prefix}_{name}") };
        match self {
            Names::One(name) => out.push(join(name)),
            Names::Xyz(quantity, unit) => {
                out.extend(["x", "y", "z"].map(|axis| join(&format!("{quantity}_{axis}_{unit}"))));
            }
            Names::List(names) => out.extend(names.iter().map(|name| join(name))),
        }
    }
}

/// Geom and body names for the contact table (by id).
#[derive(Debug, Clone, Default)]
pub(super) struct ContactNames {
    pub geoms: Vec<String>,
    pub bodies: Vec<String>,
}

impl ContactNames {
    fn name(list: &[String], id: usize) -> &str {
        list.get(id).map_or("?", String::as_str)
    }
    fn geom(&self, id: usize) -> &str {
        Self::name(&self.geoms, id)
    }
    fn body(&self, id: usize) -> &str {
        Self::name(&self.bodies, id)
    }
}

/// Where a group's values are read from.
pub(super) struct At<'a> {
    /// The recorded instant.
    pub s: &'a Snapshot,
    /// The link (for [`Per::Link`]), the joint ([`Per::Joint`]) or, in a [`Rows::PerContact`]
    /// table, the contact (index into `s.contacts`) of the value; 0 otherwise.
    pub i: usize,
    /// The step number.
    pub step: u64,
    /// Geom and body names.
    pub names: &'a ContactNames,
}

/// Appends a group's values (as many as its [`Names`], of its [`ColumnKind`]) to the row.
pub(super) type Write = fn(&mut Table, &At<'_>) -> io::Result<()>;

/// A quantity: a group of columns.
pub(super) struct Group {
    /// Whether the run records it.
    pub on: fn(Wanted<'_>) -> bool,
    /// Its column names.
    pub names: Names,
    /// The type of all its columns.
    pub kind: ColumnKind,
    /// Writes its values.
    pub write: Write,
}

impl Group {
    const fn float(on: fn(Wanted<'_>) -> bool, names: Names, write: Write) -> Self {
        Self { on, names, kind: ColumnKind::Float, write }
    }
}

/// Consecutive groups that repeat together: for each link (say), every group in order.
pub(super) struct Section {
    pub per: Per,
    pub groups: &'static [Group],
}

/// One table: its file name, when it exists, and its columns in order.
pub(super) struct TableSpec {
    /// File name without extension.
    pub name: &'static str,
    /// Whether the run writes the table.
    pub on: fn(Wanted<'_>) -> bool,
    pub rows: Rows,
    pub sections: &'static [Section],
}

fn always(_: Wanted<'_>) -> bool {
    true
}

const TIME: Group = Group::float(always, Names::One("time_s"), |t, a| t.num(a.s.time_secs));

/// `links.csv`: one row per recorded step, per link its motion and the contact forces on it.
pub(super) const LINKS: TableSpec = TableSpec {
    name: "links",
    on: always,
    rows: Rows::One,
    sections: &[
        Section { per: Per::Row, groups: &[TIME] },
        Section {
            per: Per::Link,
            groups: &[
                Group::float(
                    |w| w.flags.link_position,
                    Names::Xyz("position", "m"),
                    |t, a| t.nums(&a.s.link_position_m[a.i]),
                ),
                Group::float(
                    |w| w.flags.link_orientation,
                    Names::List(&["orientation_qw", "orientation_qx", "orientation_qy", "orientation_qz"]),
                    |t, a| t.nums(&a.s.link_quat[a.i]),
                ),
                // The same orientation, readable: the link's heading (yaw of z-y'-x'' Euler angles).
                Group::float(
                    |w| w.flags.link_orientation,
                    Names::One("yaw_rad"),
                    |t, a| t.num(crate::state::yaw_rad(a.s.link_quat[a.i])),
                ),
                Group::float(
                    |w| w.flags.link_velocity,
                    Names::Xyz("velocity", "m_per_s"),
                    |t, a| t.nums(&a.s.link_velocity_m_per_s[a.i]),
                ),
                Group::float(
                    |w| w.flags.link_acceleration,
                    Names::Xyz("acceleration", "m_per_s2"),
                    |t, a| t.nums(&a.s.link_acceleration_m_per_s2[a.i]),
                ),
                Group::float(
                    |w| w.flags.link_angular_velocity,
                    Names::Xyz("angular_velocity", "rad_per_s"),
                    |t, a| t.nums(&a.s.link_angular_velocity_rad_per_s[a.i]),
                ),
                Group::float(
                    |w| w.flags.link_angular_acceleration,
                    Names::Xyz("angular_acceleration", "rad_per_s2"),
                    |t, a| t.nums(&a.s.link_angular_acceleration_rad_per_s2[a.i]),
                ),
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("contact_force", "n"),
                    |t, a| t.nums(&a.s.link_contact_force_n[a.i]),
                ),
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("contact_torque", "nm"),
                    |t, a| t.nums(&a.s.link_contact_torque_nm[a.i]),
                ),
                // Ground truth, split: floor (normal + friction), obstacles and where they push,
                // other links (self-contact) and where they push, and any other geom (scenery);
                // the four parts add up to contact_force.
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("floor_force", "n"),
                    |t, a| t.nums(&a.s.link_floor_force_n[a.i]),
                ),
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("obstacle_force", "n"),
                    |t, a| t.nums(&a.s.link_obstacle_force_n[a.i]),
                ),
                // No obstacle contact: zeros (tables hold finite numbers only); obstacle_force is 0.
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("obstacle_point", "m"),
                    |t, a| t.nums(&a.s.link_obstacle_point_m[a.i].unwrap_or([0.0; 3])),
                ),
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("self_contact_force", "n"),
                    |t, a| t.nums(&a.s.link_self_contact_force_n[a.i]),
                ),
                // No self-contact: zeros; self_contact_force is 0.
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("self_contact_point", "m"),
                    |t, a| t.nums(&a.s.link_self_contact_point_m[a.i].unwrap_or([0.0; 3])),
                ),
                Group::float(
                    |w| w.flags.external_contact_forces,
                    Names::Xyz("other_contact_force", "n"),
                    |t, a| t.nums(&a.s.link_other_contact_force_n[a.i]),
                ),
                // The surface under the link's centre: its index in `ground.surfaces`, −1 on the
                // plain floor (region 0 is the plain floor, region k + 1 is surface k).
                Group::float(|w| w.surfaces, Names::One("surface"), |t, a| t.num(a.s.link_region[a.i] as f64 - 1.0)),
            ],
        },
    ],
};

/// `joints.csv`: one row per recorded step, per joint its motion and the forces across it.
pub(super) const JOINTS: TableSpec = TableSpec {
    name: "joints",
    on: always,
    rows: Rows::One,
    sections: &[
        Section { per: Per::Row, groups: &[TIME] },
        Section {
            per: Per::Joint,
            groups: &[
                Group::float(|w| w.flags.joint_angles, Names::One("angle_rad"), |t, a| t.num(a.s.joint_angle_rad[a.i])),
                Group::float(
                    |w| w.flags.joint_velocities,
                    Names::One("velocity_rad_per_s"),
                    |t, a| t.num(a.s.joint_velocity_rad_per_s[a.i]),
                ),
                // Actuator forces per kind, in `ControlMethod::ALL` order.
                Group::float(
                    |w| w.flags.torque_actuator_forces,
                    Names::One("torque_actuator_force_nm"),
                    |t, a| t.num(a.s.actuator_force_nm[a.i][0]),
                ),
                Group::float(
                    |w| w.flags.position_actuator_forces,
                    Names::One("position_actuator_force_nm"),
                    |t, a| t.num(a.s.actuator_force_nm[a.i][1]),
                ),
                Group::float(
                    |w| w.flags.velocity_actuator_forces,
                    Names::One("velocity_actuator_force_nm"),
                    |t, a| t.num(a.s.actuator_force_nm[a.i][2]),
                ),
                Group::float(
                    |w| w.flags.intvelocity_actuator_forces,
                    Names::One("intvelocity_actuator_force_nm"),
                    |t, a| t.num(a.s.actuator_force_nm[a.i][3]),
                ),
                Group::float(
                    |w| w.flags.internal_joint_forces,
                    Names::Xyz("internal_force", "n"),
                    |t, a| t.nums(&a.s.joint_force_n[a.i]),
                ),
                Group::float(
                    |w| w.flags.internal_joint_forces,
                    Names::Xyz("internal_torque", "nm"),
                    |t, a| t.nums(&a.s.joint_torque_nm[a.i]),
                ),
            ],
        },
    ],
};

/// The IMU columns (`recording.imu_sensors`): only these go with the switch; the joint
/// encoders and force/torque sensors stay in `sensors.csv`.
fn imu(w: Wanted<'_>) -> bool {
    w.flags.imu_sensors
}

/// The link sensors (IMUs) of one observation (`true` or `measured`).
macro_rules! link_sensors {
    ($obs:ident, $variant:literal) => {
        Section {
            per: Per::Link,
            groups: &[
                Group::float(imu, Names::Xyz(concat!("accelerometer_", $variant), "m_per_s2"), |t, a| {
                    t.nums(&a.s.$obs.imu_accel_m_per_s2[a.i])
                }),
                Group::float(imu, Names::Xyz(concat!("gyro_", $variant), "rad_per_s"), |t, a| {
                    t.nums(&a.s.$obs.imu_gyro_rad_per_s[a.i])
                }),
                Group::float(
                    imu,
                    Names::List(&[
                        concat!("orientation_", $variant, "_qw"),
                        concat!("orientation_", $variant, "_qx"),
                        concat!("orientation_", $variant, "_qy"),
                        concat!("orientation_", $variant, "_qz"),
                    ]),
                    |t, a| t.nums(&a.s.$obs.imu_quat_wxyz[a.i]),
                ),
            ],
        }
    };
}

/// The joint sensors of one observation (`true` or `measured`).
macro_rules! joint_sensors {
    ($obs:ident, $variant:literal) => {
        Section {
            per: Per::Joint,
            groups: &[
                Group::float(always, Names::One(concat!("encoder_", $variant, "_rad")), |t, a| {
                    t.num(a.s.$obs.joint_angle_rad[a.i])
                }),
                Group::float(always, Names::One(concat!("encoder_velocity_", $variant, "_rad_per_s")), |t, a| {
                    t.num(a.s.$obs.joint_velocity_rad_per_s[a.i])
                }),
                Group::float(always, Names::One(concat!("actuator_torque_", $variant, "_nm")), |t, a| {
                    t.num(a.s.$obs.actuator_torque_nm[a.i])
                }),
                Group::float(always, Names::Xyz(concat!("force_sensor_", $variant), "n"), |t, a| {
                    t.nums(&a.s.$obs.joint_force_n[a.i])
                }),
                Group::float(always, Names::Xyz(concat!("torque_sensor_", $variant), "nm"), |t, a| {
                    t.nums(&a.s.$obs.joint_torque_nm[a.i])
                }),
            ],
        }
    };
}

/// `sensors.csv`: one row per recorded step, every sensor as the controller saw it, true and
/// measured (with the noise model).
pub(super) const SENSORS: TableSpec = TableSpec {
    name: "sensors",
    on: always,
    rows: Rows::One,
    sections: &[
        Section {
            per: Per::Row,
            groups: &[
                TIME,
                Group::float(always, Names::One("sensor_time_s"), |t, a| t.num(a.s.observation_true.sensor_time_secs)),
            ],
        },
        link_sensors!(observation_true, "true"),
        joint_sensors!(observation_true, "true"),
        link_sensors!(observation_measured, "measured"),
        joint_sensors!(observation_measured, "measured"),
        Section {
            per: Per::Link,
            groups: &[Group::float(imu, Names::Xyz("velocimeter_true", "m_per_s"), |t, a| {
                t.nums(&a.s.link_velocimeter_m_per_s[a.i])
            })],
        },
    ],
};

/// `contacts.csv`: one row per contact per recorded step.
pub(super) const CONTACTS: TableSpec = TableSpec {
    name: "contacts",
    on: |w| w.flags.contacts,
    rows: Rows::PerContact,
    sections: &[Section {
        per: Per::Row,
        groups: &[
            TIME,
            Group { on: always, names: Names::One("step"), kind: ColumnKind::Int, write: |t, a| t.int(a.step) },
            Group {
                on: always,
                names: Names::List(&["geom1", "geom2"]),
                kind: ColumnKind::Text,
                write: |t, a| {
                    let c = &a.s.contacts[a.i];
                    t.text(a.names.geom(c.geom[0]))?;
                    t.text(a.names.geom(c.geom[1]))
                },
            },
            Group {
                on: always,
                names: Names::List(&["body1", "body2"]),
                kind: ColumnKind::Text,
                write: |t, a| {
                    let c = &a.s.contacts[a.i];
                    t.text(a.names.body(c.body[0]))?;
                    t.text(a.names.body(c.body[1]))
                },
            },
            Group::float(always, Names::Xyz("position", "m"), |t, a| t.nums(&a.s.contacts[a.i].position_m)),
            Group::float(always, Names::List(&["normal_x", "normal_y", "normal_z"]), |t, a| {
                t.nums(&a.s.contacts[a.i].normal)
            }),
            Group::float(always, Names::One("distance_m"), |t, a| t.num(a.s.contacts[a.i].distance_m)),
            Group::float(always, Names::One("penetration_m"), |t, a| t.num(a.s.contacts[a.i].penetration_m())),
            Group::float(always, Names::One("normal_force_n"), |t, a| t.num(a.s.contacts[a.i].normal_force_n)),
            Group::float(always, Names::List(&["friction_force_1_n", "friction_force_2_n"]), |t, a| {
                t.nums(&a.s.contacts[a.i].friction_force_n)
            }),
            Group::float(always, Names::Xyz("force_on_geom2", "n"), |t, a| t.nums(&a.s.contacts[a.i].force_on_geom2_n)),
        ],
    }],
};

/// A per-link 3-vector of the measured observation's contact estimates (zeros when inactive).
fn estimate3(v: &[[f64; 3]], i: usize) -> [f64; 3] {
    v.get(i).copied().unwrap_or([0.0; 3])
}

/// `estimates.csv`: one row per recorded step, per link the contact estimates the controller saw
/// (`estimation::MotionEstimator`, from the measured sensors) next to the ground truth. The
/// estimates describe `sensor_time_s` (the sensors' sample, one step before `time_s`), the true
/// columns `time_s`: compare an estimate with the truth of the row whose `time_s` is its
/// `sensor_time_s` (`simserpent estimate` does).
pub(super) const ESTIMATES: TableSpec = TableSpec {
    name: "estimates",
    on: |w| w.estimation,
    rows: Rows::One,
    sections: &[
        Section {
            per: Per::Row,
            groups: &[
                TIME,
                Group::float(always, Names::One("sensor_time_s"), |t, a| {
                    t.num(a.s.observation_measured.sensor_time_secs)
                }),
            ],
        },
        Section {
            per: Per::Link,
            groups: &[
                Group::float(always, Names::Xyz("estimated_external_force", "n"), |t, a| {
                    t.nums(&estimate3(&a.s.observation_measured.contacts.external_force_n, a.i))
                }),
                Group::float(always, Names::Xyz("estimated_floor_force", "n"), |t, a| {
                    t.nums(&estimate3(&a.s.observation_measured.contacts.floor_force_n, a.i))
                }),
                Group::float(always, Names::Xyz("estimated_obstacle_force", "n"), |t, a| {
                    t.nums(&estimate3(&a.s.observation_measured.contacts.obstacle_force_n, a.i))
                }),
                // 1 when the estimator flags an obstacle contact, else 0.
                Group::float(always, Names::One("estimated_contact"), |t, a| {
                    t.num(f64::from(u8::from(
                        a.s.observation_measured.contacts.contact.get(a.i).copied().unwrap_or(false),
                    )))
                }),
                // The contact point along the link from its centre (+ toward the head); NaN when
                // the estimator reports none (as in the ROS 2 message and Python's estimates).
                Group::float(always, Names::One("estimated_point_along_m"), |t, a| {
                    let p = a.s.observation_measured.contacts.contact_point_along_m.get(a.i).copied().flatten();
                    t.num(p.unwrap_or(f64::NAN))
                }),
                Group::float(always, Names::Xyz("estimated_self_contact_force", "n"), |t, a| {
                    t.nums(&estimate3(&a.s.observation_measured.contacts.self_contact_force_n, a.i))
                }),
                // 1 when the estimator finds the link touching another link, else 0.
                Group::float(always, Names::One("estimated_self_contact"), |t, a| {
                    t.num(f64::from(u8::from(
                        a.s.observation_measured.contacts.self_contact.get(a.i).copied().unwrap_or(false),
                    )))
                }),
                Group::float(always, Names::Xyz("true_external_force", "n"), |t, a| {
                    t.nums(&a.s.link_contact_force_n[a.i])
                }),
                Group::float(always, Names::Xyz("true_floor_force", "n"), |t, a| t.nums(&a.s.link_floor_force_n[a.i])),
                Group::float(always, Names::Xyz("true_obstacle_force", "n"), |t, a| {
                    t.nums(&a.s.link_obstacle_force_n[a.i])
                }),
                // NaN when the link touches no obstacle.
                Group::float(always, Names::One("true_point_along_m"), |t, a| {
                    t.num(a.s.link_obstacle_point_m[a.i].map_or(f64::NAN, |p| a.s.along_link_axis_m(a.i, p)))
                }),
                Group::float(always, Names::Xyz("true_self_contact_force", "n"), |t, a| {
                    t.nums(&a.s.link_self_contact_force_n[a.i])
                }),
            ],
        },
    ],
};

/// Every table, in the order the manifest lists them.
pub(super) const TABLES: [&TableSpec; 5] = [&LINKS, &JOINTS, &SENSORS, &CONTACTS, &ESTIMATES];

/// A table's columns resolved for one run: the writers of the groups it records, in order.
pub(super) struct Layout {
    rows: Rows,
    sections: Vec<(Per, Vec<Write>)>,
}

/// A table's header: names and types, one per column.
pub(super) struct Header {
    pub names: Vec<String>,
    pub kinds: Vec<ColumnKind>,
}

impl Layout {
    /// Resolves `spec` for a run that records `want`, for a robot with these links and joints
    /// (their names prefix the per-link and per-joint columns).
    pub fn new(spec: &TableSpec, want: Wanted<'_>, links: &[&str], joints: &[&str]) -> (Self, Header) {
        let mut header = Header { names: Vec::new(), kinds: Vec::new() };
        let mut sections = Vec::new();
        for section in spec.sections {
            let groups: Vec<&Group> = section.groups.iter().filter(|g| (g.on)(want)).collect();
            if groups.is_empty() {
                continue;
            }
            let prefixes: &[&str] = match section.per {
                Per::Row => &[""],
                Per::Link => links,
                Per::Joint => joints,
            };
            for prefix in prefixes {
                for group in &groups {
                    group.names.push_to(prefix, &mut header.names);
                    header.kinds.resize(header.names.len(), group.kind);
                }
            }
            sections.push((section.per, groups.iter().map(|g| g.write).collect()));
        }
        (Self { rows: spec.rows, sections }, header)
    }

    /// Appends the rows of one recorded step to `table`.
    pub fn write(&self, table: &mut Table, s: &Snapshot, step: u64, names: &ContactNames) -> io::Result<()> {
        let rows = match self.rows {
            Rows::One => 1,
            Rows::PerContact => s.contacts.len(),
        };
        for row in 0..rows {
            for (per, writes) in &self.sections {
                let items = match per {
                    Per::Row => row..row + 1,
                    Per::Link => 0..s.link_position_m.len(),
                    Per::Joint => 0..s.joint_angle_rad.len(),
                };
                for i in items {
                    let at = At { s, i, step, names };
                    for write in writes {
                        write(table, &at)?;
                    }
                }
            }
            table.end_row()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Config, TableFormat};
    use crate::sim::ContactRow;
    use std::collections::HashSet;

    /// Every group of every table, switched on, writes as many values as it has names, and no
    /// two columns of a table share a name.
    #[test]
    fn every_row_is_as_wide_as_its_header() {
        let mut flags = Config::default().recording;
        flags.format = TableFormat::Csv;
        let want = Wanted { flags: &flags, surfaces: true, estimation: true };
        let dir = tempfile::tempdir().expect("temporary folder");
        let mut s = Snapshot::new(3, 2);
        s.contacts.extend([ContactRow::default(), ContactRow { geom: [1, 0], body: [0, 9], ..ContactRow::default() }]);
        let names = ContactNames { geoms: vec!["floor".into(), "g1".into()], bodies: vec!["world".into()] };
        for spec in TABLES {
            assert!((spec.on)(want), "{}: the default config (with estimation) records every table", spec.name);
            for group in spec.sections.iter().flat_map(|section| section.groups) {
                assert!((group.on)(want), "{}: {:?} is recorded by default", spec.name, group.names);
            }
            let (layout, header) =
                Layout::new(spec, want, &["link_00", "link_01", "link_02"], &["joint_01", "joint_02"]);
            assert_eq!(header.names.len(), header.kinds.len(), "{}", spec.name);
            let unique: HashSet<&String> = header.names.iter().collect();
            assert_eq!(unique.len(), header.names.len(), "{}: duplicate column names", spec.name);
            let mut table =
                Table::typed(dir.path(), spec.name, &header.names, &header.kinds, &flags).expect("table created");
            layout.write(&mut table, &s, 7, &names).expect("row written");
            let (_, error) = table.finish();
            assert!(error.is_none(), "table closed: {error:?}");
            let text = std::fs::read_to_string(dir.path().join(format!("{}.csv", spec.name))).expect("table read");
            let lines: Vec<&str> = text.lines().collect();
            assert_eq!(lines[0], header.names.join(","));
            let rows = if spec.rows == Rows::PerContact { 2 } else { 1 };
            assert_eq!(lines.len(), 1 + rows, "{}", spec.name);
            for line in &lines[1..] {
                assert_eq!(line.split(',').count(), header.names.len(), "{}: {line}", spec.name);
            }
        }
    }

    #[test]
    fn names_are_prefixed_and_switched() {
        let mut flags = Config::default().recording;
        flags.link_orientation = false;
        let (_, header) =
            Layout::new(&LINKS, Wanted { flags: &flags, surfaces: false, estimation: false }, &["link_00"], &[]);
        assert_eq!(&header.names[..3], ["time_s", "link_00_position_x_m", "link_00_position_y_m"]);
        assert!(header.names.iter().all(|n| !n.contains("orientation") && !n.ends_with("surface")));
        let (_, header) =
            Layout::new(&CONTACTS, Wanted { flags: &flags, surfaces: false, estimation: false }, &["link_00"], &[]);
        assert_eq!(&header.names[..6], ["time_s", "step", "geom1", "geom2", "body1", "body2"]);
        assert_eq!(&header.kinds[..3], [ColumnKind::Float, ColumnKind::Int, ColumnKind::Text]);
    }
}
