//! Triangle meshes of stimuli: OBJ input (tobj) and output, prism extrusion of a planar
//! outline (spade's constrained Delaunay triangulation for the caps), and validation.

use std::collections::HashMap;
use std::io::BufReader;

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use crate::error::{Result, SimError};

/// An indexed triangle mesh (mm), triangles counter-clockwise seen from outside.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Vertex positions (mm).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Parses OBJ text. Polygons are fanned into triangles; every object of the file is
    /// merged. `source_name` is used in errors. The result is validated as a closed solid
    /// ([`Mesh::validate_solid`]).
    pub fn from_obj_str(text: &str, source_name: &str) -> Result<Self> {
        let options = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
        let (models, _materials) =
            tobj::load_obj_buf(&mut BufReader::new(text.as_bytes()), &options, |_| Ok(Default::default()))
                .map_err(|e| SimError::mesh(source_name, format!("OBJ parse error: {e}")))?;
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for m in &models {
            let base = vertices.len() as u32;
            let pos = &m.mesh.positions;
            if pos.len() % 3 != 0 {
                return Err(SimError::mesh(source_name, format!("object `{}` has a truncated vertex list", m.name)));
            }
            vertices.extend(pos.chunks_exact(3).map(|c| [c[0] as f64, c[1] as f64, c[2] as f64]));
            if m.mesh.indices.len() % 3 != 0 {
                return Err(SimError::mesh(
                    source_name,
                    format!("object `{}`: faces could not be triangulated", m.name),
                ));
            }
            for t in m.mesh.indices.chunks_exact(3) {
                triangles.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
        let mesh = Mesh { vertices, triangles }.welded();
        mesh.validate_solid(source_name)?;
        Ok(mesh)
    }

    /// Reads an OBJ file ([`Mesh::from_obj_str`]).
    pub fn load_obj(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SimError::io(path, "read", e))?;
        Self::from_obj_str(&text, &path.display().to_string())
    }

    /// OBJ text of the mesh, coordinates with 4 decimals (0.1 um).
    pub fn to_obj(&self, comment: &str) -> String {
        let mut s = String::new();
        for line in comment.lines() {
            s.push_str(&format!("# {line}\n"));
        }
        for v in &self.vertices {
            s.push_str(&format!("v {:.4} {:.4} {:.4}\n", v[0], v[1], v[2]));
        }
        for t in &self.triangles {
            s.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
        }
        s
    }

    /// Merges vertices with identical coordinates (OBJ exporters often duplicate them per
    /// face) so that edge connectivity can be checked.
    pub fn welded(self) -> Self {
        let mut map: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut remap = Vec::with_capacity(self.vertices.len());
        for v in &self.vertices {
            // -0.0 and 0.0 weld together.
            let key = v.map(|c| (c + 0.0).to_bits());
            let id = *map.entry(key).or_insert_with(|| {
                vertices.push(*v);
                vertices.len() as u32 - 1
            });
            remap.push(id);
        }
        let triangles =
            self.triangles.iter().map(|t| t.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX))).collect();
        Mesh { vertices, triangles }
    }

    /// Checks the mesh is a usable solid: non-empty, finite vertices, indices in range, no
    /// degenerate triangles, and closed and consistently oriented (every edge shared by
    /// exactly two triangles, traversed once in each direction), enclosing positive volume.
    pub fn validate_solid(&self, source_name: &str) -> Result<()> {
        if self.triangles.is_empty() {
            return Err(SimError::mesh(source_name, "contains no triangles"));
        }
        if let Some((i, v)) = self.vertices.iter().enumerate().find(|(_, v)| v.iter().any(|c| !c.is_finite())) {
            return Err(SimError::mesh(source_name, format!("vertex {} is not finite: {v:?}", i + 1)));
        }
        let n = self.vertices.len() as u32;
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for (ti, t) in self.triangles.iter().enumerate() {
            if t.iter().any(|&i| i >= n) {
                return Err(SimError::mesh(source_name, format!("face {} refers to a missing vertex", ti + 1)));
            }
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let cross = cross(sub(b, a), sub(c, a));
            if dot(cross, cross) == 0.0 {
                return Err(SimError::mesh(source_name, format!("face {} is degenerate (zero area)", ti + 1)));
            }
            for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((p, q)).or_insert(0) += 1;
            }
        }
        for (&(p, q), &count) in &edges {
            let back = edges.get(&(q, p)).copied().unwrap_or(0);
            if count > 1 || back > 1 {
                return Err(SimError::mesh(
                    source_name,
                    format!(
                        "non-manifold: edge between vertices {} and {} is used by more than two faces, or twice in one direction (flipped face?)",
                        p + 1,
                        q + 1
                    ),
                ));
            }
            if back == 0 {
                return Err(SimError::mesh(
                    source_name,
                    format!(
                        "open mesh: edge between vertices {} and {} borders only one face; stimuli must be closed solids",
                        p + 1,
                        q + 1
                    ),
                ));
            }
        }
        // Before the volume's sign: a surface that crosses itself (an outline that crosses
        // itself, extruded) encloses lobes of both orientations, and was told to "flip the
        // winding", as was its flipped copy (issue 88).
        if let Some((a, b)) = self.crossing_faces() {
            return Err(SimError::mesh(
                source_name,
                format!(
                    "the surface crosses itself: faces {} and {} intersect (an outline that crosses itself, extruded, \
                     does so); a stimulus must be a closed solid whose faces meet only at shared edges and vertices",
                    a + 1,
                    b + 1
                ),
            ));
        }
        let (lo, hi) = self.bounds();
        let box_volume = (0..3).map(|k| hi[k] - lo[k]).product::<f64>();
        if self.volume().abs() <= 1e-9 * box_volume {
            return Err(SimError::mesh(
                source_name,
                "encloses no volume: its parts cancel (a surface that crosses itself through its edges, such as a \
                 symmetric bow tie extruded) or it is flat",
            ));
        }
        if self.volume() < 0.0 {
            return Err(SimError::mesh(source_name, "faces are oriented inwards (negative volume): flip the winding"));
        }
        Ok(())
    }

    /// The first pair of faces (indices, the lower first) that share no vertex yet cross,
    /// `None` where the surface does not cross itself. Candidates from parry's BVH over the
    /// faces' boxes (f32, loosened by [`CROSSING_MARGIN_MM`]); each pair then tested in f64
    /// ([`faces_cross`]). parry's own triangle test (GJK in f32, with its tolerance) took the
    /// built-in `foil`'s trailing edge, two side faces 2 um apart at a 0.02 deg tip, for a
    /// crossing. Faces sharing a vertex or an edge are not tested: they touch by construction.
    fn crossing_faces(&self) -> Option<(usize, usize)> {
        use rapier3d::math::Vector;
        use rapier3d::parry::bounding_volume::BoundingVolume;
        use rapier3d::parry::shape::TriMesh;
        let vertices: Vec<Vector> =
            self.vertices.iter().map(|v| Vector::new(v[0] as f32, v[1] as f32, v[2] as f32)).collect();
        // The manifold checks before this one leave faces TriMesh accepts; a mesh it refuses
        // is left to them.
        let mesh = TriMesh::new(vertices, self.triangles.clone()).ok()?;
        let corners = |k: usize| self.triangles[k].map(|v| self.vertices[v as usize]);
        for (i, t) in self.triangles.iter().enumerate() {
            let aabb = mesh.triangle(i as u32).local_aabb().loosened(CROSSING_MARGIN_MM);
            for j in mesh.bvh().intersect_aabb(&aabb) {
                let j = j as usize;
                if j > i && !self.triangles[j].iter().any(|v| t.contains(v)) && faces_cross(corners(i), corners(j)) {
                    return Some((i, j));
                }
            }
        }
        None
    }

    /// Enclosed volume (mm^3), positive for outward-facing triangles.
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Axis-aligned bounds `(min, max)` (mm).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }

    /// Extrudes a counter-clockwise simple polygon (mm) from `z = 0` to `z = height_mm`.
    pub fn prism(outline: &[[f64; 2]], height_mm: f64, source_name: &str) -> Result<Self> {
        let n = outline.len();
        if n < 3 {
            return Err(SimError::mesh(source_name, "outline needs at least 3 vertices"));
        }
        let points: Vec<Point2<f64>> = outline.iter().map(|p| Point2::new(p[0], p[1])).collect();
        let edges: Vec<[usize; 2]> = (0..n).map(|i| [i, (i + 1) % n]).collect();
        let cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::bulk_load_cdt(points, edges)
            .map_err(|e| SimError::mesh(source_name, format!("outline cannot be triangulated: {e:?}")))?;
        if cdt.num_vertices() != n {
            return Err(SimError::mesh(source_name, "outline has duplicate or self-intersecting vertices"));
        }
        // Faces inside the outline: flood fill from the face left of each (counter-clockwise)
        // outline edge, never crossing an outline edge. Robust for slivers, unlike point tests.
        let mut inside = vec![false; cdt.num_all_faces()];
        let mut stack = Vec::new();
        for i in 0..n {
            let (a, b) = (FixedVertexHandle::from_index(i), FixedVertexHandle::from_index((i + 1) % n));
            let edge = cdt.get_edge_from_neighbors(a, b).ok_or_else(|| {
                SimError::mesh(
                    source_name,
                    format!("outline edge {i} is missing from the triangulation (self-intersecting outline?)"),
                )
            })?;
            if let Some(face) = edge.face().as_inner() {
                stack.push(face.fix());
            }
        }
        while let Some(f) = stack.pop() {
            if std::mem::replace(&mut inside[f.index()], true) {
                continue;
            }
            for e in cdt.face(f).adjacent_edges() {
                if e.is_constraint_edge() {
                    continue;
                }
                if let Some(next) = e.rev().face().as_inner()
                    && !inside[next.fix().index()]
                {
                    stack.push(next.fix());
                }
            }
        }
        let cap: Vec<[u32; 3]> = cdt
            .inner_faces()
            .filter(|f| inside[f.fix().index()])
            .map(|f| f.vertices().map(|v| v.fix().index() as u32))
            .collect();
        let nn = n as u32;
        let mut vertices: Vec<[f64; 3]> = outline.iter().map(|p| [p[0], p[1], 0.0]).collect();
        vertices.extend(outline.iter().map(|p| [p[0], p[1], height_mm]));
        let mut triangles = Vec::with_capacity(2 * cap.len() + 2 * n);
        for &[a, b, c] in &cap {
            // spade's faces are counter-clockwise: the top faces +z as is, the bottom reversed.
            triangles.push([a + nn, b + nn, c + nn]);
            triangles.push([a, c, b]);
        }
        for i in 0..nn {
            let j = (i + 1) % nn;
            triangles.push([i, j, j + nn]);
            triangles.push([i, j + nn, i + nn]);
        }
        let mesh = Mesh { vertices, triangles };
        mesh.validate_solid(source_name)?;
        Ok(mesh)
    }
}

/// How far (mm) the f32 boxes of [`Mesh::crossing_faces`] are loosened, well beyond f32's
/// rounding at a stimulus's size (1e-5 mm at 100 mm).
const CROSSING_MARGIN_MM: f32 = 1e-3;

/// Whether two triangles sharing no vertex cross: an edge of one passes through the other's
/// interior (both ends strictly on opposite sides of its plane, and the edge strictly inside
/// its three edges' planes), by the signs of the orientation determinants in f64. Two
/// crossing triangles always have such an edge (the segment they share ends on two edges);
/// triangles in one plane, or touching without crossing, do not count.
fn faces_cross(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> bool {
    // The signed volume of (p, q, r, s), six times the tetrahedron's.
    let orient = |p: [f64; 3], q: [f64; 3], r: [f64; 3], s: [f64; 3]| dot(sub(p, s), cross(sub(q, s), sub(r, s)));
    let scale = a.iter().chain(&b).flat_map(|v| v.iter()).fold(1.0f64, |m, c| m.max(c.abs()));
    let eps = 1e-12 * scale.powi(3);
    let strictly_one_side = |d: &[f64; 3]| d.iter().all(|&v| v > eps) || d.iter().all(|&v| v < -eps);
    // Each triangle's corners against the other's plane: all on one side, no crossing.
    let da = a.map(|p| orient(b[0], b[1], b[2], p));
    let db = b.map(|p| orient(a[0], a[1], a[2], p));
    if strictly_one_side(&da) || strictly_one_side(&db) {
        return false;
    }
    // Edge k of `t` (corners k, k + 1, their plane sides `d`) through `u`'s interior.
    let pierces = |t: &[[f64; 3]; 3], d: &[f64; 3], u: &[[f64; 3]; 3], k: usize| {
        let (p, q, (dp, dq)) = (t[k], t[(k + 1) % 3], (d[k], d[(k + 1) % 3]));
        if !((dp > eps && dq < -eps) || (dp < -eps && dq > eps)) {
            return false;
        }
        strictly_one_side(&[orient(p, q, u[0], u[1]), orient(p, q, u[1], u[2]), orient(p, q, u[2], u[0])])
    };
    (0..3).any(|k| pierces(&a, &da, &b, k) || pierces(&b, &db, &a, k))
}

/// Winding number of a closed polygon around `p`.
pub fn winding_number(poly: &[[f64; 2]], p: [f64; 2]) -> i32 {
    let mut w = 0;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let side = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
        if a[1] <= p[1] {
            if b[1] > p[1] && side > 0.0 {
                w += 1;
            }
        } else if b[1] <= p[1] && side < 0.0 {
            w -= 1;
        }
    }
    w
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

    #[test]
    fn quad_cube_is_fanned_and_closed() {
        let m = Mesh::from_obj_str(CUBE, "cube.obj").expect("valid cube");
        assert_eq!(m.triangles.len(), 12);
        assert!((m.volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_meshes_are_clear_errors() {
        let cases = [
            ("", "no triangles"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "open mesh"),
            ("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "not finite"),
            ("v 0 0 0\nv 1 0 0\nf 1 2 7\n", "cube.obj"),
            // A two-vertex "face" cannot be fanned into triangles.
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "cube.obj"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "cube.obj"),
            (&CUBE.replace("f 1 4 3 2", "f 1 2 3 4"), "non-manifold"),
        ];
        for (text, expect) in cases {
            let e = Mesh::from_obj_str(text, "cube.obj").expect_err(expect);
            let msg = e.to_string();
            assert!(msg.contains("cube.obj") && msg.contains(expect), "{expect}: {msg}");
        }
        let inside_out = CUBE
            .lines()
            .map(|l| {
                if let Some(rest) = l.strip_prefix("f ") {
                    let mut v: Vec<&str> = rest.split(' ').collect();
                    v.reverse();
                    format!("f {}", v.join(" "))
                } else {
                    l.to_owned()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let e = Mesh::from_obj_str(&inside_out, "cube.obj").expect_err("inside out");
        assert!(e.to_string().contains("inwards"), "{e}");
    }

    /// A bow-tie outline ((0,0), (10,8), (10,0), (0,10): its edges 1 and 3 cross) extruded 2 mm,
    /// the caps fanned: closed and manifold, but its surface crosses itself. It and its
    /// flipped copy were both told to "flip the winding" (issue 88); both now name two faces
    /// that cross. The symmetric bow tie, whose side faces cross only through their edges,
    /// encloses no volume and is told so; the cube inside out is still told to flip.
    #[test]
    fn an_extruded_outline_that_crosses_itself_is_named_as_such_not_as_inside_out() {
        let symmetric = "v 0 0 0\nv 10 10 0\nv 10 0 0\nv 0 10 0\nv 0 0 2\nv 10 10 2\nv 10 0 2\nv 0 10 2\n";
        let outline = symmetric.replace("v 10 10", "v 10 8");
        let faces = "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        let flipped: String = faces
            .lines()
            .map(|l| {
                let mut v: Vec<&str> = l.trim_start_matches("f ").split(' ').collect();
                v.reverse();
                format!("f {}\n", v.join(" "))
            })
            .collect();
        for (what, faces) in [("as drawn", faces.to_owned()), ("flipped", flipped)] {
            let e = Mesh::from_obj_str(&format!("{outline}{faces}"), "bowtie.obj").expect_err(what);
            let msg = e.to_string();
            assert!(
                msg.contains("bowtie.obj") && msg.contains("crosses itself") && !msg.contains("flip"),
                "{what}: {msg}"
            );
            let e = Mesh::from_obj_str(&format!("{symmetric}{faces}"), "bowtie.obj").expect_err(what);
            let msg = e.to_string();
            assert!(msg.contains("encloses no volume") && !msg.contains("flip"), "symmetric, {what}: {msg}");
        }
        // Every built-in shape (convex, concave, spirals) passes the check.
        for s in super::super::builtin::builtin_shapes() {
            let m = Mesh::prism(&s.outline.polygon(0.5), s.height_mm, &s.entry.name).expect("a built-in prism");
            assert!(m.crossing_faces().is_none(), "{}", s.entry.name);
        }
    }

    #[test]
    fn concave_prism_round_trips_through_obj() {
        // An L shape: concave, so the cap needs the constrained triangulation.
        let l = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
        let m = Mesh::prism(&l, 0.5, "L").expect("prism");
        assert!((m.volume() - 1.5).abs() < 1e-12);
        let back = Mesh::from_obj_str(&m.to_obj("L"), "L.obj").expect("reload");
        assert!((back.volume() - 1.5).abs() < 1e-9);
    }
}
