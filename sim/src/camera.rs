//! Pinhole camera with radial distortion, looking along `+z` of the sensor frame.
//!
//! Image coordinates are continuous pixels: pixel `(i, j)` (column, row) covers
//! `[i, i+1] x [j, j+1]`, so its centre is `(i + 0.5, j + 0.5)`; `u` grows right (`+x`), `v`
//! grows down (`+y`).
//!
//! Projection of a point `p` (mm, sensor frame), camera at `z = -d`:
//! `x_n = p.x / (p.z + d)`, `y_n = p.y / (p.z + d)`, `s = 1 + k1 r^2 + k2 r^4` with
//! `r^2 = x_n^2 + y_n^2`, then `u = c_u + f s x_n`, `v = c_v + f s y_n`, where
//! `f = (size / 2) / tan(fov / 2)` px and `c = size / 2 + offset * size`.

use nalgebra::{Point3, Vector3};

use crate::sensor::CameraParams;

/// A camera bound to an image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Focal length (px).
    pub focal_px: f64,
    /// Principal point (px), `[u, v]`.
    pub principal: [f64; 2],
    /// Distance of the pinhole behind the dome centre (mm).
    pub distance_mm: f64,
    /// Radial distortion coefficients.
    pub k: [f64; 2],
    /// Image size (px, square).
    pub size: u32,
}

/// A filled disc in image coordinates (px).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// Centre, horizontal (px).
    pub u: f64,
    /// Centre, vertical (px).
    pub v: f64,
    /// Radius (px).
    pub r: f64,
}

impl Camera {
    /// The camera of `params` for a `size` x `size` image.
    pub fn new(params: &CameraParams, size: u32) -> Self {
        let s = size as f64;
        Self {
            focal_px: 0.5 * s / (0.5 * params.fov_deg.to_radians()).tan(),
            principal: [0.5 * s + params.principal_offset[0] * s, 0.5 * s + params.principal_offset[1] * s],
            distance_mm: params.distance_mm,
            k: [params.k1, params.k2],
            size,
        }
    }

    /// Distortion scale `1 + k1 r^2 + k2 r^4` at normalised radius^2 `r2`.
    fn distortion(&self, r2: f64) -> f64 {
        1.0 + self.k[0] * r2 + self.k[1] * r2 * r2
    }

    /// Projects a point (mm, sensor frame) to pixel coordinates; `None` behind the camera.
    pub fn project(&self, p: &Point3<f64>) -> Option<[f64; 2]> {
        let z = p.z + self.distance_mm;
        if z <= 0.0 {
            return None;
        }
        let (xn, yn) = (p.x / z, p.y / z);
        let s = self.focal_px * self.distortion(xn * xn + yn * yn);
        Some([self.principal[0] + s * xn, self.principal[1] + s * yn])
    }

    /// Image of a small flat disc of `radius_mm` centred at `centre` whose normal is `axis`
    /// (a pin tip seen end-on), as the circle of equal image area. For a pinhole, a patch of
    /// area `A` at depth `z` whose normal makes angle `alpha` with the viewing ray, which makes
    /// angle `phi` with the optical axis, images to area `f^2 A cos(alpha) / (z^2 cos(phi))`;
    /// radial distortion scales it by the Jacobian `(1 + 3 k1 r^2 + 5 k2 r^4)(1 + k1 r^2 +
    /// k2 r^4)`. `None` behind the camera or seen edge-on from behind.
    pub fn project_disc(&self, centre: &Point3<f64>, axis: &Vector3<f64>, radius_mm: f64) -> Option<Disc> {
        let ray = Vector3::new(centre.x, centre.y, centre.z + self.distance_mm);
        let z = ray.z;
        if z <= 0.0 {
            return None;
        }
        let length = ray.norm();
        let cos_alpha = ray.dot(axis).abs() / (length * axis.norm());
        let cos_phi = z / length;
        let (xn, yn) = (centre.x / z, centre.y / z);
        let r2 = xn * xn + yn * yn;
        let tangential = self.distortion(r2);
        let radial = 1.0 + 3.0 * self.k[0] * r2 + 5.0 * self.k[1] * r2 * r2;
        let s = self.focal_px * tangential;
        let scale = self.focal_px * (radial * tangential).max(0.0).sqrt() * (cos_alpha / cos_phi).sqrt();
        Some(Disc { u: self.principal[0] + s * xn, v: self.principal[1] + s * yn, r: scale * radius_mm / z })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_point_lands_on_principal_point_and_fov_edge_on_border() {
        let params =
            CameraParams { fov_deg: 90.0, principal_offset: [0.0, 0.0], k1: 0.0, k2: 0.0, ..Default::default() };
        let cam = Camera::new(&params, 200);
        let c = cam.project(&Point3::new(0.0, 0.0, 5.0)).expect("in front");
        assert_eq!(c, [100.0, 100.0]);
        // At 45 deg off axis (fov 90) a point lands on the right border.
        let z = 10.0 - params.distance_mm;
        let e = cam.project(&Point3::new(10.0, 0.0, z)).expect("in front");
        assert!((e[0] - 200.0).abs() < 1e-9 && (e[1] - 100.0).abs() < 1e-12);
        assert!(cam.project(&Point3::new(0.0, 0.0, -params.distance_mm - 1.0)).is_none());
    }
}
