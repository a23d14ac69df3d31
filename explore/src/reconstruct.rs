//! Object reconstruction: each step's contact patch (points in contact: material; points the
//! dome presses into without touching anything: no material) moved into the world frame by the
//! robot's pose, fused on a grid, interpolated by natural neighbours (spade) and thresholded
//! at one half into a footprint, compared with the true shape.

use std::collections::BTreeMap;

use spade::{DelaunayTriangulation, Point2};
use tacsim_sim::SensorPose;
use tacsim_sim::contact::Grid;

use crate::contact_geometry::Sample;

/// Side of the fusion bins (mm).
const BIN_MM: f64 = 0.5;
/// Side of the raster the footprint is compared on (mm).
const RASTER_MM: f64 = 0.5;

/// Fused evidence: per world bin, the sum of samples (1 material, 0 none) and their count.
#[derive(Clone, Debug, Default)]
pub struct Fusion {
    bins: BTreeMap<(i64, i64), (f64, u32)>,
}

impl Fusion {
    /// Adds a step's contact patch: the cells of `grid` (sensor frame) with `pressure > 0` are
    /// material; those within `reach_mm` of the apex without contact are not.
    pub fn add_patch(&mut self, grid: &Grid, pressure: &[f64], pose: &SensorPose, reach_mm: f64) {
        let touching: Vec<Option<bool>> = pressure.iter().map(|p| Some(*p > 0.0)).collect();
        self.add_points(&grid.centres(), &touching, pose, reach_mm);
    }

    /// Adds a step's contact patch as points of the contact plane (mm, sensor frame) and
    /// whether the skin touches there: touching points are material; the others within
    /// `reach_mm` of the apex are not; undecided points (`None`) add nothing.
    pub fn add_points(&mut self, points: &[[f64; 2]], touching: &[Option<bool>], pose: &SensorPose, reach_mm: f64) {
        // Sensor-frame contact-plane points to world: the pose's rotation (sensor `y` is world
        // `-y` at zero yaw), then its position.
        let r = pose.rotation();
        for (centre, &touching) in points.iter().zip(touching) {
            let Some(touching) = touching else { continue };
            if !touching && centre[0].hypot(centre[1]) > reach_mm {
                continue;
            }
            let w = [
                pose.x_mm + r[(0, 0)] * centre[0] + r[(0, 1)] * centre[1],
                pose.y_mm + r[(1, 0)] * centre[0] + r[(1, 1)] * centre[1],
            ];
            let key = ((w[0] / BIN_MM).floor() as i64, (w[1] / BIN_MM).floor() as i64);
            let e = self.bins.entry(key).or_insert((0.0, 0));
            e.0 += if touching { 1.0 } else { 0.0 };
            e.1 += 1;
        }
    }

    /// The footprint over `[x0, y0, x1, y1]` (mm) on a `RASTER_MM` raster: natural-neighbour
    /// interpolation of the bins' mean evidence, at least one half inside. Returns the raster
    /// (row-major, `nx x ny`) and its shape.
    pub fn footprint(&self, bounds: [f64; 4]) -> (Vec<bool>, usize, usize) {
        let samples: Vec<Sample> = self
            .bins
            .iter()
            .map(|(&(i, j), &(sum, n))| Sample {
                p: Point2::new((i as f64 + 0.5) * BIN_MM, (j as f64 + 0.5) * BIN_MM),
                value: sum / n as f64,
            })
            .collect();
        let nx = ((bounds[2] - bounds[0]) / RASTER_MM).ceil() as usize;
        let ny = ((bounds[3] - bounds[1]) / RASTER_MM).ceil() as usize;
        let Ok(tri) = DelaunayTriangulation::<Sample>::bulk_load_stable(samples) else {
            return (vec![false; nx * ny], nx, ny);
        };
        let nn = tri.natural_neighbor();
        let mut out = vec![false; nx * ny];
        for j in 0..ny {
            for i in 0..nx {
                let p = Point2::new(bounds[0] + (i as f64 + 0.5) * RASTER_MM, bounds[1] + (j as f64 + 0.5) * RASTER_MM);
                out[j * nx + i] = nn.interpolate(|v| v.data().value, p).is_some_and(|v| v >= 0.5);
            }
        }
        (out, nx, ny)
    }
}

/// Intersection over union of a footprint raster with the truth `inside(x, y)`, over the same
/// raster.
pub fn iou(footprint: &[bool], nx: usize, bounds: [f64; 4], inside: impl Fn(f64, f64) -> bool) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (k, &f) in footprint.iter().enumerate() {
        let (i, j) = (k % nx, k / nx);
        let t = inside(bounds[0] + (i as f64 + 0.5) * RASTER_MM, bounds[1] + (j as f64 + 0.5) * RASTER_MM);
        both += usize::from(f && t);
        either += usize::from(f || t);
    }
    if either == 0 { 0.0 } else { both as f64 / either as f64 }
}
