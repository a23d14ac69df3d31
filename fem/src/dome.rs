//! The TacTip's tip: a hemispherical skin shell of uniform thickness over the gel that fills
//! it, clamped with the gel on the rigid base (the camera's window and the mount), meshed from
//! its parameters, assembled and factorised once.
//!
//! Pins are stiff posts bonded to the skin's inner face: a pin's tip follows the rigid motion
//! of the skin under its base, `u_tip = u(X) + omega(X) x (X_t - X)` with the skin's rotation
//! `omega = curl u / 2`, taken as the mean of that rule at three depths through the skin under
//! the base ([`THROUGH_SKIN`]), each from the skin element that holds the point. With a skin
//! patch ([`PinSite::patch_radius_mm`]) the tip takes the mean of that rule over the base and
//! six points around it ([`PinProbe`]).

use nalgebra::Vector3;

use crate::element::{self, face_flux, shape};
use crate::error::{FemError, Result};
use crate::material::Material;
use crate::mesh::{CubedBall, Mesh, Region};
use crate::system::{Factor, Stiffness};

/// A pin: its base on the skin's inner face, its tip (mm, sensor frame) and the skin patch it
/// moves with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinSite {
    /// Base (mm).
    pub base: [f64; 3],
    /// Tip (mm).
    pub tip: [f64; 3],
    /// Radius (mm) of the skin patch the post is bonded to, as the sensor's
    /// `pins.patch_radius_mm`: 0, the skin's motion at the base alone; more, the mean of the
    /// base's and six points' on the inner face at that distance around it (the contact
    /// engine's rule, `sim/src/contact/pins/motion.rs`, `patch_points`). Each is read through
    /// the skin's thickness ([`THROUGH_SKIN`]).
    pub patch_radius_mm: f64,
}

impl PinSite {
    /// Where the skin's motion is read: the base, then with a patch six points around it on
    /// the inner sphere, 60 deg apart from the tangent direction `z x n` (`x` at the apex).
    fn patch_points(&self) -> Vec<Vector3<f64>> {
        let b = Vector3::from(self.base);
        let mut points = vec![b];
        if self.patch_radius_mm > 0.0 {
            let n = b.normalize();
            let e1 = Vector3::z().cross(&n).try_normalize(1e-12).unwrap_or_else(Vector3::x);
            let e2 = n.cross(&e1);
            for k in 0..6 {
                let (s, c) = (std::f64::consts::FRAC_PI_3 * k as f64).sin_cos();
                let p = b + (e1 * c + e2 * s) * self.patch_radius_mm;
                points.push(p.normalize() * b.norm());
            }
        }
        points
    }
}

/// Everything that shapes a dome's response.
#[derive(Clone, Debug, PartialEq)]
pub struct DomeSpec {
    /// Outer radius of the hemisphere (mm).
    pub outer_radius_mm: f64,
    /// Skin thickness (mm).
    pub skin_thickness_mm: f64,
    /// How far the base plane lies below the hemisphere's equator (mm); the skin continues as
    /// a cylinder down to it. 0: the base at the equator.
    pub skirt_mm: f64,
    /// The skin's material.
    pub skin: Material,
    /// The gel's material.
    pub gel: Material,
    /// Lattice cells from the centre to the surface (`N`): `2N` elements span 90 deg of the
    /// surface, `N - skin_layers` the gel's radius.
    pub cells: usize,
    /// Element layers through the skin.
    pub skin_layers: usize,
    /// How many times finer the skin's elements are than the gel's along the surface: the
    /// skin cut from a lattice that many times as fine, tied to the gel's outer faces
    /// ([`CubedBall::mesh_with_refined_skin`]); 1, the one lattice for both.
    pub skin_refinement: usize,
    /// With a refined skin: the gel's outer shells of the lattice refined with it (`0`: the
    /// skin alone), at most `cells - skin_layers - 2` (the coarse gel keeps two shells).
    pub refined_gel_shells: usize,
}

impl DomeSpec {
    /// Checks every field, naming it and its accepted range.
    pub fn validate(&self) -> Result<()> {
        let check = |field: &'static str, value: f64, ok: bool, expected: &'static str| {
            if ok { Ok(()) } else { Err(FemError::Parameter { field, value, expected }) }
        };
        let r = self.outer_radius_mm;
        check("outer_radius_mm", r, r > 0.0 && r <= 1000.0, "a radius in (0, 1000] mm")?;
        let t = self.skin_thickness_mm;
        check("skin_thickness_mm", t, t > 0.0 && t < 0.5 * r, "a thickness in (0, outer_radius_mm / 2) mm")?;
        let s = self.skirt_mm;
        check("skirt_mm", s, (0.0..=r).contains(&s), "a depth in [0, outer_radius_mm] mm")?;
        check("cells", self.cells as f64, (3..=64).contains(&self.cells), "an integer in [3, 64]")?;
        // The gel needs two of the lattice's shells: with one, the cube at the centre maps its
        // corners onto the skin's inner sphere and the elements there turn inside out (3 cells
        // with 2 skin layers: element 48's Jacobian -2.2).
        check(
            "skin_layers",
            self.skin_layers as f64,
            self.skin_layers >= 1 && self.skin_layers + 2 <= self.cells,
            "an integer in [1, cells - 2]: the gel needs two of the lattice's shells",
        )?;
        check(
            "skin_refinement",
            self.skin_refinement as f64,
            (1..=MAX_SKIN_REFINEMENT).contains(&self.skin_refinement),
            "an integer in [1, 4]",
        )?;
        check(
            "refined_gel_shells",
            self.refined_gel_shells as f64,
            self.refined_gel_shells.saturating_add(self.skin_layers + 2) <= self.cells,
            "an integer in [0, cells - skin_layers - 2]: the coarse gel keeps two of the lattice's shells",
        )?;
        check(
            "refined_gel_shells",
            self.refined_gel_shells as f64,
            self.refined_gel_shells == 0 || self.skin_refinement > 1,
            "0 unless skin_refinement is above 1: the gel's shells are refined with the skin",
        )?;
        Material::new(self.skin.youngs_modulus_mpa, self.skin.poisson)?;
        Material::new(self.gel.youngs_modulus_mpa, self.gel.poisson)?;
        Ok(())
    }

    /// The mesh: the lattice's, its skin and [`DomeSpec::refined_gel_shells`] of the gel
    /// refined [`DomeSpec::skin_refinement`] times.
    pub fn mesh(&self) -> Mesh {
        self.lattice().mesh_with_refined_skin(self.skin_refinement, self.refined_gel_shells)
    }

    /// The lattice and its map.
    pub fn lattice(&self) -> CubedBall {
        let n = self.cells;
        let gel_shells = n - self.skin_layers;
        let inner = self.outer_radius_mm - self.skin_thickness_mm;
        let mut radii: Vec<f64> = (0..=gel_shells).map(|m| inner * m as f64 / gel_shells as f64).collect();
        for m in 1..=self.skin_layers {
            radii.push(inner + self.skin_thickness_mm * m as f64 / self.skin_layers as f64);
        }
        let skirt = (self.skirt_mm > 0.0).then(|| {
            let cell = inner / gel_shells as f64;
            ((self.skirt_mm / cell).round().max(1.0) as usize, self.skirt_mm)
        });
        let ni = n as i64;
        let zlo = skirt.map_or(0, |(layers, _)| -(layers as i64));
        CubedBall {
            cells: n,
            cell_range: [(-ni, ni), (-ni, ni), (zlo, ni)],
            min_shell: 0,
            radii,
            skin_from: gel_shells,
            skirt,
        }
    }

    /// The base plane's height (mm, sensor frame).
    pub fn base_z_mm(&self) -> f64 {
        -self.skirt_mm
    }
}

/// Most [`DomeSpec::skin_refinement`].
pub const MAX_SKIN_REFINEMENT: usize = 4;

/// A meshed, assembled and factorised dome.
pub struct Dome {
    /// What it was built from.
    pub spec: DomeSpec,
    /// The mesh.
    pub mesh: Mesh,
    /// Its stiffness, the base's nodes held.
    pub stiffness: Stiffness,
    /// The stiffness's Cholesky factor.
    pub factor: Factor,
    /// The outer sphere's boundary faces, as (element, local face).
    outer_faces: Vec<(usize, usize)>,
}

impl Dome {
    /// Meshes, assembles and factorises a (checked) dome.
    pub fn build(spec: &DomeSpec) -> Result<Self> {
        spec.validate()?;
        let mesh = spec.mesh();
        let base = spec.base_z_mm();
        let tol = 1e-9 * spec.outer_radius_mm;
        let held: Vec<bool> = mesh.nodes.iter().flat_map(|x| [(x[2] - base).abs() < tol; 3]).collect();
        let (skin, gel) = (spec.skin, spec.gel);
        let stiffness = Stiffness::assemble(
            &mesh,
            |r| match r {
                Region::Skin => skin,
                Region::Gel => gel,
            },
            &held,
        )?;
        let factor = stiffness.factor()?;
        let outer_faces = mesh.faces_where(|x| on_outer_sphere(spec, x));
        Ok(Self { spec: spec.clone(), mesh, stiffness, factor, outer_faces })
    }

    /// Nodes of the outer surface within `max_polar_deg` of the apex, in node order.
    pub fn outer_nodes(&self, max_polar_deg: f64) -> Vec<usize> {
        let cos_max = max_polar_deg.to_radians().cos();
        let r = self.spec.outer_radius_mm;
        (0..self.mesh.nodes.len())
            .filter(|&n| {
                let x = &self.mesh.nodes[n];
                on_outer_sphere(&self.spec, x) && x[2] >= cos_max * r - 1e-9 * r
            })
            .collect()
    }

    /// The outer sphere's boundary faces, as (element, local face).
    pub fn outer_faces(&self) -> &[(usize, usize)] {
        &self.outer_faces
    }

    /// Consistent nodal forces (N) of a pressure (MPa, pushing into the skin) on the outer
    /// sphere, as a function of the point.
    pub fn pressure_forces(&self, pressure: impl Fn([f64; 3]) -> f64) -> Vec<[f64; 3]> {
        self.mesh.pressure_forces(&self.outer_faces, pressure)
    }

    /// Consistent nodal forces (N) of a traction (MPa per unit area of the outer sphere) as a
    /// function of the point and the unit outward normal.
    pub fn traction_forces(&self, traction: impl Fn([f64; 3], [f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
        self.mesh.traction_forces(&self.outer_faces, traction)
    }

    /// Nodal displacements (mm) under nodal forces (N), one load case.
    pub fn solve(&self, forces: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut rhs = self.stiffness.load(forces);
        self.factor.solve_in_place(&mut rhs);
        self.stiffness.expand(&rhs)
    }

    /// The gel's volume change (mm^3) under nodal displacements `u`: the sum of its elements'.
    pub fn gel_volume_change(&self, u: &[[f64; 3]]) -> f64 {
        (0..self.mesh.elements.len())
            .filter(|&e| self.mesh.regions[e] == Region::Gel)
            .map(|e| self.stiffness.volume_change(&self.mesh, e, u))
            .sum()
    }

    /// The volume (mm^3) the outer sphere sweeps inwards where `inside` holds of a face's
    /// centroid: `-int u . n dA` over those faces.
    pub fn swept_volume(&self, u: &[[f64; 3]], inside: impl Fn([f64; 3]) -> bool) -> f64 {
        let mut v = 0.0;
        for &(e, face) in &self.outer_faces {
            let nodes = self.mesh.face_nodes(e, face);
            let x = nodes.map(|n| self.mesh.nodes[n]);
            let c = [0, 1, 2].map(|k| (x[0][k] + x[1][k] + x[2][k]) / 3.0);
            if inside(c) {
                v -= face_flux(&x, &nodes.map(|n| u[n]), self.mesh.centroid(e));
            }
        }
        v
    }

    /// The probe of a pin with its base on the skin's inner face and its tip (mm, sensor frame).
    pub fn pin_probe(&self, pin: usize, site: PinSite) -> Result<PinProbe> {
        self.probe_among(&self.skin_boxes(), pin, site)
    }

    /// The probes of many pins, in order (the skin elements' bounds found once for all).
    pub fn pin_probes(&self, pins: &[PinSite]) -> Result<Vec<PinProbe>> {
        let boxes = self.skin_boxes();
        pins.iter().enumerate().map(|(i, &site)| self.probe_among(&boxes, i, site)).collect()
    }

    /// Every skin element with the bounds of its nodes (mm).
    fn skin_boxes(&self) -> Vec<(usize, [[f64; 3]; 2])> {
        (0..self.mesh.elements.len())
            .filter(|&e| self.mesh.regions[e] == Region::Skin)
            .map(|e| {
                let x = self.mesh.element_nodes(e);
                let lo = [0, 1, 2].map(|k| x.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min));
                let hi = [0, 1, 2].map(|k| x.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max));
                (e, [lo, hi])
            })
            .collect()
    }

    /// Each point of the pin's patch is read at the depths [`THROUGH_SKIN`] within the skin,
    /// each a term of equal share. A point is looked up a little further out if no skin
    /// element holds it (the curved elements' faces leave the sphere between their nodes, by up
    /// to about `h^3 / R^2`): pushed by 0.1%, 1%, 10%, then 30% of the skin's thickness.
    fn probe_among(&self, boxes: &[(usize, [[f64; 3]; 2])], pin: usize, site: PinSite) -> Result<PinProbe> {
        let t = self.spec.skin_thickness_mm;
        let points: Vec<Vector3<f64>> =
            site.patch_points().into_iter().flat_map(|b| THROUGH_SKIN.map(|f| b + b.normalize() * (f * t))).collect();
        let weight = 1.0 / points.len() as f64;
        let mut terms = Vec::with_capacity(points.len());
        for b in points {
            let (holding, at) = self.skin_elements_at(boxes, b).ok_or({
                let [x, y, z] = site.base;
                FemError::PinOutside { pin, x, y, z }
            })?;
            // The point's rigid motion carried to the tip: exact for a rigid motion of the dome
            // (test `pins_follow_a_rigid_motion_of_the_dome_exactly`).
            let lever = Vector3::from(site.tip) - at;
            let share = weight / holding.len() as f64;
            for (e, l) in holding {
                terms.push(ProbeTerm::new(self.mesh.elements[e], &self.mesh.element_nodes(e), l, lever, share));
            }
        }
        Ok(PinProbe { terms })
    }

    /// The skin elements holding a point of the skin (pushed outwards as needed), with
    /// the point's barycentric coordinates in each, and the point (mm). A point on a face,
    /// edge or vertex lies in every element that shares it: the displacement is the same in
    /// each, the rotation (a gradient) is not, and the probe takes their mean, so that the
    /// pins keep the mesh's symmetries.
    fn skin_elements_at(
        &self,
        boxes: &[(usize, [[f64; 3]; 2])],
        b: Vector3<f64>,
    ) -> Option<(Vec<Holding>, Vector3<f64>)> {
        for push in [1e-3, 1e-2, 0.1, 0.3] {
            let at = b + b.normalize() * push * self.spec.skin_thickness_mm;
            let p = [at.x, at.y, at.z];
            let holding: Vec<Holding> = boxes
                .iter()
                .filter(|(_, [lo, hi])| (0..3).all(|k| p[k] >= lo[k] - 1e-6 && p[k] <= hi[k] + 1e-6))
                .filter_map(|&(e, _)| {
                    let l = element::locate(&self.mesh.element_nodes(e), p)?;
                    l.iter().all(|&v| v >= -1e-9).then_some((e, l))
                })
                .collect();
            if !holding.is_empty() {
                return Some((holding, at));
            }
        }
        None
    }
}

/// Where through the skin a pin reads its motion, as fractions of the skin's thickness out
/// from its inner face: the midpoints of three equal slices. The post turns with the skin's
/// mean rotation through its thickness (a thin shell's director), not with the gradient at
/// one point of its inner face: that gradient, linear in each element and discontinuous
/// between elements, made the pins depend on the mesh. On the convergence paths the pins of 8
/// and 10 cells differed by up to 0.041-0.048 mm read at the inner face, 0.022-0.027 mm read
/// through the skin (the contact engine's far field on a patch of 1.5 of each mesh's faces);
/// one to three element layers through the skin moved a pin 10 deg off the apex by up to
/// 0.048 mm at the inner face, 0.017 mm through the skin
/// (`docs/experiments/fem-dome.md`). The displacement read at a depth is carried to the tip
/// with the rotation there, so a rigid motion still moves the tip exactly.
pub const THROUGH_SKIN: [f64; 3] = [1.0 / 6.0, 0.5, 5.0 / 6.0];

/// An element holding a point, and the point's barycentric coordinates in it.
type Holding = (usize, [f64; 4]);

/// Whether a point lies on the outer sphere (not the skirt).
fn on_outer_sphere(spec: &DomeSpec, x: &[f64; 3]) -> bool {
    let r = spec.outer_radius_mm;
    let norm = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    (norm - r).abs() < 1e-9 * r && x[2] >= -1e-9 * r
}

/// A pin tip's displacement as a linear function of nodal displacements: one term per point
/// of its skin patch.
#[derive(Clone, Debug, PartialEq)]
pub struct PinProbe {
    /// The patch's points' terms.
    pub terms: Vec<ProbeTerm>,
}

/// One point's share of a pin tip's motion: `weight (u(X) + omega(X) x lever)` for the tip's
/// displacement, `weight omega(X)` for the post's rotation.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeTerm {
    /// The nodes of the skin element holding the point.
    pub nodes: [usize; 10],
    /// `motion[i] += sum_k coefficients[i][k] u_e[k]`, `u_e[3 a + m]` node `a`'s direction
    /// `m`; rows 0-2 the tip's displacement (mm per mm), rows 3-5 the rotation (rad per mm).
    pub coefficients: [[f64; 30]; MOTION],
    /// The point's barycentric coordinates in the element.
    pub barycentric: [f64; 4],
    /// From the point to the pin's tip (mm).
    pub lever_mm: [f64; 3],
    /// The term's share of the tip's motion (the shares of a probe sum to 1).
    pub weight: f64,
}

/// Rows of a pin's motion: the tip's displacement (3), then the post's rotation (3).
pub const MOTION: usize = 6;

impl ProbeTerm {
    fn new(nodes: [usize; 10], x: &[[f64; 3]; 10], l: [f64; 4], lever: Vector3<f64>, weight: f64) -> Self {
        let n = shape(l);
        let (_, g) = element::gradients(x, l);
        let mut coefficients = [[0.0; 30]; MOTION];
        for a in 0..10 {
            for m in 0..3 {
                // u = N_a e_m: grad u [i][j] = delta_im d_j N_a.
                let mut grad = [[0.0; 3]; 3];
                grad[m] = g[a];
                let omega = Vector3::new(
                    0.5 * (grad[2][1] - grad[1][2]),
                    0.5 * (grad[0][2] - grad[2][0]),
                    0.5 * (grad[1][0] - grad[0][1]),
                );
                let mut u = omega.cross(&lever);
                u[m] += n[a];
                for i in 0..3 {
                    coefficients[i][3 * a + m] = weight * u[i];
                    coefficients[3 + i][3 * a + m] = weight * omega[i];
                }
            }
        }
        Self { nodes, coefficients, barycentric: l, lever_mm: [lever.x, lever.y, lever.z], weight }
    }
}

impl PinProbe {
    /// The tip's displacement (mm) and the post's rotation (rad) under nodal displacements,
    /// given per node and direction.
    pub fn motion_of(&self, u: impl Fn(usize, usize) -> f64) -> [f64; MOTION] {
        let mut out = [0.0; MOTION];
        for term in &self.terms {
            for (a, &node) in term.nodes.iter().enumerate() {
                for m in 0..3 {
                    let v = u(node, m);
                    for (o, row) in out.iter_mut().zip(&term.coefficients) {
                        *o += row[3 * a + m] * v;
                    }
                }
            }
        }
        out
    }

    /// The tip's displacement (mm) under nodal displacements, given per node and direction.
    pub fn displacement_of(&self, u: impl Fn(usize, usize) -> f64) -> [f64; 3] {
        let m = self.motion_of(u);
        [m[0], m[1], m[2]]
    }

    /// The tip's displacement (mm) under nodal displacements `u`.
    pub fn displacement(&self, u: &[[f64; 3]]) -> [f64; 3] {
        self.displacement_of(|node, m| u[node][m])
    }
}
