//! Pin motion from the contact tractions: each pin base moves with the skin at its depth
//! inside the body (depth form of the Boussinesq and Cerruti solutions,
//! [`super::kernel::point_load_displacement`], one point force per loaded cell), and the pin,
//! a stiff post, turns with the skin's local rotation `omega = curl(u) / 2` at its base:
//! ```text
//! tip' = tip + u(base) + omega x (tip - base),   axis' = axis + omega x axis
//! ```
//! The lever `tip - base` (pin length, mm) amplifies the skin's rotation, which is why the
//! pins see curvature. Positions are taken relative to the contact plane (the tangent plane at
//! the apex): a base at sensor point `X` sits at lateral `(X.x, X.y)` and depth `R - X.z`.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::grid::Grid;
use super::kernel::{Elastic, point_load_displacement};
use crate::pins::{PinLayout, PinPose};

/// Finite-difference step for the rotation (mm).
const STEP_MM: f64 = 1e-3;

/// Point forces of the loaded cells: position `(x, y)` (mm) and force `(Qx, Qy, P)` (N).
#[derive(Clone, Debug, Default)]
pub struct CellForces {
    points: Vec<([f64; 2], [f64; 3])>,
}

impl CellForces {
    /// Collects the cells with non-zero traction.
    pub fn new(grid: &Grid, pressure: &[f64], qx: &[f64], qy: &[f64]) -> Self {
        let area = grid.cell_area_mm2();
        let points = (0..grid.len())
            .filter(|&k| pressure[k] != 0.0 || qx[k] != 0.0 || qy[k] != 0.0)
            .map(|k| (grid.centre(k), [qx[k] * area, qy[k] * area, pressure[k] * area]))
            .collect();
        Self { points }
    }

    /// Whether no cell is loaded.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Displacement (mm, sensor frame) of the sensor-frame point `x` of a dome of outer radius
    /// `dome_radius_mm`.
    pub fn displacement(&self, m: &Elastic, dome_radius_mm: f64, x: &Vector3<f64>) -> Vector3<f64> {
        let depth = dome_radius_mm - x.z;
        let mut u = [0.0; 3];
        for (c, f) in &self.points {
            let d = point_load_displacement(m, *f, [x.x - c[0], x.y - c[1], depth]);
            for k in 0..3 {
                u[k] += d[k];
            }
        }
        // Into the body is sensor -z.
        Vector3::new(u[0], u[1], -u[2])
    }
}

/// Deformed pin poses (sensor frame) for the given cell forces.
pub fn displaced_pins(layout: &PinLayout, m: &Elastic, dome_radius_mm: f64, forces: &CellForces) -> Vec<PinPose> {
    layout
        .pins
        .par_iter()
        .map(|pin| {
            let undeformed = PinPose { tip: pin.tip, axis: pin.normal };
            if forces.is_empty() {
                return undeformed;
            }
            let base = pin.base.coords;
            let u = forces.displacement(m, dome_radius_mm, &base);
            // Gradient by forward differences: g[i][k] = d u_i / d x_k.
            let mut g = [[0.0; 3]; 3];
            for k in 0..3 {
                let mut x = base;
                x[k] += STEP_MM;
                let du = (forces.displacement(m, dome_radius_mm, &x) - u) / STEP_MM;
                for i in 0..3 {
                    g[i][k] = du[i];
                }
            }
            let omega = 0.5 * Vector3::new(g[2][1] - g[1][2], g[0][2] - g[2][0], g[1][0] - g[0][1]);
            let lever = pin.tip.coords - base;
            let axis = (pin.normal + omega.cross(&pin.normal)).normalize();
            PinPose { tip: (pin.tip.coords + u + omega.cross(&lever)).into(), axis }
        })
        .collect()
}
