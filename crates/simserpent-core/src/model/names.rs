//! Names of every element of the generated MJCF model.
//!
//! These names are the contract between the model generator and everything that reads the
//! simulation (recording, controllers, contact read-out): look elements up by these names, never
//! by index arithmetic.
//!
//! | element | name | note |
//! |---|---|---|
//! | body of link `i` (0 = head) | `link_00`, `link_01`, … | [`link_body`] |
//! | capsule geom of link `i` | `link_00_geom` | [`link_geom`] |
//! | IMU site of link `i` (link centre) | `link_00_imu` | [`link_site`] |
//! | hinge joint `j` (`j >= 1`, between link `j-1` and link `j`) | `joint_01` | [`joint`] |
//! | site at the anchor of joint `j` (origin of link `j`) | `joint_01_site` | [`joint_site`] |
//! | actuator of kind `k` on joint `j` | `torque_01`, `position_01`, `velocity_01`, `intvelocity_01` | [`actuator`] |
//! | free joint of the head | `head_free` | [`HEAD_FREE_JOINT`] |
//! | floor plane | `floor` | [`FLOOR`] |
//! | keyframe with the starting pose | `initial` | [`INITIAL_KEYFRAME`] |
//! | obstacle `k` (geom in the world body: cylinders of `terrain.kind`, then pegs, walls, channel walls, mesh obstacles) | `obstacle_00` | [`obstacle`] |
//! | mesh asset of a mesh obstacle | `obstacle_05_mesh` | [`obstacle_mesh`] |
//! | ground-like terrain surfaces (counted as floor): slope box, heightfield from a PNG, rasterised mesh terrain (geom and hfield asset) | `terrain_slope`, `terrain_heightfield`, `terrain_mesh` | [`TERRAIN_SLOPE`], [`TERRAIN_HEIGHTFIELD`], [`TERRAIN_MESH`], [`is_ground`] |
//! | visual tile of floor surface `k` (`ground.surfaces[k]`; no collisions) | `surface_00` | [`surface`] |
//! | sensors | `link_00_vel`, `link_00_accel`, `link_00_gyro`, `link_00_pos`, `link_00_quat`, `joint_01_force`, `joint_01_torque`, `joint_01_angle`, `joint_01_angvel` | [`sensor`], [`SensorKind`] |
//!
//! Indices are written with at least two digits (`{:02}`): `link_00` … `link_99`. Models with more
//! than 100 links continue with three digits (`link_100`, `link_101`, …); every name still maps to
//! exactly one index (`usize::from_str` on the digits gives it back).
//!
//! Link indices start at 0 (the head); joint indices start at 1, so that joint `j` sits at the
//! front end of link `j`. Obstacles are numbered from 0 in the order of
//! [`GeneratedModel::obstacles`](super::GeneratedModel::obstacles).

use crate::config::ControlMethod;

/// Name of the head's free joint (the 7 first `qpos` entries: position, then quaternion w x y z).
pub const HEAD_FREE_JOINT: &str = "head_free";
/// Name of the floor plane geom.
pub const FLOOR: &str = "floor";
/// The slope's box geom (`[terrain.slope]`).
pub const TERRAIN_SLOPE: &str = "terrain_slope";
/// The heightfield from a PNG image (`[terrain.heightfield]`): geom and hfield asset.
pub const TERRAIN_HEIGHTFIELD: &str = "terrain_heightfield";
/// The rasterised mesh terrain (`[terrain.mesh_terrain]`): geom and hfield asset.
pub const TERRAIN_MESH: &str = "terrain_mesh";

/// Whether a geom carries the snake like the floor: the floor and the ground-like terrain
/// surfaces (`terrain_*`). Contact forces with them count as floor forces.
pub fn is_ground(geom_name: &str) -> bool {
    geom_name == FLOOR || geom_name.starts_with("terrain_")
}

/// Mesh asset of the mesh obstacle geom `obstacle`: `obstacle_05_mesh`.
pub fn obstacle_mesh(obstacle: &str) -> String {
    format!("{obstacle}_mesh")
}

/// Name of the keyframe that holds the starting pose (head pose and initial joint angles).
pub const INITIAL_KEYFRAME: &str = "initial";

fn idx(i: usize) -> String {
    format!("{i:02}")
}

/// Body of link `i` (0 = head): `link_00`.
pub fn link_body(i: usize) -> String {
    format!("link_{}", idx(i))
}

/// Capsule geom of link `i`: `link_00_geom`.
pub fn link_geom(i: usize) -> String {
    format!("link_{}_geom", idx(i))
}

/// IMU site of link `i`, at the link's centre: `link_00_imu`. The link's velocimeter,
/// accelerometer, gyro, framepos and framequat sensors are attached to it.
pub fn link_site(i: usize) -> String {
    format!("link_{}_imu", idx(i))
}

/// Hinge joint `j` (`j >= 1`), which connects link `j - 1` (parent) and link `j`: `joint_01`.
pub fn joint(j: usize) -> String {
    format!("joint_{}", idx(j))
}

/// Site at the anchor of joint `j` (the origin of link `j`), carrying the joint's force and torque
/// sensors: `joint_01_site`.
pub fn joint_site(j: usize) -> String {
    format!("joint_{}_site", idx(j))
}

/// Actuator of the given kind on joint `j`: `torque_01`, `position_01`, `velocity_01`,
/// `intvelocity_01`.
pub fn actuator(kind: ControlMethod, j: usize) -> String {
    format!("{}_{}", kind.name(), idx(j))
}

/// Obstacle `k` (a cylinder geom in the world body): `obstacle_00`.
pub fn obstacle(k: usize) -> String {
    format!("obstacle_{}", idx(k))
}

/// Visual tile of floor surface `k` (`ground.surfaces[k]`, a box or cylinder geom in the world
/// body that never collides): `surface_00`.
pub fn surface(k: usize) -> String {
    format!("surface_{}", idx(k))
}

/// The contact pair between link `i` and the floor (anisotropic and directional ground
/// friction, and isotropic with floor surfaces): `link_00_ground`.
pub fn ground_pair(i: usize) -> String {
    format!("{}_ground", link_body(i))
}

/// The kinds of sensors in the model, in the order they are written per link / per joint.
///
/// All link sensors of link 0 come first (in [`SensorKind::LINK`] order), then those of link 1, …;
/// then all joint sensors of joint 1 (in [`SensorKind::JOINT`] order), joint 2, ….
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SensorKind {
    /// `velocimeter` at the link's IMU site: linear velocity in the site frame (m/s). `link_ii_vel`.
    LinkVelocity,
    /// `accelerometer` at the link's IMU site: linear acceleration minus gravity, site frame
    /// (m/s²). `link_ii_accel` (mujoco_ros2_control's default IMU suffixes: `_quat`, `_gyro`, `_accel`).
    LinkAcceleration,
    /// `gyro` at the link's IMU site: angular velocity in the site frame (rad/s). `link_ii_gyro`.
    LinkGyro,
    /// `framepos` of the link's IMU site: world position (m). `link_ii_pos`.
    LinkPosition,
    /// `framequat` of the link's IMU site: world orientation (w x y z). `link_ii_quat`.
    LinkQuat,
    /// `force` at the joint site: force that the parent link exerts on link `j` and everything
    /// behind it, in the joint site frame (= link `j` frame), N. `joint_jj_force`.
    JointForce,
    /// `torque` at the joint site: the matching torque about the joint anchor, N·m.
    /// `joint_jj_torque`.
    JointTorque,
    /// `jointpos` of the hinge (rad). `joint_jj_angle`.
    JointAngle,
    /// `jointvel` of the hinge (rad/s). `joint_jj_angvel`.
    JointAngularVelocity,
}

impl SensorKind {
    /// Per-link sensors, in model order.
    pub const LINK: [SensorKind; 5] =
        [Self::LinkVelocity, Self::LinkAcceleration, Self::LinkGyro, Self::LinkPosition, Self::LinkQuat];
    /// Per-joint sensors, in model order.
    pub const JOINT: [SensorKind; 4] =
        [Self::JointForce, Self::JointTorque, Self::JointAngle, Self::JointAngularVelocity];

    /// Whether the index of this sensor is a link index (else a joint index, `>= 1`).
    pub fn is_link(self) -> bool {
        matches!(
            self,
            Self::LinkVelocity | Self::LinkAcceleration | Self::LinkGyro | Self::LinkPosition | Self::LinkQuat
        )
    }

    /// Suffix of the sensor name (`vel`, `accel`, `gyro`, `pos`, `quat`, `force`, `torque`, `angle`,
    /// `angvel`).
    pub fn suffix(self) -> &'static str {
        match self {
            Self::LinkVelocity => "vel",
            Self::LinkAcceleration => "accel",
            Self::LinkGyro => "gyro",
            Self::LinkPosition => "pos",
            Self::LinkQuat => "quat",
            Self::JointForce => "force",
            Self::JointTorque => "torque",
            Self::JointAngle => "angle",
            Self::JointAngularVelocity => "angvel",
        }
    }

    /// The MJCF element that defines this sensor.
    pub fn mjcf_element(self) -> &'static str {
        match self {
            Self::LinkVelocity => "velocimeter",
            Self::LinkAcceleration => "accelerometer",
            Self::LinkGyro => "gyro",
            Self::LinkPosition => "framepos",
            Self::LinkQuat => "framequat",
            Self::JointForce => "force",
            Self::JointTorque => "torque",
            Self::JointAngle => "jointpos",
            Self::JointAngularVelocity => "jointvel",
        }
    }

    /// Number of values the sensor produces.
    pub fn dim(self) -> usize {
        match self {
            Self::LinkQuat => 4,
            Self::JointAngle | Self::JointAngularVelocity => 1,
            _ => 3,
        }
    }
}

/// Name of a sensor: `link_{ii}_{suffix}` for link sensors (index = link, from 0),
/// `joint_{jj}_{suffix}` for joint sensors (index = joint, from 1).
pub fn sensor(kind: SensorKind, index: usize) -> String {
    let prefix = if kind.is_link() { "link" } else { "joint" };
    format!("{prefix}_{}_{}", idx(index), kind.suffix())
}

/// `link_ii_vel` (velocimeter).
pub fn link_velocimeter(i: usize) -> String {
    sensor(SensorKind::LinkVelocity, i)
}

/// `link_ii_accel` (accelerometer).
pub fn link_accelerometer(i: usize) -> String {
    sensor(SensorKind::LinkAcceleration, i)
}

/// `link_ii_gyro` (gyro).
pub fn link_gyro(i: usize) -> String {
    sensor(SensorKind::LinkGyro, i)
}

/// `link_ii_pos` (framepos of the IMU site).
pub fn link_framepos(i: usize) -> String {
    sensor(SensorKind::LinkPosition, i)
}

/// `link_ii_quat` (framequat of the IMU site).
pub fn link_framequat(i: usize) -> String {
    sensor(SensorKind::LinkQuat, i)
}

/// `joint_jj_force` (force sensor at the joint site).
pub fn joint_force(j: usize) -> String {
    sensor(SensorKind::JointForce, j)
}

/// `joint_jj_torque` (torque sensor at the joint site).
pub fn joint_torque(j: usize) -> String {
    sensor(SensorKind::JointTorque, j)
}

/// `joint_jj_angle` (jointpos).
pub fn joint_angle(j: usize) -> String {
    sensor(SensorKind::JointAngle, j)
}

/// `joint_jj_angvel` (jointvel).
pub fn joint_angvel(j: usize) -> String {
    sensor(SensorKind::JointAngularVelocity, j)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(link_body(0), "link_00");
        assert_eq!(link_geom(3), "link_03_geom");
        assert_eq!(link_site(12), "link_12_imu");
        assert_eq!(joint(1), "joint_01");
        assert_eq!(joint_site(1), "joint_01_site");
        assert_eq!(actuator(ControlMethod::Intvelocity, 2), "intvelocity_02");
        assert_eq!(obstacle(0), "obstacle_00");
        assert_eq!(surface(7), "surface_07");
        assert_eq!(link_body(119), "link_119");
        assert_eq!(sensor(SensorKind::JointAngularVelocity, 4), "joint_04_angvel");
        assert_eq!(link_framequat(0), "link_00_quat");
    }

    /// mujoco_ros2_control builds a ros2_control IMU from the MJCF sensors `<name>_quat`,
    /// `<name>_gyro` and `<name>_accel`, and a force/torque sensor from `<name>_force` and
    /// `<name>_torque` (its default suffixes): `mujoco_sensor_name` `link_03` and `joint_03`
    /// find ours without any suffix parameter.
    #[test]
    fn names_follow_mujoco_ros2_control_default_suffixes() {
        let imu = link_body(3);
        assert_eq!(link_framequat(3), format!("{imu}_quat"));
        assert_eq!(link_gyro(3), format!("{imu}_gyro"));
        assert_eq!(link_accelerometer(3), format!("{imu}_accel"));
        let ft = joint(3);
        assert_eq!(joint_force(3), format!("{ft}_force"));
        assert_eq!(joint_torque(3), format!("{ft}_torque"));
    }
}
