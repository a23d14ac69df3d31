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
        if self.volume() <= 0.0 {
            return Err(SimError::mesh(source_name, "faces are oriented inwards (negative volume): flip the winding"));
        }
        Ok(())
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
