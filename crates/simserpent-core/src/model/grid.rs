//! A uniform grid of points in the xy-plane, for rejection sampling that keeps new obstacles
//! clear of the ones already placed in O(1) per candidate instead of O(n).
//!
//! [`PointGrid::any_near`] tests a predicate on exactly the points that can be closer than the
//! grid's `reach` to the query; every point farther away must make the predicate false (the
//! caller chooses `reach` so). So it returns what testing every point would return, and the
//! obstacles placed with it are the same as those of a test against every earlier one.

use std::collections::HashMap;

/// Cell indices are clamped to this range (a huge region with a small reach): clamping is
/// monotone, so neighbouring cells stay neighbours or merge, and no near point is missed.
const MAX_CELL: f64 = (1u64 << 40) as f64;

/// The points of one cell, with their data.
type Cell<T> = Vec<([f64; 2], T)>;

/// Points in square cells of side a little more than `reach`.
#[derive(Debug)]
pub(crate) struct PointGrid<T> {
    cell_m: f64,
    cells: HashMap<(i64, i64), Cell<T>>,
}

impl<T> PointGrid<T> {
    /// A grid for queries that only care about points closer than `reach_m` (> 0, finite).
    pub(crate) fn new(reach_m: f64) -> Self {
        // The margin covers rounding in the cell computation.
        let cell_m = if reach_m.is_finite() && reach_m > 0.0 { reach_m * (1.0 + 1e-9) } else { f64::MAX };
        Self { cell_m, cells: HashMap::new() }
    }

    fn cell(&self, p: [f64; 2]) -> (i64, i64) {
        let index = |x: f64| {
            let k = (x / self.cell_m).floor();
            if k.is_nan() { 0 } else { k.clamp(-MAX_CELL, MAX_CELL) as i64 }
        };
        (index(p[0]), index(p[1]))
    }

    /// Adds a point with its data.
    pub(crate) fn insert(&mut self, p: [f64; 2], data: T) {
        let cell = self.cell(p);
        self.cells.entry(cell).or_default().push((p, data));
    }

    /// Whether `near` holds for any point in the 3 x 3 cells around `p` (which hold every point
    /// closer than the reach).
    pub(crate) fn any_near(&self, p: [f64; 2], mut near: impl FnMut([f64; 2], &T) -> bool) -> bool {
        let (cx, cy) = self.cell(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(points) = self.cells.get(&(cx + dx, cy + dy))
                    && points.iter().any(|(q, data)| near(*q, data))
                {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::PointGrid;
    use rand::{Rng, SeedableRng};

    /// The grid finds exactly the points that a test against every point finds.
    #[test]
    fn grid_queries_agree_with_testing_every_point() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for reach in [0.05, 0.3, 2.0, 1e6] {
            let mut grid = PointGrid::new(reach);
            let mut all = Vec::new();
            for _ in 0..400 {
                let p = [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)];
                grid.insert(p, ());
                all.push(p);
            }
            for _ in 0..400 {
                let q = [rng.random_range(-3.5..3.5), rng.random_range(-3.5..3.5)];
                let near = |p: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < reach;
                assert_eq!(grid.any_near(q, |p, _| near(p)), all.iter().any(|p| near(*p)), "reach {reach}, {q:?}");
            }
        }
    }

    /// 100,000 points in a square of side 400 m, queried with a reach of 0.5 m: each query looks
    /// at the points of its 3 × 3 cells only (about 1.4 on average, a few at most), not at all of
    /// them, so placing n obstacles costs O(n), not O(n²).
    #[test]
    fn a_query_visits_only_the_points_of_its_neighbourhood() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let reach = 0.5;
        let mut grid = PointGrid::new(reach);
        for _ in 0..100_000 {
            grid.insert([rng.random_range(-200.0..200.0), rng.random_range(-200.0..200.0)], ());
        }
        let (mut visited, mut most) = (0_usize, 0_usize);
        let queries = 10_000;
        for _ in 0..queries {
            let q = [rng.random_range(-200.0..200.0), rng.random_range(-200.0..200.0)];
            let mut here = 0;
            assert!(!grid.any_near(q, |_, _| {
                here += 1;
                false
            }));
            visited += here;
            most = most.max(here);
        }
        // Expected per query: 100,000 points × (9 cells of 0.25 m²) / 160,000 m² ≈ 1.4.
        let mean = visited as f64 / queries as f64;
        assert!((1.0..2.0).contains(&mean), "{mean}");
        assert!(most <= 15, "{most}");
    }

    #[test]
    fn huge_coordinates_do_not_overflow() {
        let mut grid = PointGrid::new(1e-12);
        grid.insert([1e300, -1e300], ());
        assert!(grid.any_near([1e300, -1e300], |_, _| true));
        assert!(!grid.any_near([0.0, 0.0], |_, _| true));
    }
}
