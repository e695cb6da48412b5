//! Floor surfaces in the model: the flat lookup table the step loop uses ([`SurfaceMap`]) and the
//! visual tiles that show them in pictures.
//!
//! The floor stays one plane: surfaces are not collision geometry. Their friction reaches the
//! links through the link–floor contact pairs (or the viscous forces), switched before every step
//! by `sim::ground` from the region that each link's centre lies in ([`SurfaceMap::region_at`]).
//! Separate floor tiles with their own geoms would give every link resting on a seam two contacts
//! (one per tile), each carrying part of the weight with its own friction, and a bump where the
//! tiles' surfaces meet; one plane with switched friction has no seams.

use std::fmt::{self, Write};

use super::names;
use crate::config::{Config, SurfaceFriction, SurfaceShape};

/// Visual group of the surface tiles (MuJoCo draws groups 0–2 by default).
pub const SURFACE_GEOM_GROUP: u32 = 2;
/// Half-thickness of the lowest surface tile, m (it spans z ∈ [0, 1 mm]).
const TILE_HALF_THICKNESS_M: f64 = 0.0005;
/// Each later tile is this much thicker (half-thickness, m), so that overlapping tiles do not
/// flicker in pictures and the one that wins is drawn on top.
const TILE_STEP_M: f64 = 0.00001;

/// The surfaces as flat arrays for the per-step lookup: no allocation, no names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceMap {
    /// Per surface: true for a circle, false for a rectangle.
    circle: Vec<bool>,
    /// Per surface: rectangle `[min_x, min_y, max_x, max_y]`; circle `[cx, cy, r², 0]`.
    geometry: Vec<[f64; 4]>,
    /// Per region: index 0 is the plain floor, `k + 1` surface `k`.
    friction: Vec<SurfaceFriction>,
}

impl SurfaceMap {
    /// The surfaces of `cfg.ground.surfaces` (validated config: every needed value known).
    pub fn from_config(cfg: &Config) -> Self {
        let floor = SurfaceFriction::floor(cfg);
        let mut map = Self { friction: vec![floor], ..Self::default() };
        for s in &cfg.ground.surfaces {
            match s.shape {
                SurfaceShape::Rectangle { .. } => {
                    map.circle.push(false);
                    map.geometry.push(s.bounds());
                }
                SurfaceShape::Circle { radius_m: r } => {
                    map.circle.push(true);
                    map.geometry.push([s.center_m[0], s.center_m[1], r * r, 0.0]);
                }
            }
            map.friction.push(s.resolve(&floor));
        }
        map
    }

    /// Number of surfaces (regions besides the plain floor).
    pub fn len(&self) -> usize {
        self.geometry.len()
    }

    /// Whether there are no surfaces.
    pub fn is_empty(&self) -> bool {
        self.geometry.is_empty()
    }

    /// The region of floor point (x, y): 0 for the plain floor, `k + 1` for surface `k`. Where
    /// surfaces overlap the later one wins; borders belong to the surface.
    #[inline]
    pub fn region_at(&self, x: f64, y: f64) -> usize {
        for k in (0..self.geometry.len()).rev() {
            let g = self.geometry[k];
            let inside = if self.circle[k] {
                let (dx, dy) = (x - g[0], y - g[1]);
                dx * dx + dy * dy <= g[2]
            } else {
                x >= g[0] && x <= g[2] && y >= g[1] && y <= g[3]
            };
            if inside {
                return k + 1;
            }
        }
        0
    }

    /// The friction of region `region` (0 = plain floor).
    #[inline]
    pub fn friction(&self, region: usize) -> &SurfaceFriction {
        &self.friction[region]
    }
}

/// Writes one visual tile per surface (no collisions, no mass: world-body geoms with contype and
/// conaffinity 0), named `surface_00`, `surface_01`, ….
pub(super) fn write_tiles(out: &mut String, cfg: &Config) -> fmt::Result {
    let n = super::fmt_num;
    for (k, s) in cfg.ground.surfaces.iter().enumerate() {
        let h = TILE_HALF_THICKNESS_M + TILE_STEP_M * k as f64;
        let [r, g, b, a] = s.rgba();
        let common = format!(
            "contype=\"0\" conaffinity=\"0\" group=\"{SURFACE_GEOM_GROUP}\" rgba=\"{} {} {} {}\"",
            n(r),
            n(g),
            n(b),
            n(a)
        );
        let [cx, cy] = s.center_m;
        match s.shape {
            SurfaceShape::Rectangle { size_m: [sx, sy] } => {
                writeln!(
                    out,
                    "    <geom name=\"{}\" type=\"box\" pos=\"{} {} {}\" size=\"{} {} {}\" {common}/>",
                    names::surface(k),
                    n(cx),
                    n(cy),
                    n(h),
                    n(sx / 2.0),
                    n(sy / 2.0),
                    n(h)
                )?;
            }
            SurfaceShape::Circle { radius_m } => {
                writeln!(
                    out,
                    "    <geom name=\"{}\" type=\"cylinder\" pos=\"{} {} {}\" size=\"{} {}\" {common}/>",
                    names::surface(k),
                    n(cx),
                    n(cy),
                    n(h),
                    n(radius_m),
                    n(h)
                )?;
            }
        }
    }
    Ok(())
}
