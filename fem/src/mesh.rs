//! Tetrahedral meshes of balls, shells and domes, from a cubed lattice.
//!
//! # The map
//! A cube of `2N` lattice cells a side (centre at the origin) is cut into six tetrahedra per
//! cell (Kuhn's triangulation, conforming across cells) and mapped onto a ball: a lattice point
//! `a` in `[-1, 1]^3` lies on the cube shell `s = |a|_inf` in the direction `c = a / s`; the
//! equiangular cubed-sphere map `d_k = tan(pi c_k / 4)` sends `c` onto the unit sphere's
//! `d / |d|`, and the point lands at radius `r(s)` (piecewise linear through the shells'
//! radii): every shell is an exact sphere, the skin's faces concentric spheres of uniform
//! thickness. Midside nodes are mapped too (isoparametric elements on the curved
//! geometry). The plane `z = 0` maps onto itself (`c_z = 0` gives `d_z = 0`), so the upper
//! half of the lattice is a hemisphere on its base plane; a skirt extrudes that plane's nodes
//! down by a given depth (a cylinder below the hemisphere).

use std::collections::HashMap;
use std::f64::consts::FRAC_PI_4;

use crate::element::{EDGES, FACES, face_forces};

/// Which material an element is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// The skin shell.
    Skin,
    /// The gel filling it.
    Gel,
}

/// A mesh of ten-node tetrahedra (mm).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Node positions (mm).
    pub nodes: Vec<[f64; 3]>,
    /// Elements: four vertices then six midside nodes (`crate::element::EDGES`).
    pub elements: Vec<[usize; 10]>,
    /// Each element's material.
    pub regions: Vec<Region>,
    /// Nodes whose displacement is not their own but interpolated from other nodes' (a finer
    /// mesh's nodes on a coarser mesh's face), in node order.
    pub ties: Vec<Tie>,
}

/// A node that moves with the face of a coarser element it lies on: `u(node) = sum_k w_k
/// u(master_k)`, the face's six-node shape functions at the node (exact: a quadratic field on
/// a face is quadratic on each triangle of its subdivision, so the two meshes conform).
#[derive(Clone, Debug, PartialEq)]
pub struct Tie {
    /// The tied node.
    pub node: usize,
    /// The nodes it moves with and their weights (non-zero, summing to 1).
    pub masters: Vec<(usize, f64)>,
}

impl Mesh {
    /// The coordinates of an element's nodes.
    pub fn element_nodes(&self, e: usize) -> [[f64; 3]; 10] {
        self.elements[e].map(|n| self.nodes[n])
    }

    /// Faces on the boundary, as (element, local face index in `FACES`), in element order.
    pub fn boundary_faces(&self) -> Vec<(usize, usize)> {
        let mut count: HashMap<[usize; 3], u32> = HashMap::new();
        for el in &self.elements {
            for f in FACES {
                *count.entry(sorted_face(el, f)).or_default() += 1;
            }
        }
        let mut out = Vec::new();
        for (e, el) in self.elements.iter().enumerate() {
            for (k, f) in FACES.iter().enumerate() {
                if count.get(&sorted_face(el, *f)) == Some(&1) {
                    out.push((e, k));
                }
            }
        }
        out
    }

    /// The six nodes of an element's face: its vertices, then the midside nodes of their
    /// edges `ab`, `bc`, `ca`.
    pub fn face_nodes(&self, e: usize, face: usize) -> [usize; 6] {
        let el = &self.elements[e];
        let [a, b, c] = FACES[face];
        let mid = |i: usize, j: usize| el[crate::element::edge_node(i, j)];
        [el[a], el[b], el[c], mid(a, b), mid(b, c), mid(c, a)]
    }

    /// The boundary faces all of whose six nodes satisfy `on` (see [`Mesh::boundary_faces`]).
    pub fn faces_where(&self, on: impl Fn(&[f64; 3]) -> bool) -> Vec<(usize, usize)> {
        self.boundary_faces()
            .into_iter()
            .filter(|&(e, f)| self.face_nodes(e, f).iter().all(|&n| on(&self.nodes[n])))
            .collect()
    }

    /// Consistent nodal forces (N) of a pressure (MPa, pushing against the outward normal) on
    /// the given boundary faces, as a function of the point.
    pub fn pressure_forces(&self, faces: &[(usize, usize)], pressure: impl Fn([f64; 3]) -> f64) -> Vec<[f64; 3]> {
        self.traction_forces(faces, |p, n| {
            let q = pressure(p);
            [-q * n[0], -q * n[1], -q * n[2]]
        })
    }

    /// Consistent nodal forces (N) of a traction (MPa, force per unit area of the undeformed
    /// face) on the given boundary faces, as a function of the point and the unit outward
    /// normal.
    pub fn traction_forces(
        &self,
        faces: &[(usize, usize)],
        traction: impl Fn([f64; 3], [f64; 3]) -> [f64; 3],
    ) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; self.nodes.len()];
        for &(e, face) in faces {
            let nodes = self.face_nodes(e, face);
            let x = nodes.map(|n| self.nodes[n]);
            let fe = face_forces(&x, self.centroid(e), &traction);
            for (fk, &n) in fe.iter().zip(&nodes) {
                for c in 0..3 {
                    f[n][c] += fk[c];
                }
            }
        }
        f
    }

    /// The centroid of an element's vertices (mm).
    pub fn centroid(&self, e: usize) -> [f64; 3] {
        let mut c = [0.0; 3];
        for &n in &self.elements[e][..4] {
            for (ck, xk) in c.iter_mut().zip(self.nodes[n]) {
                *ck += 0.25 * xk;
            }
        }
        c
    }
}

fn sorted_face(el: &[usize; 10], f: [usize; 3]) -> [usize; 3] {
    let mut v = [el[f[0]], el[f[1]], el[f[2]]];
    v.sort_unstable();
    v
}

/// A ball, a shell or a part of one, cut from the cubed lattice (see the module's docs).
#[derive(Clone, Debug)]
pub struct CubedBall {
    /// Lattice cells from the centre to a face of the cube (`N`).
    pub cells: usize,
    /// Cells kept along each axis: cell `i` spans `[i, i + 1]`, `lo <= i < hi`, within `[-N, N)`.
    pub cell_range: [(i64, i64); 3],
    /// Innermost shell kept: cells between shells `m` and `m + 1` with `m` below it are left out
    /// (a hollow shell).
    pub min_shell: usize,
    /// Radius (mm) of each shell `0..=N`, increasing.
    pub radii: Vec<f64>,
    /// Cells from this shell out are skin, inner ones gel.
    pub skin_from: usize,
    /// Below `z = 0`: the base plane's nodes extruded down in this many layers by this depth
    /// (mm), instead of the lower half of the ball.
    pub skirt: Option<(usize, f64)>,
}

impl CubedBall {
    /// The mesh.
    pub fn mesh(&self) -> Mesh {
        self.kuhn().mesh
    }

    /// The mesh with the skin's cells (shells from `skin_from` out) and the gel's outer
    /// `gel_shells` shells divided `refinement` times. The gel within is this lattice's; the
    /// band outside it is cut from a lattice `refinement` times as fine, its gel shells divided
    /// through their depth too, as many element layers through the skin as here. The band's
    /// nodes on the coarse gel's outer faces that are not its own lie on those faces'
    /// quadratic map and are tied to them ([`Tie`]): the two meshes conform, in their geometry
    /// and in their displacements. `refinement` 1, a lattice without skin shells, or
    /// `gel_shells` reaching its centre give [`CubedBall::mesh`] (`DomeSpec::validate` refuses
    /// the last).
    pub fn mesh_with_refined_skin(&self, refinement: usize, gel_shells: usize) -> Mesh {
        if refinement <= 1 || self.skin_from >= self.cells || gel_shells >= self.skin_from {
            return self.mesh();
        }
        let k = refinement as i64;
        let c = self.skin_from - gel_shells;
        let gel = CubedBall {
            cells: c,
            cell_range: self.cell_range,
            min_shell: self.min_shell,
            radii: self.radii[..=c].to_vec(),
            skin_from: c,
            skirt: self.skirt,
        };
        let fine_shell = c * refinement;
        let mut radii: Vec<f64> = (0..fine_shell).map(|m| self.radii[c] * m as f64 / fine_shell as f64).collect();
        for j in fine_shell..=self.skin_from * refinement {
            let (m, frac) = (j / refinement, (j % refinement) as f64 / refinement as f64);
            let next = self.radii[(m + 1).min(self.cells)];
            radii.push(self.radii[m] + frac * (next - self.radii[m]));
        }
        radii.extend_from_slice(&self.radii[self.skin_from + 1..]);
        let skin = CubedBall {
            cells: self.skin_from * refinement + (self.cells - self.skin_from),
            cell_range: self.cell_range.map(|(lo, hi)| (lo * k, hi * k)),
            min_shell: fine_shell,
            radii,
            skin_from: self.skin_from * refinement,
            skirt: self.skirt.map(|(l, depth)| (l * refinement, depth)),
        };
        let coarse = gel.kuhn();
        let fine = skin.kuhn();
        let mut mesh = coarse.mesh.clone();
        // Each fine node's point of the doubled lattice (the index is a bijection).
        let mut points = vec![[0i64; 3]; fine.mesh.nodes.len()];
        for (p, &i) in &fine.index {
            points[i] = *p;
        }
        let interface = 2 * fine_shell as i64;
        let global: Vec<usize> = points
            .iter()
            .zip(&fine.mesh.nodes)
            .map(|(p, x)| {
                if skin.shell_of(*p) != interface {
                    mesh.nodes.push(*x);
                    return mesh.nodes.len() - 1;
                }
                if p.iter().all(|v| v % k == 0) {
                    let q = p.map(|v| v / k);
                    // The gel's outer faces hold a node at every point of the doubled lattice
                    // on them (vertices, edges' midpoints, the squares' diagonals' midpoints).
                    return *coarse.index.get(&q).expect("a gel node under every coinciding skin node");
                }
                let (at, masters) = gel.on_face(&coarse, p.map(|v| v as f64 / k as f64));
                mesh.nodes.push(at);
                let node = mesh.nodes.len() - 1;
                mesh.ties.push(Tie { node, masters });
                node
            })
            .collect();
        for (el, region) in fine.mesh.elements.iter().zip(&fine.mesh.regions) {
            mesh.elements.push(el.map(|n| global[n]));
            mesh.regions.push(*region);
        }
        mesh
    }

    /// The point `q` (doubled lattice, may be fractional) of the outer boundary, on the
    /// quadratic map of an element that holds it: its position (mm) and the element's nodes
    /// with their non-zero shape functions there.
    fn on_face(&self, kuhn: &Kuhn, q: [f64; 3]) -> ([f64; 3], Vec<(usize, f64)>) {
        let n = self.cells as i64;
        let zmin = self.skirt.map_or(-n, |(layers, _)| -(layers as i64));
        let bounds = [(-n, n - 1), (-n, n - 1), (zmin, n - 1)];
        let corner = [0, 1, 2].map(|a| ((q[a] / 2.0).floor() as i64).clamp(bounds[a].0, bounds[a].1));
        for v in kuhn_tets(corner) {
            let v0 = v[0].map(|c| c as f64);
            let m = nalgebra::Matrix3::from_fn(|r, c| (v[c + 1][r] - v[0][r]) as f64);
            let Some(inv) = m.try_inverse() else { continue };
            let x = inv * nalgebra::Vector3::new(q[0] - v0[0], q[1] - v0[1], q[2] - v0[2]);
            let l = [1.0 - x.x - x.y - x.z, x.x, x.y, x.z].map(|c| if c.abs() < 1e-12 { 0.0 } else { c });
            if l.iter().any(|&c| c < 0.0) {
                continue;
            }
            let nodes = ten_points(v).map(|p| kuhn.index[&p]);
            let w = crate::element::shape(l);
            let mut at = [0.0; 3];
            let mut masters = Vec::new();
            for (&node, &wk) in nodes.iter().zip(&w) {
                if wk != 0.0 {
                    for (c, x) in at.iter_mut().zip(kuhn.mesh.nodes[node]) {
                        *c += wk * x;
                    }
                    masters.push((node, wk));
                }
            }
            return (at, masters);
        }
        unreachable!("a lattice point on the boundary lies in one of its cell's six tetrahedra")
    }

    fn kuhn(&self) -> Kuhn {
        let n = self.cells as i64;
        let mut kuhn = Kuhn::default();
        let [(xlo, xhi), (ylo, yhi), (zlo, zhi)] = self.cell_range;
        // A skirt's layers are not the lattice's: they may outnumber its cells.
        let zmin = if self.skirt.is_some() { zlo } else { zlo.max(-n) };
        for k in zmin..zhi.min(n) {
            for j in ylo.max(-n)..yhi.min(n) {
                for i in xlo.max(-n)..xhi.min(n) {
                    let shell = (0..8)
                        .map(|b| self.shell_of([i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)]))
                        .min()
                        .unwrap_or(0);
                    if shell < self.min_shell as i64 {
                        continue;
                    }
                    let region = if shell >= self.skin_from as i64 { Region::Skin } else { Region::Gel };
                    kuhn.cell([i, j, k], region, |p| self.position(p));
                }
            }
        }
        kuhn
    }

    /// The shell (in cells) of a lattice vertex.
    fn shell_of(&self, p: [i64; 3]) -> i64 {
        let z = if self.skirt.is_some() && p[2] < 0 { 0 } else { p[2].abs() };
        p[0].abs().max(p[1].abs()).max(z)
    }

    /// The position (mm) of a point of the doubled lattice (vertices at even coordinates).
    pub fn position(&self, p: [i64; 3]) -> [f64; 3] {
        if let Some((layers, depth)) = self.skirt
            && p[2] < 0
        {
            let top = self.position([p[0], p[1], 0]);
            return [top[0], top[1], depth * p[2] as f64 / (2 * layers) as f64];
        }
        let n = self.cells as f64;
        let a = p.map(|v| v as f64 / (2.0 * n));
        let s = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if s == 0.0 {
            return [0.0; 3];
        }
        let c = a.map(|v| v / s);
        let d = c.map(|v| (FRAC_PI_4 * v).tan());
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let t = s * n;
        let m = (t.floor() as usize).min(self.cells - 1);
        let r = self.radii[m] + (self.radii[m + 1] - self.radii[m]) * (t - m as f64);
        d.map(|v| r * v / norm)
    }
}

/// A box of `cells` lattice cells spanning `[0, size_mm]` along each axis, all of one
/// region (a plate, for the bending tests).
#[derive(Clone, Debug)]
pub struct Block {
    /// Cells along x, y, z.
    pub cells: [usize; 3],
    /// Edge lengths (mm).
    pub size_mm: [f64; 3],
    /// The elements' region.
    pub region: Region,
}

impl Block {
    /// The mesh.
    pub fn mesh(&self) -> Mesh {
        let mut kuhn = Kuhn::default();
        let [nx, ny, nz] = self.cells.map(|c| c as i64);
        let position = |p: [i64; 3]| [0, 1, 2].map(|k| self.size_mm[k] * p[k] as f64 / (2 * self.cells[k]) as f64);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    kuhn.cell([i, j, k], self.region, position);
                }
            }
        }
        kuhn.mesh
    }
}

/// Kuhn's six tetrahedra per lattice cell, nodes shared through the doubled lattice's points
/// (vertices at even coordinates, midside nodes where one or more is odd). Each cell's
/// tetrahedra share the diagonal from its corner nearest the origin to the farthest one
/// (Kuhn's split reflected into the cell's octant), so the mesh keeps the lattice's mirror
/// symmetries about the coordinate planes and the swaps of axes; neighbours still agree on
/// every shared face (a face in a coordinate plane is split the same way from both sides).
/// With one diagonal for all cells, a centred press on the dome moved mirror pins apart by
/// 0.26 mm at 4 cells and 0.086 mm at 8 (test
/// `a_centred_tap_moves_the_dome_pins_as_mirrors` in sim/tests/dome.rs).
#[derive(Default)]
struct Kuhn {
    index: HashMap<[i64; 3], usize>,
    mesh: Mesh,
}

impl Kuhn {
    /// Adds the cell with lowest corner `corner`; `position` maps a doubled-lattice point (mm).
    fn cell(&mut self, corner: [i64; 3], region: Region, position: impl Fn([i64; 3]) -> [f64; 3]) {
        for v in kuhn_tets(corner) {
            let el = ten_points(v).map(|p| self.node(p, &position));
            self.mesh.elements.push(el);
            self.mesh.regions.push(region);
        }
    }

    fn node(&mut self, p: [i64; 3], position: impl Fn([i64; 3]) -> [f64; 3]) -> usize {
        let nodes = &mut self.mesh.nodes;
        *self.index.entry(p).or_insert_with(|| {
            nodes.push(position(p));
            nodes.len() - 1
        })
    }
}

/// The six tetrahedra of the cell with lowest corner `corner` (its vertices on the doubled
/// lattice, each positively oriented), Kuhn's split reflected into the cell's octant.
fn kuhn_tets(corner: [i64; 3]) -> [[[i64; 3]; 4]; 6] {
    let flip = corner.map(|c| c < 0);
    let reflections = flip.iter().filter(|&&f| f).count();
    PERMUTATIONS.map(|(perm, even)| {
        let mut v = [[0i64; 3]; 4];
        v[0] = [0, 1, 2].map(|a| 2 * (corner[a] + i64::from(flip[a])));
        for s in 0..3 {
            v[s + 1] = v[s];
            v[s + 1][perm[s]] += if flip[perm[s]] { -2 } else { 2 };
        }
        // Each reflection turns the tetrahedron inside out.
        if even == (reflections % 2 == 1) {
            v.swap(2, 3);
        }
        v
    })
}

/// A tetrahedron's ten nodes on the doubled lattice: its vertices, then its edges' midpoints
/// in [`EDGES`]' order.
fn ten_points(v: [[i64; 3]; 4]) -> [[i64; 3]; 10] {
    std::array::from_fn(|k| {
        if k < 4 {
            v[k]
        } else {
            let (a, b) = EDGES[k - 4];
            [0, 1, 2].map(|c| (v[a][c] + v[b][c]) / 2)
        }
    })
}

/// The six orders of the axes that make Kuhn's tetrahedra, and whether each is even.
const PERMUTATIONS: [([usize; 3], bool); 6] = [
    ([0, 1, 2], true),
    ([1, 2, 0], true),
    ([2, 0, 1], true),
    ([0, 2, 1], false),
    ([1, 0, 2], false),
    ([2, 1, 0], false),
];
