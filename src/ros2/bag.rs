//! The ROS 2 bag of a run (`recording.format` with `"mcap"`): `run.mcap` in the run folder, one
//! MCAP file of ROS 2 CDR messages with their `ros2msg` schemas embedded, written at every
//! recorded instant (the rows of the CSV tables), stamped with simulated time.
//!
//! Topics (user guide, "ROS 2"; `<ns>` is `ros2.namespace`, `snake` by default):
//!
//! | topic | type | frame | what |
//! |---|---|---|---|
//! | `/clock` | rosgraph_msgs/Clock | — | simulated time |
//! | `/joint_states` | sensor_msgs/JointState | — | measured: encoder angle, velocity, actuator torque (sensor models applied) |
//! | `/<ns>/ground_truth/joint_states` | sensor_msgs/JointState | — | the same, true values |
//! | `/tf` | tf2_msgs/TFMessage | `world` → `link_NN` | every link's frame (true pose), the head `link_00` first |
//! | `/<ns>/joint_NN/wrench` | geometry_msgs/WrenchStamped | `link_NN` (child link) | measured joint force/torque sensor |
//! | `/<ns>/link_NN/imu` | sensor_msgs/Imu | `link_NN` | measured orientation (framequat), gyro and accelerometer, covariances from `[sensors]` |
//! | `/<ns>/link_NN/contact_wrench` | geometry_msgs/WrenchStamped | `world` | true contact force on the link, torque about its centre of mass |
//! | `/<ns>/contacts` | visualization_msgs/MarkerArray | `world` | one arrow per contact (force on its second geom) |
//! | `/<ns>/ground_truth/contacts` | ros_gz_interfaces/Contacts | `world` | every contact: geoms, bodies, point, normal, depth, force ([`msgs::Contacts`]) |
//! | `/<ns>/ground_truth/contact_forces` | simserpent_msgs/ContactEstimates | `world` | per link the true contact force split into floor, obstacles and other links (self-contact), as the estimates are |
//! | `/<ns>/contact_estimates` | simserpent_msgs/ContactEstimates | `world` | with `[estimation] enabled`: the estimator's per-link estimates ([`msgs::ContactEstimates`]) |
//! | `/<ns>/forward_<kind>_controller/commands` | std_msgs/Float64MultiArray | — | the command of the step that starts at the instant |

use super::msgs::{self, ContactMarkers, Float64MultiArray, Header, Imu, JointState, MultiArrayLayout, Quaternion};
use super::msgs::{Clock, ContactEstimates, Contacts, TfMessage, Time, Wrench, WrenchStamped};
use crate::config::{Config, ControlMethod};
use crate::control::{Command, Observation};
use crate::record::RecordError;
use crate::record::offload::{Offload, Sink};
use crate::sim::{Index, Snapshot};
use std::collections::BTreeMap;

/// The bag's file: whole records only (a killed run leaves complete chunks, see
/// [`super::bag_file`]).
type BagFile = mcap::write::NoSeek<super::bag_file::RecordAlignedFile>;
use std::path::{Path, PathBuf};

pub use super::bag_file::FILE_NAME;

/// The true contacts' topic (under `ros2.namespace`).
pub const CONTACT_STATES_TOPIC: &str = "ground_truth/contacts";

/// The true per-link contact forces' topic (under `ros2.namespace`): total, floor, obstacles and
/// other links (self-contact), in the estimates' message.
pub const CONTACT_FORCES_TOPIC: &str = "ground_truth/contact_forces";

/// The contact estimates' topic (under `ros2.namespace`), with `[estimation] enabled`.
pub const CONTACT_ESTIMATES_TOPIC: &str = "contact_estimates";

/// The fixed frame of the world (REP 105's `world`: z up, x/y of the MuJoCo world).
pub const WORLD_FRAME: &str = "world";

/// ros2_control's forward command controller that takes a command of this kind
/// (`forward_position_controller`, `forward_velocity_controller`, `forward_effort_controller`).
pub fn controller_name(method: ControlMethod) -> &'static str {
    match method {
        ControlMethod::Position => "forward_position_controller",
        ControlMethod::Velocity | ControlMethod::Intvelocity => "forward_velocity_controller",
        ControlMethod::Torque => "forward_effort_controller",
    }
}

/// The frame of joint `j`'s force/torque sensor: the child link's frame (the sensor sits at the
/// joint, which is the origin of the child link; the wrench is the one the parent link exerts
/// on the child and everything behind it). For the generated snake `joint_NN` → `link_NN`; a
/// joint whose name does not follow that scheme is its own frame.
pub fn joint_frame(joint: &str, links: &[String]) -> String {
    let link = joint.replacen("joint_", "link_", 1);
    if links.contains(&link) { link } else { joint.to_string() }
}

/// The messages of an instant, as the bag and the live bridge both make them: the robot's link
/// and joint names, each joint sensor's frame, the IMU covariances of the noise model and the
/// contact arrow scale, and one builder per message kind (the builders only borrow: nothing is
/// allocated per message).
pub struct RobotMessages {
    /// Link names (`index.links`), the head first: the IMU frames and `/tf`'s children.
    pub links: Vec<String>,
    /// Joint names (`index.joints`): `/joint_states`' names, the joint wrench topics.
    pub joints: Vec<String>,
    joint_frames: Vec<String>,
    /// Geom and body names by MuJoCo id (`index.geom_names`, `index.body_names`): the contacts'.
    geom_names: Vec<String>,
    body_names: Vec<String>,
    /// Whether the estimator runs (`estimation.enabled`): then `contact_estimates` is published.
    pub estimation: bool,
    /// The flags of the true contact forces (`estimation.detection_threshold_n`, N).
    contact_threshold_n: f64,
    gyro_covariance: [f64; 9],
    accel_covariance: [f64; 9],
    orientation_covariance: [f64; 9],
    /// Per link: whether the model has its IMU's `framequat` sensor (a user's robot may not).
    has_orientation: Vec<bool>,
    arrow_m_per_n: f64,
}

impl RobotMessages {
    /// For the robot of `index`, with the covariances of `[sensors]` (zero without noise) and
    /// `ros2.contact_arrow_m_per_n`.
    pub fn new(config: &Config, index: &Index) -> Self {
        let links: Vec<String> = index.links.iter().map(|l| l.name.clone()).collect();
        let joints: Vec<String> = index.joints.iter().map(|j| j.name.clone()).collect();
        let joint_frames = joints.iter().map(|j| joint_frame(j, &links)).collect();
        let s = &config.sensors;
        let variance = |std: f64| if s.noise_enabled { std * std } else { 0.0 };
        Self {
            links,
            joints,
            joint_frames,
            geom_names: index.geom_names.clone(),
            body_names: index.body_names.clone(),
            estimation: config.estimation.enabled,
            contact_threshold_n: config.estimation.detection_threshold_n,
            gyro_covariance: msgs::diagonal_covariance(variance(s.gyro.std)),
            accel_covariance: msgs::diagonal_covariance(variance(s.accelerometer.std)),
            orientation_covariance: msgs::diagonal_covariance(variance(s.orientation.std)),
            has_orientation: index.links.iter().map(|l| l.framequat_adr.is_some()).collect(),
            arrow_m_per_n: config.ros2.contact_arrow_m_per_n,
        }
    }

    /// `sensor_msgs/JointState` of every joint (no frame).
    pub fn joint_state<'a>(
        &'a self,
        stamp: Time,
        position: &'a [f64],
        velocity: &'a [f64],
        effort: &'a [f64],
    ) -> JointState<'a> {
        JointState { header: Header { stamp, frame_id: "" }, name: &self.joints, position, velocity, effort }
    }

    /// `sensor_msgs/Imu` of link `i` from the observation `m`, in the link's frame: the
    /// orientation is the IMU's measured `framequat` (the link's axes in `world`), with the
    /// `[sensors.orientation]` covariance. A link without that sensor (a user's robot) has no
    /// orientation estimate: element 0 of its covariance is −1 (sensor_msgs/Imu's rule).
    pub fn imu(&self, stamp: Time, m: &Observation, i: usize) -> Imu<'_> {
        let (orientation, orientation_covariance) = if self.has_orientation.get(i).copied().unwrap_or(false) {
            (Quaternion::from_wxyz(m.imu_quat_wxyz[i]), self.orientation_covariance)
        } else {
            let mut unknown = [0.0; 9];
            unknown[0] = -1.0;
            (Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }, unknown)
        };
        Imu {
            header: Header { stamp, frame_id: &self.links[i] },
            orientation,
            orientation_covariance,
            angular_velocity: m.imu_gyro_rad_per_s[i].into(),
            angular_velocity_covariance: self.gyro_covariance,
            linear_acceleration: m.imu_accel_m_per_s2[i].into(),
            linear_acceleration_covariance: self.accel_covariance,
        }
    }

    /// `geometry_msgs/WrenchStamped` of joint `j`'s force/torque sensor from the observation
    /// `m`, in the child link's frame.
    pub fn joint_wrench(&self, stamp: Time, m: &Observation, j: usize) -> WrenchStamped<'_> {
        WrenchStamped {
            header: Header { stamp, frame_id: &self.joint_frames[j] },
            wrench: Wrench { force: m.joint_force_n[j].into(), torque: m.joint_torque_nm[j].into() },
        }
    }

    /// `geometry_msgs/WrenchStamped`: the true contact wrench on link `i`, in the world frame.
    pub fn contact_wrench(&self, stamp: Time, s: &Snapshot, i: usize) -> WrenchStamped<'static> {
        WrenchStamped {
            header: Header { stamp, frame_id: WORLD_FRAME },
            wrench: Wrench { force: s.link_contact_force_n[i].into(), torque: s.link_contact_torque_nm[i].into() },
        }
    }

    /// `tf2_msgs/TFMessage`: `world` → every link (true poses).
    pub fn tf<'a>(&'a self, stamp: Time, s: &'a Snapshot) -> TfMessage<'a> {
        TfMessage {
            stamp,
            parent: WORLD_FRAME,
            children: &self.links,
            position_m: &s.link_origin_m,
            quat_wxyz: &s.link_quat,
        }
    }

    /// `ros_gz_interfaces/Contacts`: every true contact of the instant.
    pub fn contact_states<'a>(&'a self, stamp: Time, s: &'a Snapshot) -> Contacts<'a> {
        Contacts {
            stamp,
            frame_id: WORLD_FRAME,
            contacts: &s.contacts,
            geom_names: &self.geom_names,
            body_names: &self.body_names,
        }
    }

    /// `simserpent_msgs/ContactEstimates`: the estimator's per-link estimates in the observation
    /// `m` (the measured one).
    pub fn contact_estimates<'a>(&'a self, stamp: Time, m: &'a Observation) -> ContactEstimates<'a> {
        ContactEstimates { stamp, frame_id: WORLD_FRAME, link_names: &self.links, estimates: &m.contacts }
    }

    /// `simserpent_msgs/ContactEstimates` of the truth: per link the true contact force split
    /// into floor, obstacles and other links (self-contact), filled into `split` (sized for the
    /// robot's links: [`RobotMessages::contact_split`]; no allocation).
    pub fn contact_forces<'a>(
        &'a self,
        stamp: Time,
        s: &Snapshot,
        split: &'a mut crate::state::ContactEstimates,
    ) -> ContactEstimates<'a> {
        split.fill_true_split(s, self.contact_threshold_n);
        ContactEstimates { stamp, frame_id: WORLD_FRAME, link_names: &self.links, estimates: split }
    }

    /// The buffer of [`RobotMessages::contact_forces`].
    pub fn contact_split(&self) -> crate::state::ContactEstimates {
        crate::state::ContactEstimates::new(self.links.len())
    }

    /// `visualization_msgs/MarkerArray`: the contacts of the instant as arrows.
    pub fn contacts<'a>(&self, stamp: Time, s: &'a Snapshot) -> ContactMarkers<'a> {
        ContactMarkers { stamp, frame_id: WORLD_FRAME, contacts: &s.contacts, arrow_m_per_n: self.arrow_m_per_n }
    }
}

struct Channels {
    clock: u16,
    joint_states: u16,
    joint_states_true: u16,
    tf: u16,
    command: u16,
    contacts: u16,
    contact_states: u16,
    contact_forces: u16,
    contact_estimates: Option<u16>,
    wrench: Vec<u16>,
    imu: Vec<u16>,
    contact_wrench: Vec<u16>,
}

/// Where the messages go: the MCAP writer and the one buffer every message is encoded into.
struct Out {
    path: PathBuf,
    writer: Option<mcap::Writer<BagFile>>,
    buf: Vec<u8>,
    sequence: u32,
}

impl Out {
    fn put<T: serde::Serialize>(&mut self, channel: u16, nanos: u64, message: &T) -> Result<(), RecordError> {
        msgs::encode(&mut self.buf, message).map_err(encode_err(&self.path))?;
        let Some(writer) = self.writer.as_mut() else { return Ok(()) };
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: nanos,
            publish_time: nanos,
        };
        self.sequence = self.sequence.wrapping_add(1);
        writer.write_to_known_channel(&header, &self.buf).map_err(bag_err(&self.path))
    }
}

/// Writes the bag of a run (see the module doc) on a writer thread of its own
/// ([`crate::record::offload`]): the step loop copies each recorded instant (snapshot and
/// command) into a preallocated row buffer; the writer thread encodes and writes the messages.
/// The file is byte for byte that of encoding in the loop (`threaded = false`).
pub struct BagRecorder {
    out: Offload<BagWriter>,
    path: PathBuf,
    method: ControlMethod,
}

/// One recorded instant for the bag.
pub struct BagRow {
    snapshot: Snapshot,
    /// The command block of the run's control method.
    command: Vec<f64>,
}

/// The bag's writer (on the writer thread). Sized once; a recorded instant reuses one buffer
/// for every message and allocates nothing of its own.
pub struct BagWriter {
    out: Out,
    channels: Channels,
    instants: u64,
    messages: RobotMessages,
    /// The buffer of the true contact forces' message.
    split: crate::state::ContactEstimates,
}

fn bag_err(path: &Path) -> impl FnOnce(mcap::McapError) -> RecordError + '_ {
    move |e| {
        let source = match e {
            mcap::McapError::Io(e) => e,
            other => std::io::Error::other(other),
        };
        RecordError::Io { path: path.to_path_buf(), source }
    }
}

fn encode_err(path: &Path) -> impl FnOnce(cdr_encoding::Error) -> RecordError + '_ {
    move |e| RecordError::Io { path: path.to_path_buf(), source: std::io::Error::other(e) }
}

impl BagRecorder {
    /// Creates `run.mcap` in `folder` with a channel per topic for the robot of `index`, written
    /// on a writer thread (`threaded`) or in the caller's thread.
    pub fn create(folder: &Path, config: &Config, index: &Index, threaded: bool) -> Result<Self, RecordError> {
        let writer = BagWriter::create(folder, config, index)?;
        let path = writer.out.path.clone();
        let (n_links, n_joints) = (index.links.len(), index.joints.len());
        let row = || BagRow { snapshot: Snapshot::new(n_links, n_joints), command: vec![0.0; n_joints] };
        let out = Offload::new(writer, row, path.clone(), threaded)?;
        Ok(Self { out, path, method: config.control.method })
    }

    /// The bag's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Hands one recorded instant to the writer (a copy; no allocation but for more contacts
    /// than ever before).
    pub fn write(&mut self, s: &Snapshot, command: &Command) -> Result<(), RecordError> {
        let block = command.block(self.method);
        let row = self.out.slot()?;
        row.snapshot.copy_from(s);
        row.command.resize(block.len(), 0.0);
        row.command.copy_from_slice(block);
        self.out.commit()
    }

    /// Finishes the bag (see [`BagWriter::finish`]); a write error of the writer thread not
    /// returned yet comes first.
    pub fn finish(self) -> (Vec<(String, u64)>, Result<(), RecordError>) {
        match self.out.finish() {
            (Some(writer), pending) => {
                let (files, done) = writer.finish();
                (files, pending.and(done))
            }
            (None, gone) => (vec![(FILE_NAME.to_string(), 0)], gone),
        }
    }
}

impl Sink for BagWriter {
    type Row = BagRow;
    fn write(&mut self, row: &BagRow) -> Result<(), RecordError> {
        self.write_instant(&row.snapshot, &row.command)
    }
    fn flush(&mut self) -> Result<(), RecordError> {
        Ok(())
    }
}

impl BagWriter {
    /// Creates `run.mcap` in `folder` with a channel per topic for the robot of `index`.
    pub fn create(folder: &Path, config: &Config, index: &Index) -> Result<Self, RecordError> {
        let path = folder.join(FILE_NAME);
        let file = crate::files::open_for_writing(&path, false)
            .map_err(|e| RecordError::Io { path: path.clone(), source: std::io::Error::other(e.to_string()) })?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("simserpent {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            // Compress on the bag's writer thread (`record::offload`): the mcap crate would
            // otherwise start one zstd worker per physical CPU for every run (and a sweep runs
            // one per core already).
            .compression_threads(0)
            // Each chunk is compressed in memory and written whole (no seeking back to fill in a
            // chunk's length): a killed run leaves only complete chunks (`simserpent bag-repair`).
            .disable_seeking(true);
        let file = mcap::write::NoSeek::new(super::bag_file::RecordAlignedFile::new(file));
        let mut writer = options.create(file).map_err(bag_err(&path))?;
        let ros = &config.ros2;
        let no_metadata = BTreeMap::new();
        let mut schemas: BTreeMap<&str, u16> = BTreeMap::new();
        let mut channel = |writer: &mut mcap::Writer<BagFile>, topic: &str, ty: &'static str| {
            let schema = match schemas.get(ty) {
                Some(id) => *id,
                None => {
                    let text = msgs::schema(ty).unwrap_or_default();
                    let id = writer.add_schema(&msgs::ros2_type_name(ty), "ros2msg", text.as_bytes())?;
                    schemas.insert(ty, id);
                    id
                }
            };
            writer.add_channel(schema, topic, "cdr", &no_metadata)
        };
        let messages = RobotMessages::new(config, index);
        let (links, joints) = (&messages.links, &messages.joints);
        let method = config.control.method;
        let estimation = messages.estimation;
        let channels = (|| -> Result<Channels, mcap::McapError> {
            let w = &mut writer;
            Ok(Channels {
                clock: channel(w, "/clock", "rosgraph_msgs/Clock")?,
                joint_states: channel(w, "/joint_states", "sensor_msgs/JointState")?,
                joint_states_true: channel(w, &ros.topic("ground_truth/joint_states"), "sensor_msgs/JointState")?,
                tf: channel(w, "/tf", "tf2_msgs/TFMessage")?,
                command: channel(
                    w,
                    &ros.topic(&format!("{}/commands", controller_name(method))),
                    "std_msgs/Float64MultiArray",
                )?,
                contacts: channel(w, &ros.topic("contacts"), "visualization_msgs/MarkerArray")?,
                contact_states: channel(w, &ros.topic(CONTACT_STATES_TOPIC), "ros_gz_interfaces/Contacts")?,
                contact_forces: channel(w, &ros.topic(CONTACT_FORCES_TOPIC), "simserpent_msgs/ContactEstimates")?,
                contact_estimates: if estimation {
                    Some(channel(w, &ros.topic(CONTACT_ESTIMATES_TOPIC), "simserpent_msgs/ContactEstimates")?)
                } else {
                    None
                },
                wrench: joints
                    .iter()
                    .map(|j| channel(w, &ros.topic(&format!("{j}/wrench")), "geometry_msgs/WrenchStamped"))
                    .collect::<Result<_, _>>()?,
                imu: links
                    .iter()
                    .map(|l| channel(w, &ros.topic(&format!("{l}/imu")), "sensor_msgs/Imu"))
                    .collect::<Result<_, _>>()?,
                contact_wrench: links
                    .iter()
                    .map(|l| channel(w, &ros.topic(&format!("{l}/contact_wrench")), "geometry_msgs/WrenchStamped"))
                    .collect::<Result<_, _>>()?,
            })
        })()
        .map_err(bag_err(&path))?;
        // The schemas and channels in a chunk of their own, on disk at once: damage to the
        // first chunk of messages then leaves every later chunk readable (`bag-repair`).
        writer.flush().map_err(bag_err(&path))?;
        Ok(Self {
            out: Out { path, writer: Some(writer), buf: Vec::with_capacity(64 * 1024), sequence: 0 },
            channels,
            instants: 0,
            split: messages.contact_split(),
            messages,
        })
    }

    /// Writes every topic of one recorded instant (`command`: the command block of the run's
    /// control method).
    pub fn write_instant(&mut self, s: &Snapshot, command: &[f64]) -> Result<(), RecordError> {
        let nanos = msgs::nanos(s.time_secs);
        let stamp = Time::from_nanos(nanos);
        let (ch, out, msg) = (&self.channels, &mut self.out, &self.messages);
        out.put(ch.clock, nanos, &Clock { clock: stamp })?;
        let m = &s.observation_measured;
        let measured = msg.joint_state(stamp, &m.joint_angle_rad, &m.joint_velocity_rad_per_s, &m.actuator_torque_nm);
        out.put(ch.joint_states, nanos, &measured)?;
        let truth =
            msg.joint_state(stamp, &s.joint_angle_rad, &s.joint_velocity_rad_per_s, &s.joint_actuator_torque_nm);
        out.put(ch.joint_states_true, nanos, &truth)?;
        out.put(ch.tf, nanos, &msg.tf(stamp, s))?;
        for i in 0..msg.links.len() {
            out.put(ch.imu[i], nanos, &msg.imu(stamp, m, i))?;
            out.put(ch.contact_wrench[i], nanos, &msg.contact_wrench(stamp, s, i))?;
        }
        for j in 0..msg.joints.len() {
            out.put(ch.wrench[j], nanos, &msg.joint_wrench(stamp, m, j))?;
        }
        let command = Float64MultiArray { layout: MultiArrayLayout { dim: &[], data_offset: 0 }, data: command };
        out.put(ch.command, nanos, &command)?;
        out.put(ch.contacts, nanos, &msg.contacts(stamp, s))?;
        out.put(ch.contact_states, nanos, &msg.contact_states(stamp, s))?;
        out.put(ch.contact_forces, nanos, &msg.contact_forces(stamp, s, &mut self.split))?;
        if let Some(channel) = ch.contact_estimates {
            out.put(channel, nanos, &msg.contact_estimates(stamp, m))?;
        }
        self.instants += 1;
        Ok(())
    }

    /// Finishes the bag (last chunk, indexes, summary, footer) and syncs it. Returns (file name,
    /// recorded instants) for the manifest, and the error if the file could not be completed.
    /// A bag that was never finished (the process was killed) lacks its summary and footer;
    /// `simserpent bag-repair RUN_FOLDER` rebuilds it from the chunks written so far.
    pub fn finish(mut self) -> (Vec<(String, u64)>, Result<(), RecordError>) {
        let mut result = Ok(());
        let path = &self.out.path;
        if let Some(mut writer) = self.out.writer.take() {
            result = writer.finish().map(|_| ()).map_err(bag_err(path));
            if result.is_ok() {
                result = writer
                    .into_inner()
                    .into_inner()
                    .finish()
                    .and_then(|file| file.sync_all())
                    .map_err(crate::record::io_err(path));
            }
        }
        (vec![(FILE_NAME.to_string(), self.instants)], result)
    }
}
