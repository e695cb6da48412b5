//! Small 3-D geometry helpers and the snake's forward kinematics (pure Rust, no MuJoCo).
//!
//! Conventions (the same as the generated MJCF):
//! - Snake frame: the head's front tip at the origin, body along −x, z up.
//! - World placement: the head tip at `head_position_m + (0, 0, link_radius_m)`, orientation given
//!   by `head_rotation_deg` as MJCF `euler` with the default `eulerseq="xyz"` (intrinsic
//!   rotations: R = Rx(a)·Ry(b)·Rz(c)).
//! - Link `i` spans x ∈ [−L, 0] of its own frame; link `i > 0` hangs at (−L, 0, 0) of link
//!   `i − 1`, rotated by joint `i` about the joint's axis (z for yaw joints, y for pitch joints).

use crate::config::{Config, JointAxes, LegacyGeometry};

/// A 3-vector.
pub(crate) type V3 = [f64; 3];
/// A row-major 3×3 matrix.
pub(crate) type M3 = [[f64; 3]; 3];

pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub(crate) fn mat_vec(m: &M3, v: V3) -> V3 {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

pub(crate) fn mat_mul(a: &M3, b: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    r
}

/// Rotation by `angle` (rad) about the unit axis x (0), y (1) or z (2).
pub(crate) fn rot_axis(axis: usize, angle: f64) -> M3 {
    let (s, c) = angle.sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// Rotation matrix of MJCF `euler="a b c"` (radians, `eulerseq="xyz"`): Rx(a)·Ry(b)·Rz(c).
pub(crate) fn euler_xyz_matrix(e: [f64; 3]) -> M3 {
    mat_mul(&mat_mul(&rot_axis(0, e[0]), &rot_axis(1, e[1])), &rot_axis(2, e[2]))
}

/// Unit quaternion (w, x, y, z) of MJCF `euler="a b c"` (radians, `eulerseq="xyz"`), composed the
/// way MuJoCo's compiler does it: q = qx(a) ⊗ qy(b) ⊗ qz(c).
pub(crate) fn euler_xyz_quat(e: [f64; 3]) -> [f64; 4] {
    let mut q = [1.0, 0.0, 0.0, 0.0];
    for (axis, &angle) in e.iter().enumerate() {
        let (s, c) = (angle / 2.0).sin_cos();
        let mut t = [c, 0.0, 0.0, 0.0];
        t[axis + 1] = s;
        q = quat_mul(q, t);
    }
    q
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// Index (0 = x, 1 = y, 2 = z) of the local axis of joint `j` (`j >= 1`).
pub(crate) fn joint_axis_index(axes: JointAxes, j: usize) -> usize {
    match axes {
        JointAxes::Yaw => 2,
        JointAxes::Alternating => {
            if j.is_multiple_of(2) {
                1
            } else {
                2
            }
        }
    }
}

/// World position of the head link's frame: the head tip `head_position_m + (0, 0, link_radius_m)`
/// (`legacy.geometry = "no_overlap"`), or, for `"faithful"`, the head's front joint point where the
/// original tool put its head body: `head_position_m + (link_length_m, 0, link_radius_m)` (thesis
/// listing 3: head body at x = 0.2 m for head position 0 and link_lenght_in_m 0.10; the original
/// floor was at z = −radius, ours at 0).
pub(crate) fn head_tip(cfg: &Config) -> V3 {
    let p = cfg.snake.head_position_m;
    let dx = match cfg.legacy.geometry {
        LegacyGeometry::NoOverlap => 0.0,
        LegacyGeometry::Faithful => cfg.snake.link_length_m,
    };
    [p[0] + dx, p[1], p[2] + cfg.snake.link_radius_m]
}

/// Head rotation (world from snake frame) in radians, as MJCF `euler` (`xyz`). For
/// `legacy.geometry = "faithful"` the configured rotation is followed by 180° about the head's
/// z axis (R·Rz(π) = Rx(a)·Ry(b)·Rz(c + π)), so that the body extends along the rotated +x axis
/// as in the original tool, while link frames keep SimSerpent's orientation (x toward the head).
pub(crate) fn head_rotation_rad(cfg: &Config) -> [f64; 3] {
    let mut e = cfg.snake.head_rotation_deg.map(f64::to_radians);
    if cfg.legacy.geometry == LegacyGeometry::Faithful {
        e[2] += std::f64::consts::PI;
    }
    e
}

/// How far a link's capsule core starts inside its joint-to-joint segment (m): `link_radius_m`
/// for `"no_overlap"` (the caps end at the joints), 0 for `"faithful"` (the core is the segment,
/// the caps reach beyond the joints).
pub(crate) fn core_inset_m(cfg: &Config) -> f64 {
    match cfg.legacy.geometry {
        LegacyGeometry::NoOverlap => cfg.snake.link_radius_m,
        LegacyGeometry::Faithful => 0.0,
    }
}

/// Position and world rotation of every link frame for the given joint angles (missing angles are
/// zero, extra ones ignored).
pub(crate) fn link_frames(cfg: &Config, joint_angles_rad: &[f64]) -> Vec<(V3, M3)> {
    let n = cfg.snake.n_links;
    let l = cfg.snake.link_length_m;
    let mut frames = Vec::with_capacity(n);
    let mut pos = head_tip(cfg);
    let mut rot = euler_xyz_matrix(head_rotation_rad(cfg));
    for i in 0..n {
        if i > 0 {
            pos = add(pos, mat_vec(&rot, [-l, 0.0, 0.0]));
            let q = joint_angles_rad.get(i - 1).copied().unwrap_or(0.0);
            rot = mat_mul(&rot, &rot_axis(joint_axis_index(cfg.snake.joint_axes, i), q));
        }
        frames.push((pos, rot));
    }
    frames
}

/// World-frame segment (front point, back point) of each link's body axis (joint to joint; with
/// `legacy.geometry = "no_overlap"` the capsule including its caps spans exactly this segment, with
/// `"faithful"` it is the capsule's core and the caps reach `link_radius_m` beyond), for the given
/// joint angles.
///
/// `joint_angles_rad[j - 1]` is the angle of joint `j` (between link `j - 1` and link `j`); missing
/// angles count as zero and extra ones are ignored. The result has `snake.n_links` entries;
/// entry 0 is the head, whose front point is the head tip
/// `head_position_m + (0, 0, link_radius_m)` (for `"faithful"`: its front joint point, see
/// `head_tip`).
pub fn link_axis_segments_m(cfg: &Config, joint_angles_rad: &[f64]) -> Vec<[[f64; 3]; 2]> {
    let l = cfg.snake.link_length_m;
    link_frames(cfg, joint_angles_rad).into_iter().map(|(p, r)| [p, add(p, mat_vec(&r, [-l, 0.0, 0.0]))]).collect()
}

/// Distance in the xy-plane from point `p` to the segment `[a, b]` (z ignored).
pub(crate) fn dist_xy_point_segment(p: [f64; 2], a: V3, b: V3) -> f64 {
    let (ax, ay) = (a[0], a[1]);
    let (dx, dy) = (b[0] - ax, b[1] - ay);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p[0] - ax) * dx + (p[1] - ay) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (cx, cy) = (ax + t * dx, ay + t * dy);
    (p[0] - cx).hypot(p[1] - cy)
}

/// Euclidean norm of a 2-vector.
pub(crate) fn norm2(v: [f64; 2]) -> f64 {
    v[0].hypot(v[1])
}

/// `v` rotated by +90° about z.
pub(crate) fn rot90(v: [f64; 2]) -> [f64; 2] {
    [-v[1], v[0]]
}

/// z-component of the cross product of two xy-vectors.
pub(crate) fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The xy-part of a 3-vector.
pub(crate) fn xy(v: V3) -> [f64; 2] {
    [v[0], v[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quat_matches_matrix() {
        let e = [0.3, -1.1, 2.5];
        let q = euler_xyz_quat(e);
        let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
        let from_q = [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
            [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
            [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
        ];
        let m = euler_xyz_matrix(e);
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - from_q[i][j]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn point_segment() {
        let d = dist_xy_point_segment([0.5, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 5.0]);
        assert!((d - 1.0).abs() < 1e-15);
        let d = dist_xy_point_segment([2.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        assert!((d - 1.0).abs() < 1e-15);
    }
}
