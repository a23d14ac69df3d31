//! The cells a stimulus's sharp edge cuts: found where neighbouring cells' gaps jump, the
//! edge taken from the stimulus's contour where each cell's ray crosses its top.

use nalgebra::Vector3;

use crate::contact::geometry::cut::Cut;
use crate::contact::geometry::frame::ContactFrame;
use crate::contact::geometry::gap::{CellHit, DomeCells, PoseRays, hits_at};
use crate::contact::geometry::grid::Grid;
use crate::contact::model::ContactModel;
use crate::contact::pose::SensorPose;
use crate::scene::{NearEdges, Scene};

/// By how many cell sides two neighbours' gaps must differ for the cells to be looked at for
/// a sharp edge between them ([`cut_cells`]): a smooth surface under the dome
/// changes the gap by less than a side per side where the contact is (a false alarm near the
/// dome's flanks only costs an edge query, which finds no edge within the cell).
const JUMP_PER_SIDE: f64 = 1.0;

/// The cells a stimulus's sharp edge cuts ([`super::geometry::cut`]), with their rays' `hits` made
/// the cut part's: the gap at its load point and its stimulus's friction. Looked at: both
/// cells of each pair of neighbours (diagonals included) one of which is within half a
/// side of touching and whose gaps differ by more than [`JUMP_PER_SIDE`] sides; the edge
/// is the contour of the stimulus the nearer one's ray hit, at the point where the cell's
/// centre ray crosses that stimulus's top.
pub(in crate::contact) fn cut_cells(
    (model, scene, frame): (&ContactModel, &Scene, &ContactFrame),
    dome: &DomeCells,
    grid: &Grid,
    pose: &SensorPose,
    hits: &mut [CellHit],
) -> Vec<Option<Cut>> {
    if !model.sensor.skin.cut_edges {
        // Off: no cut anywhere, as an empty field.
        return Vec::new();
    }
    let n = grid.len();
    let h = grid.cell_mm;
    let mut edge_object: Vec<Option<usize>> = vec![None; n];
    for k in 0..n {
        let (i, j) = grid.column_row(k);
        for (di, dj) in [(1isize, 0isize), (0, 1), (1, 1), (1, -1)] {
            let (ni, nj) = (i as isize + di, j as isize + dj);
            if ni < 0 || nj < 0 || ni as usize >= grid.nx || nj as usize >= grid.ny {
                continue;
            }
            let l = nj as usize * grid.nx + ni as usize;
            let (a, b) = (hits[k], hits[l]);
            let near = if a.gap <= b.gap { a } else { b };
            let jump = (a.gap - b.gap).abs();
            if near.gap < 0.5 * h && jump > JUMP_PER_SIDE * h && near.object.is_some() {
                edge_object[k] = edge_object[k].or(near.object);
                edge_object[l] = edge_object[l].or(near.object);
            }
        }
    }
    let mut cuts: Vec<Option<Cut>> = vec![None; n];
    if edge_object.iter().all(Option::is_none) {
        return cuts;
    }
    let Some(top) = scene.top_height_mm() else { return cuts };
    let rays = PoseRays::new(model, top, pose, frame);
    if rays.dir.z > -1e-6 {
        // Rays that do not go down cross no top.
        return cuts;
    }
    // The grid's axes as moves of a ray's crossing with a horizontal top (world).
    let on_top = |v: Vector3<f64>| {
        let w = rays.rot * frame.to_sensor(v);
        w - rays.dir * (w.z / rays.dir.z)
    };
    let (ux, uy) = (on_top(Vector3::x()), on_top(Vector3::y()));
    // Where each looked-at cell's centre ray crosses its stimulus's top (world).
    let crossings: Vec<(usize, usize, Vector3<f64>)> = (0..n)
        .filter_map(|k| {
            let id = edge_object[k]?;
            let top_z = scene.object_top_mm(id)?;
            let start = rays.start(&dome.points[k]);
            Some((k, id, start + rays.dir * ((top_z - start.z) / rays.dir.z)))
        })
        .collect();
    // The edges near them, per stimulus: only an edge within a cell side can cut a cell.
    let mut near: Vec<(usize, NearEdges)> = Vec::new();
    // Per cut cell, its load point (grid frame, mm) and whether the cell counts.
    let mut load_points: Vec<(usize, [f64; 2], bool)> = Vec::new();
    for &(k, id, at) in &crossings {
        if !near.iter().any(|(i, _)| *i == id) {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for (_, _, p) in crossings.iter().filter(|(_, i, _)| *i == id) {
                lo = [lo[0].min(p.x), lo[1].min(p.y)];
                hi = [hi[0].max(p.x), hi[1].max(p.y)];
            }
            near.push((id, scene.edges_near(id, lo, hi, h)));
        }
        let Some(e) = near.iter().find(|(i, _)| *i == id).and_then(|(_, edges)| edges.edge(at.x, at.y)) else {
            continue;
        };
        let d = e.signed_distance_mm;
        // The outward normal of the edge (world), along which `d` grows: off the edge from
        // the nearest point, on it the tangent turned clockwise (material on its left).
        let normal = if d.abs() > 1e-9 {
            nalgebra::Vector2::new(at.x - e.point[0], at.y - e.point[1]) / d
        } else {
            nalgebra::Vector2::new(e.tangent[1], -e.tangent[0])
        };
        let (a, b) = (normal.dot(&ux.xy()), normal.dot(&uy.xy()));
        if let Some(cut) = Cut::of_half_plane(h, d, a, b, model.edge_profile) {
            cuts[k] = Some(cut);
            let (c, at) = (grid.centre(k), cut.load_point_mm());
            load_points.push((k, [c[0] + at[0], c[1] + at[1]], dome.inside[k]));
        }
    }
    // The cut parts' own rays, from their load points.
    let found = hits_at(model, scene, frame, pose, load_points.iter().map(|(_, at, inside)| (*at, *inside)));
    for ((k, _, _), hit) in load_points.iter().zip(found) {
        if hit.gap.is_finite() {
            hits[*k] = hit;
        } else {
            cuts[*k] = None;
        }
    }
    cuts
}
