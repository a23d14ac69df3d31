//! Large deformation: the dome as a compressible neo-Hookean solid, pressed by a rigid flat,
//! against the linear model under the same press (issue 85's geometric-nonlinearity check).
//!
//! # The material
//! Total Lagrangian, per unit undeformed volume, with `F = I + grad u`, `J = det F`,
//! `I1 = F : F`:
//!
//! `W = mu / 2 (J^(-2/3) I1 - 3) + kappa / 2 (Jbar - 1)^2`,
//!
//! the isochoric part at each quadrature point, the volumetric part on the element's mean
//! dilatation `Jbar = v / V` (current over undeformed volume; Simo, Taylor & Pister 1985), the
//! large-deformation form of [`crate::element`]'s P2-P0 element: at `u = 0` its tangent is that
//! element's stiffness (test `neo_hookean_tangent_at_rest_is_the_linear_stiffness`). The
//! first Piola-Kirchhoff stress of the isochoric part is
//! `P = mu J^(-2/3) (F - I1/3 F^-T)`, its tangent
//!
//! `dP = mu J^(-2/3) [dF - 2/3 (F^-T : dF) F - 2/3 (F : dF) F^-T + 2/9 I1 (F^-T : dF) F^-T
//!       + 1/3 I1 F^-T dF^T F^-T]`,
//!
//! and the volumetric force on node `a` is `kappa (Jbar - 1) g_a`, `g_a = int J F^-T grad N_a dV`
//! (`d v / d u_a`), its tangent `kappa / V g g^T + kappa (Jbar - 1) d g / d u`.
//!
//! # The press
//! A rigid flat `z = R - depth` (sensor frame, apex at `(0, 0, R)`), frictionless: a penalty
//! spring of stiffness `k` (N/mm) on every node of the outer sphere that passes it,
//! `f_z = -k (z + u_z - (R - depth))`. The depth grows in steps; each step is solved by
//! Newton's method from the last (no node moving more than a step's depth per iteration; a
//! step that does not converge is tried again at half the depth, up to six times).
//! [`Kinematics::Linear`] solves the same press with the
//! linear stiffness (small strain and small rotation), so the two differ only by the
//! kinematics and the material's nonlinearity.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::dome::{Dome, PinProbe};
use crate::element::{ElementMatrices, gradients, quadrature, shape};
use crate::error::{FemError, Result};
use crate::material::Material;
use crate::mesh::{Mesh, Region};
use crate::system::Stiffness;

/// An element's state under a displacement: its tangent (as [`ElementMatrices`]), internal
/// force and stored energy.
pub struct NonlinearElement {
    /// The tangent stiffness (N/mm); `volume_change` holds `g = d v / d u_e` (mm^2),
    /// `min_jacobian` the smallest `det (d x / d xi)` of the deformed element.
    pub matrices: ElementMatrices,
    /// Internal force (N), `3 a + i`.
    pub force: [f64; 30],
    /// Stored energy (N mm).
    pub energy: f64,
}

/// The neo-Hookean element (see the module's docs) at nodes `x` (mm) displaced by `u` (mm).
pub fn neo_hookean(x: &[[f64; 3]; 10], u: &[[f64; 3]; 10], material: &Material) -> NonlinearElement {
    let mu = material.shear_modulus_mpa();
    let kappa = material.bulk_modulus_mpa();
    let mut k = Box::new([[0.0; 30]; 30]);
    let mut force = [0.0; 30];
    let mut gv = [0.0; 30];
    let mut geometric = Box::new([[0.0; 30]; 30]);
    let (mut volume, mut current, mut energy) = (0.0, 0.0, 0.0);
    let mut min_jacobian = f64::INFINITY;
    for (l, w) in quadrature() {
        let (det0, g) = gradients(x, l);
        let dv = w * det0;
        let mut f = Matrix3::identity();
        for a in 0..10 {
            f += Vector3::from(u[a]) * Vector3::from(g[a]).transpose();
        }
        let j = f.determinant();
        min_jacobian = min_jacobian.min(det0 * j);
        let Some(inv) = f.try_inverse() else {
            continue;
        };
        let fit = inv.transpose();
        let i1 = f.norm_squared();
        let c = j.abs().powf(-2.0 / 3.0);
        volume += dv;
        current += dv * j;
        energy += dv * 0.5 * mu * (c * i1 - 3.0);
        let p = (f - fit * (i1 / 3.0)) * (mu * c);
        let ga: Vec<Vector3<f64>> = g.iter().map(|v| Vector3::from(*v)).collect();
        let fg: Vec<Vector3<f64>> = ga.iter().map(|v| f * v).collect();
        let n: Vec<Vector3<f64>> = ga.iter().map(|v| fit * v).collect();
        let s = mu * c * dv;
        for a in 0..10 {
            let pa = p * ga[a];
            for i in 0..3 {
                force[3 * a + i] += dv * pa[i];
                gv[3 * a + i] += dv * j * n[a][i];
            }
            for b in 0..10 {
                let dot = ga[a].dot(&ga[b]);
                for i in 0..3 {
                    for jj in 0..3 {
                        let mut v = -(2.0 / 3.0) * fg[a][i] * n[b][jj] - (2.0 / 3.0) * n[a][i] * fg[b][jj]
                            + (2.0 / 9.0) * i1 * n[a][i] * n[b][jj]
                            + (1.0 / 3.0) * i1 * n[b][i] * n[a][jj];
                        if i == jj {
                            v += dot;
                        }
                        k[3 * a + i][3 * b + jj] += s * v;
                        geometric[3 * a + i][3 * b + jj] += dv * j * (n[b][jj] * n[a][i] - n[b][i] * n[a][jj]);
                    }
                }
            }
        }
    }
    if volume > 0.0 {
        let jbar = current / volume;
        energy += volume * 0.5 * kappa * (jbar - 1.0).powi(2);
        let pressure = kappa * (jbar - 1.0);
        for r in 0..30 {
            force[r] += pressure * gv[r];
            for c in 0..30 {
                k[r][c] += kappa * gv[r] * gv[c] / volume + pressure * geometric[r][c];
            }
        }
    }
    NonlinearElement {
        matrices: ElementMatrices { stiffness: k, volume_change: gv, volume, min_jacobian },
        force,
        energy,
    }
}

/// How the body's strain and stress follow its displacement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kinematics {
    /// Small strain, small rotation: the dome's linear stiffness.
    Linear,
    /// Large deformation, the neo-Hookean material of the module's docs.
    NeoHookean,
}

/// A rigid flat pressed on the dome's apex (see the module's docs).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatPress {
    /// The depths (mm) at which the state is reported, increasing.
    pub depths_mm: Vec<f64>,
    /// The largest step of depth (mm) between two solves.
    pub step_mm: f64,
    /// The penalty spring on each outer node that passes the flat (N/mm).
    pub penalty_n_per_mm: f64,
}

/// The dome pressed to one depth.
#[derive(Clone, Debug)]
pub struct PressState {
    /// The flat's depth below the apex (mm).
    pub depth_mm: f64,
    /// Nodal displacements (mm).
    pub displacement: Vec<[f64; 3]>,
    /// The flat's force on the dome (N, along -z).
    pub force_n: f64,
    /// The deepest node past the flat (mm): the penalty's error.
    pub penetration_mm: f64,
    /// Newton iterations of the last step.
    pub iterations: usize,
    /// Iterations since the last reported depth that took the linear stiffness because the
    /// tangent was not positive definite.
    pub linear_steps: usize,
}

/// Newton's method stops when a step moves no node more than this fraction of the radius (2e-6
/// mm on the TacTip's 20 mm: the solves' rounding on the 8-cell dome, whose gel is 5,000 times
/// stiffer in volume than in shear, is of order 1e-8 mm).
const STEP_TOLERANCE: f64 = 1e-7;
const MAX_ITERATIONS: usize = 40;
/// A depth step that does not converge is halved, at most this many times.
const MAX_HALVINGS: u32 = 6;

impl FlatPress {
    /// Checks the press's fields, naming the one out of range.
    fn validate(&self) -> Result<()> {
        let bad = |field: &'static str, value: f64, expected: &'static str| {
            Err(FemError::Parameter { field, value, expected })
        };
        if !(self.step_mm > 0.0 && self.step_mm.is_finite()) {
            return bad("step_mm", self.step_mm, "a depth step in (0, inf) mm");
        }
        if !(self.penalty_n_per_mm > 0.0 && self.penalty_n_per_mm.is_finite()) {
            return bad("penalty_n_per_mm", self.penalty_n_per_mm, "a spring stiffness in (0, inf) N/mm");
        }
        let mut last = 0.0;
        for &d in &self.depths_mm {
            if !(d > last && d.is_finite()) {
                return bad("depths_mm", d, "increasing depths above 0 mm");
            }
            last = d;
        }
        Ok(())
    }

    /// Presses `dome` with the given kinematics and returns the state at each reported depth;
    /// `progress` is told each depth solved (mm) and the Newton iterations it took.
    pub fn run(&self, dome: &Dome, kinematics: Kinematics, progress: impl Fn(f64, usize)) -> Result<Vec<PressState>> {
        self.validate()?;
        let stiffness = &dome.stiffness;
        let held = stiffness.held();
        let mesh = &dome.mesh;
        let r = dome.spec.outer_radius_mm;
        let contact: Vec<usize> = dome.outer_nodes(90.0);
        let (skin, gel) = (dome.spec.skin, dome.spec.gel);
        let material = move |region: Region| match region {
            Region::Skin => skin,
            Region::Gel => gel,
        };
        let mut u = vec![0.0; stiffness.size()];
        let mut depth = 0.0;
        let mut out = Vec::new();
        for &target in &self.depths_mm {
            let (mut iterations, mut linear_steps) = (0, 0);
            let mut halvings: u32 = 0;
            while depth < target {
                let next = (depth + self.step_mm * 0.5f64.powi(halvings as i32)).min(target);
                let mut trial = u.clone();
                match self.newton(dome, kinematics, &held, &contact, &material, next, &mut trial, &mut linear_steps) {
                    Ok(n) => {
                        (u, depth, iterations) = (trial, next, n);
                        halvings = halvings.saturating_sub(1);
                        progress(depth, n);
                    }
                    Err(FemError::NoConvergence { .. }) if halvings < MAX_HALVINGS => halvings += 1,
                    Err(e) => return Err(e),
                }
            }
            let displacement = stiffness.expand(&u);
            let plane = r - depth;
            let (mut force_n, mut penetration_mm) = (0.0, 0.0f64);
            for &n in &contact {
                let gap = mesh.nodes[n][2] + displacement[n][2] - plane;
                if gap > 0.0 {
                    force_n += self.penalty_n_per_mm * gap;
                    penetration_mm = penetration_mm.max(gap);
                }
            }
            out.push(PressState { depth_mm: depth, displacement, force_n, penetration_mm, iterations, linear_steps });
        }
        Ok(out)
    }

    /// Newton's method at one depth from `u` (free displacements, mm); the iterations taken.
    #[allow(clippy::too_many_arguments)]
    fn newton(
        &self,
        dome: &Dome,
        kinematics: Kinematics,
        held: &[bool],
        contact: &[usize],
        material: &(impl Fn(Region) -> Material + Sync),
        depth: f64,
        u: &mut [f64],
        linear_steps: &mut usize,
    ) -> Result<usize> {
        let stiffness = &dome.stiffness;
        let mesh = &dome.mesh;
        let plane = dome.spec.outer_radius_mm - depth;
        for iteration in 1..=MAX_ITERATIONS {
            let nodal = stiffness.expand(u);
            let (tangent, internal) = match kinematics {
                Kinematics::Linear => (stiffness.clone(), stiffness.apply(u)),
                Kinematics::NeoHookean => {
                    let states: Vec<NonlinearElement> = (0..mesh.elements.len())
                        .into_par_iter()
                        .map(|e| {
                            let ue = mesh.elements[e].map(|n| nodal[n]);
                            neo_hookean(&mesh.element_nodes(e), &ue, &material(mesh.regions[e]))
                        })
                        .collect();
                    let mut forces = vec![[0.0; 3]; mesh.nodes.len()];
                    for (e, s) in states.iter().enumerate() {
                        for (a, &n) in mesh.elements[e].iter().enumerate() {
                            for (i, f) in forces[n].iter_mut().enumerate() {
                                *f += s.force[3 * a + i];
                            }
                        }
                    }
                    let tangent = Stiffness::assemble_with(mesh, held, |e| states[e].matrices.clone())?;
                    (tangent, stiffness.load(&forces))
                }
            };
            let mut residual: Vec<f64> = internal.iter().map(|f| -f).collect();
            let mut springs = Vec::new();
            for &n in contact {
                let gap = mesh.nodes[n][2] + nodal[n][2] - plane;
                if gap > 0.0
                    && let Some(f) = stiffness.free_index(3 * n + 2)
                {
                    residual[f] -= self.penalty_n_per_mm * gap;
                    springs.push(f);
                }
            }
            let with_springs = |mut k: Stiffness| {
                for &f in &springs {
                    k.add_to_diagonal(f, self.penalty_n_per_mm);
                }
                k.factor()
            };
            // Where the tangent is not positive definite (an iterate past a stable state), the
            // step takes the linear stiffness instead: slower, but it does not diverge.
            let factor = match with_springs(tangent) {
                Ok(f) => f,
                Err(FemError::Factorisation(_)) if kinematics == Kinematics::NeoHookean => {
                    *linear_steps += 1;
                    with_springs(stiffness.clone())?
                }
                Err(e) => return Err(e),
            };
            factor.solve_in_place(&mut residual);
            let step = residual.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if !step.is_finite() {
                return Err(FemError::Factorisation(format!("Newton's step at depth {depth} mm is not finite")));
            }
            // No node moves farther than a depth step in one iteration.
            let scale = (self.step_mm / step).min(1.0);
            for (ui, du) in u.iter_mut().zip(&residual) {
                *ui += scale * du;
            }
            if step < STEP_TOLERANCE * dome.spec.outer_radius_mm {
                return Ok(iteration);
            }
        }
        Err(FemError::NoConvergence { depth_mm: depth, iterations: MAX_ITERATIONS })
    }
}

/// A pin tip's displacement (mm) under a large deformation: each point of its probe carries
/// the lever to the tip by the rotation of the deformation gradient there (`F = R U`, the
/// polar decomposition), `u(X) + (R - I) lever`; the probe's shares weigh the points. For a
/// small displacement it is [`PinProbe::displacement`].
pub fn large_displacement(probe: &PinProbe, mesh: &Mesh, u: &[[f64; 3]]) -> [f64; 3] {
    let mut out = Vector3::zeros();
    for term in &probe.terms {
        let x = term.nodes.map(|n| mesh.nodes[n]);
        let (_, g) = gradients(&x, term.barycentric);
        let n = shape(term.barycentric);
        let mut f = Matrix3::identity();
        let mut at = Vector3::zeros();
        for a in 0..10 {
            let ua = Vector3::from(u[term.nodes[a]]);
            f += ua * Vector3::from(g[a]).transpose();
            at += n[a] * ua;
        }
        let rotation = polar_rotation(&f);
        let lever = Vector3::from(term.lever_mm);
        out += term.weight * (at + rotation * lever - lever);
    }
    [out.x, out.y, out.z]
}

/// The rotation `R` of `F = R U` (`U` symmetric positive definite), from the singular value
/// decomposition `F = A S B^T`: `R = A B^T`.
fn polar_rotation(f: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = f.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(a), Some(bt)) => a * bt,
        _ => Matrix3::identity(),
    }
}
