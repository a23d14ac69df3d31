//! The ten-node (quadratic, isoparametric) tetrahedron, and the six-node triangle of its faces.
//!
//! # Why this element
//! Linear tetrahedra lock when the gel's Poisson's ratio nears 0.5: every element must keep its
//! volume, and four-node elements cannot bend while doing so. Quadratic tetrahedra with the
//! volumetric strain taken as one constant per element (the P2-P0 mixed element with its
//! pressure condensed, inf-sup stable in 3D: Boffi, Brezzi & Fortin 2013, section 8.7) do not
//! lock: the deviatoric energy `mu eps_dev : eps_dev` is integrated exactly (for straight
//! elements) and the volumetric `kappa/2 V theta^2` uses the element's mean volume change
//! `theta = (1/V) int div u dV = (1/V) b . u_e`. The stiffness of nodes `a`, `b` and
//! directions `i`, `j` is then
//!
//! `K_ai,bj = int mu (delta_ij grad N_a . grad N_b + d_j N_a d_i N_b) - (2 mu / 3) d_i N_a d_j N_b dV
//!            + kappa b_ai b_bj / V`.
//!
//! Node order: the vertices 0..3, then the edges' midside nodes in [`EDGES`]'s order.

use nalgebra::{Matrix3, Vector3};

use crate::material::Material;

/// The six edges of a tetrahedron by their vertices; midside node `4 + k` sits on edge `k`.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// The four faces by their vertices, each opposite the vertex of the same index.
pub const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// The midside node of the edge between vertices `i` and `j`.
pub fn edge_node(i: usize, j: usize) -> usize {
    let k = EDGES.iter().position(|&(a, b)| (a, b) == (i, j) || (a, b) == (j, i));
    // Every pair of distinct vertices is an edge.
    4 + k.unwrap_or(0)
}

/// The degree-2 rule of four points (barycentric coordinates, weight on the reference
/// tetrahedron of volume 1/6): exact for the straight element's deviatoric stiffness.
pub(crate) fn quadrature() -> [([f64; 4], f64); 4] {
    let a = 0.585_410_196_624_968_5;
    let b = 0.138_196_601_125_010_5;
    let w = 1.0 / 24.0;
    [([a, b, b, b], w), ([b, a, b, b], w), ([b, b, a, b], w), ([b, b, b, a], w)]
}

/// The ten shape functions at barycentric coordinates `l`.
pub fn shape(l: [f64; 4]) -> [f64; 10] {
    let mut n = [0.0; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
    }
    for (k, &(i, j)) in EDGES.iter().enumerate() {
        n[4 + k] = 4.0 * l[i] * l[j];
    }
    n
}

/// Derivatives of the shape functions with respect to the reference coordinates
/// `(xi, eta, zeta) = (l1, l2, l3)`, `l0 = 1 - xi - eta - zeta`.
fn reference_gradients(l: [f64; 4]) -> [[f64; 3]; 10] {
    // d l_m / d xi_k
    const DL: [[f64; 3]; 4] = [[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut g = [[0.0; 3]; 10];
    for i in 0..4 {
        let d = 4.0 * l[i] - 1.0;
        for k in 0..3 {
            g[i][k] = d * DL[i][k];
        }
    }
    for (e, &(i, j)) in EDGES.iter().enumerate() {
        for k in 0..3 {
            g[4 + e][k] = 4.0 * (l[j] * DL[i][k] + l[i] * DL[j][k]);
        }
    }
    g
}

/// The map's Jacobian `d x / d xi` from the nodes and the reference gradients.
fn jacobian(x: &[[f64; 3]; 10], g: &[[f64; 3]; 10]) -> Matrix3<f64> {
    let mut j = Matrix3::zeros();
    for (xa, ga) in x.iter().zip(g) {
        j += Vector3::from(*xa) * Vector3::from(*ga).transpose();
    }
    j
}

/// The Jacobian determinant and the shape functions' spatial gradients (1/mm) at `l`.
pub fn gradients(x: &[[f64; 3]; 10], l: [f64; 4]) -> (f64, [[f64; 3]; 10]) {
    let g = reference_gradients(l);
    let j = jacobian(x, &g);
    let det = j.determinant();
    let inv = j.try_inverse().unwrap_or_else(Matrix3::zeros);
    let mut out = [[0.0; 3]; 10];
    for a in 0..10 {
        let v = inv.transpose() * Vector3::from(g[a]);
        out[a] = [v.x, v.y, v.z];
    }
    (det, out)
}

/// The point at barycentric coordinates `l` (mm).
pub fn position(x: &[[f64; 3]; 10], l: [f64; 4]) -> [f64; 3] {
    let n = shape(l);
    let mut p = [0.0; 3];
    for a in 0..10 {
        for c in 0..3 {
            p[c] += n[a] * x[a][c];
        }
    }
    p
}

/// An element's stiffness and volume-change row.
#[derive(Clone)]
pub struct ElementMatrices {
    /// Stiffness (N/mm), row `3 a + i`, column `3 b + j`.
    pub stiffness: Box<[[f64; 30]; 30]>,
    /// `b`: the element's volume change (mm^3) is `b . u_e`.
    pub volume_change: [f64; 30],
    /// Volume (mm^3).
    pub volume: f64,
    /// The smallest Jacobian determinant at a quadrature point (6 x the volume it stands for).
    pub min_jacobian: f64,
}

/// The element's matrices (see the module's documentation for the form).
pub fn matrices(x: &[[f64; 3]; 10], material: &Material) -> ElementMatrices {
    let mu = material.shear_modulus_mpa();
    let kappa = material.bulk_modulus_mpa();
    let mut k = Box::new([[0.0; 30]; 30]);
    let mut b = [0.0; 30];
    let mut volume = 0.0;
    let mut min_jacobian = f64::INFINITY;
    for (l, w) in quadrature() {
        let (det, g) = gradients(x, l);
        min_jacobian = min_jacobian.min(det);
        let dv = w * det;
        volume += dv;
        for a in 0..10 {
            for i in 0..3 {
                b[3 * a + i] += dv * g[a][i];
            }
            for bn in 0..10 {
                let dot = g[a][0] * g[bn][0] + g[a][1] * g[bn][1] + g[a][2] * g[bn][2];
                for i in 0..3 {
                    for j in 0..3 {
                        let mut v = mu * g[a][j] * g[bn][i] - (2.0 / 3.0) * mu * g[a][i] * g[bn][j];
                        if i == j {
                            v += mu * dot;
                        }
                        k[3 * a + i][3 * bn + j] += dv * v;
                    }
                }
            }
        }
    }
    if volume > 0.0 {
        for r in 0..30 {
            for c in 0..30 {
                k[r][c] += kappa * b[r] * b[c] / volume;
            }
        }
    }
    ElementMatrices { stiffness: k, volume_change: b, volume, min_jacobian }
}

/// Barycentric coordinates of `p` in the element, by Newton's method on the isoparametric
/// map from the straight element's guess; `None` where it does not converge.
pub fn locate(x: &[[f64; 3]; 10], p: [f64; 3]) -> Option<[f64; 4]> {
    // Straight-element guess.
    let v0 = Vector3::from(x[0]);
    let m = Matrix3::from_columns(&[Vector3::from(x[1]) - v0, Vector3::from(x[2]) - v0, Vector3::from(x[3]) - v0]);
    let guess = m.try_inverse()? * (Vector3::from(p) - v0);
    // Start inside the element (the straight guess clamped onto it): a quadratic map has other
    // preimages outside, which Newton's method from far away can find instead.
    let mut l0 = [1.0 - guess.x - guess.y - guess.z, guess.x, guess.y, guess.z].map(|v| v.max(0.0));
    let sum: f64 = l0.iter().sum();
    l0 = l0.map(|v| v / sum);
    let mut xi = Vector3::new(l0[1], l0[2], l0[3]);
    for _ in 0..20 {
        let l = [1.0 - xi.x - xi.y - xi.z, xi.x, xi.y, xi.z];
        let at = Vector3::from(position(x, l));
        let r = Vector3::from(p) - at;
        let step = jacobian(x, &reference_gradients(l)).try_inverse()? * r;
        xi += step;
        if step.norm() < 1e-13 {
            break;
        }
    }
    let l = [1.0 - xi.x - xi.y - xi.z, xi.x, xi.y, xi.z];
    let at = Vector3::from(position(x, l));
    ((at - Vector3::from(p)).norm() < 1e-9).then_some(l)
}

/// The six-node triangle's shape functions at barycentric coordinates `l` (node order of
/// [`face_forces`]: vertices `a, b, c`, then the midside nodes of `ab`, `bc`, `ca`).
pub fn face_shape(l: [f64; 3]) -> [f64; 6] {
    [
        l[0] * (2.0 * l[0] - 1.0),
        l[1] * (2.0 * l[1] - 1.0),
        l[2] * (2.0 * l[2] - 1.0),
        4.0 * l[0] * l[1],
        4.0 * l[1] * l[2],
        4.0 * l[2] * l[0],
    ]
}

/// Derivatives of [`face_shape`] with respect to `l1` and `l2`, `l0 = 1 - l1 - l2`.
pub fn face_shape_derivatives(l: [f64; 3]) -> [[f64; 6]; 2] {
    [
        [1.0 - 4.0 * l[0], 4.0 * l[1] - 1.0, 0.0, 4.0 * (l[0] - l[1]), 4.0 * l[2], -4.0 * l[2]],
        [1.0 - 4.0 * l[0], 0.0, 4.0 * l[2] - 1.0, -4.0 * l[1], 4.0 * l[1], 4.0 * (l[0] - l[2])],
    ]
}

/// The six-node triangle on a face: vertices `a, b, c`, then the midside nodes of `ab`, `bc`,
/// `ca`. Consistent nodal forces (N) of a traction `t(point, unit outward normal)` (MPa) over
/// the face, with the degree-4 rule of six points; `outward` is a point the normal must face
/// away from (the element's centroid).
pub fn face_forces(
    x: &[[f64; 3]; 6],
    outward: [f64; 3],
    traction: impl Fn([f64; 3], [f64; 3]) -> [f64; 3],
) -> [[f64; 3]; 6] {
    let a = 0.445_948_490_915_965;
    let b = 0.091_576_213_509_771;
    let wa = 0.223_381_589_678_011 / 2.0;
    let wb = 0.109_951_743_655_322 / 2.0;
    let rule = [
        ([a, a, 1.0 - 2.0 * a], wa),
        ([a, 1.0 - 2.0 * a, a], wa),
        ([1.0 - 2.0 * a, a, a], wa),
        ([b, b, 1.0 - 2.0 * b], wb),
        ([b, 1.0 - 2.0 * b, b], wb),
        ([1.0 - 2.0 * b, b, b], wb),
    ];
    let mut f = [[0.0; 3]; 6];
    for (l, w) in rule {
        let n = face_shape(l);
        let [d1, d2] = face_shape_derivatives(l);
        let mut p = Vector3::zeros();
        let mut t1 = Vector3::zeros();
        let mut t2 = Vector3::zeros();
        for k in 0..6 {
            let xk = Vector3::from(x[k]);
            p += n[k] * xk;
            t1 += d1[k] * xk;
            t2 += d2[k] * xk;
        }
        let mut normal = t1.cross(&t2);
        let area = normal.norm();
        normal /= area;
        if (p - Vector3::from(outward)).dot(&normal) < 0.0 {
            normal = -normal;
        }
        let t = traction([p.x, p.y, p.z], [normal.x, normal.y, normal.z]);
        for k in 0..6 {
            for c in 0..3 {
                f[k][c] += w * area * n[k] * t[c];
            }
        }
    }
    f
}

/// The flux `int u . n dA` (mm^3) of a displacement field over a six-node face (node order of
/// [`face_forces`]), `n` facing away from `outward`: the volume the face sweeps outwards.
pub fn face_flux(x: &[[f64; 3]; 6], u: &[[f64; 3]; 6], outward: [f64; 3]) -> f64 {
    let mut flux = 0.0;
    // Forces of a unit normal traction are `int N_k n dA`; the flux is their sum against `u`.
    let f = face_forces(x, outward, |_, n| n);
    for k in 0..6 {
        for c in 0..3 {
            flux += f[k][c] * u[k][c];
        }
    }
    flux
}
