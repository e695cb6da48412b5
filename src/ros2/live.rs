//! The live ROS 2 bridge (`simserpent run --ros2`, cargo feature `ros2`): the bag's topics
//! published over DDS while the run simulates, and joint commands taken from DDS.
//!
//! DDS is RustDDS (pure Rust, the RTPS wire protocol every ROS 2 middleware speaks); ROS 2
//! names map onto DDS as ROS 2 does it: topic `/joint_states` is DDS topic `rt/joint_states`,
//! type `sensor_msgs/msg/JointState` is `sensor_msgs::msg::dds_::JointState_`, payloads are
//! CDR (the bytes of [`super::msgs::encode`]).
//!
//! The bridge is an [`Observer`] of the step loop:
//! - at recorded instants (`recording.every_n_steps`; a forward pass has run, so poses and
//!   contact forces describe the instant): `/tf`, `/<ns>/link_NN/contact_wrench`,
//!   `/<ns>/contacts`, `/<ns>/ground_truth/contacts`, `/<ns>/ground_truth/contact_forces`;
//! - at publish instants (`ros2.publish_rate_hz` with the free clock, every
//!   `ros2.steps_per_command` steps in lockstep): `/clock`, `/joint_states` (measured),
//!   `/<ns>/ground_truth/joint_states`, `/<ns>/link_NN/imu`, `/<ns>/joint_NN/wrench`,
//!   `/<ns>/contact_estimates` (with `[estimation] enabled`);
//! - at every step it takes the commands that arrived ([`super::commands::CommandGate`]);
//!   in lockstep it first publishes, then waits for a command; with the free clock it sleeps
//!   to keep `ros2.real_time_factor`.
//!
//! A command that answers the state of instant k acts from instant k + 1 (the step from k was
//! already commanded when the state of k was published): one step of transport delay, as a
//! real robot's sensor-to-actuator loop has.

use super::bag::{CONTACT_ESTIMATES_TOPIC, CONTACT_FORCES_TOPIC, CONTACT_STATES_TOPIC, RobotMessages};
use super::commands::{CommandGate, CommandSource, Float64MultiArrayMsg, Interface, JointTrajectoryMsg, Ros2Report};
use super::msgs::{self, Clock, Time};
use super::{LiveBridge, Ros2Error};
use crate::config::{Config, Ros2Clock, Ros2Durability, Ros2Reliability};
use crate::sim::{Index, Observer, StepView};
use crate::state::Snapshot;
use rustdds::no_key::{DataReader, DataWriter, SerializerAdapter};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    CDRDeserializerAdapter, DataWriterStatus, DomainParticipant, Publisher, QosPolicies, QosPolicyBuilder,
    RepresentationIdentifier, StatusEvented, Subscriber, TopicKind,
};
use std::time::{Duration, Instant};

/// A message already encoded as CDR (without the encapsulation header, which RustDDS writes).
#[derive(Debug)]
struct RawCdr(bytes::Bytes);

/// Passes [`RawCdr`] through to RustDDS unchanged.
struct RawAdapter;

impl SerializerAdapter<RawCdr> for RawAdapter {
    type Error = std::convert::Infallible;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &RawCdr) -> Result<bytes::Bytes, Self::Error> {
        Ok(value.0.clone())
    }
}

type Writer = DataWriter<RawCdr, RawAdapter>;
type Reader<D> = DataReader<D, CDRDeserializerAdapter<D>>;

/// The DDS name of a ROS 2 type: `sensor_msgs/JointState` → `sensor_msgs::msg::dds_::JointState_`.
pub fn dds_type_name(type_name: &str) -> String {
    match type_name.split_once('/') {
        Some((package, name)) => format!("{package}::msg::dds_::{name}_"),
        None => type_name.to_string(),
    }
}

/// The DDS topic of a ROS 2 topic: `/joint_states` → `rt/joint_states`.
pub fn dds_topic_name(topic: &str) -> String {
    format!("rt/{}", topic.trim_start_matches('/'))
}

struct Writers {
    clock: Writer,
    joint_states: Writer,
    joint_states_true: Writer,
    tf: Writer,
    contacts: Writer,
    contact_states: Writer,
    contact_forces: Writer,
    contact_estimates: Option<Writer>,
    imu: Vec<Writer>,
    wrench: Vec<Writer>,
    contact_wrench: Vec<Writer>,
}

struct Readers {
    arrays: Vec<(Interface, String, Reader<Float64MultiArrayMsg>)>,
    trajectory: (String, Reader<JointTrajectoryMsg>),
}

/// The bridge: DDS participant, writers, readers, the command gate (see the module doc).
pub struct Bridge {
    writers: Writers,
    readers: Readers,
    gate: CommandGate,
    buf: Vec<u8>,
    messages: RobotMessages,
    /// The buffer of the true contact forces' message.
    split: crate::state::ContactEstimates,
    clock: Ros2Clock,
    publish_every_n_steps: u64,
    steps_per_command: u64,
    real_time_factor: f64,
    timeout: Duration,
    started: Option<Instant>,
    domain_id: u16,
    report: Ros2Report,
    /// Last: dropped after its writers and readers.
    _participant: DomainParticipant,
}

fn dds_err(what: &str) -> impl FnOnce(rustdds::dds::CreateError) -> Ros2Error + '_ {
    move |e| Ros2Error::Dds { what: what.to_string(), message: format!("{e:?}") }
}

impl Bridge {
    /// Joins DDS domain `ros2.domain_id` with a writer per topic and a reader per command topic
    /// for the robot of `index`; returns the bridge and the controller that applies the
    /// commands.
    pub fn open(config: &Config, index: &Index) -> Result<(Self, CommandSource), Ros2Error> {
        let ros = &config.ros2;
        let mut builder = rustdds::DomainParticipantBuilder::new(ros.domain_id);
        if !ros.interfaces.is_empty() {
            // Validated as IP addresses with the config.
            let addrs: Vec<std::net::IpAddr> = ros.interfaces.iter().filter_map(|a| a.parse().ok()).collect();
            builder = builder.with_only_networks(addrs);
        }
        let participant = builder.build().map_err(dds_err("joining the DDS domain"))?;
        let qos = qos(config);
        let publisher = participant.create_publisher(&qos).map_err(dds_err("creating the publisher"))?;
        let subscriber = participant.create_subscriber(&qos).map_err(dds_err("creating the subscriber"))?;
        let writer = |topic: &str, ty: &str| -> Result<Writer, Ros2Error> {
            make_writer(&participant, &publisher, &qos, topic, ty)
        };
        let messages = RobotMessages::new(config, index);
        let (links, joints) = (&messages.links, &messages.joints);
        let writers = Writers {
            clock: writer("/clock", "rosgraph_msgs/Clock")?,
            joint_states: writer("/joint_states", "sensor_msgs/JointState")?,
            joint_states_true: writer(&ros.topic("ground_truth/joint_states"), "sensor_msgs/JointState")?,
            tf: writer("/tf", "tf2_msgs/TFMessage")?,
            contacts: writer(&ros.topic("contacts"), "visualization_msgs/MarkerArray")?,
            contact_states: writer(&ros.topic(CONTACT_STATES_TOPIC), "ros_gz_interfaces/Contacts")?,
            contact_forces: writer(&ros.topic(CONTACT_FORCES_TOPIC), "simserpent_msgs/ContactEstimates")?,
            contact_estimates: if messages.estimation {
                Some(writer(&ros.topic(CONTACT_ESTIMATES_TOPIC), "simserpent_msgs/ContactEstimates")?)
            } else {
                None
            },
            imu: links
                .iter()
                .map(|l| writer(&ros.topic(&format!("{l}/imu")), "sensor_msgs/Imu"))
                .collect::<Result<_, _>>()?,
            wrench: joints
                .iter()
                .map(|j| writer(&ros.topic(&format!("{j}/wrench")), "geometry_msgs/WrenchStamped"))
                .collect::<Result<_, _>>()?,
            contact_wrench: links
                .iter()
                .map(|l| writer(&ros.topic(&format!("{l}/contact_wrench")), "geometry_msgs/WrenchStamped"))
                .collect::<Result<_, _>>()?,
        };
        let mut arrays = Vec::new();
        for (interface, kind) in
            [(Interface::Position, "position"), (Interface::Velocity, "velocity"), (Interface::Effort, "effort")]
        {
            let topic = ros.topic(&format!("forward_{kind}_controller/commands"));
            arrays.push((
                interface,
                topic.clone(),
                make_reader(&participant, &subscriber, &qos, &topic, "std_msgs/Float64MultiArray")?,
            ));
        }
        let trajectory_topic = ros.topic("joint_trajectory_controller/joint_trajectory");
        let trajectory = (
            trajectory_topic.clone(),
            make_reader(&participant, &subscriber, &qos, &trajectory_topic, "trajectory_msgs/JointTrajectory")?,
        );
        let (gate, source) = CommandGate::new(joints.clone(), config.control.method);
        let dt = config.general.timestep_secs;
        let publish_every_n_steps = match ros.clock {
            Ros2Clock::Free => (1.0 / (ros.publish_rate_hz * dt)).round().max(1.0) as u64,
            Ros2Clock::Lockstep => ros.steps_per_command,
        };
        let report = Ros2Report {
            clock: match ros.clock {
                Ros2Clock::Free => "free",
                Ros2Clock::Lockstep => "lockstep",
            }
            .to_string(),
            domain_id: ros.domain_id,
            ..Ros2Report::default()
        };
        let bridge = Self {
            _participant: participant,
            writers,
            readers: Readers { arrays, trajectory },
            gate,
            buf: Vec::with_capacity(64 * 1024),
            split: messages.contact_split(),
            messages,
            clock: ros.clock,
            publish_every_n_steps,
            steps_per_command: ros.steps_per_command,
            real_time_factor: ros.real_time_factor,
            timeout: Duration::from_secs_f64(ros.lockstep_timeout_secs),
            started: None,
            domain_id: ros.domain_id,
            report,
        };
        Ok((bridge, source))
    }

    /// Encodes `message` and writes it on `writer`.
    fn put<T: serde::Serialize>(buf: &mut Vec<u8>, writer: &Writer, message: &T) -> Result<(), Ros2Error> {
        msgs::encode(buf, message).map_err(|e| Ros2Error::Dds { what: "encoding".into(), message: e.to_string() })?;
        let payload = bytes::Bytes::copy_from_slice(&buf[4..]);
        writer
            .write(RawCdr(payload), None)
            .map_err(|e| Ros2Error::Dds { what: "publishing".into(), message: format!("{e:?}") })
    }

    /// The state topics of the instant of `view` (counted by the caller: a lockstep resend of
    /// the same instant is not a new published instant).
    fn publish_state(&mut self, view: &StepView<'_>) -> Result<(), Ros2Error> {
        let stamp = Time::from_nanos(msgs::nanos(view.time_secs()));
        let (w, buf, msg) = (&self.writers, &mut self.buf, &self.messages);
        Self::put(buf, &w.clock, &Clock { clock: stamp })?;
        let m = view.observation;
        let measured = msg.joint_state(stamp, &m.joint_angle_rad, &m.joint_velocity_rad_per_s, &m.actuator_torque_nm);
        Self::put(buf, &w.joint_states, &measured)?;
        let t = view.observation_true;
        let truth = msg.joint_state(stamp, &t.joint_angle_rad, &t.joint_velocity_rad_per_s, &t.actuator_torque_nm);
        Self::put(buf, &w.joint_states_true, &truth)?;
        for (i, writer) in w.imu.iter().enumerate() {
            Self::put(buf, writer, &msg.imu(stamp, m, i))?;
        }
        for (j, writer) in w.wrench.iter().enumerate() {
            Self::put(buf, writer, &msg.joint_wrench(stamp, m, j))?;
        }
        if let Some(writer) = &w.contact_estimates {
            Self::put(buf, writer, &msg.contact_estimates(stamp, m))?;
        }
        Ok(())
    }

    /// Takes every command that arrived; returns how many were valid.
    fn take_commands(&mut self, now_secs: f64) -> u64 {
        let before = self.gate.accepted();
        for (interface, topic, reader) in &mut self.readers.arrays {
            loop {
                match reader.take_next_sample() {
                    Ok(Some(sample)) => {
                        let _ = self.gate.array(*interface, &sample.value().data);
                    }
                    Ok(None) => break,
                    Err(e) => {
                        self.gate.undecodable(topic, &format!("{e:?}"));
                        break;
                    }
                }
            }
        }
        let (topic, reader) = &mut self.readers.trajectory;
        loop {
            match reader.take_next_sample() {
                Ok(Some(sample)) => {
                    let _ = self.gate.trajectory(sample.value(), now_secs);
                }
                Ok(None) => break,
                Err(e) => {
                    self.gate.undecodable(topic, &format!("{e:?}"));
                    break;
                }
            }
        }
        self.gate.accepted() - before
    }

    /// Lockstep, before the first state: waits until a peer subscribes to `/joint_states`
    /// (a volatile sample written before that would be lost, and the loop would wait forever).
    /// Necessary, not sufficient: the peer may learn of this writer only after the first sample
    /// arrived ([`super::FIRST_STATE_RESEND_SECS`] covers that).
    fn wait_for_peer(&mut self) -> Result<(), Ros2Error> {
        let start = Instant::now();
        let mut matched = false;
        while !matched {
            while let Some(status) = self.writers.joint_states.try_recv_status() {
                if let DataWriterStatus::PublicationMatched { current, .. } = status {
                    matched = current.count() > 0;
                }
            }
            if matched {
                break;
            }
            if start.elapsed() >= self.timeout {
                let e = Ros2Error::NoPeer { waited_secs: start.elapsed().as_secs_f64(), domain_id: self.domain_id };
                self.report.stopped = Some(e.to_string());
                return Err(e);
            }
            if crate::interrupt::requested() {
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Ok(())
    }

    /// Lockstep, after the first answer when the first state was sent more than once: a peer
    /// that received several copies answers each. Every command that arrives within `window`
    /// still answers the first instant (the next state is not published yet); it is applied in
    /// turn (the last valid one holds) and counted as an extra answer, so that it does not
    /// count as the answer to the next instant.
    fn absorb_extra_answers(&mut self, view: &StepView<'_>, window: Duration) {
        let start = Instant::now();
        while start.elapsed() < window && !crate::interrupt::requested() {
            self.report.lockstep_extra_answers += self.take_commands(view.time_secs());
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// Lockstep: waits until a valid command arrives, or the timeout. Until the first command
    /// has come, the state of the instant is published again every
    /// [`super::FIRST_STATE_RESEND_SECS`] (see there: the peer's reader may have missed it).
    fn wait_for_command(&mut self, view: &StepView<'_>) -> Result<(), Ros2Error> {
        let start = Instant::now();
        let resend_every = Duration::from_secs_f64(super::FIRST_STATE_RESEND_SECS);
        let mut sent = start;
        let mut idle = 0u32;
        loop {
            let valid = self.take_commands(view.time_secs());
            if valid > 0 {
                self.report.lockstep_commands += 1;
                if self.report.lockstep_commands == 1 && self.report.lockstep_state_resends > 0 {
                    // Answers to several copies may arrive together.
                    self.report.lockstep_extra_answers += valid - 1;
                    self.absorb_extra_answers(view, resend_every);
                }
                return Ok(());
            }
            if self.report.lockstep_commands == 0 && sent.elapsed() >= resend_every {
                self.publish_state(view)?;
                self.report.lockstep_state_resends += 1;
                sent = Instant::now();
            }
            let waited = start.elapsed();
            if waited >= self.timeout {
                let e = Ros2Error::PeerTimeout {
                    waited_secs: waited.as_secs_f64(),
                    time_secs: view.time_secs(),
                    step: view.k,
                };
                self.report.stopped = Some(e.to_string());
                return Err(e);
            }
            if crate::interrupt::requested() {
                return Ok(());
            }
            // Spin briefly (a loopback round trip is tens of microseconds), then sleep.
            idle += 1;
            if idle < 200 {
                std::thread::yield_now();
            } else {
                std::thread::sleep(Duration::from_micros(50));
            }
        }
    }
}

fn qos(config: &Config) -> QosPolicies {
    let ros = &config.ros2;
    QosPolicyBuilder::new()
        .reliability(match ros.reliability {
            Ros2Reliability::Reliable => {
                Reliability::Reliable { max_blocking_time: rustdds::Duration::from_millis(100) }
            }
            Ros2Reliability::BestEffort => Reliability::BestEffort,
        })
        .durability(match ros.durability {
            Ros2Durability::Volatile => Durability::Volatile,
            Ros2Durability::TransientLocal => Durability::TransientLocal,
        })
        .history(History::KeepLast { depth: ros.history_depth.min(i32::MAX as u32) as i32 })
        .build()
}

fn make_writer(
    participant: &DomainParticipant,
    publisher: &Publisher,
    qos: &QosPolicies,
    topic: &str,
    ty: &str,
) -> Result<Writer, Ros2Error> {
    let t = participant
        .create_topic(dds_topic_name(topic), dds_type_name(ty), qos, TopicKind::NoKey)
        .map_err(dds_err(topic))?;
    publisher.create_datawriter_no_key::<RawCdr, RawAdapter>(&t, None).map_err(dds_err(topic))
}

fn make_reader<D: serde::de::DeserializeOwned + 'static>(
    participant: &DomainParticipant,
    subscriber: &Subscriber,
    qos: &QosPolicies,
    topic: &str,
    ty: &str,
) -> Result<Reader<D>, Ros2Error> {
    let t = participant
        .create_topic(dds_topic_name(topic), dds_type_name(ty), qos, TopicKind::NoKey)
        .map_err(dds_err(topic))?;
    subscriber.create_datareader_no_key_cdr::<D>(&t, None).map_err(dds_err(topic))
}

impl Observer<Ros2Error> for Bridge {
    fn on_start(&mut self, _view: &StepView<'_>) -> Result<(), Ros2Error> {
        // Lockstep: a peer before anything of instant 0 (also its /tf) is published.
        if self.clock == Ros2Clock::Lockstep {
            self.wait_for_peer()?;
        }
        self.started = Some(Instant::now());
        Ok(())
    }

    fn on_record(&mut self, _view: &StepView<'_>, s: &Snapshot) -> Result<(), Ros2Error> {
        let stamp = Time::from_nanos(msgs::nanos(s.time_secs));
        let (w, buf, msg) = (&self.writers, &mut self.buf, &self.messages);
        Self::put(buf, &w.tf, &msg.tf(stamp, s))?;
        for (i, writer) in w.contact_wrench.iter().enumerate() {
            Self::put(buf, writer, &msg.contact_wrench(stamp, s, i))?;
        }
        Self::put(buf, &w.contacts, &msg.contacts(stamp, s))?;
        Self::put(buf, &w.contact_states, &msg.contact_states(stamp, s))?;
        Self::put(buf, &w.contact_forces, &msg.contact_forces(stamp, s, &mut self.split))?;
        Ok(())
    }

    fn on_step(&mut self, view: &StepView<'_>) -> Result<(), Ros2Error> {
        let publish = view.k.is_multiple_of(self.publish_every_n_steps) || view.k >= view.plan.steps;
        if publish {
            self.publish_state(view)?;
            self.report.published_instants += 1;
        }
        match self.clock {
            Ros2Clock::Lockstep => {
                if view.k.is_multiple_of(self.steps_per_command) && view.k < view.plan.steps {
                    self.wait_for_command(view)?;
                }
            }
            Ros2Clock::Free => {
                self.take_commands(view.time_secs());
                if publish && self.real_time_factor > 0.0 {
                    let due = Duration::from_secs_f64(view.time_secs() / self.real_time_factor);
                    let elapsed = self.started.map(|s| s.elapsed()).unwrap_or_default();
                    if due > elapsed {
                        std::thread::sleep(due - elapsed);
                    }
                }
            }
        }
        Ok(())
    }
}

impl LiveBridge for Bridge {
    fn report(&self) -> Ros2Report {
        let mut r = self.report.clone();
        self.gate.fill(&mut r);
        r
    }
}
