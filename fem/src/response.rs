//! The pins' response to a force anywhere on the dome's outer hemisphere, computed once per
//! sensor by reciprocity and cached on disk.
//!
//! A pin's motion is a linear read-out of the nodal displacements, `m_r = a_r . u` (its
//! [`PinProbe`]'s rows: tip displacement and rotation), and `u = K^-1 f`, so
//! `m_r = (K^-1 a_r) . f`: one solve per read-out row (`6 P`, whatever the surface's size)
//! gives every row's response to a unit force on every outer node. A force `F` (N) at a point
//! `X` of the outer sphere acts on the nodes of the face holding `X` as the consistent point
//! load `f_k = N_k(X) F` (the six-node triangle's shape functions), so
//! ```text
//! m_r = sum_k N_k(X) sum_c F_c T[3 s_k + c][r]
//! ```
//! with `T` the table (one column of `6 P` rows per surface degree of freedom). Forces are in
//! the sensor frame; motions are the tip's displacement (mm) and the post's rotation (rad).
//!
//! # The cache file
//! `tacsim-pins-<key>.bin` in the layout of `cache.rs` (magic `TACSIMPINS1`): the JSON header
//! ([`ResponseHeader`]), then the outer nodes' positions (`f64`), the faces' node indices
//! (`u32`, six per face) and the table (`f32`: its values are read to far below the pins'
//! 1e-4 mm of discretisation, and the file is half as large). The key hashes the spec, the
//! pins and the format's version.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cache;
use crate::dome::{Dome, DomeSpec, MOTION, PinSite};
use crate::element::{face_forces, face_shape, face_shape_derivatives};
use crate::error::{FemError, Result};
use crate::system::SOLVE_BLOCK;

/// Bump when the table's meaning or the file's layout change.
const FORMAT: u32 = 3;
const MAGIC: &[u8] = b"TACSIMPINS1\n";
/// Bins per side of the faces' index over the hemisphere's projection `(x, y) / R`.
const BINS: usize = 64;

/// How far outside its straight triangle (in barycentric coordinates) the ray may meet a face's
/// chord for the face to be solved on its curved surface ([`PinResponse::locate`]). The chord's
/// coordinates and the curved face's differ by at most 0.050 on the coarsest dome's faces that
/// hold a point or nearly do (test `the_chord_keeps_the_face_and_the_bits_of_every_candidate`,
/// 4 cells: the mid-edge nodes sit on the sphere, off their chords' midpoints), so a face whose
/// chord the ray meets five times that far outside holds no point that another face does not
/// hold further inside.
const CHORD_MARGIN: f64 = 0.25;

/// The bin of a coordinate of the projection `(x, y) / R`, in [-1, 1].
fn bin_of(v: f64) -> usize {
    (((v + 1.0) * 0.5 * BINS as f64).floor().max(0.0) as usize).min(BINS - 1)
}

/// The pins' response to forces on the outer hemisphere.
#[derive(Clone, Debug)]
pub struct PinResponse {
    /// The inputs' key.
    pub key: u64,
    /// Outer radius (mm).
    pub radius_mm: f64,
    /// The outer hemisphere's nodes (mm, sensor frame), in the mesh's node order.
    pub nodes: Vec<[f64; 3]>,
    /// The outer hemisphere's six-node faces, as indices into `nodes` (vertices, then the
    /// midside nodes of `ab`, `bc`, `ca`).
    pub faces: Vec<[u32; 6]>,
    /// Pins.
    pub pins: usize,
    /// Per surface degree of freedom `3 s + c`, the `6 P` rows of every pin's motion per unit
    /// force (mm/N for the tip, rad/N for the rotation), pin by pin.
    pub table: Vec<f32>,
    /// The Gaussian patch's `s` (mm) each force is spread over (0: point forces).
    pub spread_mm: f64,
    /// The outer nodes' displacement (mm/N, sensor frame) under a unit force along each
    /// sensor axis spread as the same Gaussian patch centred on the apex `(0, 0, R)`
    /// ([`PinResponse::with_apex`]): `apex[(3 c + k) + 9 s]`, force axis `c`, displacement
    /// axis `k`, node `s`; empty until computed.
    pub apex: Vec<f32>,
    /// The faces binned by the bounds of their projection `(x, y) / R`.
    bins: Vec<Vec<u32>>,
}

/// The cache file's header.
#[derive(Debug, Serialize, Deserialize)]
pub struct ResponseHeader {
    /// The inputs' key, in hex.
    pub key: String,
    /// The format's version.
    pub format: u32,
    /// Outer radius (mm).
    pub radius_mm: f64,
    /// Outer nodes.
    pub nodes: usize,
    /// Outer faces.
    pub faces: usize,
    /// Pins.
    pub pins: usize,
    /// The spec, for a reader.
    pub spec: String,
    /// The Gaussian patch's `s` (mm) the table spreads each force over (0: point forces).
    #[serde(default)]
    pub spread_mm: f64,
    /// Whether the file holds [`PinResponse::apex`] (after the table, `f32`).
    #[serde(default)]
    pub apex: bool,
}

/// The key of a response's inputs: a 64-bit FNV-1a hash of the format, the spec, the pins and
/// the Gaussian patch's `s` (mm; 0 for point forces, [`PinResponse::spread`]).
pub fn response_key(spec: &DomeSpec, pins: &[PinSite], spread_mm: f64) -> u64 {
    let words = format!("pins {FORMAT} {spec:?} {pins:?} spread {spread_mm:?}");
    cache::key_of(&words)
}

/// Where a Gaussian patch is cut ([`PinResponse::spread`]), in widths `s`.
const PATCH_REACH: f64 = 3.5;

/// The Gaussian patch's weight `exp(-|p - centre|^2 / s^2)` at `p` (chord distance, mm), cut
/// at [`PATCH_REACH`] `s`: the far field's load ([`PinResponse::spread`],
/// [`PinResponse::with_apex`]).
pub fn patch_weight(p: [f64; 3], centre: Vector3<f64>, spread_mm: f64) -> f64 {
    let d2 = (Vector3::from(p) - centre).norm_squared();
    let reach = PATCH_REACH * spread_mm;
    if d2 < reach * reach { (-d2 / (spread_mm * spread_mm)).exp() } else { 0.0 }
}

impl PinResponse {
    /// Solves for the response of a built dome's pins. Rows are solved [`SOLVE_BLOCK`] at a
    /// time, each block on one thread, so the table does not depend on the thread count;
    /// `progress` is called with the rows done and their total.
    pub fn compute(dome: &Dome, pins: &[PinSite], progress: impl Fn(usize, usize) + Sync) -> Result<Self> {
        let probes = dome.pin_probes(pins)?;
        let outer = dome.outer_nodes(90.0);
        let index: HashMap<usize, u32> = outer.iter().enumerate().map(|(i, &n)| (n, i as u32)).collect();
        let faces: Vec<[u32; 6]> = dome
            .outer_faces()
            .iter()
            .filter_map(|&(e, f)| {
                let nodes = dome.mesh.face_nodes(e, f);
                let mapped: Vec<u32> = nodes.iter().filter_map(|n| index.get(n).copied()).collect();
                <[u32; 6]>::try_from(mapped).ok()
            })
            .collect();
        let n = dome.stiffness.size();
        let rows = MOTION * probes.len();
        let dofs: Vec<Option<usize>> =
            outer.iter().flat_map(|&s| (0..3).map(move |c| 3 * s + c)).map(|d| dome.stiffness.free_index(d)).collect();
        let done = std::sync::atomic::AtomicUsize::new(0);
        let row_ids: Vec<usize> = (0..rows).collect();
        // Per block of rows, each row's response on the outer dofs.
        let blocks: Vec<Vec<f64>> = row_ids
            .par_chunks(SOLVE_BLOCK)
            .map(|ids| {
                let k = ids.len();
                let mut block = vec![0.0; n * k];
                for (j, &r) in ids.iter().enumerate() {
                    let (p, i) = (r / MOTION, r % MOTION);
                    for term in &probes[p].terms {
                        for (a, &node) in term.nodes.iter().enumerate() {
                            for c in 0..3 {
                                for &(f, w) in dome.stiffness.terms(3 * node + c).iter() {
                                    block[j * n + f] += w * term.coefficients[i][3 * a + c];
                                }
                            }
                        }
                    }
                }
                dome.factor.solve_block(&mut block);
                let mut out = vec![0.0; k * dofs.len()];
                for j in 0..k {
                    for (d, free) in dofs.iter().enumerate() {
                        out[j * dofs.len() + d] = free.map_or(0.0, |f| block[j * n + f]);
                    }
                }
                let total = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
                progress(total, rows);
                out
            })
            .collect();
        let mut table = vec![0.0f32; rows * dofs.len()];
        for (b, block) in blocks.iter().enumerate() {
            for (j, row) in block.chunks_exact(dofs.len()).enumerate() {
                let r = b * SOLVE_BLOCK + j;
                for (d, &v) in row.iter().enumerate() {
                    table[d * rows + r] = v as f32;
                }
            }
        }
        Ok(Self::with_bins(
            response_key(&dome.spec, pins, 0.0),
            dome.spec.outer_radius_mm,
            outer.iter().map(|&s| dome.mesh.nodes[s]).collect(),
            faces,
            probes.len(),
            table,
        ))
    }

    fn with_bins(
        key: u64,
        radius_mm: f64,
        nodes: Vec<[f64; 3]>,
        faces: Vec<[u32; 6]>,
        pins: usize,
        table: Vec<f32>,
    ) -> Self {
        let mut bins = vec![Vec::new(); BINS * BINS];
        let bin = |v: f64| bin_of(v / radius_mm);
        for (f, face) in faces.iter().enumerate() {
            let x = face.map(|k| nodes[k as usize]);
            let lo = [0, 1].map(|c| x.iter().map(|p| p[c]).fold(f64::INFINITY, f64::min));
            let hi = [0, 1].map(|c| x.iter().map(|p| p[c]).fold(f64::NEG_INFINITY, f64::max));
            // The curved face leaves its nodes' bounds by far less than its size.
            let margin = 0.25 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
            for j in bin(lo[1] - margin)..=bin(hi[1] + margin) {
                for i in bin(lo[0] - margin)..=bin(hi[0] + margin) {
                    bins[j * BINS + i].push(f as u32);
                }
            }
        }
        Self { key, radius_mm, nodes, faces, pins, table, spread_mm: 0.0, apex: Vec::new(), bins }
    }

    /// The response to the same forces spread as Gaussian patches on the outer sphere: a
    /// force `F` at `X` acts as the traction `F g(Y) / int g`, `g(Y) = exp(-|Y - X|^2 / s^2)`
    /// (`s = spread_mm`, the chord distance, cut at `3.5 s`), so that its total is `F`. Each
    /// node's column is the patch centred on it, carried to the nodes by the faces'
    /// consistent loads (the six-point rule); between nodes the faces' shape functions
    /// interpolate the columns as they do the point load's. A patch a few elements wide is a
    /// load the mesh resolves, unlike a point force (the contact engine adds the near field
    /// from the layered kernels, `sim/src/contact/body/dome.rs`). Columns are computed in parallel,
    /// each on its own, so the table does not depend on the thread count.
    pub fn spread(&self, spread_mm: f64) -> Result<Self> {
        if !(spread_mm > 0.0 && spread_mm <= self.radius_mm) {
            return Err(FemError::Parameter {
                field: "spread_mm",
                value: spread_mm,
                expected: "a Gaussian patch's width in (0, outer radius] mm",
            });
        }
        let reach = PATCH_REACH * spread_mm;
        let rows = self.rows();
        let nodes = &self.nodes;
        let centre_of = |face: &[u32; 6]| {
            let x = face.map(|k| Vector3::from(nodes[k as usize]));
            let c = (x[0] + x[1] + x[2]) / 3.0;
            let size = x.iter().map(|p| (p - c).norm()).fold(0.0, f64::max);
            (c, size)
        };
        let centres: Vec<(Vector3<f64>, f64)> = self.faces.iter().map(centre_of).collect();
        let columns: Vec<Vec<f32>> = (0..nodes.len())
            .into_par_iter()
            .map(|j| {
                let xj = Vector3::from(nodes[j]);
                let mut weights = vec![0.0f64; nodes.len()];
                for (face, (c, size)) in self.faces.iter().zip(&centres) {
                    if (c - xj).norm() > reach + size {
                        continue;
                    }
                    let x = face.map(|k| nodes[k as usize]);
                    let f = face_forces(&x, [0.0; 3], |p, _| [patch_weight(p, xj, spread_mm), 0.0, 0.0]);
                    for (&k, fk) in face.iter().zip(f) {
                        weights[k as usize] += fk[0];
                    }
                }
                let total: f64 = weights.iter().sum();
                let mut out = vec![0.0f64; 3 * rows];
                for (k, &w) in weights.iter().enumerate() {
                    if w == 0.0 {
                        continue;
                    }
                    for c in 0..3 {
                        let column = &self.table[(3 * k + c) * rows..(3 * k + c + 1) * rows];
                        for (o, &t) in out[c * rows..(c + 1) * rows].iter_mut().zip(column) {
                            *o += w / total * f64::from(t);
                        }
                    }
                }
                out.into_iter().map(|v| v as f32).collect()
            })
            .collect();
        let table = columns.concat();
        let mut out =
            Self::with_bins(self.key, self.radius_mm, self.nodes.clone(), self.faces.clone(), self.pins, table);
        out.spread_mm = spread_mm;
        Ok(out)
    }

    /// The same response with [`PinResponse::apex`]: the surface's own displacement under the
    /// Gaussian patch (`s` = [`PinResponse::spread_mm`], as [`PinResponse::spread`] spreads
    /// each force; a point force at the apex where it is 0) of a unit force (1 N) along each
    /// sensor axis at the apex of `dome`, the dome this response was computed from. Three
    /// solves.
    pub fn with_apex(mut self, dome: &Dome) -> Result<Self> {
        let outer = dome.outer_nodes(90.0);
        if outer.len() != self.nodes.len() {
            return Err(FemError::Parameter {
                field: "dome",
                value: outer.len() as f64,
                expected: "the dome the response was computed from (the same outer nodes)",
            });
        }
        let apex = Vector3::new(0.0, 0.0, self.radius_mm);
        let weights: Vec<f64> = if self.spread_mm > 0.0 {
            dome.traction_forces(|p, _| [patch_weight(p, apex, self.spread_mm), 0.0, 0.0])
                .iter()
                .map(|f| f[0])
                .collect()
        } else {
            let (nodes, n) = self.locate([0.0, 0.0, self.radius_mm]).ok_or(FemError::Parameter {
                field: "apex",
                value: self.radius_mm,
                expected: "a point of the outer hemisphere",
            })?;
            let mut w = vec![0.0; dome.mesh.nodes.len()];
            for (&k, nk) in nodes.iter().zip(n) {
                w[outer[k as usize]] += nk;
            }
            w
        };
        let total: f64 = weights.iter().sum();
        let mut field = vec![0.0f32; 9 * outer.len()];
        for c in 0..3 {
            let forces: Vec<[f64; 3]> = weights
                .iter()
                .map(|w| {
                    let mut f = [0.0; 3];
                    f[c] = w / total;
                    f
                })
                .collect();
            let u = dome.solve(&forces);
            for (s, &node) in outer.iter().enumerate() {
                for k in 0..3 {
                    field[9 * s + 3 * c + k] = u[node][k] as f32;
                }
            }
        }
        self.apex = field;
        Ok(self)
    }

    /// The outer surface's displacement (mm/N, sensor frame) where the ray from the centre
    /// through `x` meets it, under the apex's unit patch force along each sensor axis
    /// ([`PinResponse::apex`]): `[force axis][displacement axis]`. `None` off the hemisphere
    /// or before [`PinResponse::with_apex`].
    pub fn apex_field(&self, x: [f64; 3]) -> Option<[[f64; 3]; 3]> {
        if self.apex.len() != 9 * self.nodes.len() {
            return None;
        }
        let (nodes, n) = self.locate(x)?;
        let mut out = [[0.0; 3]; 3];
        for (&k, w) in nodes.iter().zip(n) {
            for (c, row) in out.iter_mut().enumerate() {
                for (d, o) in row.iter_mut().enumerate() {
                    *o += w * f64::from(self.apex[9 * k as usize + 3 * c + d]);
                }
            }
        }
        Some(out)
    }

    /// Rows of the table (`6 P`).
    pub fn rows(&self) -> usize {
        MOTION * self.pins
    }

    /// The face holding the point where the ray from the centre through `x` (mm, sensor frame,
    /// `z >= 0`) meets the outer surface, and the six nodes' shape functions there; `None` off
    /// the hemisphere. Of the faces near the ray (its bin's), the one whose barycentric
    /// coordinates are least outside; only faces whose chord the ray meets within
    /// `CHORD_MARGIN` of them are solved on their curved surface (the same face and bits as
    /// solving every candidate: test `the_chord_keeps_the_face_and_the_bits_of_every_candidate`).
    pub fn locate(&self, x: [f64; 3]) -> Option<([u32; 6], [f64; 6])> {
        self.locate_among(x, CHORD_MARGIN)
    }

    /// [`PinResponse::locate`] solving on the curved surface only the candidates whose chord the
    /// ray meets with no barycentric coordinate below `-margin` (`f64::INFINITY`: every one).
    fn locate_among(&self, x: [f64; 3], margin: f64) -> Option<([u32; 6], [f64; 6])> {
        let d = Vector3::from(x).try_normalize(1e-12)?;
        if d.z < -1e-9 {
            return None;
        }
        let candidates = &self.bins[bin_of(d.y) * BINS + bin_of(d.x)];
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        for &f in candidates {
            let Some(chord) = self.ray_on_chord(f as usize, &d) else { continue };
            if (1.0 - chord[0] - chord[1]).min(chord[0]).min(chord[1]) < -margin {
                continue;
            }
            let Some(l) = self.ray_on_face(f as usize, &d, chord) else { continue };
            let inside = l.iter().copied().fold(f64::INFINITY, f64::min);
            if best.is_none_or(|b| inside > b.0) {
                best = Some((inside, f, l));
            }
        }
        let (inside, f, l) = best?;
        (inside > -1e-6).then(|| (self.faces[f as usize], face_shape(l)))
    }

    /// Where the ray along `d` meets face `f`'s straight triangle (its corner nodes): the
    /// barycentric coordinates `l1`, `l2` and the ray's parameter `t`.
    fn ray_on_chord(&self, f: usize, d: &Vector3<f64>) -> Option<[f64; 3]> {
        let [a, b, c] = [0, 1, 2].map(|k| Vector3::from(self.nodes[self.faces[f][k] as usize]));
        let m = Matrix3::from_columns(&[b - a, c - a, -d]).try_inverse()?;
        Some((m * (-a)).into())
    }

    /// Barycentric coordinates where the ray along `d` meets face `f` (Newton's method on the
    /// six-node map from the straight triangle's answer `chord`, [`PinResponse::ray_on_chord`]).
    fn ray_on_face(&self, f: usize, d: &Vector3<f64>, chord: [f64; 3]) -> Option<[f64; 3]> {
        let x = self.faces[f].map(|k| Vector3::from(self.nodes[k as usize]));
        let [mut l1, mut l2, mut t] = chord;
        for _ in 0..12 {
            let l = [1.0 - l1 - l2, l1, l2];
            let n = face_shape(l);
            let [d1, d2] = face_shape_derivatives(l);
            let (mut p, mut t1, mut t2) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
            for k in 0..6 {
                p += n[k] * x[k];
                t1 += d1[k] * x[k];
                t2 += d2[k] * x[k];
            }
            let step = Matrix3::from_columns(&[t1, t2, -d]).try_inverse()? * (t * d - p);
            l1 += step.x;
            l2 += step.y;
            t += step.z;
            if step.norm() < 1e-13 {
                break;
            }
        }
        (t > 0.0).then_some([1.0 - l1 - l2, l1, l2])
    }

    /// Every pin's motion (tip displacement in mm, then rotation in rad, sensor frame) under
    /// point forces `(point, force)` (mm, N; sensor frame) on the outer hemisphere, each acting
    /// where the ray from the centre through its point meets the surface. Returns the forces'
    /// total that fell on no face (N; zero where every point lies on the hemisphere).
    pub fn motions(&self, loads: impl IntoIterator<Item = ([f64; 3], [f64; 3])>) -> (Vec<[f64; MOTION]>, [f64; 3]) {
        let mut nodal = vec![[0.0; 3]; self.nodes.len()];
        let mut missed = [0.0; 3];
        for (x, force) in loads {
            match self.locate(x) {
                Some((nodes, n)) => {
                    for (&k, w) in nodes.iter().zip(n) {
                        for c in 0..3 {
                            nodal[k as usize][c] += w * force[c];
                        }
                    }
                }
                None => (0..3).for_each(|c| missed[c] += force[c]),
            }
        }
        let rows = self.rows();
        let mut out = vec![0.0; rows];
        let columns = nodal
            .iter()
            .enumerate()
            .flat_map(|(s, f)| f.iter().enumerate().filter(|(_, fc)| **fc != 0.0).map(move |(c, &fc)| (fc, 3 * s + c)));
        let mut group = [(0.0, &self.table[..0]); COLUMN_GROUP];
        let mut held = 0;
        for (w, k) in columns {
            group[held] = (w, &self.table[k * rows..(k + 1) * rows]);
            held += 1;
            if held == COLUMN_GROUP {
                add_columns(&mut out, &group);
                held = 0;
            }
        }
        for &(w, column) in &group[..held] {
            add_column(&mut out, w, column);
        }
        let motions = out.chunks_exact(MOTION).map(|m| std::array::from_fn(|i| m[i])).collect();
        (motions, missed)
    }

    /// The cache file's path in `dir` for these inputs.
    pub fn path_in(dir: &Path, key: u64) -> PathBuf {
        dir.join(format!("tacsim-pins-{key:016x}.bin"))
    }

    /// Writes the response to `path` atomically.
    pub fn save(&self, path: &Path, spec: &DomeSpec) -> Result<()> {
        let header = ResponseHeader {
            key: format!("{:016x}", self.key),
            format: FORMAT,
            radius_mm: self.radius_mm,
            nodes: self.nodes.len(),
            faces: self.faces.len(),
            pins: self.pins,
            spec: format!("{spec:?}"),
            spread_mm: self.spread_mm,
            apex: !self.apex.is_empty(),
        };
        let nodes: Vec<f64> = self.nodes.iter().flatten().copied().collect();
        let faces: Vec<u32> = self.faces.iter().flatten().copied().collect();
        let mut body = cache::bytes_of(&nodes, f64::to_le_bytes);
        body.extend(cache::bytes_of(&faces, u32::to_le_bytes));
        body.extend(cache::bytes_of(&self.table, f32::to_le_bytes));
        body.extend(cache::bytes_of(&self.apex, f32::to_le_bytes));
        cache::write(path, MAGIC, &header, &body)
    }

    /// Reads a response back, checking the magic, format, key, sizes and face indices; an
    /// error names the file and says what to do.
    pub fn load(path: &Path, key: u64) -> Result<Self> {
        let (header, mut data): (ResponseHeader, _) = cache::read(path, MAGIC)?;
        let err = |message: String| cache::unusable(path, message);
        cache::check(path, (header.format, FORMAT), (&header.key, key))?;
        // Counts and bytes of the four tables, in u128 (each product of two usizes fits, and
        // past that saturating) so that no header's counts overflow; once they add up to the
        // file's bytes, each fits a usize.
        let (nodes, faces, pins) = (header.nodes as u128, header.faces as u128, header.pins as u128);
        let apex = if header.apex { 9 * nodes } else { 0 };
        let counts = [3 * nodes, 6 * faces, (3 * MOTION as u128 * pins).saturating_mul(nodes), apex];
        let bytes = counts.iter().zip([8, 4, 4, 4]).fold(0u128, |sum, (&n, b)| sum.saturating_add(n.saturating_mul(b)));
        if u128::from(data.left()) != bytes {
            return Err(err(format!("{} bytes of tables where {bytes} were expected", data.left())));
        }
        let counts = counts.map(|n| n as usize);
        let nodes: Vec<[f64; 3]> = data.values::<f64>(counts[0])?.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let faces: Vec<[u32; 6]> =
            data.values::<u32>(counts[1])?.chunks_exact(6).map(|c| std::array::from_fn(|i| c[i])).collect();
        if faces.iter().flatten().any(|&k| k as usize >= nodes.len()) {
            return Err(err("a face names a node past the nodes stored".into()));
        }
        let table = data.values::<f32>(counts[2])?;
        let mut out = Self::with_bins(key, header.radius_mm, nodes, faces, header.pins, table);
        out.spread_mm = header.spread_mm;
        out.apex = data.values::<f32>(counts[3])?;
        Ok(out)
    }

    /// The response for these inputs: read from `dir` where a file with their key is there,
    /// else built (the dome meshed, assembled, factorised and solved) and saved there.
    /// With `spread_mm > 0` the table saved and returned is the point forces' spread over
    /// Gaussian patches of that `s` ([`PinResponse::spread`]), and it carries the surface's
    /// response to the apex's patch ([`PinResponse::with_apex`]).
    pub fn cached(
        dir: &Path,
        spec: &DomeSpec,
        pins: &[PinSite],
        spread_mm: f64,
        progress: impl Fn(usize, usize) + Sync,
    ) -> Result<Self> {
        spec.validate()?;
        let key = response_key(spec, pins, spread_mm);
        let path = Self::path_in(dir, key);
        if path.exists() {
            return Self::load(&path, key);
        }
        cache::check_writable(dir)?;
        let dome = Dome::build(spec)?;
        let mut response = Self::compute(&dome, pins, progress)?;
        if spread_mm != 0.0 {
            response = response.spread(spread_mm)?;
            response.key = key;
        }
        let response = response.with_apex(&dome)?;
        response.save(&path, spec)?;
        Ok(response)
    }
}

/// `out += w * column` (an f32 column into f64 sums), row by row, each the bits of
/// `out[i] += w * f64::from(column[i])` (no fused multiply-add); compiled with AVX2 where the
/// CPU has it, four rows an instruction (a dome tap's pins read about 750 columns, all but
/// the last few in groups, [`add_columns`]).
fn add_column(out: &mut [f64], w: f64, column: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, AddColumn { out, w, column });
    }
    AddColumn { out, w, column }.run();
}

/// Columns [`PinResponse::motions`] adds in one pass over the rows, so that the sums are read
/// and written once a group (8 and 16 alike, 4 slower: `docs/experiments/fem-dome.md`,
/// 2026-12-07 "the far field's columns in groups").
const COLUMN_GROUP: usize = 8;

/// [`add_column`] of `COLUMN_GROUP` columns in turn, row by row: each row's sum takes the
/// columns in their order, so `out` holds the bits of adding them one at a time, read and
/// written once a group instead of once a column.
fn add_columns(out: &mut [f64], group: &[(f64, &[f32]); COLUMN_GROUP]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, AddColumns { out, group });
    }
    AddColumns { out, group }.run();
}

/// [`add_columns`]' loop.
struct AddColumns<'a, 'b> {
    out: &'a mut [f64],
    group: &'a [(f64, &'b [f32]); COLUMN_GROUP],
}

impl AddColumns<'_, '_> {
    #[inline(always)]
    fn run(self) {
        let n = self.out.len();
        let w: [f64; COLUMN_GROUP] = std::array::from_fn(|k| self.group[k].0);
        let c: [&[f32]; COLUMN_GROUP] = std::array::from_fn(|k| &self.group[k].1[..n]);
        for (i, o) in self.out.iter_mut().enumerate() {
            let mut sum = *o;
            for k in 0..COLUMN_GROUP {
                sum += w[k] * f64::from(c[k][i]);
            }
            *o = sum;
        }
    }
}

impl pulp::WithSimd for AddColumns<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        self.run();
    }
}

/// [`add_column`]'s loop.
struct AddColumn<'a> {
    out: &'a mut [f64],
    w: f64,
    column: &'a [f32],
}

impl AddColumn<'_> {
    #[inline(always)]
    fn run(self) {
        for (o, &t) in self.out.iter_mut().zip(self.column) {
            *o += self.w * f64::from(t);
        }
    }
}

impl pulp::WithSimd for AddColumn<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        self.run();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays over the whole hemisphere (and a little below it) on the coarsest dome the tests
    /// build (4 cells: the largest faces, so the most curved against their chords): `locate`
    /// finds the face and the bits that solving every candidate finds, and on the faces that
    /// hold a point or nearly do the chord's coordinates are within a quarter of the margin of
    /// the surface's.
    #[test]
    fn the_chord_keeps_the_face_and_the_bits_of_every_candidate() {
        let spec = DomeSpec {
            outer_radius_mm: 20.0,
            skin_thickness_mm: 0.66,
            skirt_mm: 0.0,
            skin: crate::Material::new(1.0, 0.436).expect("skin"),
            gel: crate::Material::new(0.1, 0.4999).expect("gel"),
            cells: 4,
            skin_layers: 1,
            skin_refinement: 1,
            refined_gel_shells: 0,
        };
        let dome = Dome::build(&spec).expect("dome");
        let pin = PinSite { base: [0.0, 0.0, 19.34], tip: [0.0, 0.0, 16.5], patch_radius_mm: 0.0 };
        let response = PinResponse::compute(&dome, &[pin], |_, _| {}).expect("response");
        let (mut found, mut apart, mut candidates, mut solved) = (0, 0.0f64, 0, 0);
        for i in 0..=120 {
            let polar = (91.0 * i as f64 / 120.0).to_radians();
            for j in 0..97 {
                let azimuth = (360.0 * j as f64 / 97.0 + 0.37 * i as f64).to_radians();
                let x = [polar.sin() * azimuth.cos(), polar.sin() * azimuth.sin(), polar.cos()].map(|v| 20.0 * v);
                let every = response.locate_among(x, f64::INFINITY);
                let chord = response.locate(x);
                let bits = |l: &Option<([u32; 6], [f64; 6])>| l.map(|(f, n)| (f, n.map(f64::to_bits)));
                assert_eq!(bits(&chord), bits(&every), "polar {polar} azimuth {azimuth}");
                found += usize::from(every.is_some());
                let d = Vector3::from(x).normalize();
                for &f in &response.bins[bin_of(d.y) * BINS + bin_of(d.x)] {
                    let Some(c) = response.ray_on_chord(f as usize, &d) else { continue };
                    candidates += 1;
                    solved += usize::from((1.0 - c[0] - c[1]).min(c[0]).min(c[1]) >= -CHORD_MARGIN);
                    let Some(curved) = response.ray_on_face(f as usize, &d, c) else { continue };
                    let inside = curved.iter().copied().fold(f64::INFINITY, f64::min);
                    if inside > -0.1 {
                        let straight = [1.0 - c[0] - c[1], c[0], c[1]];
                        for (a, b) in straight.iter().zip(curved) {
                            apart = apart.max((a - b).abs());
                        }
                    }
                }
            }
        }
        assert!(found > 11_000, "{found} rays on a face");
        eprintln!("chord against surface: {apart:.3} at most; {solved} of {candidates} candidates solved");
        assert!(apart < 0.25 * CHORD_MARGIN, "the chord's coordinates {apart} off the surface's");
    }

    /// The column sums compiled for AVX2 are the scalar loop's bits (no fused multiply-add),
    /// rows in full runs of four and a remainder alike.
    #[test]
    fn a_column_adds_the_scalar_loops_bits() {
        let column: Vec<f32> = (0..1_987).map(|i| ((i * 7919 % 1000) as f32 - 500.0) * 1.37e-3).collect();
        let start: Vec<f64> = (0..1_987).map(|i| (i as f64 * 0.618).sin() * 1e-2).collect();
        let w = 0.123_456_789_f64;
        let mut got = start.clone();
        add_column(&mut got, w, &column);
        let want: Vec<f64> = start.iter().zip(&column).map(|(o, &t)| o + w * f64::from(t)).collect();
        assert_eq!(
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }

    /// A group of columns summed in one pass over the rows gives the bits of adding them one
    /// at a time in their order (the sums a tap's pins took before columns were grouped).
    #[test]
    fn grouped_columns_add_the_bits_of_one_column_at_a_time() {
        let rows = 1_987;
        let columns: Vec<Vec<f32>> = (0..COLUMN_GROUP)
            .map(|k| (0..rows).map(|i| (((i * 7919 + k * 104_729) % 1000) as f32 - 500.0) * 1.37e-3).collect())
            .collect();
        let weights: [f64; COLUMN_GROUP] = std::array::from_fn(|k| (k as f64 + 0.5).sin() * 3.1e2);
        let start: Vec<f64> = (0..rows).map(|i| (i as f64 * 0.618).sin() * 1e-2).collect();
        let group: [(f64, &[f32]); COLUMN_GROUP] = std::array::from_fn(|k| (weights[k], columns[k].as_slice()));
        let mut got = start.clone();
        add_columns(&mut got, &group);
        let mut want = start;
        for (w, column) in group {
            add_column(&mut want, w, column);
        }
        assert_eq!(
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
}
