//! Half-space kernels: point loads (Boussinesq, Cerruti) at the surface and at depth, and their
//! exact integrals over a uniformly loaded rectangle (Love 1929; Pohrt & Li 2014).
//!
//! # Conventions
//! `z` points into the elastic body, pressure `p > 0` pushes into it, `(x, y)` is the surface
//! plane. Offsets are field point minus load point. All lengths in mm, moduli in MPa, loads in N,
//! tractions in MPa, displacements in mm.
//!
//! Surface displacement of a point force `(Qx, Qy, P)` at distance `r` (Johnson 1985, 3.19 and
//! 3.86, with `c = 1 / (2 pi G)`):
//! ```text
//! u_z = c (1 - nu) P / r            + c (1 - 2 nu)/2 (Qx x + Qy y) / r^2
//! u_x = c [(1 - nu)/r + nu x^2/r^3] Qx + c nu x y / r^3 Qy  - c (1 - 2 nu)/2 P x / r^2
//! ```
//! Surface points move towards a normal load; ahead of a tangential load the surface sinks. The
//! two coupling terms are each other's reciprocal (Betti).
//!
//! The integral of each kernel over the rectangle `[x1, x2] x [y1, y2]` is the double difference
//! of an antiderivative `F(X, Y) = int_0^X int_0^Y k`, defined in the first quadrant and extended
//! by the kernel's parity (so the same formula is exact for the cell that holds its own load).

use std::f64::consts::PI;

use crate::contact::algebra::lanes::Real;

/// `a * asinh(b / a)` with the limit 0 at `a = 0`.
fn a_asinh_b_over_a(a: f64, b: f64) -> f64 {
    if a == 0.0 { 0.0 } else { a * (b / a).asinh() }
}

/// `a * atan(b / a)` with the limit 0 at `a = 0` (for `a, b >= 0`).
fn a_atan_b_over_a(a: f64, b: f64) -> f64 {
    if a == 0.0 { 0.0 } else { a * (b / a).atan() }
}

/// `a * ln(1 + b^2 / a^2) / 2` with the limit 0 at `a = 0`.
fn half_a_ln1p_b2_over_a2(a: f64, b: f64) -> f64 {
    if a == 0.0 { 0.0 } else { 0.5 * a * ((b / a) * (b / a)).ln_1p() }
}

/// The six scalar kernels whose rectangle integrals build every component.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// `1 / r`.
    InvR,
    /// `x^2 / r^3`.
    XxOverR3,
    /// `y^2 / r^3`.
    YyOverR3,
    /// `x y / r^3`.
    XyOverR3,
    /// `x / r^2`.
    XOverR2,
    /// `y / r^2`.
    YOverR2,
}

impl Kernel {
    /// All six.
    pub const ALL: [Kernel; 6] =
        [Kernel::InvR, Kernel::XxOverR3, Kernel::YyOverR3, Kernel::XyOverR3, Kernel::XOverR2, Kernel::YOverR2];

    /// Pointwise value at offset `(x, y) != 0`.
    pub fn value(self, x: f64, y: f64) -> f64 {
        let r2 = x * x + y * y;
        let r = r2.sqrt();
        match self {
            Kernel::InvR => 1.0 / r,
            Kernel::XxOverR3 => x * x / (r2 * r),
            Kernel::YyOverR3 => y * y / (r2 * r),
            Kernel::XyOverR3 => x * y / (r2 * r),
            Kernel::XOverR2 => x / r2,
            Kernel::YOverR2 => y / r2,
        }
    }

    /// `F(X, Y) = int_0^X int_0^Y k(s, t) dt ds`.
    fn antiderivative(self, x: f64, y: f64) -> f64 {
        let (ax, ay) = (x.abs(), y.abs());
        let (sx, sy) = (sign(x), sign(y));
        let r = x.hypot(y);
        match self {
            Kernel::InvR => sx * sy * (a_asinh_b_over_a(ax, ay) + a_asinh_b_over_a(ay, ax)),
            Kernel::XxOverR3 => sx * sy * a_asinh_b_over_a(ay, ax),
            Kernel::YyOverR3 => sx * sy * a_asinh_b_over_a(ax, ay),
            Kernel::XyOverR3 => ax + ay - r,
            Kernel::XOverR2 => sy * (half_a_ln1p_b2_over_a2(ay, ax) + a_atan_b_over_a(ax, ay)),
            Kernel::YOverR2 => sx * (half_a_ln1p_b2_over_a2(ax, ay) + a_atan_b_over_a(ay, ax)),
        }
    }

    /// The even kernels' antiderivatives at `(x, y)` (`1 / r`, `x^2 / r^3`, `y^2 / r^3`,
    /// `x y / r^3`: [`Kernel::ALL`]'s first four, all the normal and in-plane blocks use),
    /// sharing their square root and inverse hyperbolic sines (each equals
    /// [`Kernel::antiderivative`]'s).
    pub(crate) fn even_antiderivatives(x: f64, y: f64) -> [f64; 4] {
        let (ax, ay) = (x.abs(), y.abs());
        let s = sign(x) * sign(y);
        // `a asinh(b / a) = a ln((b + r) / a)`, one square root and two logarithms for both
        // (a point's offsets are cells, far from overflow; at `b << a`, where the term is
        // `~ b`, the ratio's rounding costs `a 1e-16` absolute, as `asinh`'s own).
        let r = (x * x + y * y).sqrt();
        let term = |a: f64, b: f64| if a == 0.0 { 0.0 } else { a * ((b + r) / a).ln() };
        let (xy, yx) = (term(ax, ay), term(ay, ax));
        [s * (xy + yx), s * yx, s * xy, ax + ay - r]
    }

    /// The even kernels' [`Kernel::rectangle`] integrals over a `w x h` rectangle at offset
    /// `(dx, dy)` from its centre, per unit area (a unit force), from one set of
    /// [`Kernel::even_antiderivatives`] per corner.
    pub(crate) fn even_rectangles(dx: f64, dy: f64, w: f64, h: f64) -> [f64; 4] {
        let (x1, x2) = (dx - 0.5 * w, dx + 0.5 * w);
        let (y1, y2) = (dy - 0.5 * h, dy + 0.5 * h);
        let corners = [(x2, y2, 1.0), (x1, y2, -1.0), (x2, y1, -1.0), (x1, y1, 1.0)]
            .map(|(x, y, s)| (Self::even_antiderivatives(x, y), s));
        std::array::from_fn(|m| corners.iter().map(|(v, s)| s * v[m]).sum::<f64>() / (w * h))
    }

    /// Exact integral of the kernel over a `w x h` rectangle centred at the load point, seen from
    /// the field point at offset `(dx, dy)` from the rectangle's centre:
    /// `int int k(dx - s, dy - t) ds dt` over `|s| <= w/2, |t| <= h/2`.
    pub fn rectangle(self, dx: f64, dy: f64, w: f64, h: f64) -> f64 {
        let (x1, x2) = (dx - 0.5 * w, dx + 0.5 * w);
        let (y1, y2) = (dy - 0.5 * h, dy + 0.5 * h);
        self.antiderivative(x2, y2) - self.antiderivative(x1, y2) - self.antiderivative(x2, y1)
            + self.antiderivative(x1, y1)
    }
}

fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Isotropic linear elastic material (MPa, dimensionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    /// Shear modulus `G` (MPa).
    pub shear_modulus_mpa: f64,
    /// Poisson's ratio `nu`, `0 <= nu <= 0.5`.
    pub poisson: f64,
}

impl Elastic {
    /// From Young's modulus `E` (MPa) and `nu`: `G = E / (2 (1 + nu))`.
    pub fn from_young(youngs_modulus_mpa: f64, poisson: f64) -> Self {
        Self { shear_modulus_mpa: youngs_modulus_mpa / (2.0 * (1.0 + poisson)), poisson }
    }

    /// Young's modulus `E = 2 G (1 + nu)` (MPa).
    pub fn youngs_modulus_mpa(&self) -> f64 {
        2.0 * self.shear_modulus_mpa * (1.0 + self.poisson)
    }

    /// Plane-strain modulus `E* = E / (1 - nu^2)` (MPa) of this body against a rigid one.
    pub fn plane_strain_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa() / (1.0 - self.poisson * self.poisson)
    }
}

/// Displacement (mm) at depth `z >= 0` below the surface, at lateral offset `(x, y)` from a
/// surface point force `(qx, qy, p)` (N), on a half-space (Johnson 1985, 3.20 and 3.86; `z`
/// into the body). Singular at the load point itself.
pub fn point_load_displacement(m: &Elastic, force: [f64; 3], offset: [f64; 3]) -> [f64; 3] {
    DepthKernel::new(m).displacement(force, offset)
}

/// [`point_load_displacement`] with the material constants hoisted, for sums over many loads.
#[derive(Clone, Copy, Debug)]
pub struct DepthKernel {
    c: f64,
    k: f64,
    two_one_minus_nu: f64,
}

impl DepthKernel {
    /// The kernel of material `m`.
    pub fn new(m: &Elastic) -> Self {
        let nu = m.poisson;
        Self { c: 1.0 / (4.0 * PI * m.shear_modulus_mpa), k: 1.0 - 2.0 * nu, two_one_minus_nu: 2.0 * (1.0 - nu) }
    }

    /// `[c, k, 2 (1 - nu)]` of [`DepthKernel::displacement`] (the GPU's copy).
    #[cfg(feature = "wgpu")]
    pub(crate) fn coefficients(&self) -> [f64; 3] {
        [self.c, self.k, self.two_one_minus_nu]
    }

    /// Displacement (mm) at `offset` (lateral x, y; depth z >= 0) from the surface force
    /// `(qx, qy, p)` (N).
    #[inline]
    pub fn displacement(&self, force: [f64; 3], offset: [f64; 3]) -> [f64; 3] {
        self.terms(offset).displacement(self, force)
    }

    /// Displacement (mm) and rotation `omega = curl(u) / 2` (rad) at `offset` from the surface
    /// force `(qx, qy, p)` (N), both in the kernel's frame (`z` into the body). The rotation is
    /// the curl of [`DepthKernel::displacement`] in closed form, with `rho = |offset|`,
    /// `g = 1 / (rho (rho + z))` and `g' = (2 rho + z) / (rho^3 (rho + z)^2)`:
    /// ```text
    /// omega_x = c [-2 (1 - nu) p y / rho^3 - k x y g' qx + (k g + z / rho^3 - k y^2 g') qy]
    /// omega_y = c [ 2 (1 - nu) p x / rho^3 + (k x^2 g' - k g - z / rho^3) qx + k x y g' qy]
    /// omega_z = c (qx y - qy x) / rho^3
    /// ```
    /// (`c = 1 / (4 pi G)`, `k = 1 - 2 nu`; a normal load turns the skin about the horizontal
    /// circles around it, and only a tangential one twists it about `z`). The displacement is
    /// [`DepthKernel::displacement`]'s to the last bit. On [`crate::contact::algebra::lanes::Lanes`], each lane
    /// is the `f64` result's bits (one formula; the products written with the material
    /// constant last, which changes no bit).
    #[inline(always)]
    pub fn motion<T: Real>(&self, force: [T; 3], offset: [T; 3]) -> ([T; 3], [T; 3]) {
        let t = self.terms(offset);
        let u = t.displacement(self, force);
        let [x, y, z] = offset;
        let [qx, qy, p] = force;
        let k = self.k;
        let g = t.ir_irz;
        let g1 = t.ir3 * t.irz + t.ir_irz * t.ir_irz;
        let zr3 = z * t.ir3;
        let pn = p * self.two_one_minus_nu * t.ir3;
        let kxy = x * k * y * g1;
        let wx = -pn * y - kxy * qx + (g * k + zr3 - y * k * y * g1) * qy;
        let wy = pn * x + (x * k * x * g1 - g * k - zr3) * qx + kxy * qy;
        let wz = (qx * y - qy * x) * t.ir3;
        (u, [wx * self.c, wy * self.c, wz * self.c])
    }

    /// The powers of the distance that the displacement and its rotation share.
    #[inline(always)]
    fn terms<T: Real>(&self, offset: [T; 3]) -> Terms<T> {
        let [x, y, z] = offset;
        let rho = (x * x + y * y + z * z).sqrt();
        let ir = rho.splat_like(1.0) / rho;
        let ir3 = ir * ir * ir;
        let irz = rho.splat_like(1.0) / (rho + z);
        let ir_irz = ir * irz;
        Terms { offset, ir, ir3, irz, ir_irz, ir_irz2: ir_irz * irz }
    }
}

/// `1 / rho`, `1 / rho^3`, `1 / (rho + z)`, `1 / (rho (rho + z))` and `1 / (rho (rho + z)^2)`
/// at one offset.
#[derive(Clone, Copy, Debug)]
struct Terms<T> {
    offset: [T; 3],
    ir: T,
    ir3: T,
    irz: T,
    ir_irz: T,
    ir_irz2: T,
}

impl<T: Real> Terms<T> {
    /// Boussinesq (normal force p) and Cerruti (tangential forces qx, qy) at depth.
    #[inline(always)]
    fn displacement(&self, kernel: &DepthKernel, force: [T; 3]) -> [T; 3] {
        let [x, y, z] = self.offset;
        let [qx, qy, p] = force;
        let k = kernel.k;
        let Terms { ir, ir3, irz, ir_irz, ir_irz2, .. } = *self;
        let b = p * (z * ir3 - ir_irz * k);
        let xy = x * y * (ir3 - ir_irz2 * k);
        let ux = b * x + qx * (ir + x * x * ir3 + (irz - x * x * ir_irz2) * k) + qy * xy;
        let uy = b * y + qy * (ir + y * y * ir3 + (irz - y * y * ir_irz2) * k) + qx * xy;
        let uz = p * (z * z * ir3 + ir * kernel.two_one_minus_nu) + (qx * x + qy * y) * (z * ir3 + ir_irz * k);
        [ux * kernel.c, uy * kernel.c, uz * kernel.c]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gauss-Legendre midpoint-refined quadrature of a kernel over a rectangle away from `0`.
    fn quadrature(k: Kernel, dx: f64, dy: f64, w: f64, h: f64) -> f64 {
        let n = 400;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let s = -0.5 * w + (i as f64 + 0.5) * w / n as f64;
                let t = -0.5 * h + (j as f64 + 0.5) * h / n as f64;
                sum += k.value(dx - s, dy - t);
            }
        }
        sum * w * h / (n * n) as f64
    }

    #[test]
    fn rectangle_integrals_match_quadrature_in_every_quadrant() {
        for k in Kernel::ALL {
            for &(dx, dy) in &[(2.0, 1.5), (-2.0, 1.5), (2.0, -1.5), (-2.0, -1.5), (0.0, 2.0), (3.0, 0.0)] {
                let exact = k.rectangle(dx, dy, 1.0, 0.8);
                let quad = quadrature(k, dx, dy, 1.0, 0.8);
                assert!((exact - quad).abs() < 1e-5 * (1.0 + quad.abs()), "{k:?} at ({dx},{dy}): {exact} vs {quad}");
            }
        }
    }

    /// The shared antiderivatives are each kernel's own, in every quadrant and on the axes.
    #[test]
    fn shared_antiderivatives_equal_each_kernels() {
        for &(x, y) in &[
            (0.7, 0.3),
            (-0.7, 0.3),
            (0.2, -1.4),
            (-2.0, -0.1),
            (0.0, 0.5),
            (0.4, 0.0),
            (0.0, 0.0),
            (3.0, 1e-6),
            (-1e-7, 2.5),
            (12.5, -9.75),
        ] {
            let all = Kernel::even_antiderivatives(x, y);
            for (k, v) in Kernel::ALL.iter().zip(all) {
                assert!((k.antiderivative(x, y) - v).abs() < 1e-14, "{k:?} at ({x}, {y})");
            }
        }
    }

    #[test]
    fn self_cell_integral_of_inverse_distance_is_known() {
        // int int 1/r over the square [-a, a]^2 seen from its centre = 8 a ln(1 + sqrt 2).
        let a = 0.7;
        let exact = 8.0 * a * (1.0 + 2f64.sqrt()).ln();
        assert!((Kernel::InvR.rectangle(0.0, 0.0, 2.0 * a, 2.0 * a) - exact).abs() < 1e-12);
        // Odd kernels vanish at the centre of a symmetric cell.
        for k in [Kernel::XyOverR3, Kernel::XOverR2, Kernel::YOverR2] {
            assert!(k.rectangle(0.0, 0.0, 1.0, 1.0).abs() < 1e-12, "{k:?}");
        }
        // The self integral of x^2/r^3 plus y^2/r^3 is that of 1/r.
        let s = Kernel::XxOverR3.rectangle(0.1, -0.2, 1.0, 1.3) + Kernel::YyOverR3.rectangle(0.1, -0.2, 1.0, 1.3);
        assert!((s - Kernel::InvR.rectangle(0.1, -0.2, 1.0, 1.3)).abs() < 1e-12);
    }

    /// The closed-form rotation is half the curl of the displacement, taken here by central
    /// differences (step 1e-5 mm: truncation and rounding both near 1e-9 of the value).
    #[test]
    fn depth_kernel_rotation_is_half_the_curl_of_its_displacement() {
        let kernel = DepthKernel::new(&Elastic::from_young(1.3, 0.436));
        let h = 1e-5;
        for force in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, -0.7, 0.5]] {
            for at in [[0.7, -0.4, 0.9], [-1.5, 0.2, 0.66], [0.05, 0.1, 0.3], [3.0, 2.0, 0.66]] {
                let d = |k: usize, i: usize| {
                    let (mut a, mut b) = (at, at);
                    a[k] += h;
                    b[k] -= h;
                    (kernel.displacement(force, a)[i] - kernel.displacement(force, b)[i]) / (2.0 * h)
                };
                let curl = [0.5 * (d(1, 2) - d(2, 1)), 0.5 * (d(2, 0) - d(0, 2)), 0.5 * (d(0, 1) - d(1, 0))];
                let (u, omega) = kernel.motion(force, at);
                assert_eq!(u, kernel.displacement(force, at), "the displacement must be the same bits");
                let scale = omega.iter().chain(&curl).fold(0.0f64, |m, v| m.max(v.abs()));
                for i in 0..3 {
                    assert!(
                        (omega[i] - curl[i]).abs() < 1e-7 * scale,
                        "force {force:?} at {at:?}, component {i}: {omega:?} against {curl:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn depth_kernel_reduces_to_surface_formulas() {
        let m = Elastic { shear_modulus_mpa: 2.0, poisson: 0.3 };
        let c = 1.0 / (2.0 * PI * m.shear_modulus_mpa);
        let (x, y) = (1.2, -0.7);
        let r = f64::hypot(x, y);
        let u = point_load_displacement(&m, [0.0, 0.0, 1.0], [x, y, 0.0]);
        assert!((u[2] - c * (1.0 - 0.3) / r).abs() < 1e-12);
        assert!((u[0] + c * 0.5 * (1.0 - 0.6) * x / (r * r)).abs() < 1e-12);
        let u = point_load_displacement(&m, [1.0, 0.0, 0.0], [x, y, 0.0]);
        assert!((u[0] - c * ((1.0 - 0.3) / r + 0.3 * x * x / (r * r * r))).abs() < 1e-12);
        assert!((u[1] - c * 0.3 * x * y / (r * r * r)).abs() < 1e-12);
        assert!((u[2] - c * 0.5 * (1.0 - 0.6) * x / (r * r)).abs() < 1e-12);
    }

    #[test]
    fn depth_kernel_is_reciprocal_between_surface_and_depth_components() {
        // Betti on the surface: u_x at B from P at A equals u_z at A from Qx at B.
        let m = Elastic { shear_modulus_mpa: 1.0, poisson: 0.2 };
        let ab = [0.8, 0.3, 0.0];
        let ba = [-0.8, -0.3, 0.0];
        let ux_b = point_load_displacement(&m, [0.0, 0.0, 1.0], ab)[0];
        let uz_a = point_load_displacement(&m, [1.0, 0.0, 0.0], ba)[2];
        assert!((ux_b - uz_a).abs() < 1e-12, "{ux_b} vs {uz_a}");
    }

    /// Navier's equation `(1 - 2 nu) lap u + grad div u = 0` holds inside the body, and the
    /// surface away from the load is free of traction: checks the depth formulas term by term.
    #[test]
    fn depth_kernels_satisfy_navier_and_free_surface() {
        let m = Elastic { shear_modulus_mpa: 1.0, poisson: 0.27 };
        #[allow(clippy::needless_range_loop)]
        for force in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            let u = |p: [f64; 3]| point_load_displacement(&m, force, p);
            let h = 1e-3;
            let at = [0.7, -0.4, 0.9];
            let shifted = |p: [f64; 3], k: usize, d: f64| {
                let mut q = p;
                q[k] += d;
                q
            };
            // Gradient tensor g[i][k] = d u_i / d x_k by central differences.
            let grad = |p: [f64; 3]| {
                let mut g = [[0.0; 3]; 3];
                for k in 0..3 {
                    let (a, b) = (u(shifted(p, k, h)), u(shifted(p, k, -h)));
                    for i in 0..3 {
                        g[i][k] = (a[i] - b[i]) / (2.0 * h);
                    }
                }
                g
            };
            let div = |p: [f64; 3]| {
                let g = grad(p);
                g[0][0] + g[1][1] + g[2][2]
            };
            for i in 0..3 {
                let mut lap = 0.0;
                let mut grad_div = 0.0;
                for k in 0..3 {
                    lap += (u(shifted(at, k, h))[i] - 2.0 * u(at)[i] + u(shifted(at, k, -h))[i]) / (h * h);
                }
                grad_div += (div(shifted(at, i, h)) - div(shifted(at, i, -h))) / (2.0 * h);
                let residual = (1.0 - 2.0 * m.poisson) * lap + grad_div;
                assert!(residual.abs() < 1e-4, "force {force:?}, component {i}: {residual}");
            }
            // Free surface: sigma_zx = G (du_x/dz + du_z/dx) and sigma_zz vanish at z = 0+.
            let g = grad([0.6, 0.5, 2e-3]);
            let lambda = 2.0 * m.poisson / (1.0 - 2.0 * m.poisson);
            let szx = g[0][2] + g[2][0];
            let szy = g[1][2] + g[2][1];
            let szz = 2.0 * g[2][2] + lambda * (g[0][0] + g[1][1] + g[2][2]);
            for (name, s) in [("zx", szx), ("zy", szy), ("zz", szz)] {
                assert!(s.abs() < 2e-3, "force {force:?}: sigma_{name} = {s}");
            }
        }
    }
}
