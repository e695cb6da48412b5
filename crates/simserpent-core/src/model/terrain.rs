//! Obstacle placement for every `terrain.kind` (pure geometry, no MuJoCo).
//!
//! Every obstacle is a vertical cylinder standing on the floor (centre at z = height / 2), named
//! `obstacle_kk` in the order returned here. Notation used below:
//! - `T`: world position of the head tip, `head_position_m + (0, 0, link_radius_m)`, in xy;
//! - `h`: unit heading in the xy-plane (the snake's +x axis after `head_rotation_deg`, projected);
//! - `n`: `h` rotated by +90° about z (the snake's left);
//! - `M`: middle of the straight snake's body axis, `T + R·(−n_links·L/2, 0, 0)`, in xy;
//! - `r`: link radius.
//!
//! Kinds:
//! - `two_cylinders` (thesis experiment II, collisions along x and y): obstacle 0 straight ahead at
//!   `T + h·(distance_m + radius_m)` (its surface `distance_m` ahead of the head tip); obstacle 1
//!   beside the middle of the body at `M + n·(r + distance_m + radius_m)` (surface gap
//!   `distance_m` to the body axis ± `r`, on the left). With an even number of links `M` is a
//!   joint, where the rounded caps of the two links leave a slightly larger real gap (under 1 mm
//!   for the default sizes).
//! - `random_cylinders`: `count` cylinders, radius uniform in `radius_range_m`, centre uniform in
//!   the square `T ± half_size_m` (xy); rejection sampling keeps a surface gap of at least
//!   `min_gap_m` to every other cylinder and to every link's body axis (± `r`) at the starting pose.
//!   The random stream is ChaCha8 seeded with `general.seed` on its own stream number
//!   ([`TERRAIN_RNG_STREAM`]), so the terrain only depends on the seed and the terrain keys.
//! - `cylinder_path`: for pair `k` in `0..n_pairs`, obstacle `2k` at
//!   `T + h·(start_m + k·spacing_m) + n·width_m/2` (left) and obstacle `2k + 1` at the same point
//!   `− n·width_m/2` (right): a corridor ahead of the snake (`width_m` is centre to centre).
//! - `form_closure` (thesis 7.4; J. Løwer's form-closure tutorial, thesis reference 38): pegs
//!   around the starting shape of the form-closure gait so that the snake, with stiff joints,
//!   cannot translate or rotate in the plane. Needs `snake.joint_axes = "yaw"` and a starting
//!   shape with at least one bend (`gait.kind = "form_closure"` with a non-zero angle in
//!   `gait.form_closure.pattern_deg`).
//!   * A *bend* is a maximal run of consecutive joints whose starting angles have the same
//!     non-zero sign. Each bend gets one peg on its concave (inner) side, the side the body turns
//!     to going from head to tail, at its apex, with a 1 mm gap ([`FORM_CLOSURE_GAP_M`]) to the
//!     body axis ± `r`, i.e. its centre at distance `D = r + radius_m + 0.001` from the body axis.
//!   * Odd run length: the apex is the middle joint of the run. The peg sits on the bisector of
//!     that corner, on the concave side, at the distance from the joint at which it is exactly `D`
//!     from *both* links meeting there (`D / cos(turn / 2)`). Placing it at `D` from the joint
//!     point itself would put it inside the two links: on the inner side of a corner they come
//!     closer to the bisector than the joint point is.
//!   * Even run length: the apex is the middle of the link between the two middle joints; the peg
//!     sits on that link's normal, on the concave side, at `D` from its axis.
//!   * These pegs give second-order form closure (`order = 2`): the snake is held because its
//!     curvature presses against the pegs; it can still slip along the bends.
//!   * `order = 1` adds two more pegs (first-order closure): one beside the centre of the head
//!     link and one beside the centre of the tail link, each on the side of its link opposite to
//!     the bend peg nearest to that link's centre, also at `D` from the link's axis. They add
//!     contacts at both ends whose normals oppose the bend pegs, aiming at closure by the contact
//!     normals alone (first order; in the plane that needs at least four contacts, so at least two
//!     bends).
//!   * Order of the obstacles: the bend pegs from head to tail, then (order 1) the head peg, then
//!     the tail peg.
//! - `none`: no obstacles.

use rand::SeedableRng;
use rand::distr::{Distribution, Uniform};
use rand_chacha::ChaCha8Rng;

use super::Cylinder;
use super::geometry::{
    V3, add, cross2, dist_xy_point_segment, euler_xyz_matrix, head_rotation_rad, head_tip, mat_vec, norm2, rot90, sub,
    xy,
};
use super::names;
use crate::config::{Config, ConfigError, GaitKind, JointAxes, TerrainKind};

/// Gap between a form-closure peg and the body (surface to surface, body axis ± link radius), m.
pub const FORM_CLOSURE_GAP_M: f64 = 0.001;

/// ChaCha stream number of the random-terrain generator (other random users of `general.seed`
/// use other streams).
pub const TERRAIN_RNG_STREAM: u64 = 0x0074_6572_7261_696e; // "terrain" in ASCII

/// Attempts per requested cylinder in `random_cylinders` before giving up.
const ATTEMPTS_PER_CYLINDER: usize = 1000;
/// Upper bound on the total attempts, whatever the count.
const MAX_ATTEMPTS: usize = 10_000_000;

pub use crate::config::MAX_OBSTACLES;

/// An obstacle and the config key (with its value) responsible for where it stands.
#[derive(Debug, Clone)]
pub(crate) struct Placed {
    pub cylinder: Cylinder,
    pub key: &'static str,
    pub value: String,
}

/// Places the obstacles of `cfg.terrain.kind` around the snake whose link axes at the starting
/// pose are `segments` (see [`super::link_axis_segments_m`]).
pub(crate) fn place_obstacles(cfg: &Config, segments: &[[V3; 2]]) -> Result<Vec<Placed>, ConfigError> {
    let too_many = |key: &str, n: usize, per: usize| {
        (n.saturating_mul(per) > MAX_OBSTACLES)
            .then(|| ConfigError::invalid(key, n, format!("at most {MAX_OBSTACLES} obstacles in all")))
    };
    let err = match cfg.terrain.kind {
        TerrainKind::RandomCylinders => {
            too_many("terrain.random_cylinders.count", cfg.terrain.random_cylinders.count, 1)
        }
        TerrainKind::CylinderPath => too_many("terrain.cylinder_path.n_pairs", cfg.terrain.cylinder_path.n_pairs, 2),
        _ => None,
    };
    if let Some(e) = err {
        return Err(e);
    }
    let height = cfg.terrain.cylinder_height_m;
    let mut out: Vec<Placed> = Vec::new();
    let mut push = |center: [f64; 2], radius: f64, key: &'static str, value: String| {
        let name = names::obstacle(out.len());
        out.push(Placed {
            cylinder: Cylinder { name, center_m: center, radius_m: radius, height_m: height },
            key,
            value,
        });
    };
    match cfg.terrain.kind {
        TerrainKind::None => {}
        TerrainKind::TwoCylinders => {
            let tc = &cfg.terrain.two_cylinders;
            let (h, n) = heading(cfg, "two_cylinders")?;
            let t = xy(head_tip(cfg));
            let m = straight_middle(cfg);
            let a = along(t, h, tc.distance_m + tc.radius_m);
            let b = along(m, n, cfg.snake.link_radius_m + tc.distance_m + tc.radius_m);
            let key = "terrain.two_cylinders.distance_m";
            push(a, tc.radius_m, key, tc.distance_m.to_string());
            push(b, tc.radius_m, key, tc.distance_m.to_string());
        }
        TerrainKind::CylinderPath => {
            let cp = &cfg.terrain.cylinder_path;
            let (h, n) = heading(cfg, "cylinder_path")?;
            let t = xy(head_tip(cfg));
            let key = "terrain.cylinder_path.width_m";
            for k in 0..cp.n_pairs {
                let c = along(t, h, cp.start_m + k as f64 * cp.spacing_m);
                push(along(c, n, cp.width_m / 2.0), cp.radius_m, key, cp.width_m.to_string());
                push(along(c, n, -cp.width_m / 2.0), cp.radius_m, key, cp.width_m.to_string());
            }
        }
        TerrainKind::RandomCylinders => {
            for (c, r) in random_cylinders(cfg, segments)? {
                push(c, r, "terrain.random_cylinders.count", cfg.terrain.random_cylinders.count.to_string());
            }
        }
        TerrainKind::FormClosure => {
            let key = "terrain.form_closure.radius_m";
            for c in form_closure_pegs(cfg, segments)? {
                push(c, cfg.terrain.form_closure.radius_m, key, cfg.terrain.form_closure.radius_m.to_string());
            }
        }
    }
    Ok(out)
}

fn along(p: [f64; 2], dir: [f64; 2], s: f64) -> [f64; 2] {
    [p[0] + dir[0] * s, p[1] + dir[1] * s]
}

/// Unit heading `h` and its left normal `n` in the xy-plane.
fn heading(cfg: &Config, kind: &str) -> Result<([f64; 2], [f64; 2]), ConfigError> {
    let x = mat_vec(&euler_xyz_matrix(head_rotation_rad(cfg)), [1.0, 0.0, 0.0]);
    let len = norm2(xy(x));
    if len.is_nan() || len <= 1e-9 {
        return Err(ConfigError::invalid(
            "snake.head_rotation_deg",
            format!("{:?}", cfg.snake.head_rotation_deg),
            format!(
                "terrain.kind = \"{kind}\" places obstacles along the snake's heading, but this rotation \
                 points the snake vertically (no horizontal heading); tilt it less than 90°"
            ),
        ));
    }
    let h = [x[0] / len, x[1] / len];
    Ok((h, rot90(h)))
}

/// Middle of the straight snake's body axis, in xy.
fn straight_middle(cfg: &Config) -> [f64; 2] {
    let half = cfg.snake.n_links as f64 * cfg.snake.link_length_m / 2.0;
    let rot = euler_xyz_matrix(head_rotation_rad(cfg));
    xy(add(head_tip(cfg), mat_vec(&rot, [-half, 0.0, 0.0])))
}

/// Minimum xy-distance from `c` to the link axes.
fn dist_to_body(c: [f64; 2], segments: &[[V3; 2]]) -> f64 {
    segments.iter().map(|s| dist_xy_point_segment(c, s[0], s[1])).fold(f64::INFINITY, f64::min)
}

fn random_cylinders(cfg: &Config, segments: &[[V3; 2]]) -> Result<Vec<([f64; 2], f64)>, ConfigError> {
    let rc = &cfg.terrain.random_cylinders;
    if rc.count == 0 {
        return Ok(Vec::new());
    }
    let [lo, hi] = rc.radius_range_m;
    let radius = Uniform::new_inclusive(lo, hi).map_err(|e| {
        ConfigError::invalid(
            "terrain.random_cylinders.radius_range_m",
            format!("{:?}", rc.radius_range_m),
            format!("[min, max] with 0 < min <= max, finite ({e})"),
        )
    })?;
    let hs = rc.half_size_m;
    let coord = Uniform::new_inclusive(-hs, hs).map_err(|e| {
        ConfigError::invalid("terrain.random_cylinders.half_size_m", hs, format!("a finite number >= 0 ({e})"))
    })?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.general.seed);
    rng.set_stream(TERRAIN_RNG_STREAM);
    let t = xy(head_tip(cfg));
    let r_link = cfg.snake.link_radius_m;
    let gap = rc.min_gap_m;
    let attempts = rc.count.saturating_mul(ATTEMPTS_PER_CYLINDER).min(MAX_ATTEMPTS);
    let mut placed: Vec<([f64; 2], f64)> = Vec::new();
    // Two cylinders can only be too close when their centres are less than 2 hi + gap apart:
    // the grid tests exactly those (same result as testing all, O(1) instead of O(n)).
    let mut grid = super::grid::PointGrid::new(2.0 * hi + gap);
    for _ in 0..attempts {
        if placed.len() == rc.count {
            break;
        }
        let rad = radius.sample(&mut rng);
        let c = [t[0] + coord.sample(&mut rng), t[1] + coord.sample(&mut rng)];
        let clear_of_body = dist_to_body(c, segments) - r_link - rad >= gap;
        let clear_of_others = !grid.any_near(c, |o, ro: &f64| norm2([c[0] - o[0], c[1] - o[1]]) - ro - rad < gap);
        if clear_of_body && clear_of_others {
            placed.push((c, rad));
            grid.insert(c, rad);
        }
    }
    if placed.len() < rc.count {
        return Err(ConfigError::invalid(
            "terrain.random_cylinders.count",
            rc.count,
            format!(
                "only {} of {} cylinders fit in the square of half size {} m around the head with radii in \
                 {:?} m and gaps of at least {} m (after {attempts} attempts); lower the count or min_gap_m, \
                 or enlarge half_size_m",
                placed.len(),
                rc.count,
                hs,
                rc.radius_range_m,
                gap
            ),
        ));
    }
    Ok(placed)
}

/// Unit xy-direction of link `i` (front to back), or `None` when it is vertical.
fn link_dir_xy(segments: &[[V3; 2]], i: usize) -> Option<[f64; 2]> {
    let s = segments.get(i)?;
    let d = xy(sub(s[1], s[0]));
    let len = norm2(d);
    (len > 1e-12).then(|| [d[0] / len, d[1] / len])
}

fn form_closure_pegs(cfg: &Config, segments: &[[V3; 2]]) -> Result<Vec<[f64; 2]>, ConfigError> {
    let fc = &cfg.terrain.form_closure;
    if fc.order != 1 && fc.order != 2 {
        return Err(ConfigError::invalid(
            "terrain.form_closure.order",
            fc.order,
            "1 (first-order form closure) or 2 (second-order)",
        ));
    }
    if cfg.snake.joint_axes != JointAxes::Yaw {
        return Err(ConfigError::invalid(
            "snake.joint_axes",
            "\"alternating\"",
            "terrain.kind = \"form_closure\" places pegs around a planar snake: use joint_axes = \"yaw\"",
        ));
    }
    let angles = super::initial_joint_angles(cfg)?;
    let bends = bends(&angles);
    if bends.is_empty() {
        return Err(if cfg.gait.kind == GaitKind::FormClosure {
            ConfigError::invalid(
                "gait.form_closure.pattern_deg",
                format!("{:?}", cfg.gait.form_closure.pattern_deg),
                format!(
                    "terrain.kind = \"form_closure\" needs at least one bent joint at the start: a non-zero angle \
                     in the pattern and at least 2 links (n_links = {})",
                    cfg.snake.n_links
                ),
            )
        } else {
            ConfigError::invalid(
                "terrain.kind",
                "\"form_closure\"",
                "the form-closure pegs are placed around the bent starting shape of the form-closure gait: \
                 set gait.kind = \"form_closure\" too",
            )
        });
    }
    let degenerate = || {
        ConfigError::invalid(
            "snake.head_rotation_deg",
            format!("{:?}", cfg.snake.head_rotation_deg),
            "terrain.kind = \"form_closure\" needs the snake's bends to be visible from above (xy-plane); \
             this rotation tilts the snake too far",
        )
    };
    let d = cfg.snake.link_radius_m + fc.radius_m + FORM_CLOSURE_GAP_M;
    let mut pegs = Vec::new();
    for (start, end) in bends {
        let len = end - start + 1;
        if len % 2 == 1 {
            // Apex at the middle joint m: the corner between link m-1 and link m.
            let m = start + len / 2;
            let (dp, dc) = (
                link_dir_xy(segments, m - 1).ok_or_else(degenerate)?,
                link_dir_xy(segments, m).ok_or_else(degenerate)?,
            );
            let u = [dc[0] - dp[0], dc[1] - dp[1]];
            let ul = norm2(u);
            if ul.is_nan() || ul <= 1e-12 {
                return Err(degenerate());
            }
            let u = [u[0] / ul, u[1] / ul];
            let sin = cross2(u, dc).abs();
            if sin.is_nan() || sin <= 1e-12 {
                return Err(degenerate());
            }
            let v = xy(segments[m][0]);
            pegs.push(along(v, u, d / sin));
        } else {
            // Apex at the middle of link a, between the two middle joints a and a + 1.
            let a = start + len / 2 - 1;
            let (d0, d1, d2) = (
                link_dir_xy(segments, a - 1).ok_or_else(degenerate)?,
                link_dir_xy(segments, a).ok_or_else(degenerate)?,
                link_dir_xy(segments, a + 1).ok_or_else(degenerate)?,
            );
            let turn = cross2(d0, d1) + cross2(d1, d2);
            if turn.is_nan() || turn.abs() <= 1e-12 {
                return Err(degenerate());
            }
            let left = rot90(d1);
            let side = turn.signum();
            let mid = xy(midpoint(segments[a]));
            pegs.push(along(mid, left, side * d));
        }
    }
    if fc.order == 1 {
        let n = segments.len();
        let bend_pegs = pegs.clone();
        for link in [0, n - 1] {
            let dir = link_dir_xy(segments, link).ok_or_else(degenerate)?;
            let centre = xy(midpoint(segments[link]));
            let nearest = bend_pegs
                .iter()
                .copied()
                .min_by(|p, q| {
                    norm2([p[0] - centre[0], p[1] - centre[1]]).total_cmp(&norm2([q[0] - centre[0], q[1] - centre[1]]))
                })
                .ok_or_else(degenerate)?;
            let peg_side = cross2(dir, [nearest[0] - centre[0], nearest[1] - centre[1]]);
            let side = if peg_side > 0.0 { -1.0 } else { 1.0 };
            pegs.push(along(centre, rot90(dir), side * d));
        }
    }
    Ok(pegs)
}

/// Midpoint of a segment.
fn midpoint(s: [V3; 2]) -> V3 {
    [(s[0][0] + s[1][0]) / 2.0, (s[0][1] + s[1][1]) / 2.0, (s[0][2] + s[1][2]) / 2.0]
}

/// Bends: maximal runs `(first joint, last joint)` (1-based joint numbers) of consecutive joints
/// whose angles have the same non-zero sign. `angles[j - 1]` is joint `j`.
pub(crate) fn bends(angles: &[f64]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut run: Option<(usize, f64)> = None;
    for (k, &a) in angles.iter().enumerate() {
        let j = k + 1;
        let sign = if a > 0.0 {
            1.0
        } else if a < 0.0 {
            -1.0
        } else {
            0.0
        };
        match run {
            Some((_, rs)) if rs == sign => {}
            Some((s, _)) => {
                out.push((s, j - 1));
                run = (sign != 0.0).then_some((j, sign));
            }
            None => run = (sign != 0.0).then_some((j, sign)),
        }
    }
    if let Some((s, _)) = run {
        out.push((s, angles.len()));
    }
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::bends;
    use crate::config::{ConfigSource, load_config_str};

    /// The grid placement gives the cylinders that testing every earlier cylinder gave (the
    /// O(n^2) placement), for several seeds, counts and gaps.
    #[test]
    fn random_cylinder_placement_is_the_same_as_testing_every_cylinder() {
        use super::*;
        for (seed, count, gap, half) in
            [(1, 20, 0.1, 3.0), (2, 200, 0.0, 3.0), (3, 400, 0.05, 6.0), (99, 50, 1.0, 20.0)]
        {
            let overrides = [
                "terrain.kind=\"random_cylinders\"".to_string(),
                format!("general.seed={seed}"),
                format!("terrain.random_cylinders.count={count}"),
                format!("terrain.random_cylinders.min_gap_m={gap}"),
                format!("terrain.random_cylinders.half_size_m={half}"),
            ];
            let cfg = load_config_str("", ConfigSource::Toml, &overrides).unwrap();
            let segments = crate::model::link_axis_segments_m(&cfg, &vec![0.0; cfg.snake.n_joints()]);
            let placed = random_cylinders(&cfg, &segments).unwrap();
            // The placement of every earlier version: test against all placed cylinders.
            let rc = &cfg.terrain.random_cylinders;
            let radius = Uniform::new_inclusive(rc.radius_range_m[0], rc.radius_range_m[1]).unwrap();
            let coord = Uniform::new_inclusive(-half, half).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(TERRAIN_RNG_STREAM);
            let t = xy(head_tip(&cfg));
            let mut naive: Vec<([f64; 2], f64)> = Vec::new();
            while naive.len() < count {
                let rad = radius.sample(&mut rng);
                let c = [t[0] + coord.sample(&mut rng), t[1] + coord.sample(&mut rng)];
                let body = dist_to_body(c, &segments) - cfg.snake.link_radius_m - rad >= gap;
                let others = naive.iter().all(|(o, ro)| norm2([c[0] - o[0], c[1] - o[1]]) - ro - rad >= gap);
                if body && others {
                    naive.push((c, rad));
                }
            }
            assert_eq!(placed, naive, "seed {seed}, count {count}");
        }
    }

    /// 100,000 cylinders in a large square are placed (each candidate is tested against its grid
    /// neighbours only: `grid::tests::a_query_visits_only_the_points_of_its_neighbourhood`).
    #[test]
    fn placing_100000_random_cylinders_succeeds() {
        let overrides = [
            "terrain.kind=\"random_cylinders\"".to_string(),
            "terrain.random_cylinders.count=100000".to_string(),
            "terrain.random_cylinders.half_size_m=200.0".to_string(),
        ];
        let cfg = load_config_str("", ConfigSource::Toml, &overrides).unwrap();
        let segments = crate::model::link_axis_segments_m(&cfg, &vec![0.0; cfg.snake.n_joints()]);
        let placed = super::random_cylinders(&cfg, &segments).unwrap();
        assert_eq!(placed.len(), 100_000);
    }

    #[test]
    fn bend_runs() {
        assert_eq!(bends(&[0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, 1.0, 1.0]), vec![(2, 3), (5, 6), (8, 9)]);
        assert_eq!(bends(&[1.0, -1.0, -1.0]), vec![(1, 1), (2, 3)]);
        assert_eq!(bends(&[0.0, 0.0]), vec![]);
        assert_eq!(bends(&[]), vec![]);
    }
}
