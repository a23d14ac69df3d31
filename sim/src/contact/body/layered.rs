//! Elastic layers bonded on a rigid base: a finite layer (the gel bounded by the camera
//! window) or a stiff skin over a soft gel (the real TacTip build), with surface and depth
//! point-load kernels from the Fourier transfer form of each layer.
//!
//! Coordinates: `z` is depth into the body (mm), the load sits at the surface origin, and a
//! horizontal wavevector `k` (1/mm) splits the problem into P-SV (displacements along `k` and
//! `z`) and SH (displacement across `k`). In each layer the Navier equation has four P-SV
//! solutions per `k` (Papkovich-Neuber, with `kappa = 3 - 4 nu`, valid up to `nu = 0.5`):
//! ```text
//! for s = -1 (decaying from the layer top) and s = +1 (decaying from the layer bottom),
//! e = exp(s k zeta), zeta = z - z_ref (z_ref: layer top for s = -1, bottom for s = +1):
//!   A: U = e,          W = s e,                 tau = 2 G s k e,              sigma = 2 G k e
//!   B: U = -k zeta e,  W = (kappa - s k zeta) e, tau = G k (2 - 4 nu - 2 s k zeta) e,
//!                                               sigma = 2 G s k (2 - 2 nu - s k zeta) e
//! ```
//! where a field `f(z) exp(i k x)` has horizontal displacement `i U`, vertical `W`, shear stress
//! `sigma_zx = i tau` and normal stress `sigma_zz = sigma`; SH has `V = exp(-+ k zeta)`,
//! `tau = G dV/dz`. Exponentials referenced to each layer's own faces never exceed 1, so the
//! global system (surface tractions, continuity at interfaces, zero displacement on the base)
//! stays well conditioned at every `k`.
//!
//! The surface responses `C(k)` (mm^3/N: displacement amplitude per traction amplitude) give
//! the point-load kernels by Hankel transforms, for a surface force `(Q, P)` at the origin and
//! a field point at distance `r` and azimuth `theta`:
//! ```text
//! u_z  = P F_zz(r) + (Q . e_r) F_zq(r)                 F_zz = 1/(2 pi) int C_zz J0(k r) k dk
//! u_r  = -P F_pr(r) ...                                F_pr = 1/(2 pi) int C_xz J1(k r) k dk
//! u_xx = F_s - cos(2 theta) F_d, u_yy = F_s + cos(2 theta) F_d, u_xy = -sin(2 theta) F_d
//!        F_s = 1/(2 pi) int (C_LL + C_TT)/2 J0 k dk,   F_d = 1/(2 pi) int (C_LL - C_TT)/2 J2 k dk
//! ```
//! (`C_xz = C_zx` by reciprocity). On the surface the transforms of `C(k)` diverge like the
//! half-space's `1/r`, so the operator uses the exact half-space rectangle coefficients of the
//! top layer ([`crate::contact::body::operator`]) plus the transform of `C(k) - C_halfspace(k)`: finite at
//! `k = 0` after the factor `k`, decaying like `exp(-2 k h_top)`, and smooth in `r`. At the pin
//! depth the transforms converge on their own (`exp(-k z)`).

use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::contact::algebra::lanes::Real;
use crate::contact::body::kernel::Elastic;

/// One elastic layer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Thickness (mm).
    pub thickness_mm: f64,
    /// Material.
    pub material: Elastic,
}

/// Layers bonded to each other and to a rigid base, top (loaded surface) first.
#[derive(Clone, Debug, PartialEq)]
pub struct LayeredBody {
    /// The layers, top first.
    pub layers: Vec<Layer>,
}

/// Responses at one wavenumber: surface `[C_zz, C_xz, C_zx, C_LL, C_TT]` and, at the pin depth,
/// `[W_p, U_p, W_q, U_q, V_q]` and their depth derivatives (per mm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spectrum {
    /// Surface compliances (mm^3/N): `u_z` from `p`, `u` along `k` from `p` (times `i`),
    /// `u_z` from `q` along `k` (times `-i`; equal to the previous by reciprocity), `u` along
    /// `k` from `q` along `k`, `u` across `k` from `q` across `k`.
    pub surface: [f64; 5],
    /// The same responses at the pin depth (`W_p`, `U_p`, `W_q`, `U_q` along `k`, `V_q`).
    pub depth: [f64; 5],
    /// Their depth derivatives (mm^2/N).
    pub depth_dz: [f64; 5],
}

impl LayeredBody {
    /// Total thickness (mm): the depth of the rigid base.
    pub fn depth_mm(&self) -> f64 {
        self.layers.iter().map(|l| l.thickness_mm).sum()
    }

    /// The responses at wavenumber `k` (1/mm, > 0), with the depth responses at `pin_depth_mm`
    /// (taken on the upper side of an interface).
    pub fn spectrum(&self, k: f64, pin_depth_mm: f64) -> Spectrum {
        let n = self.layers.len();
        let g0 = self.layers[0].material.shear_modulus_mpa;
        let tops: Vec<f64> = self
            .layers
            .iter()
            .scan(0.0, |z, l| {
                let top = *z;
                *z += l.thickness_mm;
                Some(top)
            })
            .collect();
        // P-SV: state [U, W, tau / (G0 k), sigma / (G0 k)] of layer i at depth z.
        let state = |i: usize, coefs: &[f64], z: f64| -> ([f64; 4], [f64; 2]) {
            let l = &self.layers[i];
            let (g, nu) = (l.material.shear_modulus_mpa / g0, l.material.poisson);
            let mut st = [0.0; 4];
            let mut dz = [0.0; 2];
            for (j, c) in coefs.iter().enumerate() {
                let (s, zeta) = if j < 2 { (-1.0, z - tops[i]) } else { (1.0, z - tops[i] - l.thickness_mm) };
                let e = (s * k * zeta).exp();
                let skz = s * k * zeta;
                let (b, d) = if j % 2 == 0 {
                    ([1.0, s, 2.0 * g * s, 2.0 * g], [s * k, k])
                } else {
                    (
                        [
                            -k * zeta,
                            3.0 - 4.0 * nu - skz,
                            g * (2.0 - 4.0 * nu - 2.0 * skz),
                            2.0 * g * s * (2.0 - 2.0 * nu - skz),
                        ],
                        [-k * (1.0 + skz), s * k * (2.0 - 4.0 * nu - skz)],
                    )
                };
                for (o, v) in st.iter_mut().zip(b) {
                    *o += c * e * v;
                }
                for (o, v) in dz.iter_mut().zip(d) {
                    *o += c * e * v;
                }
            }
            (st, dz)
        };
        let m = 4 * n;
        let mut a = DMatrix::<f64>::zeros(m, m);
        let unit = |j: usize| -> Vec<f64> {
            let mut v = vec![0.0; 4];
            v[j] = 1.0;
            v
        };
        for j in 0..4 {
            let (s, _) = state(0, &unit(j), 0.0);
            a[(0, j)] = s[2];
            a[(1, j)] = s[3];
            for i in 0..n {
                let z = tops[i] + self.layers[i].thickness_mm;
                let (s, _) = state(i, &unit(j), z);
                if i + 1 < n {
                    for r in 0..4 {
                        a[(2 + 4 * i + r, 4 * i + j)] = s[r];
                    }
                    let (t, _) = state(i + 1, &unit(j), z);
                    for r in 0..4 {
                        a[(2 + 4 * i + r, 4 * (i + 1) + j)] = -t[r];
                    }
                } else {
                    a[(m - 2, 4 * i + j)] = s[0];
                    a[(m - 1, 4 * i + j)] = s[1];
                }
            }
        }
        let mut rhs = DMatrix::<f64>::zeros(m, 2);
        rhs[(1, 0)] = -1.0 / (g0 * k); // sigma_zz(0) = -p
        rhs[(0, 1)] = -1.0 / (g0 * k); // tau(0) = -q
        let lu = a.lu();
        let sol = lu.solve(&rhs).unwrap_or_else(|| DMatrix::from_element(m, 2, f64::NAN));
        let pin_layer = tops.iter().rposition(|&t| t < pin_depth_mm).unwrap_or(0);
        let at = |col: usize, i: usize, z: f64| {
            let coefs: Vec<f64> = (0..4).map(|j| sol[(4 * i + j, col)]).collect();
            state(i, &coefs, z)
        };
        let (sp, _) = at(0, 0, 0.0);
        let (sq, _) = at(1, 0, 0.0);
        let (dp, dpz) = at(0, pin_layer, pin_depth_mm);
        let (dq, dqz) = at(1, pin_layer, pin_depth_mm);
        let (v, vz) = self.sh(k, &tops, pin_layer, pin_depth_mm);
        Spectrum {
            surface: [sp[1], sp[0], sq[1], sq[0], v[0]],
            depth: [dp[1], dp[0], dq[1], dq[0], v[1]],
            depth_dz: [dpz[1], dpz[0], dqz[1], dqz[0], vz],
        }
    }

    /// SH response to a unit shear across `k`: `([V(0), V(z_pin)], dV/dz(z_pin))`.
    fn sh(&self, k: f64, tops: &[f64], pin_layer: usize, pin_depth_mm: f64) -> ([f64; 2], f64) {
        let n = self.layers.len();
        let g0 = self.layers[0].material.shear_modulus_mpa;
        // Layer i: V = c exp(-k (z - top)) + d exp(k (z - bottom)); tau / (G0 k) = g (-c e1 + d e2).
        let basis = |i: usize, z: f64| -> ([f64; 2], [f64; 2]) {
            let l = &self.layers[i];
            let g = l.material.shear_modulus_mpa / g0;
            let e1 = (-k * (z - tops[i])).exp();
            let e2 = (k * (z - tops[i] - l.thickness_mm)).exp();
            ([e1, e2], [-g * e1, g * e2])
        };
        let m = 2 * n;
        let mut a = DMatrix::<f64>::zeros(m, m);
        let (_, t0) = basis(0, 0.0);
        a[(0, 0)] = t0[0];
        a[(0, 1)] = t0[1];
        for i in 0..n {
            let z = tops[i] + self.layers[i].thickness_mm;
            let (v, t) = basis(i, z);
            if i + 1 < n {
                let (v2, t2) = basis(i + 1, z);
                for j in 0..2 {
                    a[(1 + 2 * i, 2 * i + j)] = v[j];
                    a[(1 + 2 * i, 2 * (i + 1) + j)] = -v2[j];
                    a[(2 + 2 * i, 2 * i + j)] = t[j];
                    a[(2 + 2 * i, 2 * (i + 1) + j)] = -t2[j];
                }
            } else {
                a[(m - 1, 2 * i)] = v[0];
                a[(m - 1, 2 * i + 1)] = v[1];
            }
        }
        let mut rhs = DVector::<f64>::zeros(m);
        rhs[0] = -1.0 / (g0 * k);
        let c = a.lu().solve(&rhs).unwrap_or_else(|| DVector::from_element(m, f64::NAN));
        let (b0, _) = basis(0, 0.0);
        let (bz, _) = basis(pin_layer, pin_depth_mm);
        let (c1, d1) = (c[2 * pin_layer], c[2 * pin_layer + 1]);
        ([c[0] * b0[0] + c[1] * b0[1], c1 * bz[0] + d1 * bz[1]], k * (-c1 * bz[0] + d1 * bz[1]))
    }

    /// Surface compliances of a half-space of the top layer's material (mm^3/N), in the
    /// order of [`Spectrum::surface`].
    pub fn half_space_surface(&self, k: f64) -> [f64; 5] {
        let m = self.layers[0].material;
        let (g, nu) = (m.shear_modulus_mpa, m.poisson);
        let coupling = (1.0 - 2.0 * nu) / (2.0 * g * k);
        [(1.0 - nu) / (g * k), coupling, coupling, (1.0 - nu) / (g * k), 1.0 / (g * k)]
    }
}

/// Gauss-Legendre nodes and weights on `[0, 1]` (Newton iteration on `P_n`).
pub(crate) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for j in 2..=n {
                    let p2 = ((2 * j - 1) as f64 * x * p1 - (j - 1) as f64 * p0) / j as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (0.5 * (1.0 - x), 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Point-load kernels of a layered body, tabulated in `r` once per body: the surface
/// correction to the top layer's half-space `[F_zz, F_pr, F_s, F_d]` and the pin-depth kernels
/// `[F_zz, F_pr, F_zq, F_s, F_d]` with their depth derivatives (mm/N and mm/N per mm).
///
/// A near-field table ([`LayeredKernels::near_field`]) holds at the pin depth the point load's
/// kernels minus those of the same force spread as a Gaussian patch
/// `exp(-r^2 / s^2) / (pi s^2)` (transform `exp(-k^2 s^2 / 4)`): what the patch leaves out, a
/// field that matters only within a few `s` of the load. Its surface table is the point
/// load's.
#[derive(Debug)]
pub struct LayeredKernels {
    body: LayeredBody,
    pin_depth_mm: f64,
    /// The Gaussian patch's `s` (mm) taken out of the depth tables; 0 for a point load's.
    near_field_mm: f64,
    dr_mm: f64,
    surface: Vec<[f64; 4]>,
    /// A near-field table's surface functions of the Gaussian patch itself (the whole
    /// response, not a correction to the half-space); empty for a point load's table.
    surface_patch: Vec<[f64; 4]>,
    depth: Vec<[f64; 5]>,
    depth_dz: Vec<[f64; 5]>,
}

/// Radial step of the tables (mm): cubic (Catmull-Rom) interpolation errs by about
/// `(dr / h)^4` for kernels smooth over the top layer's thickness `h` (1e-5 at 1.5 mm; the
/// quadrature tests hold to 1e-4).
const TABLE_STEP_MM: f64 = 0.08;
/// Parity in `r` of the surface functions `[F_zz, F_pr, F_s, F_d]` and of the depth
/// functions `[F_zz, F_pr, F_zq, F_s, F_d]` (`J1` transforms are odd).
const SURFACE_PARITY: [f64; 4] = [1.0, -1.0, 1.0, 1.0];
const DEPTH_PARITY: [f64; 5] = [1.0, -1.0, -1.0, 1.0, 1.0];

/// The depth tables of [`LayeredKernels`], borrowed (for the GPU's copy).
#[cfg(feature = "wgpu")]
pub(crate) struct DepthTables<'a> {
    /// Row spacing in `r` (mm).
    pub dr_mm: f64,
    /// `[F_zz, F_pr, F_zq, F_s, F_d]` at the pin depth, one row per `r`.
    pub depth: &'a [[f64; 5]],
    /// Their derivatives in depth (per mm).
    pub depth_dz: &'a [[f64; 5]],
    /// Each column's parity in `r`.
    pub parity: [f64; 5],
}

/// Gauss points per wavenumber interval.
const GAUSS_POINTS: usize = 8;
/// The transforms stop where their integrands have fallen by `exp(-DECAY)`.
const DECAY: f64 = 40.0;

impl LayeredKernels {
    /// Kernels of `body` for radii up to `r_max_mm`, with pins at `pin_depth_mm` (inside the
    /// top layer or at its bottom). Cached: the same body and depths return the same tables.
    pub fn get(body: &LayeredBody, pin_depth_mm: f64, r_max_mm: f64) -> Arc<LayeredKernels> {
        Self::near_field(body, pin_depth_mm, r_max_mm, 0.0)
    }

    /// [`LayeredKernels::get`] with the depth tables of a point load minus a Gaussian patch of
    /// the same force, `spread_mm` its `s` (see the type's docs); 0 gives the point load's.
    pub fn near_field(body: &LayeredBody, pin_depth_mm: f64, r_max_mm: f64, spread_mm: f64) -> Arc<LayeredKernels> {
        type Cache = Mutex<HashMap<Vec<u64>, Arc<LayeredKernels>>>;
        static CACHE: OnceLock<Cache> = OnceLock::new();
        let mut key: Vec<u64> = vec![pin_depth_mm.to_bits(), r_max_mm.to_bits(), spread_mm.to_bits()];
        for l in &body.layers {
            key.extend([l.thickness_mm, l.material.shear_modulus_mpa, l.material.poisson].map(f64::to_bits));
        }
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        if let Some(k) = cache.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return k.clone();
        }
        let built = Arc::new(Self::build(body, pin_depth_mm, r_max_mm, TABLE_STEP_MM, spread_mm));
        cache.lock().unwrap_or_else(|p| p.into_inner()).insert(key, built.clone());
        built
    }

    fn build(body: &LayeredBody, pin_depth_mm: f64, r_max_mm: f64, dr_mm: f64, near_field_mm: f64) -> Self {
        let h_top = body.layers[0].thickness_mm;
        let k_max = DECAY / (2.0 * h_top).min(pin_depth_mm.max(1e-3));
        // Intervals of half the shortest Bessel period; below k = DECAY / (2 H) (H: depth of
        // the base) also no wider than 1 / (4 H), so the response's variation on the scale of
        // the whole body is resolved.
        let depth = body.depth_mm();
        let (coarse, fine) = (PI / r_max_mm, (PI / r_max_mm).min(0.25 / depth));
        let k_fine = (DECAY / (2.0 * depth)).min(k_max);
        let mut edges = vec![0.0];
        while let Some(&k) = edges.last().filter(|&&k| k < k_max) {
            edges.push((k + if k < k_fine { fine } else { coarse }).min(k_max));
        }
        let gl = gauss_legendre(GAUSS_POINTS);
        // One quadrature point: k, its weight, and the surface, patch and depth transforms.
        type Sample = (f64, f64, [f64; 4], [f64; 4], [f64; 10]);
        let samples: Vec<Sample> = edges
            .par_windows(2)
            .flat_map_iter(|e| {
                let (k0, dk) = (e[0], e[1] - e[0]);
                let gl = &gl;
                gl.iter()
                    .map(move |&(t, w)| {
                        let k = k0 + t * dk;
                        let s = body.spectrum(k, pin_depth_mm);
                        let hs = body.half_space_surface(k);
                        let ds: [f64; 5] = std::array::from_fn(|j| s.surface[j] - hs[j]);
                        let surf = [ds[0], ds[1], 0.5 * (ds[3] + ds[4]), 0.5 * (ds[3] - ds[4])];
                        let c = &s.surface;
                        let spread = (-0.25 * (k * near_field_mm).powi(2)).exp();
                        let patch = [c[0], c[1], 0.5 * (c[3] + c[4]), 0.5 * (c[3] - c[4])].map(|v| v * spread);
                        let d = |a: &[f64; 5]| [a[0], a[1], a[2], 0.5 * (a[3] + a[4]), 0.5 * (a[3] - a[4])];
                        let (dd, dz) = (d(&s.depth), d(&s.depth_dz));
                        let mut depth = [dd[0], dd[1], dd[2], dd[3], dd[4], dz[0], dz[1], dz[2], dz[3], dz[4]];
                        if near_field_mm > 0.0 {
                            depth = depth.map(|v| v * (1.0 - spread));
                        }
                        // Weight includes k dk / (2 pi).
                        (k, w * dk * k / (2.0 * PI), surf, patch, depth)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let n = (r_max_mm / dr_mm).ceil() as usize + 3;
        // Bessel order per function: surface [0, 1, 0, 2]; depth [0, 1, 1, 0, 2] twice.
        const SURF_ORDER: [usize; 4] = [0, 1, 0, 2];
        const DEPTH_ORDER: [usize; 10] = [0, 1, 1, 0, 2, 0, 1, 1, 0, 2];
        let with_patch = near_field_mm > 0.0;
        let rows: Vec<([f64; 4], [f64; 4], [f64; 10])> = (0..n)
            .into_par_iter()
            .map(|i| {
                let r = i as f64 * dr_mm;
                let mut surf = [0.0; 4];
                let mut patch = [0.0; 4];
                let mut depth = [0.0; 10];
                for (k, w, s, g, d) in &samples {
                    let x = k * r;
                    let j0 = libm::j0(x);
                    let j1 = libm::j1(x);
                    let j2 = if x > 1e-8 { 2.0 * j1 / x - j0 } else { 0.0 };
                    let j = [j0, j1, j2];
                    for (o, (v, order)) in surf.iter_mut().zip(s.iter().zip(SURF_ORDER)) {
                        *o += w * v * j[order];
                    }
                    for (o, (v, order)) in depth.iter_mut().zip(d.iter().zip(DEPTH_ORDER)) {
                        *o += w * v * j[order];
                    }
                    if with_patch {
                        for (o, (v, order)) in patch.iter_mut().zip(g.iter().zip(SURF_ORDER)) {
                            *o += w * v * j[order];
                        }
                    }
                }
                // u_x from p is -cos(theta) int C_xz J1: store F_pr with its sign folded in.
                surf[1] = -surf[1];
                patch[1] = -patch[1];
                depth[1] = -depth[1];
                depth[6] = -depth[6];
                (surf, patch, depth)
            })
            .collect();
        let mut surface = Vec::with_capacity(n);
        let mut surface_patch = Vec::with_capacity(if with_patch { n } else { 0 });
        let mut both: Vec<[f64; 10]> = Vec::with_capacity(n);
        for (surf, patch, depth) in rows {
            surface.push(surf);
            if with_patch {
                surface_patch.push(patch);
            }
            both.push(depth);
        }
        let depth = both.iter().map(|b| std::array::from_fn(|j| b[j])).collect();
        let depth_dz = both.iter().map(|b| std::array::from_fn(|j| b[j + 5])).collect();
        Self { body: body.clone(), pin_depth_mm, near_field_mm, dr_mm, surface, surface_patch, depth, depth_dz }
    }

    /// The body.
    pub fn body(&self) -> &LayeredBody {
        &self.body
    }

    /// The Gaussian patch's `s` (mm) the depth tables leave out (0: a point load's tables).
    pub fn near_field_mm(&self) -> f64 {
        self.near_field_mm
    }

    /// Depth of the pin bases (mm).
    pub fn pin_depth_mm(&self) -> f64 {
        self.pin_depth_mm
    }

    /// Largest tabulated radius (mm).
    pub fn r_max_mm(&self) -> f64 {
        (self.surface.len() - 3) as f64 * self.dr_mm
    }

    /// Catmull-Rom interpolation in `r`; on the first interval the row at `r = -dr` comes from
    /// each function's parity (`J0`, `J2` transforms are even in `r`, `J1` ones odd).
    #[inline]
    fn lerp<const N: usize>(&self, table: &[[f64; N]], parity: &[f64; N], r: f64) -> [f64; N] {
        self.lerp_lanes(table, parity, [r], &|v: [f64; 1]| v[0])
    }

    /// [`Self::lerp`] and its derivative in `r` (per mm): the cubic's own, zero beyond the
    /// table where the value is held.
    #[inline]
    fn lerp_with_slope<const N: usize>(&self, table: &[[f64; N]], parity: &[f64; N], r: f64) -> ([f64; N], [f64; N]) {
        let end = (table.len() - 3) as f64;
        let t = (r / self.dr_mm).min(end);
        let i = t as usize;
        let f = t - i as f64;
        let (p1, p2, p3) = (&table[i], &table[i + 1], &table[i + 2]);
        let p0 = if i > 0 { table[i - 1] } else { std::array::from_fn(|j| parity[j] * p2[j]) };
        let held = r / self.dr_mm >= end;
        let mut value = [0.0; N];
        let mut slope = [0.0; N];
        for j in 0..N {
            let (a, b, c, d) = (p0[j], p1[j], p2[j], p3[j]);
            let (q, w) = (2.0 * a - 5.0 * b + 4.0 * c - d, 3.0 * (b - c) + d - a);
            value[j] = b + 0.5 * f * (c - a + f * (q + f * w));
            if !held {
                slope[j] = 0.5 * (c - a + f * (2.0 * q + 3.0 * f * w)) / self.dr_mm;
            }
        }
        (value, slope)
    }

    /// Displacement (mm, `z` into the body) at the pins' depth and lateral offset `(x, y)`
    /// (field minus load, mm) from the surface force `(qx, qy, p)` (N), with its gradient
    /// `[d/dx, d/dy, d/d depth]` (per mm) in closed form: the radial functions' slopes from the
    /// interpolating cubics, the angular terms' derivatives (`dc/dx = s^2 / r`, `dc2/dx =
    /// 4 c s^2 / r`, `ds2/dx = -2 s c2 / r`, ...), and the depth derivative from the `d/dz`
    /// tables (the displacement is linear in depth about the pins' depth). What the pins' four-point
    /// stencil approximates by forward differences (`pins/motion.rs`), in one table lookup.
    pub(crate) fn displacement_and_gradient(&self, force: [f64; 3], x: f64, y: f64) -> ([f64; 3], [[f64; 3]; 3]) {
        if x * x + y * y == 0.0 {
            // The limit at the load: `pr` and `zq` are odd in r, so `p pr c = p pr'(0) x` and
            // `zq (qx c + qy s) = zq'(0) (qx x + qy y)`; the even terms are flat there.
            let (f, df) = self.lerp_with_slope(&self.depth, &DEPTH_PARITY, 0.0);
            let g = self.lerp(&self.depth_dz, &DEPTH_PARITY, 0.0);
            let u = combine(force, x, y, f[0], f[1], f[2], f[3], f[4]);
            let d_depth = combine(force, x, y, g[0], g[1], g[2], g[3], g[4]);
            let [qx, qy, p] = force;
            let (dpr, dzq) = (df[1], df[2]);
            return (u, [[p * dpr, 0.0, dzq * qx], [0.0, p * dpr, dzq * qy], d_depth]);
        }
        self.displacement_and_gradient_lanes(force, ([x], [y]), |v: [f64; 1]| v[0])
    }

    /// [`Self::displacement_and_gradient`] of `N` forces at once (the pins take
    /// [`LANES`](crate::contact::algebra::lanes::LANES)),
    /// each at its own offset `(x, y)` (mm; none with `x^2 + y^2 = 0`, where the angles need
    /// the scalar limit): the table rows are gathered lane by lane, the rest is one formula on `T`
    /// ([`Real`]; `f64` with `N = 1` is the scalar's), so each lane gives the same bits on
    /// every kind of lanes. One division a force: the angles and the radial slopes by
    /// reciprocals. `lanes` makes values into `T`.
    #[inline(always)]
    pub(crate) fn displacement_and_gradient_lanes<T: Real, const N: usize>(
        &self,
        force: [T; 3],
        (x, y): ([f64; N], [f64; N]),
        lanes: impl Fn([f64; N]) -> T,
    ) -> ([T; 3], [[T; 3]; 3]) {
        let end = (self.depth.len() - 3) as f64;
        let mut r = [0.0; N];
        let mut frac = [0.0; N];
        let mut slope = [0.0; N];
        // Each lane's rows `i - 1 .. i + 2` of both tables (the row before the first from
        // the functions' parity, as [`Self::lerp`] takes it).
        let mut at = [0usize; N];
        let mut first = [[[0.0; 5]; N]; 2];
        let per_mm = 1.0 / self.dr_mm;
        for l in 0..N {
            r[l] = (x[l] * x[l] + y[l] * y[l]).sqrt();
            // Beyond the table the value is held and its slope is zero.
            let t = r[l] * per_mm;
            let (t, held) = if t < end { (t, false) } else { (end, true) };
            at[l] = t as usize;
            frac[l] = t - at[l] as f64;
            slope[l] = if held { 0.0 } else { 0.5 * per_mm };
            for (table, first) in [&self.depth, &self.depth_dz].into_iter().zip(first.iter_mut()) {
                let i = at[l];
                first[l] =
                    if i > 0 { table[i - 1] } else { std::array::from_fn(|j| DEPTH_PARITY[j] * table[i + 1][j]) };
            }
        }
        let (f, slope) = (lanes(frac), lanes(slope));
        // Function `j` of row `k` (0: the row before the interval) of `table`, lane by lane.
        let row = |table: &[[f64; 5]], first: &[[f64; 5]; N], k: usize, j: usize| {
            lanes(std::array::from_fn(|l| if k == 0 { first[l][j] } else { table[at[l] + k - 1][j] }))
        };
        let (mut v, mut df, mut g) = ([f; 5], [f; 5], [f; 5]);
        for j in 0..5 {
            let [a, b, c, d] = std::array::from_fn(|k| row(&self.depth, &first[0], k, j));
            let (q, w) = (a * 2.0 - b * 5.0 + c * 4.0 - d, (b - c) * 3.0 + d - a);
            v[j] = b + f * 0.5 * (c - a + f * (q + f * w));
            df[j] = (c - a + f * (q * 2.0 + f * 3.0 * w)) * slope;
            g[j] = catmull_rom(std::array::from_fn(|k| row(&self.depth_dz, &first[1], k, j)), f);
        }
        let inv = f.splat_like(1.0) / lanes(r);
        let (c, sn) = (lanes(x) * inv, lanes(y) * inv);
        let angles = (c, sn, c * c - sn * sn, c * sn * 2.0);
        let c2 = angles.2;
        let u = combine_lanes(force, angles, v);
        let d_depth = combine_lanes(force, angles, g);
        // Along x (dr/dx = c) and y (dr/dy = s): the radial slopes with the angles held, plus
        // the angles' own change with the radial functions held (`dc/dx = s^2 / r`, `dc2/dx =
        // 4 c s^2 / r`, `ds2/dx = -2 s c2 / r`, ...).
        let (ss, cs, cc) = (sn * sn * inv, c * sn * inv, c * c * inv);
        let dx = along_lanes(force, angles, &v, &df, [c, ss, -cs, c * ss * 4.0, -(sn * c2 * inv * 2.0)]);
        let dy = along_lanes(force, angles, &v, &df, [sn, -cs, cc, -(c * cs * 4.0), c * c2 * inv * 2.0]);
        (u, [dx, dy, d_depth])
    }

    /// [`Self::lerp`] at `N` radii at once (`N = 1` on `f64` is it): the rows gathered per
    /// lane, the cubic ([`catmull_rom`]) on `T` ([`Real`]), each lane the bits of one radius
    /// alone. `lanes` makes values into `T`.
    #[inline(always)]
    fn lerp_lanes<T: Real, const F: usize, const N: usize>(
        &self,
        table: &[[f64; F]],
        parity: &[f64; F],
        r: [f64; N],
        lanes: &impl Fn([f64; N]) -> T,
    ) -> [T; F] {
        let end = (table.len() - 3) as f64;
        let mut at = [0usize; N];
        let mut frac = [0.0; N];
        let mut first = [[0.0; F]; N];
        for l in 0..N {
            let t = (r[l] / self.dr_mm).min(end);
            at[l] = t as usize;
            frac[l] = t - at[l] as f64;
            let i = at[l];
            first[l] = if i > 0 { table[i - 1] } else { std::array::from_fn(|j| parity[j] * table[i + 1][j]) };
        }
        let f = lanes(frac);
        // Plain loops, not closures, around the lanes' arithmetic: it stays inlined where the
        // vector unit's instructions are enabled.
        let mut out = [f; F];
        for (j, out) in out.iter_mut().enumerate() {
            let row =
                |k: usize| lanes(std::array::from_fn(|l| if k == 0 { first[l][j] } else { table[at[l] + k - 1][j] }));
            *out = catmull_rom([row(0), row(1), row(2), row(3)], f);
        }
        out
    }

    /// [`Self::surface_radial`] at `N` radii at once, each lane its bits.
    #[inline(always)]
    pub(crate) fn surface_radial_lanes<T: Real, const N: usize>(
        &self,
        r: [f64; N],
        lanes: &impl Fn([f64; N]) -> T,
    ) -> [T; 4] {
        self.lerp_lanes(&self.surface, &SURFACE_PARITY, r, lanes)
    }

    /// Radial functions `[F_zz, F_pr, F_s, F_d]` (mm/N) of the surface displacement under the
    /// Gaussian patch a near-field table leaves out ([`LayeredKernels::near_field`]) at `N`
    /// radii `r` (mm) from its centre at once, each lane the bits of its radius alone: the
    /// whole response, `C(k) exp(-k^2 s^2 / 4)` transformed; `None` for a point load's table.
    #[inline(always)]
    pub(crate) fn surface_patch_radial<T: Real, const N: usize>(
        &self,
        r: [f64; N],
        lanes: &impl Fn([f64; N]) -> T,
    ) -> Option<[T; 4]> {
        (!self.surface_patch.is_empty()).then(|| self.lerp_lanes(&self.surface_patch, &SURFACE_PARITY, r, lanes))
    }

    /// Radial functions `[F_zz, F_pr, F_s, F_d]` (mm/N) of the surface correction at `r` (mm).
    pub(crate) fn surface_radial(&self, r: f64) -> [f64; 4] {
        self.surface_radial_lanes([r], &|v: [f64; 1]| v[0])
    }

    /// Surface displacement correction (mm) to the top layer's half-space at lateral offset
    /// `(x, y)` (field minus load, mm) from the surface force `(qx, qy, p)` (N).
    pub fn surface_correction(&self, force: [f64; 3], x: f64, y: f64) -> [f64; 3] {
        let [zz, pr, s, d] = self.surface_radial(x.hypot(y));
        combine(force, x, y, zz, pr, -pr, s, d)
    }

    /// The tables of [`LayeredKernels::displacement`] (the GPU's copy).
    #[cfg(feature = "wgpu")]
    pub(crate) fn depth_tables(&self) -> DepthTables<'_> {
        DepthTables { dr_mm: self.dr_mm, depth: &self.depth, depth_dz: &self.depth_dz, parity: DEPTH_PARITY }
    }

    /// Displacement (mm; `z` into the body) at depth `depth_mm` (close to the pin depth: linear
    /// in depth about it) and lateral offset `(x, y)` (mm) from the surface force
    /// `(qx, qy, p)` (N).
    pub fn displacement(&self, force: [f64; 3], offset: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = offset;
        let r = x.hypot(y);
        let mut f = self.lerp(&self.depth, &DEPTH_PARITY, r);
        let dz = z - self.pin_depth_mm;
        if dz != 0.0 {
            let d = self.lerp(&self.depth_dz, &DEPTH_PARITY, r);
            for (v, d) in f.iter_mut().zip(d) {
                *v += dz * d;
            }
        }
        combine(force, x, y, f[0], f[1], f[2], f[3], f[4])
    }
}

/// `(cos theta, sin theta, cos 2 theta, sin 2 theta)` of the offset `(x, y)`; zeros at the
/// origin, where the angular terms of the kernels vanish.
#[inline]
pub(crate) fn angular(x: f64, y: f64) -> (f64, f64, f64, f64) {
    let r2 = x * x + y * y;
    if r2 > 0.0 {
        let r = r2.sqrt();
        (x / r, y / r, (x * x - y * y) / r2, 2.0 * x * y / r2)
    } else {
        (0.0, 0.0, 0.0, 0.0)
    }
}

/// Displacement from the radial kernels: `u_z = P zz + (Q . e_r) zq`,
/// `u_h = P pr e_r + Q (s - d cos 2 theta ...)`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn combine(force: [f64; 3], x: f64, y: f64, zz: f64, pr: f64, zq: f64, s: f64, d: f64) -> [f64; 3] {
    let [qx, qy, p] = force;
    let (c, sn, c2, s2) = angular(x, y);
    [
        p * pr * c + qx * (s - c2 * d) - qy * s2 * d,
        p * pr * sn - qx * s2 * d + qy * (s + c2 * d),
        p * zz + zq * (qx * c + qy * sn),
    ]
}

/// The Catmull-Rom cubic through the rows `[a, b, c, d]` at the fraction `f` of the way
/// from `b` to `c`.
#[inline(always)]
fn catmull_rom<T: Real>([a, b, c, d]: [T; 4], f: T) -> T {
    b + f * 0.5 * (c - a + f * (a * 2.0 - b * 5.0 + c * 4.0 - d + f * ((b - c) * 3.0 + d - a)))
}

/// The displacement's derivative along a lateral direction on lanes
/// ([`LayeredKernels::displacement_and_gradient`]'s `along`): the radial slopes `df` times
/// `dr` with the angles held, plus the angles' own change `(dc, dsn, dc2, ds2)` with the radial
/// functions `v` held.
#[inline(always)]
fn along_lanes<T: Real>(
    force: [T; 3],
    angles: (T, T, T, T),
    v: &[T; 5],
    df: &[T; 5],
    [dr, dc, dsn, dc2, ds2]: [T; 5],
) -> [T; 3] {
    let radial = combine_lanes(force, angles, df.map(|d| d * dr));
    let [qx, qy, p] = force;
    let (pr, zq, d) = (v[1], v[2], v[4]);
    [
        radial[0] + p * pr * dc - qx * dc2 * d - qy * ds2 * d,
        radial[1] + p * pr * dsn - qx * ds2 * d + qy * dc2 * d,
        radial[2] + zq * (qx * dc + qy * dsn),
    ]
}

/// [`combine`] on lanes, with the angles `(cos theta, sin theta, cos 2 theta, sin 2 theta)`
/// given and the radial functions `[zz, pr, zq, s, d]`.
#[inline(always)]
fn combine_lanes<T: Real>(force: [T; 3], (c, sn, c2, s2): (T, T, T, T), [zz, pr, zq, s, d]: [T; 5]) -> [T; 3] {
    let [qx, qy, p] = force;
    [
        p * pr * c + qx * (s - c2 * d) - qy * s2 * d,
        p * pr * sn - qx * s2 * d + qy * (s + c2 * d),
        p * zz + zq * (qx * c + qy * sn),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(layers: &[(f64, f64, f64)]) -> LayeredBody {
        LayeredBody {
            layers: layers
                .iter()
                .map(|&(h, e, nu)| Layer { thickness_mm: h, material: Elastic::from_young(e, nu) })
                .collect(),
        }
    }

    /// The closed-form gradient of the pins' displacement is the tables' own: central
    /// differences (1e-5 mm; 1e-8 through the origin) of [`LayeredKernels::displacement`] agree within 1e-6 of the
    /// gradient's size, at offsets on and between the tables' knots, near and far, for a
    /// force of all three components; the displacement is the same to rounding (1e-15 of its
    /// size). Regression: right
    /// under the load (offset 0, a pin over a sub-square's centre) the lateral gradient was
    /// taken as 0, where the odd terms' slopes make it `p pr'(0)` and `zq'(0) q`.
    #[test]
    fn the_closed_form_gradient_is_the_tables_own() {
        let b = body(&[(0.66, 1.0, 0.436), (19.34, 0.02, 0.4999)]);
        let k = LayeredKernels::near_field(&b, 0.66, 60.0, 3.0);
        let force = [0.3, -0.2, 1.1];
        for (x, y) in [
            (0.0, 0.0),
            (0.05, 0.0),
            (0.01, 0.02),
            (-0.003, 0.001),
            (0.1, -0.07),
            (0.4, 0.3),
            (-1.7, 2.2),
            (3.0, -0.01),
            (-6.5, -4.25),
            (12.0, 9.0),
            (0.0, 25.0),
        ] {
            let (u, g) = k.displacement_and_gradient(force, x, y);
            let depth = k.pin_depth_mm();
            // Through the origin the differences see `|r|`, first order in the step: a finer one.
            let h = if x == 0.0 && y == 0.0 { 1e-8 } else { 1e-5 };
            // The same tables and formula; the angles by one reciprocal here (one division a
            // force on the pins' lanes) and by divisions there: equal to rounding.
            let plain = k.displacement(force, [x, y, depth]);
            let scale = plain.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in u.iter().zip(&plain) {
                assert!((a - b).abs() <= 1e-15 * scale, "({x}, {y}): {u:?} vs {plain:?}");
            }
            let fd = |d: [f64; 3]| -> [f64; 3] {
                let (p, m) = (
                    k.displacement(force, [x + d[0], y + d[1], depth + d[2]]),
                    k.displacement(force, [x - d[0], y - d[1], depth - d[2]]),
                );
                std::array::from_fn(|c| (p[c] - m[c]) / (2.0 * h))
            };
            let expected = [fd([h, 0.0, 0.0]), fd([0.0, h, 0.0]), fd([0.0, 0.0, h])];
            let size = expected.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, e) in g.iter().flatten().zip(expected.iter().flatten()) {
                assert!((a - e).abs() <= 1e-6 * size, "({x}, {y}): {g:?} vs {expected:?}");
            }
        }
    }

    /// The near field is the point load's kernel minus the Gaussian patch's, the patch's
    /// computed here by quadrature of the point load's tables over the patch (polar
    /// Gauss-Legendre rule out to 5 s).
    #[test]
    fn near_field_is_the_point_load_minus_a_gaussian_patch() {
        let b = body(&[(0.66, 1.0, 0.436), (19.34, 0.1, 0.4999)]);
        let (depth, s) = (0.66, 3.0);
        let point = LayeredKernels::get(&b, depth, 60.0);
        let near = LayeredKernels::near_field(&b, depth, 60.0, s);
        assert_eq!(near.near_field_mm(), s);
        let gl = gauss_legendre(96);
        let angles = 256;
        let scale = point.displacement([0.0, 0.0, 1.0], [0.0, 0.0, depth])[2].abs();
        for r0 in [0.0, 1.5, 4.0, 9.0] {
            for force in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
                let mut patch = [0.0; 3];
                for &(t, w) in &gl {
                    let rho = 5.0 * s * t;
                    let g = (-(rho / s).powi(2)).exp() / (PI * s * s);
                    for a in 0..angles {
                        let phi = 2.0 * PI * (a as f64 + 0.5) / angles as f64;
                        let u = point.displacement(force, [r0 - rho * phi.cos(), -rho * phi.sin(), depth]);
                        let weight = w * 5.0 * s * rho * (2.0 * PI / angles as f64) * g;
                        for c in 0..3 {
                            patch[c] += weight * u[c];
                        }
                    }
                }
                let (p, n) = (point.displacement(force, [r0, 0.0, depth]), near.displacement(force, [r0, 0.0, depth]));
                for c in 0..3 {
                    let err = (p[c] - patch[c] - n[c]).abs();
                    assert!(
                        err < 2e-3 * scale,
                        "r {r0} force {force:?} component {c}: {} - {} against {}",
                        p[c],
                        patch[c],
                        n[c]
                    );
                }
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let gl = gauss_legendre(8);
        for p in 0..16 {
            let s: f64 = gl.iter().map(|(x, w)| w * x.powi(p)).sum();
            assert!((s - 1.0 / (p + 1) as f64).abs() < 1e-14, "x^{p}: {s}");
        }
    }

    #[test]
    fn thick_layer_responds_like_a_half_space() {
        for nu in [0.0, 0.3, 0.5] {
            let b = body(&[(1e3, 2.0, nu)]);
            for k in [0.5, 2.0, 10.0] {
                let s = b.spectrum(k, 1.0);
                let hs = b.half_space_surface(k);
                for j in 0..5 {
                    assert!((s.surface[j] - hs[j]).abs() < 1e-12 * hs[4], "nu {nu} k {k} {j}: {s:?} vs {hs:?}");
                }
            }
        }
    }

    #[test]
    fn responses_are_reciprocal_and_thin_layers_shear_simply() {
        // Betti: u along k from p equals u_z from q along k, at the surface, also in two
        // layers. A thin layer under uniform load (k -> 0): u_z = p h / M, u = q h / G.
        let b = body(&[(1.5, 1.0, 0.45), (18.0, 0.1, 0.3)]);
        for k in [0.01, 0.7, 5.0] {
            let s = b.spectrum(k, 1.5).surface;
            assert!((s[1] - s[2]).abs() < 1e-12 * s[4], "k {k}: {s:?}");
            assert!(s[1].abs() > 1e-3 * s[4], "an incompressible-ish two-layer body couples: {s:?}");
        }
        let thin = body(&[(0.2, 1.0, 0.3)]);
        let s = thin.spectrum(1e-4, 0.1);
        let m = thin.layers[0].material;
        let g = m.shear_modulus_mpa;
        let pwave = 2.0 * g * (1.0 - m.poisson) / (1.0 - 2.0 * m.poisson);
        assert!((s.surface[0] / (0.2 / pwave) - 1.0).abs() < 1e-6, "{:?}", s.surface);
        assert!((s.surface[3] / (0.2 / g) - 1.0).abs() < 1e-6);
        assert!((s.surface[4] / (0.2 / g) - 1.0).abs() < 1e-6);
        // Half-way down, a thin layer in simple shear moves half as much.
        assert!((s.depth[3] / s.surface[3] - 0.5).abs() < 1e-6);
        assert!((s.depth_dz[3] * 0.2 / s.surface[3] + 1.0).abs() < 1e-6);
    }

    #[test]
    fn identical_layers_equal_one_layer() {
        let one = body(&[(12.0, 0.5, 0.4)]);
        let two = body(&[(1.5, 0.5, 0.4), (10.5, 0.5, 0.4)]);
        for k in [0.01, 0.3, 3.0] {
            let (a, b) = (one.spectrum(k, 1.5), two.spectrum(k, 1.5));
            for j in 0..5 {
                assert!((a.surface[j] - b.surface[j]).abs() < 1e-12 * a.surface[4].abs(), "{k}: {a:?} {b:?}");
                assert!((a.depth[j] - b.depth[j]).abs() < 1e-10 * a.surface[4].abs(), "{k}: {a:?} {b:?}");
            }
        }
    }

    #[test]
    fn thick_layer_depth_kernel_is_boussinesq_cerruti() {
        use crate::contact::body::kernel::DepthKernel;
        // 3 m of material under a pin 1.5 mm deep: the base holds the column back by about the
        // half-space's displacement at its depth, 0.1% of the field here.
        let b = body(&[(3000.0, 1.0, 0.4)]);
        let t = std::time::Instant::now();
        let k = LayeredKernels::get(&b, 1.5, 8.0);
        eprintln!("tables: {:?}", t.elapsed());
        let exact = DepthKernel::new(&b.layers[0].material);
        for force in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.3, -0.8, 0.5]] {
            for (x, y) in [(0.0, 0.0), (0.7, 0.2), (-2.0, 1.5), (4.0, -3.0)] {
                // The depth derivative, as the pins take it (1e-3 mm steps).
                let (u0, u1) = (k.displacement(force, [x, y, 1.5]), k.displacement(force, [x, y, 1.499]));
                let (e0, e1) = (exact.displacement(force, [x, y, 1.5]), exact.displacement(force, [x, y, 1.499]));
                let de: Vec<f64> = e0.iter().zip(e1).map(|(a, b)| (b - a) / 1e-3).collect();
                let dscale = de.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for (j, d) in de.iter().enumerate() {
                    let da = (u1[j] - u0[j]) / 1e-3;
                    assert!((da - d).abs() < 1e-2 * dscale, "d/dz {force:?} at ({x}, {y}): {da} vs {d}");
                }
                for z in [1.5, 1.499] {
                    let (a, e) = (k.displacement(force, [x, y, z]), exact.displacement(force, [x, y, z]));
                    let scale = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    // The base holds the column back by about twice the half-space's
                    // displacement at its depth, 2 (1 - nu) / (2 pi G H) per newton.
                    let m = b.layers[0].material;
                    let base = 2.0 * (1.0 - m.poisson) / (PI * m.shear_modulus_mpa * 3000.0);
                    let norm = force.iter().map(|f| f.abs()).sum::<f64>();
                    for (u, v) in a.iter().zip(e) {
                        let tol = 1e-3 * scale + base * norm;
                        assert!((u - v).abs() < tol, "{force:?} at ({x}, {y}, {z}): {a:?} vs {e:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_stiff_skin_over_a_soft_gel_carries_a_point_shear_far() {
        use crate::contact::body::kernel::DepthKernel;
        // At the skin's inner surface, 10 mm from a point shear: a half-space of the skin
        // material falls off like 1 / distance; a skin over a gel ten times softer carries the
        // shear farther (0.47 of the pin above the load against 0.29).
        let b = body(&[(1.5, 1.0, 0.5), (18.5, 0.1, 0.5)]);
        let k = LayeredKernels::get(&b, 1.5, 30.0);
        let hs = DepthKernel::new(&b.layers[0].material);
        let ratio = |f: &dyn Fn([f64; 3]) -> [f64; 3]| f([10.0, 0.0, 1.5])[0] / f([0.0, 0.0, 1.5])[0];
        let layered = ratio(&|at| k.displacement([1.0, 0.0, 0.0], at));
        let half_space = ratio(&|at| hs.displacement([1.0, 0.0, 0.0], at));
        assert!(layered > 1.5 * half_space, "{layered} vs {half_space}");
    }

    #[test]
    fn interpolated_tables_equal_fine_tables() {
        let b = body(&[(1.5, 1.0, 0.5), (18.5, 0.1, 0.5)]);
        let coarse = LayeredKernels::build(&b, 1.5, 20.0, TABLE_STEP_MM, 0.0);
        let fine = LayeredKernels::build(&b, 1.5, 20.0, 0.005, 0.0);
        let scale = fine.depth[0][0].abs();
        for i in 0..400 {
            let r = 0.0173 + i as f64 * 0.0491;
            let (a, e) = (coarse.lerp(&coarse.depth, &DEPTH_PARITY, r), fine.lerp(&fine.depth, &DEPTH_PARITY, r));
            let (da, de) =
                (coarse.lerp(&coarse.depth_dz, &DEPTH_PARITY, r), fine.lerp(&fine.depth_dz, &DEPTH_PARITY, r));
            let dscale = fine.depth_dz[0][0].abs();
            for (x, y) in da.iter().zip(&de) {
                assert!((x - y).abs() < 1e-4 * dscale, "r {r}: {da:?} vs {de:?}");
            }
            let (sa, se) =
                (coarse.lerp(&coarse.surface, &SURFACE_PARITY, r), fine.lerp(&fine.surface, &SURFACE_PARITY, r));
            for (x, y) in a.iter().zip(&e).chain(sa.iter().zip(&se)) {
                assert!((x - y).abs() < 1e-4 * scale, "r {r}: {a:?} vs {e:?}");
            }
        }
    }
}
