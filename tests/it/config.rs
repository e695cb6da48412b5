//! Config loading: defaults, `init` round trip, every field, every validation rule, unknown
//! keys, `--set` overrides, the original tool's config.json.

use crate::common::{data, leaf_paths};
use simserpent::config::*;
use std::path::{Path, PathBuf};

fn sets(overrides: &[&str]) -> Vec<String> {
    overrides.iter().map(|s| s.to_string()).collect()
}

fn load_toml(text: &str, overrides: &[&str]) -> Result<Config, ConfigError> {
    load_config_str(text, ConfigSource::Toml, &sets(overrides))
}

fn load_json(text: &str) -> Result<Config, ConfigError> {
    load_config_str(text, ConfigSource::LegacyJson, &[])
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The key of an InvalidValue or UnknownKey error.
fn error_key(e: &ConfigError) -> &str {
    match e {
        ConfigError::InvalidValue { key, .. } | ConfigError::UnknownKey { key, .. } => key,
        other => panic!("expected a key error, got {other:?}"),
    }
}

fn invalid(result: Result<Config, ConfigError>) -> (String, String, String) {
    match result {
        Err(ConfigError::InvalidValue { key, value, allowed }) => (key, value, allowed),
        other => panic!("expected InvalidValue, got {other:?}"),
    }
}

fn thesis_json_path() -> PathBuf {
    data("thesis_config.json")
}

// --- defaults -------------------------------------------------------------------------------

#[test]
fn embedded_default_parses_and_validates() {
    let table: toml::Table = DEFAULT_CONFIG_TOML.parse().unwrap();
    assert!(table.contains_key("general"));
    let config = load_toml(DEFAULT_CONFIG_TOML, &[]).unwrap();
    config.validate().unwrap();
    assert_eq!(config, Config::default());
    // A few spot checks against default.toml.
    assert_eq!(config.snake.n_links, 10);
    assert_eq!(config.general.integrator, Integrator::RK4);
    assert_eq!(config.control.method, ControlMethod::Position);
    assert_eq!(config.gait.kind, GaitKind::SineWave);
    assert_eq!(config.terrain.kind, TerrainKind::CylinderPath);
}

#[test]
fn init_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "config.toml", DEFAULT_CONFIG_TOML);
    let config = load_config(&path, &[]).unwrap();
    assert_eq!(config, Config::default());

    let resolved = write(dir.path(), "resolved.toml", &config.to_toml_string());
    let again = load_config(&resolved, &[]).unwrap();
    assert_eq!(again, config);
}

#[test]
fn empty_toml_is_all_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "empty.toml", "");
    assert_eq!(load_config(&path, &[]).unwrap(), Config::default());
    assert_eq!(load_toml("", &[]).unwrap(), Config::default());
    assert_eq!(load_toml("# only a comment\n", &[]).unwrap(), Config::default());
}

#[test]
fn partial_file_keeps_other_defaults() {
    let config = load_toml("[snake]\nn_links = 4\n", &[]).unwrap();
    let mut expected = Config::default();
    expected.snake.n_links = 4;
    assert_eq!(config, expected);
}

// --- every field ----------------------------------------------------------------------------

const ALL_FIELDS: &str = r#"
[general]
run_name = "field-test.1"
output_dir = "out/dir"
duration_secs = 7.5
timestep_secs = 0.002
integrator = "implicitfast"
seed = 42
gravity_m_per_s2 = [0.1, -0.2, -9.0]
plot = true

[physics]
friction_cone = "pyramidal"
self_collision = false
contact_time_constant_secs = 0.01
contact_damping_ratio = 0.8
contact_stiffness_per_s2 = 2000.0
contact_damping_per_s = 3.0
solver_iterations = 50
floor_friction = "mujoco"
environment_contact_solve = "per_link"
floor_stick_time_constant_secs = 0.01
environment_contact_time_constant_secs = 0.004
environment_contact_damping_ratio = 0.7
contact_restitution = 0.6
external_forces = [{ link = 1, direction = [0.0, 1.0, 0.0], start_secs = 0.5, ramp_n_per_s = 2.0, force_n = 3.0, duration_secs = 1.0 }]

[safety]
max_kinetic_energy_j_per_kg = 250.0
check_every_n_steps = 3

[visual]
show_contact_forces = true
show_contact_points = true
show_actuators = true
show_joints = true
show_center_of_mass = true
make_transparent = true

[snake]
n_links = 7
link_length_m = 0.3
link_radius_m = 0.05
link_mass_kg = 0.4
joint_range_deg = 60.0
joint_damping_nm_s_per_rad = 0.25
joint_armature_kg_m2 = 0.02
joint_axes = "alternating"
torque_range_nm = [-2.0, 4.0]
ground_friction = [0.6, 0.0, 0.0]
link_friction = [0.3, 0.002, 0.0002]
color_rgba = [1.0, 0.5, 0.25, 0.75]
head_position_m = [1.0, 2.0, 0.5]
head_rotation_deg = [10.0, 20.0, 30.0]

[initial_state]
joint_angles_deg = [1.0, -2.0, 3.0, -4.0, 5.0, -6.0]
linear_velocity_m_per_s = [0.5, 0.0, -0.1]
angular_velocity_rad_per_s = [0.0, 0.2, 1.0]

[robot]
floating_base = false
position_m = [1.0, -1.0, 0.25]
rotation_deg = [0.0, 0.0, 45.0]
place_on_floor = false
position_servos = true

[ground]
model = "directional"
axial_friction = 0.15
lateral_friction = 1.5
backward_friction = 0.45
viscous_tangential_n_s_per_m = 2.0
viscous_normal_n_s_per_m = 20.0
surfaces = [{ shape = "circle", center_m = [3.0, 3.0], radius_m = 0.5, preset = "ice" }]

[sensors]
noise_enabled = true

[sensors.accelerometer]
std = 0.11
bias = 0.0020
bias_random_walk_per_sqrt_s = 0.0030
resolution = 0.0040
rate_hz = 100.0

[sensors.gyro]
std = 0.12
bias = 0.0021
bias_random_walk_per_sqrt_s = 0.0031
resolution = 0.0041
rate_hz = 101.0

[sensors.orientation]
std = 0.19
bias = 0.0028
bias_random_walk_per_sqrt_s = 0.0038
resolution = 0.0048
rate_hz = 108.0

[sensors.joint_angle]
std = 0.13
bias = 0.0022
bias_random_walk_per_sqrt_s = 0.0032
resolution = 0.0042
rate_hz = 102.0

[sensors.joint_velocity]
std = 0.14
bias = 0.0023
bias_random_walk_per_sqrt_s = 0.0033
resolution = 0.0043
rate_hz = 103.0

[sensors.actuator_torque]
std = 0.15
bias = 0.0024
bias_random_walk_per_sqrt_s = 0.0034
resolution = 0.0044
rate_hz = 104.0

[sensors.joint_force]
std = 0.16
bias = 0.0025
bias_random_walk_per_sqrt_s = 0.0035
resolution = 0.0045
rate_hz = 105.0

[sensors.joint_torque]
std = 0.17
bias = 0.0026
bias_random_walk_per_sqrt_s = 0.0036
resolution = 0.0046
rate_hz = 106.0

[control]
controller = "gait"
method = "intvelocity"
torque_gear = 2.5
position_kp_nm_per_rad = 6.0
position_kv_nm_s_per_rad = 0.2
velocity_kv_nm_s_per_rad = 1.5
intvelocity_kp_nm_per_rad = 12.0
pid_kp_nm_per_rad = 3.0
pid_ki_nm_per_rad_s = 0.1
pid_kd_nm_s_per_rad = 0.3

[gait]
kind = "form_closure"
ramp_secs = 0.5

[gait.sine_wave]
amplitude_deg = 20.0
frequency_hz = 1.5
phase_lag_deg = 30.0
offset_deg = 5.0

[gait.serpenoid]
winding_angle_deg = 25.0
n_waves = 1.5
frequency_hz = 0.8
offset_deg = 2.0

[gait.sidewinding]
yaw_amplitude_deg = 22.0
pitch_amplitude_deg = 11.0
frequency_hz = 0.7
phase_lag_deg = 35.0
pitch_phase_deg = 80.0

[gait.rolling]
amplitude_deg = 18.0
frequency_hz = 0.9

[gait.form_closure]
pattern_deg = [10.0, -10.0, 20.0]
shift_period_secs = 3.0

[terrain]
kind = "random_cylinders"
obstacle_friction = [0.7, 0.02, 0.002]
cylinder_height_m = 0.4
floor_size_m = 30.0
include_mjcf = "/abs/yard.xml"
walls = [{ start_m = [0.0, 2.0], end_m = [1.0, 2.0], height_m = 0.3, thickness_m = 0.1 }]
mesh_obstacles = [{ file = "/abs/rock.stl", position_m = [1.0, 2.0, 0.0], rotation_deg = [0.0, 0.0, 45.0], scale = 0.001 }]

[terrain.two_cylinders]
distance_m = 3.0
radius_m = 0.3

[terrain.random_cylinders]
count = 5
radius_range_m = [0.1, 0.2]
half_size_m = 2.0
min_gap_m = 0.2

[terrain.cylinder_path]
n_pairs = 4
spacing_m = 0.6
width_m = 1.0
radius_m = 0.06
start_m = 1.0

[terrain.form_closure]
order = 1
radius_m = 0.07

[terrain.pegboard]
layout = "hexagonal"
peg_radius_m = 0.04
peg_height_m = 0.25
spacing_m = 0.3
region_min_m = [1.0, -2.0]
region_max_m = [3.0, 2.0]
count = 12
skip_pegs_on_snake = false

[terrain.channel]
enabled = true
start_m = [1.0, 1.0]
end_m = [4.0, 1.0]
width_m = 0.5
height_m = 0.3
thickness_m = 0.08

[terrain.slope]
angle_deg = 12.0
start_m = [2.0, 3.0]
direction_deg = 90.0
length_m = 1.5
width_m = 1.0

[terrain.heightfield]
file = "/abs/hills.png"
center_m = [1.0, -1.0]
size_x_m = 2.0
size_y_m = 3.0
height_m = 0.2
base_m = 0.1

[terrain.mesh_terrain]
file = "/abs/ground.obj"
position_m = [0.5, 0.5, -0.1]
scale = 0.01
resolution_m = 0.05
base_m = 0.2

[recording]
enabled = false
every_n_steps = 5
format = "both"
parquet_row_group_rows = 77
parquet_rows_per_file = 1234
parquet_compression = "zstd"
link_position = false
link_orientation = false
link_velocity = false
link_acceleration = false
link_angular_velocity = false
link_angular_acceleration = false
joint_angles = false
joint_velocities = false
torque_actuator_forces = false
position_actuator_forces = false
velocity_actuator_forces = false
intvelocity_actuator_forces = false
external_contact_forces = false
internal_joint_forces = false
imu_sensors = false
contacts = false

[plot]
width_px = 800
height_px = 500

[render]
width_px = 320
height_px = 240
quality = "full"
camera = "top"
camera_distance_m = 4.0
camera_azimuth_deg = 45.0
camera_elevation_deg = -60.0
fixed_lookat_m = [0.5, 0.5, 0.1]
time_overlay = false
image_times_secs = [1.0, 2.5]
image_cameras = ["fixed", "follow"]
record_state = false

[video]
enabled = true
format = "gif"
frames_per_sec = 12.5
playback_speed = 2.0

[env]
observation_version = 1
observe_imu = true
observe_joint_force_torque = true
observe_contact_estimates = true
action = "torque"
control_period_secs = 0.01
max_episode_secs = 5.0
reward_forward_weight = 2.0
reward_energy_weight = 0.5
reward_contact_force_weight = 0.001
terminate_contact_force_n = 500.0
reward_ctrl_cost_weight = 0.01
reset_noise_scale = 0.05
reset_heading_noise_rad = 0.3
exclude_current_positions_from_observation = false
normalize_action = false
preset = "fast"

[legacy]
geometry = "faithful"

[ros2]
namespace = "lab/snake_1"
contact_arrow_m_per_n = 0.02
domain_id = 42
interfaces = ["127.0.0.1"]
publish_rate_hz = 50.0
reliability = "best_effort"
durability = "transient_local"
history_depth = 3
clock = "lockstep"
real_time_factor = 0.5
steps_per_command = 4
lockstep_timeout_secs = 2.5

[estimation]
enabled = true
orientation = "true"
detection_threshold_n = 0.6
min_lateral_force_n = 0.7
sliding_speed_m_per_s = 0.01
tilt_gain_per_s = 2.0
contact_point_filter_secs = 0.03
friction = "identify"
friction_prior = 0.4
friction_window_secs = 3.0
self_contacts = false
self_contact_margin_m = 0.002

[path_following]
waypoints_m = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]
lookahead_m = 1.5
heading_gain = 0.7
max_offset_deg = 15.0
acceptance_radius_m = 0.4

[follow_the_leader_reflex]
contacts = "true"
feedback = false
goal_heading_deg = 5.0
heading_gain = 0.3
heading_max_offset_deg = 12.0
propulsive_gain_rad_per_n = 0.03
resisting_gain_rad_per_n = 0.01
force_filter_secs = 0.1
max_offset_deg = 20.0

[directional_admittance]
contacts = "true"
feedback = false
goal_heading_deg = -5.0
heading_gain = 0.4
heading_max_offset_deg = 8.0
windows = 2
window_sigma_joints = 2.0
stiffness_nm_per_rad = 8.0
damping_nm_s_per_rad = 1.5
min_amplitude_deg = 5.0
max_amplitude_deg = 70.0
wedge_force_n = 4.0
wedge_speed_m_per_s = 0.02
wedge_secs = 1.5
filter_secs = 0.4
escape_stiffness_ratio = 0.5
escape_secs = 1.0

[jam_resolution]
contacts = "true"
feedback = false
goal_heading_deg = 15.0
heading_gain = 0.5
heading_max_offset_deg = 6.0
jam_window_secs = 1.5
jam_min_progress_m = 0.04
resolve_secs = 1.0
push_force_n = 3.0
min_propulsion = 0.3
offset_filter_secs = 0.1
max_offset_deg = 25.0
"#;

fn all_fields_expected() -> Config {
    let mut c = Config::default();
    let g = &mut c.general;
    g.run_name = "field-test.1".into();
    g.output_dir = "out/dir".into();
    g.duration_secs = 7.5;
    g.timestep_secs = 0.002;
    g.integrator = Integrator::ImplicitFast;
    g.seed = 42;
    g.gravity_m_per_s2 = [0.1, -0.2, -9.0];
    g.plot = true;

    let p = &mut c.physics;
    p.friction_cone = FrictionCone::Pyramidal;
    p.self_collision = false;
    p.contact_time_constant_secs = 0.01;
    p.contact_damping_ratio = 0.8;
    p.contact_stiffness_per_s2 = 2000.0;
    p.contact_damping_per_s = 3.0;
    p.solver_iterations = 50;
    p.floor_friction = FloorFriction::Mujoco;
    p.floor_stick_time_constant_secs = StickTimeConstant::Secs(0.01);
    p.environment_contact_time_constant_secs = AutoSecs::Secs(0.004);
    p.environment_contact_damping_ratio = 0.7;
    p.contact_restitution = 0.6;
    p.external_forces = vec![simserpent::config::ExternalForce {
        link: 1,
        direction: [0.0, 1.0, 0.0],
        start_secs: 0.5,
        ramp_n_per_s: 2.0,
        force_n: 3.0,
        duration_secs: 1.0,
    }];

    c.safety.max_kinetic_energy_j_per_kg = 250.0;
    c.safety.check_every_n_steps = 3;

    let v = &mut c.visual;
    v.show_contact_forces = true;
    v.show_contact_points = true;
    v.show_actuators = true;
    v.show_joints = true;
    v.show_center_of_mass = true;
    v.make_transparent = true;

    let s = &mut c.snake;
    s.n_links = 7;
    s.link_length_m = 0.3;
    s.link_radius_m = 0.05;
    s.link_mass_kg = 0.4;
    s.joint_range_deg = 60.0;
    s.joint_damping_nm_s_per_rad = 0.25;
    s.joint_armature_kg_m2 = 0.02;
    s.joint_axes = JointAxes::Alternating;
    s.torque_range_nm = [-2.0, 4.0];
    s.ground_friction = [0.6, 0.0, 0.0];
    s.link_friction = [0.3, 0.002, 0.0002];
    s.color_rgba = [1.0, 0.5, 0.25, 0.75];
    s.head_position_m = [1.0, 2.0, 0.5];
    s.head_rotation_deg = [10.0, 20.0, 30.0];

    c.initial_state = InitialState {
        joint_angles_deg: vec![1.0, -2.0, 3.0, -4.0, 5.0, -6.0],
        linear_velocity_m_per_s: [0.5, 0.0, -0.1],
        angular_velocity_rad_per_s: [0.0, 0.2, 1.0],
    };
    c.robot = Robot {
        floating_base: false,
        position_m: [1.0, -1.0, 0.25],
        rotation_deg: [0.0, 0.0, 45.0],
        place_on_floor: false,
        position_servos: true,
    };

    let gr = &mut c.ground;
    gr.model = GroundModel::Directional;
    gr.axial_friction = 0.15;
    gr.lateral_friction = 1.5;
    gr.backward_friction = 0.45;
    gr.viscous_tangential_n_s_per_m = 2.0;
    gr.viscous_normal_n_s_per_m = 20.0;
    gr.surfaces = vec![simserpent::config::Surface {
        name: String::new(),
        shape: simserpent::config::SurfaceShape::Circle { radius_m: 0.5 },
        center_m: [3.0, 3.0],
        base: simserpent::config::surfaces::preset("ice").map(simserpent::config::FrictionSource::Preset),
        explicit: simserpent::config::ExplicitFriction::default(),
    }];

    let n = &mut c.sensors;
    n.noise_enabled = true;
    n.accelerometer = SensorModel {
        std: 0.11,
        bias: 0.0020,
        bias_random_walk_per_sqrt_s: 0.0030,
        resolution: 0.0040,
        rate_hz: 100.0,
    };
    n.gyro = SensorModel {
        std: 0.12,
        bias: 0.0021,
        bias_random_walk_per_sqrt_s: 0.0031,
        resolution: 0.0041,
        rate_hz: 101.0,
    };
    n.orientation = SensorModel {
        std: 0.19,
        bias: 0.0028,
        bias_random_walk_per_sqrt_s: 0.0038,
        resolution: 0.0048,
        rate_hz: 108.0,
    };
    n.joint_angle = SensorModel {
        std: 0.13,
        bias: 0.0022,
        bias_random_walk_per_sqrt_s: 0.0032,
        resolution: 0.0042,
        rate_hz: 102.0,
    };
    n.joint_velocity = SensorModel {
        std: 0.14,
        bias: 0.0023,
        bias_random_walk_per_sqrt_s: 0.0033,
        resolution: 0.0043,
        rate_hz: 103.0,
    };
    n.actuator_torque = SensorModel {
        std: 0.15,
        bias: 0.0024,
        bias_random_walk_per_sqrt_s: 0.0034,
        resolution: 0.0044,
        rate_hz: 104.0,
    };
    n.joint_force = SensorModel {
        std: 0.16,
        bias: 0.0025,
        bias_random_walk_per_sqrt_s: 0.0035,
        resolution: 0.0045,
        rate_hz: 105.0,
    };
    n.joint_torque = SensorModel {
        std: 0.17,
        bias: 0.0026,
        bias_random_walk_per_sqrt_s: 0.0036,
        resolution: 0.0046,
        rate_hz: 106.0,
    };

    let k = &mut c.control;
    k.method = ControlMethod::Intvelocity;
    k.torque_gear = 2.5;
    k.position_kp_nm_per_rad = 6.0;
    k.position_kv_nm_s_per_rad = 0.2;
    k.velocity_kv_nm_s_per_rad = 1.5;
    k.intvelocity_kp_nm_per_rad = 12.0;
    k.pid_kp_nm_per_rad = 3.0;
    k.pid_ki_nm_per_rad_s = 0.1;
    k.pid_kd_nm_s_per_rad = 0.3;

    let w = &mut c.gait;
    w.kind = GaitKind::FormClosure;
    w.ramp_secs = 0.5;
    w.sine_wave = SineWave { amplitude_deg: 20.0, frequency_hz: 1.5, phase_lag_deg: 30.0, offset_deg: 5.0 };
    w.serpenoid = Serpenoid { winding_angle_deg: 25.0, n_waves: 1.5, frequency_hz: 0.8, offset_deg: 2.0 };
    w.sidewinding = Sidewinding {
        yaw_amplitude_deg: 22.0,
        pitch_amplitude_deg: 11.0,
        frequency_hz: 0.7,
        phase_lag_deg: 35.0,
        pitch_phase_deg: 80.0,
    };
    w.rolling = Rolling { amplitude_deg: 18.0, frequency_hz: 0.9 };
    w.form_closure = FormClosureGait { pattern_deg: vec![10.0, -10.0, 20.0], shift_period_secs: 3.0 };

    let t = &mut c.terrain;
    t.kind = TerrainKind::RandomCylinders;
    t.obstacle_friction = [0.7, 0.02, 0.002];
    t.cylinder_height_m = 0.4;
    t.floor_size_m = 30.0;
    t.two_cylinders = TwoCylinders { distance_m: 3.0, radius_m: 0.3 };
    t.random_cylinders = RandomCylinders { count: 5, radius_range_m: [0.1, 0.2], half_size_m: 2.0, min_gap_m: 0.2 };
    t.cylinder_path = CylinderPath { n_pairs: 4, spacing_m: 0.6, width_m: 1.0, radius_m: 0.06, start_m: 1.0 };
    t.form_closure = FormClosureTerrain { order: 1, radius_m: 0.07 };
    t.include_mjcf = "/abs/yard.xml".into();
    t.walls = vec![Wall { start_m: [0.0, 2.0], end_m: [1.0, 2.0], height_m: 0.3, thickness_m: 0.1 }];
    t.mesh_obstacles = vec![MeshObstacle {
        file: "/abs/rock.stl".into(),
        position_m: [1.0, 2.0, 0.0],
        rotation_deg: [0.0, 0.0, 45.0],
        scale: 0.001,
    }];
    t.pegboard = Pegboard {
        layout: PegLayout::Hexagonal,
        peg_radius_m: 0.04,
        peg_height_m: 0.25,
        spacing_m: 0.3,
        region_min_m: [1.0, -2.0],
        region_max_m: [3.0, 2.0],
        count: 12,
        skip_pegs_on_snake: false,
    };
    t.channel = Channel {
        enabled: true,
        start_m: [1.0, 1.0],
        end_m: [4.0, 1.0],
        width_m: 0.5,
        height_m: 0.3,
        thickness_m: 0.08,
    };
    t.slope = Slope { angle_deg: 12.0, start_m: [2.0, 3.0], direction_deg: 90.0, length_m: 1.5, width_m: 1.0 };
    t.heightfield = Heightfield {
        file: "/abs/hills.png".into(),
        center_m: [1.0, -1.0],
        size_x_m: 2.0,
        size_y_m: 3.0,
        height_m: 0.2,
        base_m: 0.1,
    };
    t.mesh_terrain = MeshTerrain {
        file: "/abs/ground.obj".into(),
        position_m: [0.5, 0.5, -0.1],
        scale: 0.01,
        resolution_m: 0.05,
        base_m: 0.2,
    };

    c.recording = Recording {
        enabled: false,
        every_n_steps: 5,
        format: TableFormat::Both,
        parquet_row_group_rows: 77,
        parquet_rows_per_file: 1234,
        parquet_compression: ParquetCompression::Zstd,
        link_position: false,
        link_orientation: false,
        link_velocity: false,
        link_acceleration: false,
        link_angular_velocity: false,
        link_angular_acceleration: false,
        joint_angles: false,
        joint_velocities: false,
        torque_actuator_forces: false,
        position_actuator_forces: false,
        velocity_actuator_forces: false,
        intvelocity_actuator_forces: false,
        external_contact_forces: false,
        internal_joint_forces: false,
        imu_sensors: false,
        contacts: false,
    };
    c.plot = Plot { width_px: 800, height_px: 500 };
    c.render = Render {
        width_px: 320,
        height_px: 240,
        quality: RenderQuality::Full,
        camera: CameraKind::Top,
        camera_distance_m: 4.0,
        camera_azimuth_deg: 45.0,
        camera_elevation_deg: -60.0,
        fixed_lookat_m: [0.5, 0.5, 0.1],
        time_overlay: false,
        image_times_secs: vec![1.0, 2.5],
        image_cameras: vec![CameraKind::Fixed, CameraKind::Follow],
        record_state: false,
    };
    c.video = Video { enabled: true, format: VideoFormat::Gif, frames_per_sec: 12.5, playback_speed: 2.0 };
    c.env = Env {
        observation_version: 1,
        observe_imu: true,
        observe_joint_force_torque: true,
        observe_contact_estimates: true,
        action: EnvAction::Torque,
        control_period_secs: 0.01,
        max_episode_secs: 5.0,
        reward_forward_weight: 2.0,
        reward_energy_weight: 0.5,
        reward_contact_force_weight: 0.001,
        terminate_contact_force_n: 500.0,
        reward_ctrl_cost_weight: 0.01,
        reset_noise_scale: 0.05,
        reset_heading_noise_rad: 0.3,
        exclude_current_positions_from_observation: false,
        normalize_action: false,
        preset: EnvPreset::Fast,
    };
    c.legacy.geometry = LegacyGeometry::Faithful;
    c.ros2 = Ros2 {
        namespace: "lab/snake_1".into(),
        contact_arrow_m_per_n: 0.02,
        domain_id: 42,
        interfaces: vec!["127.0.0.1".into()],
        publish_rate_hz: 50.0,
        reliability: simserpent::config::Ros2Reliability::BestEffort,
        durability: simserpent::config::Ros2Durability::TransientLocal,
        history_depth: 3,
        clock: simserpent::config::Ros2Clock::Lockstep,
        real_time_factor: 0.5,
        steps_per_command: 4,
        lockstep_timeout_secs: 2.5,
    };
    c.control.controller = ControllerKind::Gait;
    c.estimation = Estimation {
        enabled: true,
        orientation: OrientationSource::True,
        detection_threshold_n: 0.6,
        min_lateral_force_n: 0.7,
        sliding_speed_m_per_s: 0.01,
        tilt_gain_per_s: 2.0,
        contact_point_filter_secs: 0.03,
        friction: FloorFrictionSource::Identify,
        friction_prior: 0.4,
        friction_window_secs: 3.0,
        self_contacts: false,
        self_contact_margin_m: 0.002,
    };
    c.path_following = PathFollowing {
        waypoints_m: vec![[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]],
        lookahead_m: 1.5,
        heading_gain: 0.7,
        max_offset_deg: 15.0,
        acceptance_radius_m: 0.4,
    };
    c.follow_the_leader_reflex = FollowTheLeaderReflex {
        contacts: ContactSource::True,
        feedback: false,
        goal_heading_deg: 5.0,
        heading_gain: 0.3,
        heading_max_offset_deg: 12.0,
        propulsive_gain_rad_per_n: 0.03,
        resisting_gain_rad_per_n: 0.01,
        force_filter_secs: 0.1,
        max_offset_deg: 20.0,
    };
    c.directional_admittance = DirectionalAdmittance {
        contacts: ContactSource::True,
        feedback: false,
        goal_heading_deg: -5.0,
        heading_gain: 0.4,
        heading_max_offset_deg: 8.0,
        windows: 2,
        window_sigma_joints: 2.0,
        stiffness_nm_per_rad: 8.0,
        damping_nm_s_per_rad: 1.5,
        min_amplitude_deg: 5.0,
        max_amplitude_deg: 70.0,
        wedge_force_n: 4.0,
        wedge_speed_m_per_s: 0.02,
        wedge_secs: 1.5,
        filter_secs: 0.4,
        escape_stiffness_ratio: 0.5,
        escape_secs: 1.0,
    };
    c.jam_resolution = JamResolution {
        contacts: ContactSource::True,
        feedback: false,
        goal_heading_deg: 15.0,
        heading_gain: 0.5,
        heading_max_offset_deg: 6.0,
        jam_window_secs: 1.5,
        jam_min_progress_m: 0.04,
        resolve_secs: 1.0,
        push_force_n: 3.0,
        min_propulsion: 0.3,
        offset_filter_secs: 0.1,
        max_offset_deg: 25.0,
    };
    c
}

/// Leaf paths whose values differ between two tables.
fn differing_leaves(a: &toml::Table, b: &toml::Table, prefix: &str, out: &mut Vec<String>) {
    for (k, va) in a {
        let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match (va, b.get(k)) {
            (toml::Value::Table(ta), Some(toml::Value::Table(tb))) => differing_leaves(ta, tb, &path, out),
            (va, Some(vb)) if va == vb => {}
            _ => out.push(path),
        }
    }
}

#[test]
#[cfg_attr(not(feature = "parquet"), ignore = "sets recording.format = \"both\", which needs the `parquet` feature")]
fn every_field_can_be_set_from_toml() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "all.toml", ALL_FIELDS);
    let config = load_config(&path, &[]).unwrap();
    assert_eq!(config, all_fields_expected());

    // The file really sets every field to a non-default value, so a new field without a line
    // above makes this fail.
    let defaults: toml::Table = DEFAULT_CONFIG_TOML.parse().unwrap();
    let file: toml::Table = ALL_FIELDS.parse().unwrap();
    let mut all = leaf_paths(&defaults);
    let mut in_file = leaf_paths(&file);
    all.sort();
    in_file.sort();
    assert_eq!(all, in_file, "ALL_FIELDS must set every key of the default config");
    let mut changed = Vec::new();
    differing_leaves(&defaults, &file, "", &mut changed);
    // `env.observation_version` has one allowed value so far (1, the default);
    // `physics.environment_contact_solve = "whole_body"` needs `floor_friction = "stick_slip"`,
    // which the file changes to "mujoco" (the rule is in RULES below).
    let unchanged: Vec<&String> = all
        .iter()
        .filter(|k| {
            !changed.contains(k)
                && k.as_str() != "env.observation_version"
                && k.as_str() != "physics.environment_contact_solve"
        })
        .collect();
    assert!(unchanged.is_empty(), "keys left at their default: {unchanged:?}");
}

// --- validation -----------------------------------------------------------------------------

/// (overrides, key path of the expected error). Every rule of `Config::validate`.
const RULES: &[(&[&str], &str)] = &[
    // the whole-body solve needs the own contact law
    (
        &["physics.environment_contact_solve=\"whole_body\"", "physics.floor_friction=\"mujoco\""],
        "physics.environment_contact_solve",
    ),
    (
        &["physics.environment_contact_solve=\"whole_body\"", "ground.model=\"viscous\""],
        "physics.environment_contact_solve",
    ),
    // terrain features
    (&["terrain.pegboard.spacing_m=0.05"], "terrain.pegboard.spacing_m"),
    (&["terrain.pegboard.peg_radius_m=0"], "terrain.pegboard.peg_radius_m"),
    (&["terrain.pegboard.region_max_m=[0.0, 0.0]"], "terrain.pegboard.region_max_m"),
    (&["terrain.channel.enabled=true", "terrain.channel.width_m=0.05"], "terrain.channel.width_m"),
    (&["terrain.channel.enabled=true", "terrain.channel.end_m=[0.0, 0.0]"], "terrain.channel.end_m"),
    (&["terrain.slope.angle_deg=-1"], "terrain.slope.angle_deg"),
    (&["terrain.slope.length_m=0"], "terrain.slope.length_m"),
    (&["terrain.heightfield.height_m=0"], "terrain.heightfield.height_m"),
    (&["terrain.heightfield.base_m=-1"], "terrain.heightfield.base_m"),
    (&["terrain.mesh_terrain.resolution_m=0"], "terrain.mesh_terrain.resolution_m"),
    (&["terrain.walls=[{start_m=[0,0], end_m=[1,0], height_m=0.2, thickness_m=-1}]"], "terrain.walls[0].thickness_m"),
    (
        &["terrain.mesh_obstacles=[{file=\"\", position_m=[0,0,0], rotation_deg=[0,0,0], scale=1}]"],
        "terrain.mesh_obstacles[0].file",
    ),
    // general
    (&["general.duration_secs=0"], "general.duration_secs"),
    (&["general.duration_secs=-1"], "general.duration_secs"),
    (&["general.duration_secs=inf"], "general.duration_secs"),
    (&["general.timestep_secs=0"], "general.timestep_secs"),
    (&["general.timestep_secs=-0.001"], "general.timestep_secs"),
    (&["general.timestep_secs=30"], "general.timestep_secs"),
    (&["general.run_name=\"\""], "general.run_name"),
    (&["general.run_name=\"a b\""], "general.run_name"),
    (&["general.run_name=\"a/b\""], "general.run_name"),
    (&["general.output_dir=\"\""], "general.output_dir"),
    (&["general.gravity_m_per_s2=[0, 0, nan]"], "general.gravity_m_per_s2"),
    // plot, render, video
    (&["plot.width_px=10"], "plot.width_px"),
    (&["plot.height_px=9000"], "plot.height_px"),
    (&["render.width_px=8"], "render.width_px"),
    (&["render.height_px=5000"], "render.height_px"),
    (&["render.camera_distance_m=0"], "render.camera_distance_m"),
    (&["render.camera_azimuth_deg=nan"], "render.camera_azimuth_deg"),
    (&["render.camera_elevation_deg=-91"], "render.camera_elevation_deg"),
    (&["render.fixed_lookat_m=[0, inf, 0]"], "render.fixed_lookat_m"),
    (&["render.image_times_secs=[-1.0]"], "render.image_times_secs"),
    (&["render.image_times_secs=[21.0]"], "render.image_times_secs"),
    (&["render.image_times_secs=[1.0]", "render.image_cameras=[]"], "render.image_cameras"),
    (&["video.frames_per_sec=0"], "video.frames_per_sec"),
    (&["video.frames_per_sec=500"], "video.frames_per_sec"),
    (&["video.playback_speed=-1"], "video.playback_speed"),
    (&["video.playback_speed=1000"], "video.playback_speed"),
    // physics
    (&["physics.contact_time_constant_secs=0"], "physics.contact_time_constant_secs"),
    (&["physics.contact_time_constant_secs=0.0015"], "physics.contact_time_constant_secs"),
    (&["general.timestep_secs=0.011"], "physics.contact_time_constant_secs"),
    (&["physics.contact_damping_ratio=0"], "physics.contact_damping_ratio"),
    (&["physics.solver_iterations=0"], "physics.solver_iterations"),
    (&["physics.contact_stiffness_per_s2=-1"], "physics.contact_stiffness_per_s2"),
    (&["physics.contact_stiffness_per_s2=2e6"], "physics.contact_stiffness_per_s2"),
    (&["physics.contact_damping_per_s=-1", "physics.contact_stiffness_per_s2=1e4"], "physics.contact_damping_per_s"),
    (&["physics.contact_damping_per_s=1"], "physics.contact_damping_per_s"),
    // safety
    (&["safety.max_kinetic_energy_j_per_kg=-1"], "safety.max_kinetic_energy_j_per_kg"),
    (&["safety.max_kinetic_energy_j_per_kg=nan"], "safety.max_kinetic_energy_j_per_kg"),
    (&["safety.check_every_n_steps=0"], "safety.check_every_n_steps"),
    // snake
    (&["snake.n_links=0"], "snake.n_links"),
    (&["snake.n_links=201"], "snake.n_links"),
    (&["snake.link_length_m=0"], "snake.link_length_m"),
    (&["snake.link_radius_m=0"], "snake.link_radius_m"),
    (&["snake.link_radius_m=-0.1"], "snake.link_radius_m"),
    (&["snake.link_length_m=0.079"], "snake.link_length_m"),
    (&["snake.link_radius_m=0.2"], "snake.link_length_m"),
    (&["snake.link_mass_kg=0"], "snake.link_mass_kg"),
    (&["snake.joint_range_deg=0"], "snake.joint_range_deg"),
    (&["snake.joint_range_deg=180.5"], "snake.joint_range_deg"),
    (&["snake.joint_damping_nm_s_per_rad=-0.1"], "snake.joint_damping_nm_s_per_rad"),
    (&["snake.joint_armature_kg_m2=-0.1"], "snake.joint_armature_kg_m2"),
    (&["snake.torque_range_nm=[3, -3]"], "snake.torque_range_nm"),
    (&["snake.torque_range_nm=[2, 2]"], "snake.torque_range_nm"),
    (&["snake.torque_range_nm=[1, 3]"], "snake.torque_range_nm"),
    (&["snake.torque_range_nm=[-3, -1]"], "snake.torque_range_nm"),
    (&["snake.torque_range_nm=[nan, 3]"], "snake.torque_range_nm"),
    (&["snake.ground_friction=[-0.1, 0.005, 0.0001]"], "snake.ground_friction"),
    (&["ground.axial_friction=-0.1"], "ground.axial_friction"),
    (&["ground.lateral_friction=-1"], "ground.lateral_friction"),
    (&["ground.backward_friction=nan"], "ground.backward_friction"),
    (&["ground.viscous_tangential_n_s_per_m=-1"], "ground.viscous_tangential_n_s_per_m"),
    (&["ground.viscous_normal_n_s_per_m=-1"], "ground.viscous_normal_n_s_per_m"),
    (&["ground.model=\"sticky\""], "ground.model"),
    (&["snake.ground_friction=[0.5, -0.005, 0.0001]"], "snake.ground_friction"),
    (&["snake.ground_friction=[0.5, 0.005, -0.0001]"], "snake.ground_friction"),
    (&["snake.link_friction=[-1, 0, 0]"], "snake.link_friction"),
    (&["snake.link_friction=[0.5, inf, 0]"], "snake.link_friction"),
    (&["snake.color_rgba=[1.5, 0, 0, 1]"], "snake.color_rgba"),
    (&["snake.color_rgba=[0, 0, 0, -0.1]"], "snake.color_rgba"),
    (&["snake.head_position_m=[inf, 0, 0]"], "snake.head_position_m"),
    (&["snake.head_rotation_deg=[0, nan, 0]"], "snake.head_rotation_deg"),
    // sensors
    (&["sensors.accelerometer.std=-0.01"], "sensors.accelerometer.std"),
    (&["sensors.gyro.std=-0.01"], "sensors.gyro.std"),
    (&["sensors.joint_angle.std=-0.01"], "sensors.joint_angle.std"),
    (&["sensors.joint_velocity.std=-0.01"], "sensors.joint_velocity.std"),
    (&["sensors.actuator_torque.std=-0.01"], "sensors.actuator_torque.std"),
    (&["sensors.joint_force.std=-0.01"], "sensors.joint_force.std"),
    (&["sensors.joint_torque.std=nan"], "sensors.joint_torque.std"),
    (&["sensors.joint_force.bias=inf"], "sensors.joint_force.bias"),
    (&["sensors.gyro.bias_random_walk_per_sqrt_s=-1"], "sensors.gyro.bias_random_walk_per_sqrt_s"),
    (&["sensors.joint_angle.resolution=-0.001"], "sensors.joint_angle.resolution"),
    (&["sensors.accelerometer.rate_hz=-100"], "sensors.accelerometer.rate_hz"),
    // control
    (&["control.torque_gear=0"], "control.torque_gear"),
    (&["control.position_kp_nm_per_rad=-1"], "control.position_kp_nm_per_rad"),
    (&["control.position_kv_nm_s_per_rad=-1"], "control.position_kv_nm_s_per_rad"),
    (&["control.velocity_kv_nm_s_per_rad=-1"], "control.velocity_kv_nm_s_per_rad"),
    (&["control.intvelocity_kp_nm_per_rad=-1"], "control.intvelocity_kp_nm_per_rad"),
    (&["control.pid_kp_nm_per_rad=-1"], "control.pid_kp_nm_per_rad"),
    (&["control.pid_ki_nm_per_rad_s=-1"], "control.pid_ki_nm_per_rad_s"),
    (&["control.pid_kd_nm_s_per_rad=-1"], "control.pid_kd_nm_s_per_rad"),
    // gait
    (&["gait.ramp_secs=-1"], "gait.ramp_secs"),
    (&["gait.sine_wave.amplitude_deg=-1"], "gait.sine_wave.amplitude_deg"),
    (&["gait.sine_wave.amplitude_deg=91"], "gait.sine_wave.amplitude_deg"),
    (&["snake.joint_range_deg=20"], "gait.sine_wave.amplitude_deg"),
    (&["gait.sine_wave.offset_deg=70"], "gait.sine_wave.offset_deg"),
    (&["gait.sine_wave.offset_deg=-61"], "gait.sine_wave.offset_deg"),
    (&["gait.sine_wave.frequency_hz=-0.5"], "gait.sine_wave.frequency_hz"),
    (&["gait.sine_wave.phase_lag_deg=nan"], "gait.sine_wave.phase_lag_deg"),
    (&["gait.serpenoid.winding_angle_deg=-1"], "gait.serpenoid.winding_angle_deg"),
    (&["gait.serpenoid.n_waves=0"], "gait.serpenoid.n_waves"),
    (&["gait.kind=\"serpenoid\"", "gait.serpenoid.winding_angle_deg=200"], "gait.serpenoid.winding_angle_deg"),
    (&["gait.sidewinding.pitch_amplitude_deg=-3"], "gait.sidewinding.pitch_amplitude_deg"),
    (&["gait.kind=\"sidewinding\""], "gait.kind"),
    (
        &["gait.kind=\"rolling\"", "snake.joint_axes=\"alternating\"", "gait.rolling.amplitude_deg=95"],
        "gait.rolling.amplitude_deg",
    ),
    (&["gait.rolling.frequency_hz=-1"], "gait.rolling.frequency_hz"),
    (&["gait.form_closure.pattern_deg=[]"], "gait.form_closure.pattern_deg"),
    (&["gait.form_closure.pattern_deg=[0, nan]"], "gait.form_closure.pattern_deg"),
    (&["gait.kind=\"form_closure\"", "gait.form_closure.pattern_deg=[0, 90]"], "gait.form_closure.pattern_deg"),
    (&["terrain.kind=\"form_closure\"", "gait.form_closure.pattern_deg=[-100]"], "gait.form_closure.pattern_deg"),
    (&["gait.form_closure.shift_period_secs=0"], "gait.form_closure.shift_period_secs"),
    // terrain
    (&["terrain.obstacle_friction=[-0.5, 0, 0]"], "terrain.obstacle_friction"),
    (&["terrain.cylinder_height_m=0"], "terrain.cylinder_height_m"),
    (&["terrain.floor_size_m=0"], "terrain.floor_size_m"),
    (&["terrain.two_cylinders.distance_m=0"], "terrain.two_cylinders.distance_m"),
    (&["terrain.two_cylinders.radius_m=0"], "terrain.two_cylinders.radius_m"),
    (&["terrain.random_cylinders.radius_range_m=[0.2, 0.1]"], "terrain.random_cylinders.radius_range_m"),
    (&["terrain.random_cylinders.radius_range_m=[0, 0.1]"], "terrain.random_cylinders.radius_range_m"),
    (&["terrain.random_cylinders.half_size_m=0"], "terrain.random_cylinders.half_size_m"),
    (&["terrain.random_cylinders.min_gap_m=-0.1"], "terrain.random_cylinders.min_gap_m"),
    (&["terrain.cylinder_path.n_pairs=0"], "terrain.cylinder_path.n_pairs"),
    (&["terrain.cylinder_path.spacing_m=0"], "terrain.cylinder_path.spacing_m"),
    (&["terrain.cylinder_path.radius_m=0"], "terrain.cylinder_path.radius_m"),
    (
        &[
            "control.controller=\"follow_the_leader_reflex\"",
            "estimation.enabled=true",
            "follow_the_leader_reflex.max_offset_deg=90",
        ],
        "follow_the_leader_reflex.max_offset_deg",
    ),
    (&["follow_the_leader_reflex.propulsive_gain_rad_per_n=-1"], "follow_the_leader_reflex.propulsive_gain_rad_per_n"),
    (&["follow_the_leader_reflex.force_filter_secs=-1"], "follow_the_leader_reflex.force_filter_secs"),
    (
        &[
            "control.controller=\"follow_the_leader_reflex\"",
            "estimation.enabled=true",
            "gait.sine_wave.phase_lag_deg=-30",
        ],
        "gait.sine_wave.phase_lag_deg",
    ),
    (
        &["control.controller=\"follow_the_leader_reflex\"", "estimation.enabled=false"],
        "follow_the_leader_reflex.contacts",
    ),
    (&["control.controller=\"follow_the_leader_reflex\"", "gait.kind=\"serpenoid\""], "gait.kind"),
    (&["directional_admittance.windows=0"], "directional_admittance.windows"),
    (
        &[
            "control.controller=\"directional_admittance\"",
            "estimation.enabled=true",
            "directional_admittance.windows=50",
        ],
        "directional_admittance.windows",
    ),
    (
        &["directional_admittance.min_amplitude_deg=50", "directional_admittance.max_amplitude_deg=40"],
        "directional_admittance.min_amplitude_deg",
    ),
    (&["directional_admittance.escape_stiffness_ratio=2"], "directional_admittance.escape_stiffness_ratio"),
    (&["directional_admittance.damping_nm_s_per_rad=0"], "directional_admittance.damping_nm_s_per_rad"),
    (
        &["control.controller=\"directional_admittance\"", "estimation.enabled=true", "gait.sine_wave.amplitude_deg=5"],
        "gait.sine_wave.amplitude_deg",
    ),
    (&["control.controller=\"directional_admittance\"", "estimation.enabled=false"], "directional_admittance.contacts"),
    (&["jam_resolution.min_propulsion=1"], "jam_resolution.min_propulsion"),
    (&["jam_resolution.push_force_n=0"], "jam_resolution.push_force_n"),
    (&["jam_resolution.jam_window_secs=0"], "jam_resolution.jam_window_secs"),
    (
        &["control.controller=\"jam_resolution\"", "estimation.enabled=true", "control.method=\"velocity\""],
        "control.method",
    ),
    (&["control.controller=\"jam_resolution\"", "estimation.enabled=false"], "jam_resolution.contacts"),
    (&["terrain.cylinder_path.width_m=0.1"], "terrain.cylinder_path.width_m"),
    (&["terrain.cylinder_path.width_m=0.15"], "terrain.cylinder_path.width_m"),
    (&["terrain.cylinder_path.start_m=nan"], "terrain.cylinder_path.start_m"),
    (&["terrain.form_closure.order=0"], "terrain.form_closure.order"),
    (&["terrain.form_closure.order=3"], "terrain.form_closure.order"),
    (&["terrain.form_closure.radius_m=0"], "terrain.form_closure.radius_m"),
    // recording
    (&["recording.every_n_steps=0"], "recording.every_n_steps"),
    (&["recording.parquet_row_group_rows=0"], "recording.parquet_row_group_rows"),
    (&["recording.parquet_rows_per_file=0"], "recording.parquet_rows_per_file"),
    (&["recording.format=\"xml\""], "recording.format"),
    (&["recording.every_n_steps=20001"], "recording.every_n_steps"),
    // env
    (&["env.observation_version=2"], "env.observation_version"),
    (&["env.control_period_secs=0"], "env.control_period_secs"),
    (&["env.control_period_secs=nan"], "env.control_period_secs"),
    (&["env.max_episode_secs=-1"], "env.max_episode_secs"),
    (&["env.reward_forward_weight=inf"], "env.reward_forward_weight"),
    (&["env.reward_energy_weight=-0.1"], "env.reward_energy_weight"),
    (&["env.reward_contact_force_weight=-1"], "env.reward_contact_force_weight"),
    (&["env.terminate_contact_force_n=-5"], "env.terminate_contact_force_n"),
    (&["env.reward_ctrl_cost_weight=-1e-4"], "env.reward_ctrl_cost_weight"),
    (&["env.reset_noise_scale=-0.1"], "env.reset_noise_scale"),
    (&["env.reset_heading_noise_rad=4.0"], "env.reset_heading_noise_rad"),
    (&["env.action=\"velocity\""], "env.action"),
];

#[test]
fn every_validation_rule_rejects_with_key_path() {
    for (overrides, key) in RULES {
        let result = load_toml("", overrides);
        let Err(e) = result else {
            panic!("{overrides:?} was accepted, expected an error at `{key}`");
        };
        assert!(matches!(e, ConfigError::InvalidValue { .. }), "{overrides:?}: {e:?}");
        assert_eq!(error_key(&e), *key, "{overrides:?}: {e}");
        let message = e.to_string();
        assert!(message.contains(key), "{message}");
    }
}

#[test]
fn validate_on_a_built_config() {
    let mut config = Config::default();
    config.snake.n_links = 0;
    let e = config.validate().unwrap_err();
    assert_eq!(
        e,
        ConfigError::InvalidValue {
            key: "snake.n_links".into(),
            value: "0".into(),
            allowed: "must be at least 1".into()
        }
    );
    assert_eq!(e.to_string(), "`snake.n_links` = 0: must be at least 1");
}

#[test]
fn validation_messages_explain() {
    let (_, value, allowed) = invalid(load_toml("", &["snake.link_length_m=0.05"]));
    assert_eq!(value, "0.05");
    assert!(allowed.contains("diameter") && allowed.contains("between neighbouring joints"), "{allowed}");
    let (_, _, allowed) = invalid(load_toml("", &["physics.contact_time_constant_secs=0.001"]));
    assert!(allowed.contains("MuJoCo") && allowed.contains("0.002"), "{allowed}");
    assert!(load_toml("", &["general.plot=true"]).unwrap().general.plot);
    let (_, _, allowed) = invalid(load_toml("", &["terrain.cylinder_path.width_m=0.15"]));
    assert!(allowed.contains("snake fits between the rows"), "{allowed}");
}

#[test]
fn consistency_rules_apply_only_to_sections_in_use() {
    // Unused gait / terrain / recording settings do not have to match the snake.
    let config = load_toml(
        "",
        &[
            "gait.kind=none",
            "gait.sine_wave.amplitude_deg=100",
            "terrain.kind=none",
            "terrain.cylinder_path.width_m=0.15",
            "recording.enabled=false",
            "recording.every_n_steps=1000000",
        ],
    )
    .unwrap();
    assert_eq!(config.gait.sine_wave.amplitude_deg, 100.0);
    // Plain ranges apply even when unused.
    let e = load_toml("", &["terrain.kind=none", "terrain.cylinder_path.radius_m=0"]).unwrap_err();
    assert_eq!(error_key(&e), "terrain.cylinder_path.radius_m");
    // Boundaries that are allowed.
    load_toml("", &["gait.sine_wave.amplitude_deg=90", "snake.joint_range_deg=180", "snake.torque_range_nm=[0, 3]"])
        .unwrap();
    load_toml("", &["general.timestep_secs=0.01"]).unwrap(); // 0.02 >= 2 x 0.01
}

#[test]
fn nan_in_toml_is_rejected() {
    let (key, value, allowed) = invalid(load_toml("[general]\nduration_secs = nan\n", &[]));
    assert_eq!(key, "general.duration_secs");
    assert_eq!(value, "nan");
    assert!(allowed.contains("finite"));
    let e = load_toml("[snake]\nlink_mass_kg = -inf\n", &[]).unwrap_err();
    assert_eq!(error_key(&e), "snake.link_mass_kg");
}

// --- keys and types -------------------------------------------------------------------------

#[test]
fn unknown_key_suggests_the_closest() {
    let e = load_toml("[snake]\nn_link = 3\n", &[]).unwrap_err();
    let ConfigError::UnknownKey { key, suggestion, allowed } = &e else { panic!("{e:?}") };
    assert_eq!(key, "snake.n_link");
    assert_eq!(suggestion.as_deref(), Some("snake.n_links"));
    assert!(allowed.starts_with("n_links, link_length_m, "), "{allowed}");
    assert!(e.to_string().contains("did you mean `snake.n_links`"), "{e}");

    let e = load_toml("[snak]\nn_links = 3\n", &[]).unwrap_err();
    let ConfigError::UnknownKey { key, suggestion, allowed } = &e else { panic!("{e:?}") };
    assert_eq!(key, "snak");
    assert_eq!(suggestion.as_deref(), Some("snake"));
    assert!(allowed.contains("general") && allowed.contains("recording"), "{allowed}");

    let e = load_toml("[gait.sine_wave]\namplitude = 3\n", &[]).unwrap_err();
    assert!(
        matches!(&e, ConfigError::UnknownKey { suggestion: Some(s), .. } if s == "gait.sine_wave.amplitude_deg"),
        "{e:?}"
    );

    // A key of another table points there.
    let e = load_toml("[general]\nn_links = 3\n", &[]).unwrap_err();
    assert!(matches!(&e, ConfigError::UnknownKey { suggestion: Some(s), .. } if s == "snake.n_links"), "{e:?}");

    // Nothing close: no suggestion.
    let e = load_toml("[snake]\nzzzzzzzz = 3\n", &[]).unwrap_err();
    assert!(matches!(&e, ConfigError::UnknownKey { suggestion: None, .. }), "{e:?}");
}

/// A controller or controller section that SimSerpent does not have (`obstacle_aided`, `rail`)
/// is refused, naming the key, the value and the controllers there are (no silent fallback to
/// another controller).
#[test]
fn a_controller_or_section_that_does_not_exist_is_refused() {
    for name in ["obstacle_aided", "rail"] {
        let (key, value, allowed) = invalid(load_toml(&format!("[control]\ncontroller = \"{name}\"\n"), &[]));
        assert_eq!((key.as_str(), value.as_str()), ("control.controller", format!("\"{name}\"").as_str()));
        assert!(allowed.contains("`path_following`") && allowed.contains("`jam_resolution`"), "{allowed}");
        let e = load_toml(&format!("[{name}]\ncontacts = \"true\"\n"), &[]).unwrap_err();
        assert!(matches!(&e, ConfigError::UnknownKey { key, .. } if key == name), "{e:?}");
    }
}

#[test]
fn table_and_value_mixups_are_invalid_values() {
    let (key, value, _) = invalid(load_toml("snake = 3\n", &[]));
    assert_eq!((key.as_str(), value.as_str()), ("snake", "3"));
    let (key, _, allowed) = invalid(load_toml("[snake.n_links]\nx = 1\n", &[]));
    assert_eq!(key, "snake.n_links");
    assert!(allowed.contains("not a table"));
}

#[test]
fn wrong_type_names_key_and_value() {
    let e = load_toml("[general]\nduration_secs = \"ten\"\n", &[]).unwrap_err();
    let ConfigError::InvalidValue { key, value, allowed } = &e else { panic!("{e:?}") };
    assert_eq!(key, "general.duration_secs");
    assert_eq!(value, "\"ten\"");
    assert!(allowed.contains("number"), "{allowed}");
    assert!(e.to_string().contains("general.duration_secs") && e.to_string().contains("ten"), "{e}");

    let (key, value, allowed) = invalid(load_toml("[control]\nmethod = \"torq\"\n", &[]));
    assert_eq!((key.as_str(), value.as_str()), ("control.method", "\"torq\""));
    assert!(allowed.contains("`torque`") && allowed.contains("`intvelocity`"), "{allowed}");

    let (key, value, _) = invalid(load_toml("[snake]\ntorque_range_nm = [1]\n", &[]));
    assert_eq!((key.as_str(), value.as_str()), ("snake.torque_range_nm", "[1]"));

    let (key, _, _) = invalid(load_toml("[snake]\ntorque_range_nm = [1, \"a\"]\n", &[]));
    assert_eq!(key, "snake.torque_range_nm[1]");

    let (key, _, _) = invalid(load_toml("[snake]\nn_links = -1\n", &[]));
    assert_eq!(key, "snake.n_links");
    let (key, _, _) = invalid(load_toml("[snake]\nn_links = 2.5\n", &[]));
    assert_eq!(key, "snake.n_links");
    let (key, _, _) = invalid(load_toml("[visual]\nshow_joints = 1\n", &[]));
    assert_eq!(key, "visual.show_joints");
}

#[test]
fn integers_are_accepted_for_floats() {
    let config = load_toml(
        "[general]\nduration_secs = 5\n[snake]\ntorque_range_nm = [-2, 2]\n[gait.form_closure]\npattern_deg = [0, 30, -30]\n",
        &[],
    )
    .unwrap();
    assert_eq!(config.general.duration_secs, 5.0);
    assert_eq!(config.snake.torque_range_nm, [-2.0, 2.0]);
    assert_eq!(config.gait.form_closure.pattern_deg, vec![0.0, 30.0, -30.0]);
}

#[test]
fn toml_syntax_error_names_file_and_position() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "bad.toml", "[snake]\nn_links = = 3\n");
    let e = load_config(&path, &[]).unwrap_err();
    let ConfigError::Syntax { file, message } = &e else { panic!("{e:?}") };
    assert!(file.ends_with("bad.toml"), "{file}");
    assert!(message.contains("line 2"), "{message}");
}

// --- overrides ------------------------------------------------------------------------------

#[test]
fn parse_override_keeps_types() {
    use toml::Value;
    let v = |s: &str| parse_override(s).unwrap();
    assert_eq!(v("snake.n_links=15"), ("snake.n_links".into(), Value::Integer(15)));
    assert_eq!(v("general.duration_secs=0.5").1, Value::Float(0.5));
    assert_eq!(v("general.plot=true").1, Value::Boolean(true));
    assert_eq!(v("general.run_name=\"s\"").1, Value::String("s".into()));
    assert_eq!(v("a.b=[1,2]").1, Value::Array(vec![Value::Integer(1), Value::Integer(2)]));
    assert_eq!(v("control.method=torque").1, Value::String("torque".into()));
    assert_eq!(v(" control.method = torque ").0, "control.method");
    assert_eq!(v("general.run_name=my-run_2").1, Value::String("my-run_2".into()));

    for bad in ["snake.n_links", "=3", "snake..n_links=3", "snake.n_links=", "snake.n_links=[1,", "a b=1"] {
        let e = parse_override(bad).unwrap_err();
        let ConfigError::Syntax { file, .. } = &e else { panic!("{bad}: {e:?}") };
        assert!(file.contains(bad), "{file}");
    }
}

#[test]
fn overrides_apply_in_order_on_top_of_the_file() {
    let config = load_toml(
        "[snake]\nn_links = 4\n",
        &[
            "snake.n_links=5",
            "general.duration_secs=5",
            "control.method=torque",
            "gait.form_closure.pattern_deg=[10, -10]",
            "snake.torque_range_nm=[-2, 2.5]",
            "general.run_name=my-run",
            "snake.n_links=6",
            "gait.sine_wave={ amplitude_deg = 10 }",
        ],
    )
    .unwrap();
    assert_eq!(config.snake.n_links, 6);
    assert_eq!(config.general.duration_secs, 5.0);
    assert_eq!(config.control.method, ControlMethod::Torque);
    assert_eq!(config.gait.form_closure.pattern_deg, vec![10.0, -10.0]);
    assert_eq!(config.snake.torque_range_nm, [-2.0, 2.5]);
    assert_eq!(config.general.run_name, "my-run");
    assert_eq!(config.gait.sine_wave.amplitude_deg, 10.0);
    assert_eq!(config.gait.sine_wave.frequency_hz, Config::default().gait.sine_wave.frequency_hz);
}

#[test]
fn override_errors() {
    let e = load_toml("", &["snake.n_link=3"]).unwrap_err();
    assert!(
        matches!(&e, ConfigError::UnknownKey { key, suggestion: Some(s), .. } if key == "snake.n_link" && s == "snake.n_links"),
        "{e:?}"
    );
    let e = load_toml("", &["snak.n_links=3"]).unwrap_err();
    assert!(
        matches!(&e, ConfigError::UnknownKey { key, suggestion: Some(s), .. } if key == "snak" && s == "snake"),
        "{e:?}"
    );
    let e = load_toml("", &["control.method=torq"]).unwrap_err();
    assert_eq!(error_key(&e), "control.method");
    let e = load_toml("", &["snake=3"]).unwrap_err();
    assert_eq!(error_key(&e), "snake");
    let e = load_toml("", &["snake.n_links.x=3"]).unwrap_err();
    assert_eq!(error_key(&e), "snake.n_links");
    let e = load_toml("", &["snake.n_links"]).unwrap_err();
    assert!(matches!(e, ConfigError::Syntax { .. }), "{e:?}");
}

// --- files ----------------------------------------------------------------------------------

#[test]
fn file_types_and_io_errors() {
    let dir = tempfile::tempdir().unwrap();

    let path = write(dir.path(), "config.yaml", "snake: 1\n");
    let e = load_config(&path, &[]).unwrap_err();
    let ConfigError::Syntax { file, message } = &e else { panic!("{e:?}") };
    assert!(file.ends_with("config.yaml"));
    assert!(message.contains(".yaml") && message.contains(".toml") && message.contains(".json"), "{message}");

    let path = write(dir.path(), "config", "");
    assert!(matches!(load_config(&path, &[]), Err(ConfigError::Syntax { .. })));

    let e = load_config(&dir.path().join("missing.toml"), &[]).unwrap_err();
    assert!(matches!(&e, ConfigError::Io { file, .. } if file.ends_with("missing.toml")), "{e:?}");

    let path = write(dir.path(), "UPPER.TOML", "[snake]\nn_links = 3\n");
    assert_eq!(load_config(&path, &[]).unwrap().snake.n_links, 3);

    let path = write(dir.path(), "empty.json", "");
    let e = load_config(&path, &[]).unwrap_err();
    assert!(matches!(&e, ConfigError::Syntax { file, .. } if file.ends_with("empty.json")), "{e:?}");

    let path = write(dir.path(), "bad.json", "{ \"simulation_time\": 1, }");
    let e = load_config(&path, &[]).unwrap_err();
    assert!(matches!(&e, ConfigError::Syntax { message, .. } if message.contains("line 1")), "{e:?}");
}

// --- the original tool's config.json --------------------------------------------------------

#[test]
fn thesis_config_json_maps_as_documented() {
    let config = load_config(&thesis_json_path(), &[]).unwrap();
    let d = Config::default();

    assert_eq!(config.general.duration_secs, 100.0);
    assert_eq!(config.general.timestep_secs, 0.01);
    assert_eq!(config.general.integrator, Integrator::RK4);
    assert!(!config.general.plot);
    assert_eq!(config.general.run_name, d.general.run_name);

    assert_eq!(config.visual, Visual { show_contact_forces: false, ..d.visual.clone() });

    let s = &config.snake;
    assert_eq!(s.n_links, 2);
    assert_eq!(s.link_mass_kg, 0.3);
    assert_eq!(s.link_length_m, 0.2); // 2 x the original half length 0.10
    assert_eq!(s.link_radius_m, 0.08);
    assert_eq!(s.torque_range_nm, [-3.0, 3.0]);
    assert_eq!(s.ground_friction, [0.5, d.snake.ground_friction[1], d.snake.ground_friction[2]]);
    assert_eq!(s.link_friction, [0.5, d.snake.link_friction[1], d.snake.link_friction[2]]);
    assert_eq!(config.terrain.obstacle_friction, [0.5, d.terrain.obstacle_friction[1], d.terrain.obstacle_friction[2]]);
    assert_eq!(s.joint_damping_nm_s_per_rad, 0.5);
    assert_eq!(s.joint_armature_kg_m2, 0.2);
    assert_eq!(s.color_rgba, [0.0, 0.2, 1.0, 1.0]);
    assert_eq!(s.head_position_m, [0.0, 0.0, 0.0]);
    assert_eq!(s.head_rotation_deg, [0.0, 0.0, 0.0]);

    let n = &config.sensors;
    assert!(!n.noise_enabled);
    for (kind, m) in n.models() {
        assert_eq!(m.std, 0.0, "sensors.{kind}.std");
        assert_eq!(
            *m,
            SensorModel { std: 0.0, ..d.sensors.accelerometer },
            "sensors.{kind}: only std comes from the JSON"
        );
    }

    let c = &config.control;
    assert_eq!(c.method, ControlMethod::Position);
    assert_eq!(c.torque_gear, 1.0);
    assert_eq!(c.position_kp_nm_per_rad, 0.7);
    assert_eq!(c.velocity_kv_nm_s_per_rad, 0.0);
    assert_eq!(c.intvelocity_kp_nm_per_rad, 50.0);
    assert_eq!([c.pid_kp_nm_per_rad, c.pid_ki_nm_per_rad_s, c.pid_kd_nm_s_per_rad], [0.4, 0.0, 0.0]);
    // velocity_actuator_KP is also the position servo's D gain (the thesis' PD control).
    assert_eq!(c.position_kv_nm_s_per_rad, 0.0);
    assert_eq!(config.legacy.geometry, LegacyGeometry::NoOverlap);

    assert_eq!(config.terrain.kind, TerrainKind::None);
    assert_eq!(config.gait.kind, GaitKind::None);

    let r = &config.recording;
    assert!(!r.enabled);
    for flag in [
        r.link_position,
        r.link_velocity,
        r.link_acceleration,
        r.link_orientation,
        r.link_angular_velocity,
        r.link_angular_acceleration,
        r.torque_actuator_forces,
        r.position_actuator_forces,
        r.velocity_actuator_forces,
        r.joint_angles,
        r.external_contact_forces,
    ] {
        assert!(!flag);
    }
    // Tables the original tool did not have keep their defaults.
    assert_eq!(r.joint_velocities, d.recording.joint_velocities);
    assert_eq!(r.contacts, d.recording.contacts);
    assert_eq!(r.every_n_steps, d.recording.every_n_steps);

    // Overrides work on legacy files too.
    let config = load_config(&thesis_json_path(), &sets(&["snake.n_links=3"])).unwrap();
    assert_eq!(config.snake.n_links, 3);
}

#[test]
fn empty_legacy_object_is_all_defaults() {
    // All defaults, except that the original tool's friction was always isotropic.
    let mut expected = Config::default();
    expected.ground.model = GroundModel::Isotropic;
    assert_eq!(load_json("{}").unwrap(), expected);
}

#[test]
fn legacy_experiments_and_terrain() {
    let c = load_json(r#"{"prebuilt_experiments": {"do_sinus": true, "form_closure": false}}"#).unwrap();
    assert_eq!(c.gait.kind, GaitKind::SineWave);
    assert_eq!(c.terrain.kind, Config::default().terrain.kind); // no terrain section: default

    let c =
        load_json(r#"{"prebuilt_experiments": {"form_closure": true}, "terrain": {"generate_two_cylinders": false}}"#)
            .unwrap();
    assert_eq!(c.gait.kind, GaitKind::FormClosure);
    assert_eq!(c.terrain.kind, TerrainKind::FormClosure);

    for (flag, kind) in [
        ("generate_two_cylinders", TerrainKind::TwoCylinders),
        ("generate_random_cylinders", TerrainKind::RandomCylinders),
        ("generate_cylinder_path", TerrainKind::CylinderPath),
    ] {
        let c = load_json(&format!(r#"{{"terrain": {{"{flag}": true}}}}"#)).unwrap();
        assert_eq!(c.terrain.kind, kind, "{flag}");
    }

    let (key, _, allowed) = invalid(load_json(
        r#"{"terrain": {"generate_two_cylinders": true, "generate_random_cylinders": false, "generate_cylinder_path": true}}"#,
    ));
    assert_eq!(key, "terrain.generate_cylinder_path");
    assert!(allowed.contains("terrain.generate_two_cylinders"), "{allowed}");

    let (key, _, allowed) = invalid(load_json(r#"{"prebuilt_experiments": {"form_closure": true, "do_sinus": true}}"#));
    assert_eq!(key, "prebuilt_experiments.form_closure");
    assert!(allowed.contains("prebuilt_experiments.do_sinus"), "{allowed}");

    let (key, _, allowed) = invalid(load_json(
        r#"{"prebuilt_experiments": {"form_closure": true}, "terrain": {"generate_random_cylinders": true}}"#,
    ));
    assert_eq!(key, "prebuilt_experiments.form_closure");
    assert!(allowed.contains("terrain.generate_random_cylinders"), "{allowed}");
}

#[test]
fn legacy_values_map() {
    let c = load_json(
        r#"{
            "snake_specifications": {"sensor_noise": "Enable", "sensor_noise_amount": 0.02, "friction": 1,
                                      "maximum_torque_in_nm": 2, "snake_color_rgb": [1, 0, 0]},
            "control_parameters": {"control_method": "IntVelocity"},
            "visual_options": {"show_contact_force": true, "make_transparent": true},
            "store_data_to_csv": {"store_data": true, "angle": false, "accel": false}
        }"#,
    )
    .unwrap();
    assert!(c.sensors.noise_enabled);
    for (kind, m) in c.sensors.models() {
        assert_eq!(m.std, 0.02, "sensors.{kind}.std");
    }
    assert_eq!(c.snake.ground_friction[0], 1.0);
    assert_eq!(c.snake.torque_range_nm, [-2.0, 2.0]);
    assert_eq!(c.snake.color_rgba, [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(c.control.method, ControlMethod::Intvelocity);
    assert!(c.visual.show_contact_forces && c.visual.make_transparent && !c.visual.show_joints);
    assert!(c.recording.enabled && !c.recording.link_orientation && !c.recording.link_acceleration);
    assert!(c.recording.link_position);

    for (method, expected) in [
        ("TORQUE", ControlMethod::Torque),
        ("velocity", ControlMethod::Velocity),
        ("intvelocity", ControlMethod::Intvelocity),
        ("Position", ControlMethod::Position),
    ] {
        let c = load_json(&format!(r#"{{"control_parameters": {{"control_method": "{method}"}}}}"#)).unwrap();
        assert_eq!(c.control.method, expected);
    }
}

#[test]
fn legacy_errors_use_legacy_names() {
    let e = load_json(r#"{"snake_specifications": {"link_length_in_m": 0.1}}"#).unwrap_err();
    let ConfigError::UnknownKey { key, suggestion, allowed } = &e else { panic!("{e:?}") };
    assert_eq!(key, "snake_specifications.link_length_in_m");
    assert_eq!(suggestion.as_deref(), Some("snake_specifications.link_lenght_in_m"));
    assert!(allowed.starts_with("nr_of_links, "), "{allowed}");

    let e = load_json(r#"{"simulation_tim": 3}"#).unwrap_err();
    assert!(matches!(&e, ConfigError::UnknownKey { suggestion: Some(s), .. } if s == "simulation_time"), "{e:?}");
    let e = load_json(r#"{"snake_specification": {}}"#).unwrap_err();
    assert!(matches!(&e, ConfigError::UnknownKey { suggestion: Some(s), .. } if s == "snake_specifications"), "{e:?}");

    let (key, _, _) = invalid(load_json(r#"{"control_parameters": {"control_method": "pid"}}"#));
    assert_eq!(key, "control_parameters.control_method");
    let (key, _, _) = invalid(load_json(r#"{"snake_specifications": {"sensor_noise": "maybe"}}"#));
    assert_eq!(key, "snake_specifications.sensor_noise");
    let (key, _, _) = invalid(load_json(r#"{"control_parameters": {"PID_parameters_Kp_Ki_Kd": [1, 2]}}"#));
    assert_eq!(key, "control_parameters.PID_parameters_Kp_Ki_Kd");
    let (key, _, _) = invalid(load_json(r#"{"snake_specifications": {"friction": "high"}}"#));
    assert_eq!(key, "snake_specifications.friction");
    let (key, _, _) = invalid(load_json(r#"{"terrain": {"generate_two_cylinders": "yes"}}"#));
    assert_eq!(key, "terrain.generate_two_cylinders");
    let (key, _, _) = invalid(load_json(r#"{"snake_specifications": 3}"#));
    assert_eq!(key, "snake_specifications");
    let (key, _, _) = invalid(load_json(r#"{"simulation_time": null}"#));
    assert_eq!(key, "simulation_time");

    // Errors found after conversion name the new key and the config.json key it came from.
    let (key, _, allowed) = invalid(load_json(r#"{"snake_specifications": {"nr_of_links": 0}}"#));
    assert_eq!(key, "snake.n_links");
    assert!(allowed.contains("snake_specifications.nr_of_links"), "{allowed}");
    let (key, value, allowed) = invalid(load_json(r#"{"snake_specifications": {"link_lenght_in_m": 0.03}}"#));
    assert_eq!((key.as_str(), value.as_str()), ("snake.link_length_m", "0.06"));
    assert!(allowed.contains("link_lenght_in_m"), "{allowed}");
    assert!(load_json(r#"{"plot_data": true}"#).unwrap().general.plot);
}
