//! The ROS 2 messages SimSerpent writes, as serde types that borrow the run's buffers (so a
//! message is serialised without allocating), and their definitions (`.msg` text, the
//! `ros2msg` schema encoding of MCAP) for the bag file.
//!
//! The wire format is ROS 2's: OMG CDR, little-endian, behind the 4-byte encapsulation header
//! `00 01 00 00` (CDR_LE), serialised by the `cdr-encoding` crate (RustDDS's serialiser). Field
//! order and types follow the definitions below, which are those of ROS 2 Jazzy's
//! `common_interfaces` (comments and constants left out; they do not change the wire format).

use serde::Serialize;
use serde::ser::{SerializeStruct, Serializer};

/// `builtin_interfaces/Time` (and `Duration`, same fields): seconds and nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// The time of `nanos` nanoseconds since the start.
    pub fn from_nanos(nanos: u64) -> Self {
        Self { sec: (nanos / 1_000_000_000) as i32, nanosec: (nanos % 1_000_000_000) as u32 }
    }
}

/// Simulated time in nanoseconds (rounded to the nearest nanosecond).
pub fn nanos(time_secs: f64) -> u64 {
    (time_secs.max(0.0) * 1e9).round() as u64
}

/// `rosgraph_msgs/Clock`.
#[derive(Debug, Serialize)]
pub struct Clock {
    pub clock: Time,
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Header<'a> {
    pub stamp: Time,
    pub frame_id: &'a str,
}

/// `sensor_msgs/JointState`.
#[derive(Debug, Serialize)]
pub struct JointState<'a> {
    pub header: Header<'a>,
    pub name: &'a [String],
    pub position: &'a [f64],
    pub velocity: &'a [f64],
    pub effort: &'a [f64],
}

/// `geometry_msgs/Vector3` (and `Point`: same fields).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl From<[f64; 3]> for Vector3 {
    fn from(v: [f64; 3]) -> Self {
        Self { x: v[0], y: v[1], z: v[2] }
    }
}

/// `geometry_msgs/Quaternion` (x, y, z, w: ROS order; MuJoCo's is w, x, y, z).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    /// From MuJoCo's order (w, x, y, z).
    pub fn from_wxyz(q: [f64; 4]) -> Self {
        Self { x: q[1], y: q[2], z: q[3], w: q[0] }
    }
}

/// `geometry_msgs/Transform`.
#[derive(Debug, Serialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Debug, Serialize)]
pub struct TransformStamped<'a> {
    pub header: Header<'a>,
    pub child_frame_id: &'a str,
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage` of a robot's frames: one transform from `parent` to each of
/// `children[i]` (origin `position_m[i]`, orientation `quat_wxyz[i]`), serialised straight from
/// the slices.
#[derive(Debug)]
pub struct TfMessage<'a> {
    pub stamp: Time,
    pub parent: &'a str,
    pub children: &'a [String],
    pub position_m: &'a [[f64; 3]],
    pub quat_wxyz: &'a [[f64; 4]],
}

impl Serialize for TfMessage<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        struct Transforms<'b, 'a>(&'b TfMessage<'a>);
        impl Serialize for Transforms<'_, '_> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let m = self.0;
                let n = m.children.len().min(m.position_m.len()).min(m.quat_wxyz.len());
                serializer.collect_seq((0..n).map(|i| TransformStamped {
                    header: Header { stamp: m.stamp, frame_id: m.parent },
                    child_frame_id: &m.children[i],
                    transform: Transform {
                        translation: m.position_m[i].into(),
                        rotation: Quaternion::from_wxyz(m.quat_wxyz[i]),
                    },
                }))
            }
        }
        let mut s = serializer.serialize_struct("TFMessage", 1)?;
        s.serialize_field("transforms", &Transforms(self))?;
        s.end()
    }
}

/// `geometry_msgs/Wrench`.
#[derive(Debug, Serialize)]
pub struct Wrench {
    pub force: Vector3,
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`.
#[derive(Debug, Serialize)]
pub struct WrenchStamped<'a> {
    pub header: Header<'a>,
    pub wrench: Wrench,
}

/// `sensor_msgs/Imu`.
#[derive(Debug, Serialize)]
pub struct Imu<'a> {
    pub header: Header<'a>,
    pub orientation: Quaternion,
    pub orientation_covariance: [f64; 9],
    pub angular_velocity: Vector3,
    pub angular_velocity_covariance: [f64; 9],
    pub linear_acceleration: Vector3,
    pub linear_acceleration_covariance: [f64; 9],
}

/// A diagonal 3×3 covariance (row-major) with `variance` on the diagonal.
pub fn diagonal_covariance(variance: f64) -> [f64; 9] {
    let mut c = [0.0; 9];
    c[0] = variance;
    c[4] = variance;
    c[8] = variance;
    c
}

/// `std_msgs/MultiArrayDimension`.
#[derive(Debug, Serialize, serde::Deserialize)]
pub struct MultiArrayDimension<'a> {
    pub label: &'a str,
    pub size: u32,
    pub stride: u32,
}

/// `std_msgs/Float64MultiArray` as written (the layout left empty, as ros2_control's forward
/// command controllers expect it).
#[derive(Debug, Serialize)]
pub struct Float64MultiArray<'a> {
    pub layout: MultiArrayLayout<'a>,
    pub data: &'a [f64],
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Debug, Serialize)]
pub struct MultiArrayLayout<'a> {
    pub dim: &'a [MultiArrayDimension<'a>],
    pub data_offset: u32,
}

/// `std_msgs/ColorRGBA`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ColorRgba {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}

/// The contacts of one instant as `visualization_msgs/MarkerArray`: a `DELETEALL` marker (so
/// the arrows of the previous instant disappear), then per contact one `ARROW` from the contact
/// point along the force on the contact's second geom, `arrow_m_per_n` metres per newton
/// (namespace `contacts`, id = the contact's index in the instant's list).
#[derive(Debug)]
pub struct ContactMarkers<'a> {
    pub stamp: Time,
    pub frame_id: &'a str,
    pub contacts: &'a [crate::state::ContactRow],
    pub arrow_m_per_n: f64,
}

/// `visualization_msgs/Marker` constants used here.
pub mod marker {
    pub const ARROW: i32 = 0;
    pub const ADD: i32 = 0;
    pub const DELETEALL: i32 = 3;
}

#[derive(Serialize)]
struct Pose {
    position: Vector3,
    orientation: Quaternion,
}

/// Zero or two points of a marker, serialised as a sequence.
struct Points(Option<[Vector3; 2]>);

impl Serialize for Points {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match &self.0 {
            Some(p) => serializer.collect_seq(p.iter()),
            None => serializer.collect_seq(std::iter::empty::<Vector3>()),
        }
    }
}

#[derive(Serialize)]
struct CompressedImage<'a> {
    header: Header<'a>,
    format: &'a str,
    data: &'a [u8],
}

#[derive(Serialize)]
struct UvCoordinate {
    u: f32,
    v: f32,
}

#[derive(Serialize)]
struct MeshFile<'a> {
    filename: &'a str,
    data: &'a [u8],
}

#[derive(Serialize)]
struct Marker<'a> {
    header: Header<'a>,
    ns: &'a str,
    id: i32,
    #[serde(rename = "type")]
    kind: i32,
    action: i32,
    pose: Pose,
    scale: Vector3,
    color: ColorRgba,
    lifetime: Time,
    frame_locked: bool,
    points: Points,
    colors: &'a [ColorRgba],
    texture_resource: &'a str,
    texture: CompressedImage<'a>,
    uv_coordinates: &'a [UvCoordinate],
    text: &'a str,
    mesh_resource: &'a str,
    mesh_file: MeshFile<'a>,
    mesh_use_embedded_materials: bool,
}

impl<'a> Marker<'a> {
    fn new(header: Header<'a>, id: i32, action: i32, points: Option<[Vector3; 2]>) -> Self {
        Self {
            header,
            ns: "contacts",
            id,
            kind: marker::ARROW,
            action,
            pose: Pose { position: Vector3::default(), orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 } },
            // Arrow with points: shaft diameter, head diameter, head length (0 = default).
            scale: Vector3 { x: 0.004, y: 0.008, z: 0.0 },
            color: ColorRgba { r: 0.9, g: 0.2, b: 0.1, a: 1.0 },
            lifetime: Time::default(),
            frame_locked: false,
            points: Points(points),
            colors: &[],
            texture_resource: "",
            texture: CompressedImage { header: Header { stamp: Time::default(), frame_id: "" }, format: "", data: &[] },
            uv_coordinates: &[],
            text: "",
            mesh_resource: "",
            mesh_file: MeshFile { filename: "", data: &[] },
            mesh_use_embedded_materials: false,
        }
    }
}

impl Serialize for ContactMarkers<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        struct Markers<'b, 'a>(&'b ContactMarkers<'a>);
        impl Serialize for Markers<'_, '_> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let m = self.0;
                let header = Header { stamp: m.stamp, frame_id: m.frame_id };
                let clear = std::iter::once(Marker::new(header, 0, marker::DELETEALL, None));
                let arrows = m.contacts.iter().enumerate().map(|(i, c)| {
                    let p = c.position_m;
                    let f = c.force_on_geom2_n;
                    let s = m.arrow_m_per_n;
                    let tip = [p[0] + s * f[0], p[1] + s * f[1], p[2] + s * f[2]];
                    Marker::new(header, i as i32, marker::ADD, Some([p.into(), tip.into()]))
                });
                serializer.collect_seq(clear.chain(arrows))
            }
        }
        let mut s = serializer.serialize_struct("MarkerArray", 1)?;
        s.serialize_field("markers", &Markers(self))?;
        s.end()
    }
}

/// `ros_gz_interfaces/Entity` type constants used here.
pub mod entity {
    /// A collision shape (a MuJoCo geom).
    pub const COLLISION: u8 = 5;
}

#[derive(Serialize)]
struct Entity<'a> {
    id: u64,
    name: &'a str,
    #[serde(rename = "type")]
    kind: u8,
}

/// A one-element sequence (the per-point arrays of `ros_gz_interfaces/Contact`: SimSerpent's
/// contacts have one point each).
struct One<T>(T);

impl<T: Serialize> Serialize for One<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(std::iter::once(&self.0))
    }
}

#[derive(Serialize)]
struct JointWrench<'a> {
    header: Header<'a>,
    // std_msgs/String and std_msgs/UInt32: a struct of one field is that field on the wire.
    body_1_name: &'a str,
    body_1_id: u32,
    body_2_name: &'a str,
    body_2_id: u32,
    body_1_wrench: Wrench,
    body_2_wrench: Wrench,
}

#[derive(Serialize)]
struct Contact<'a> {
    collision1: Entity<'a>,
    collision2: Entity<'a>,
    positions: One<Vector3>,
    normals: One<Vector3>,
    depths: One<f64>,
    wrenches: One<JointWrench<'a>>,
}

/// The true contacts of one instant as `ros_gz_interfaces/Contacts` (the type Gazebo's contact
/// sensors reach ROS 2 with, through `ros_gz_bridge`), one `Contact` per row of the instant in
/// `contacts.csv`, in its order: `collision1`/`collision2` the two geoms (MuJoCo geom id and
/// name, type `COLLISION`), one point each: `positions` the contact point (m), `normals` the
/// contact normal (from geom 1 to geom 2, unit), `depths` the penetration (m, = −`distance_m`:
/// negative for a contact inside the margin that does not touch yet), and one `JointWrench`
/// naming the two bodies (MuJoCo body id and name) with the force on each (N, world axes)
/// applied at the contact point (torque zero about it): body 2 feels `force_on_geom2`, body 1
/// the opposite. Every vector is in `frame_id`'s axes (`world`).
#[derive(Debug)]
pub struct Contacts<'a> {
    pub stamp: Time,
    pub frame_id: &'a str,
    pub contacts: &'a [crate::state::ContactRow],
    pub geom_names: &'a [String],
    pub body_names: &'a [String],
}

impl Serialize for Contacts<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        struct List<'b, 'a>(&'b Contacts<'a>);
        impl Serialize for List<'_, '_> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let m = self.0;
                let header = Header { stamp: m.stamp, frame_id: m.frame_id };
                fn name(names: &[String], i: usize) -> &str {
                    names.get(i).map_or("", String::as_str)
                }
                serializer.collect_seq(m.contacts.iter().map(|c| {
                    let f = c.force_on_geom2_n;
                    let zero = Vector3::default();
                    Contact {
                        collision1: Entity {
                            id: c.geom[0] as u64,
                            name: name(m.geom_names, c.geom[0]),
                            kind: entity::COLLISION,
                        },
                        collision2: Entity {
                            id: c.geom[1] as u64,
                            name: name(m.geom_names, c.geom[1]),
                            kind: entity::COLLISION,
                        },
                        positions: One(c.position_m.into()),
                        normals: One(c.normal.into()),
                        depths: One(-c.distance_m),
                        wrenches: One(JointWrench {
                            header,
                            body_1_name: name(m.body_names, c.body[0]),
                            body_1_id: c.body[0] as u32,
                            body_2_name: name(m.body_names, c.body[1]),
                            body_2_id: c.body[1] as u32,
                            body_1_wrench: Wrench { force: [-f[0], -f[1], -f[2]].into(), torque: zero },
                            body_2_wrench: Wrench { force: f.into(), torque: zero },
                        }),
                    }
                }))
            }
        }
        let mut s = serializer.serialize_struct("Contacts", 2)?;
        s.serialize_field("header", &Header { stamp: self.stamp, frame_id: self.frame_id })?;
        s.serialize_field("contacts", &List(self))?;
        s.end()
    }
}

/// The per-link contact estimates of one instant as `simserpent_msgs/ContactEstimates` (its
/// definition: [`CONTACT_ESTIMATES_MSG`]): the estimator's output the controller saw
/// ([`crate::state::ContactEstimates`]), world axes, index i of every array = `link_names[i]`.
#[derive(Debug)]
pub struct ContactEstimates<'a> {
    pub stamp: Time,
    pub frame_id: &'a str,
    pub link_names: &'a [String],
    pub estimates: &'a crate::state::ContactEstimates,
}

/// A per-link sequence of 3-vectors as `geometry_msgs/Vector3[]`.
struct Vectors<'a>(&'a [[f64; 3]]);

impl Serialize for Vectors<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.0.iter().map(|v| Vector3::from(*v)))
    }
}

/// `float64[]` of optional values, NaN for `None`.
struct OrNan<'a>(&'a [Option<f64>]);

impl Serialize for OrNan<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.0.iter().map(|v| v.unwrap_or(f64::NAN)))
    }
}

/// `geometry_msgs/Point[]` of optional points, NaN coordinates for `None`.
struct PointsOrNan<'a>(&'a [Option<[f64; 3]>]);

impl Serialize for PointsOrNan<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.0.iter().map(|v| Vector3::from(v.unwrap_or([f64::NAN; 3]))))
    }
}

impl Serialize for ContactEstimates<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let e = self.estimates;
        let mut s = serializer.serialize_struct("ContactEstimates", 10)?;
        s.serialize_field("header", &Header { stamp: self.stamp, frame_id: self.frame_id })?;
        s.serialize_field("link_names", self.link_names)?;
        s.serialize_field("external_force", &Vectors(&e.external_force_n))?;
        s.serialize_field("floor_force", &Vectors(&e.floor_force_n))?;
        s.serialize_field("obstacle_force", &Vectors(&e.obstacle_force_n))?;
        s.serialize_field("contact", &e.contact)?;
        s.serialize_field("contact_point_along", &OrNan(&e.contact_point_along_m))?;
        s.serialize_field("contact_point", &PointsOrNan(&e.contact_point_m))?;
        s.serialize_field("self_contact_force", &Vectors(&e.self_contact_force_n))?;
        s.serialize_field("self_contact", &e.self_contact)?;
        s.end()
    }
}

/// `simserpent_msgs/msg/ContactEstimates.msg`, SimSerpent's own message (no standard ROS 2
/// message holds per-link force estimates with a contact flag and point; user guide, "ROS 2").
/// The file of the ROS 2 package `simserpent_msgs` (`ros2/simserpent_msgs`), embedded in bags
/// as written.
pub const CONTACT_ESTIMATES_MSG: &str = include_str!("../../ros2/simserpent_msgs/msg/ContactEstimates.msg");

/// The definitions of every message type used, `package/Type` → fields. Nested types are
/// written with their package, as ROS 2 bags embed them.
const DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec\n"),
    ("rosgraph_msgs/Clock", "builtin_interfaces/Time clock\n"),
    ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n"),
    (
        "sensor_msgs/JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    ),
    ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"),
    ("geometry_msgs/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"),
    ("geometry_msgs/Transform", "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"),
    (
        "geometry_msgs/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    ),
    ("tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n"),
    ("geometry_msgs/Wrench", "geometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n"),
    ("geometry_msgs/WrenchStamped", "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n"),
    (
        "sensor_msgs/Imu",
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n\
         geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n\
         geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
    ),
    ("std_msgs/MultiArrayDimension", "string label\nuint32 size\nuint32 stride\n"),
    ("std_msgs/MultiArrayLayout", "std_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n"),
    ("std_msgs/Float64MultiArray", "std_msgs/MultiArrayLayout layout\nfloat64[] data\n"),
    ("std_msgs/ColorRGBA", "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"),
    ("sensor_msgs/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data\n"),
    ("visualization_msgs/UVCoordinate", "float32 u\nfloat32 v\n"),
    ("visualization_msgs/MeshFile", "string filename\nuint8[] data\n"),
    (
        "visualization_msgs/Marker",
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\n\
         int32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\n\
         int32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
         std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\n\
         geometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\n\
         bool frame_locked\ngeometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\nstring texture_resource\n\
         sensor_msgs/CompressedImage texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\nstring text\n\
         string mesh_resource\nvisualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials\n",
    ),
    ("visualization_msgs/MarkerArray", "visualization_msgs/Marker[] markers\n"),
    ("std_msgs/String", "string data\n"),
    ("std_msgs/UInt32", "uint32 data\n"),
    (
        "ros_gz_interfaces/Entity",
        "uint8 NONE=0\nuint8 LIGHT=1\nuint8 MODEL=2\nuint8 LINK=3\nuint8 VISUAL=4\nuint8 COLLISION=5\nuint8 SENSOR=6\n\
         uint8 JOINT=7\nuint64 id\nstring name\nuint8 type\n",
    ),
    (
        "ros_gz_interfaces/JointWrench",
        "std_msgs/Header header\nstd_msgs/String body_1_name\nstd_msgs/UInt32 body_1_id\n\
         std_msgs/String body_2_name\nstd_msgs/UInt32 body_2_id\ngeometry_msgs/Wrench body_1_wrench\n\
         geometry_msgs/Wrench body_2_wrench\n",
    ),
    (
        "ros_gz_interfaces/Contact",
        "ros_gz_interfaces/Entity collision1\nros_gz_interfaces/Entity collision2\n\
         geometry_msgs/Vector3[] positions\ngeometry_msgs/Vector3[] normals\nfloat64[] depths\n\
         ros_gz_interfaces/JointWrench[] wrenches\n",
    ),
    ("ros_gz_interfaces/Contacts", "std_msgs/Header header\nros_gz_interfaces/Contact[] contacts\n"),
    ("simserpent_msgs/ContactEstimates", CONTACT_ESTIMATES_MSG),
    (
        "trajectory_msgs/JointTrajectoryPoint",
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n\
         builtin_interfaces/Duration time_from_start\n",
    ),
    (
        "trajectory_msgs/JointTrajectory",
        "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points\n",
    ),
];

fn definition(type_name: &str) -> Option<&'static str> {
    DEFINITIONS.iter().find(|(name, _)| *name == type_name).map(|(_, text)| *text)
}

/// The message types a field list refers to (`pkg/Type name`, `pkg/Type[] name`, …), in order.
fn nested_types(text: &str) -> impl Iterator<Item = &str> {
    text.lines().filter_map(|line| {
        let ty = line.split_whitespace().next().filter(|t| !t.starts_with('#'))?;
        let ty = ty.split('[').next()?;
        ty.contains('/').then_some(ty)
    })
}

/// The ROS 2 type name as bags and DDS name it: `sensor_msgs/msg/JointState`.
pub fn ros2_type_name(type_name: &str) -> String {
    match type_name.split_once('/') {
        Some((package, name)) => format!("{package}/msg/{name}"),
        None => type_name.to_string(),
    }
}

/// The `ros2msg` schema of `type_name` (`sensor_msgs/JointState`): its definition, then every
/// type it uses (depth first, each once) after a line of 80 `=` and `MSG: pkg/Type`, as
/// rosbag2 writes them. `None` for a type not listed here.
pub fn schema(type_name: &str) -> Option<String> {
    let mut text = definition(type_name)?.to_string();
    let mut done: Vec<&str> = vec![type_name];
    let mut todo: Vec<&str> = nested_types(definition(type_name)?).collect();
    todo.reverse();
    while let Some(ty) = todo.pop() {
        if done.contains(&ty) {
            continue;
        }
        let body = definition(ty)?;
        text.push_str(&"=".repeat(80));
        text.push_str(&format!("\nMSG: {ty}\n"));
        text.push_str(body);
        done.push(ty);
        let mut inner: Vec<&str> = nested_types(body).collect();
        inner.reverse();
        todo.extend(inner);
    }
    Some(text)
}

/// Serialises `message` into `buf` (cleared first) as ROS 2 does: the CDR_LE encapsulation
/// header, then the CDR body. Reuses `buf`'s capacity.
pub fn encode<T: Serialize>(buf: &mut Vec<u8>, message: &T) -> Result<(), cdr_encoding::Error> {
    buf.clear();
    buf.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    cdr_encoding::to_writer::<T, byteorder::LittleEndian, _>(&mut *buf, message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_nested_type_has_a_definition() {
        for (name, _) in DEFINITIONS {
            assert!(schema(name).is_some(), "{name}");
        }
        let imu = schema("sensor_msgs/Imu").expect("listed");
        assert!(imu.starts_with("std_msgs/Header header\n"));
        for ty in ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Quaternion", "geometry_msgs/Vector3"] {
            assert_eq!(imu.matches(&format!("\nMSG: {ty}\n")).count(), 1, "{ty} once in\n{imu}");
        }
    }

    /// A JointState by hand, byte for byte as CDR lays it out (ROS 2's rmw implementations
    /// produce the same bytes): alignment is counted from the end of the encapsulation header.
    #[test]
    fn joint_state_bytes_follow_cdr() {
        let names = vec!["j".to_string()];
        let msg = JointState {
            header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "" },
            name: &names,
            position: &[0.5],
            velocity: &[],
            effort: &[],
        };
        let mut buf = Vec::new();
        encode(&mut buf, &msg).expect("encodes");
        let mut want = vec![0, 1, 0, 0];
        want.extend(1i32.to_le_bytes());
        want.extend(2u32.to_le_bytes());
        want.extend(1u32.to_le_bytes()); // frame_id: length 1 (the NUL)
        want.push(0);
        want.extend([0, 0, 0]); // pad to 4
        want.extend(1u32.to_le_bytes()); // one name
        want.extend(2u32.to_le_bytes());
        want.extend(b"j\0");
        want.extend([0, 0]); // pad to 4
        want.extend(1u32.to_le_bytes()); // one position (its f64 at offset 32: aligned)
        want.extend(0.5f64.to_le_bytes());
        want.extend(0u32.to_le_bytes());
        want.extend(0u32.to_le_bytes());
        assert_eq!(buf, want);
    }
}
