//! The initial gap: rays from behind the undeformed dome, along the contact frame's `+z`,
//! into the scene; the dome's points and slope over a grid's cells; the skin's rigid slip over
//! the stimulus between two poses.

use nalgebra::Vector3;

use crate::contact::geometry::frame::ContactFrame;
use crate::contact::geometry::grid::Grid;
use crate::contact::model::ContactModel;
use crate::contact::pose::SensorPose;
use crate::scene::Scene;

/// Gap cells are only taken inside this fraction of the dome radius (the flat contact plane
/// does not describe the dome's flanks).
pub(in crate::contact) const DOME_FRACTION: f64 = 0.95;

/// `factor` times the slope `grad h = c / sqrt(R^2 - |c|^2)` of the dome (radius `R`, mm) at
/// each cell centre `c` of `grid`: how far the undeformed surface recedes from the contact
/// plane per mm outwards (in the grid's frame the dome is a sphere about the origin).
pub(in crate::contact) fn dome_slope(grid: &Grid, dome_radius: f64, factor: f64) -> (Vec<f64>, Vec<f64>) {
    grid.centres()
        .into_iter()
        .map(|c| {
            let z =
                (dome_radius * dome_radius - c[0] * c[0] - c[1] * c[1]).max(1e-6 * dome_radius * dome_radius).sqrt();
            (factor * c[0] / z, factor * c[1] / z)
        })
        .unzip()
}

/// Point of the undeformed outer dome surface above grid point `c` (in the grid's frame: the
/// dome is a sphere about the origin in the sensor frame and every contact frame).
pub(in crate::contact) fn dome_point(dome_radius: f64, c: [f64; 2]) -> Vector3<f64> {
    let r2 = c[0] * c[0] + c[1] * c[1];
    Vector3::new(c[0], c[1], (dome_radius * dome_radius - r2).max(0.0).sqrt())
}

/// Point of the undeformed outer surface the gap is measured on above grid point `c` (grid
/// frame, mm): the dome's own ([`dome_point`]) or, on a sensor with a gap profile of its own
/// (radius `rho` mm, [`crate::sensor::SkinParams::gap_radius_mm`]), the apex height `R` less
/// that sphere's sag `rho - sqrt(rho^2 - |c|^2)`.
pub(in crate::contact) fn surface_point(model: &ContactModel, c: [f64; 2]) -> Vector3<f64> {
    let radius = model.dome_radius();
    match model.gap_radius() {
        None => dome_point(radius, c),
        Some(rho) => {
            let r2 = c[0] * c[0] + c[1] * c[1];
            Vector3::new(c[0], c[1], radius - (rho - (rho * rho - r2).max(0.0).sqrt()))
        }
    }
}

/// The radius (mm) of the profile the gap is measured on: the gap profile's where the sensor
/// has one, else the dome's own.
pub(in crate::contact) fn profile_radius(model: &ContactModel) -> f64 {
    model.gap_radius().unwrap_or(model.dome_radius())
}

/// The smaller of the dome's radius and the gap profile's (mm): where the gap cells end and
/// how fast the gap can rise over a cell.
pub(in crate::contact) fn tightest_radius(model: &ContactModel) -> f64 {
    profile_radius(model).min(model.dome_radius())
}

/// How far (mm) from the frame's apex a gap cell counts: [`DOME_FRACTION`] of
/// [`tightest_radius`].
pub(in crate::contact) fn cell_limit(model: &ContactModel) -> f64 {
    DOME_FRACTION * tightest_radius(model)
}

/// The undeformed dome under each cell of a grid: the point of its outer surface above the
/// cell's centre ([`surface_point`], sensor frame, mm) and whether the cell counts (within
/// [`cell_limit`] of the frame's apex, and on the hemisphere). Fixed for a path's grid, so a
/// [`Simulation`] finds it once instead of at every step.
#[derive(Clone, Debug, Default)]
pub(in crate::contact) struct DomeCells {
    pub(in crate::contact) points: Vec<Vector3<f64>>,
    pub(in crate::contact) inside: Vec<bool>,
}

impl DomeCells {
    pub(in crate::contact) fn new(model: &ContactModel, frame: &ContactFrame, grid: &Grid) -> Self {
        let limit = cell_limit(model);
        let (points, inside) = grid
            .centres()
            .into_iter()
            .map(|c| {
                let x = frame.to_sensor(surface_point(model, c));
                (x, c[0].hypot(c[1]) < limit && x.z > 0.0)
            })
            .unzip();
        Self { points, inside }
    }
}

/// Initial gap (mm, along `+z` of `frame`, negative where the undeformed dome is inside a
/// stimulus, `+inf` where nothing is below or off the dome) and the friction coefficient of the
/// stimulus under each cell of `grid` (in `frame`).
pub fn initial_gap(
    model: &ContactModel,
    scene: &Scene,
    pose: &SensorPose,
    frame: &ContactFrame,
    grid: &Grid,
) -> Vec<(f64, f64)> {
    gaps_below(model, scene, pose, frame, &DomeCells::new(model, frame, grid), f64::INFINITY)
        .into_iter()
        .map(|h| (h.gap, h.friction))
        .collect()
}

/// What the ray of one cell found: the gap (mm, `+inf` for nothing), the friction of the
/// stimulus hit and which object it is.
#[derive(Clone, Copy, Debug)]
pub(in crate::contact) struct CellHit {
    pub(in crate::contact) gap: f64,
    pub(in crate::contact) friction: f64,
    pub(in crate::contact) object: Option<usize>,
}

/// How one pose's rays are cast: from behind the dome's points (sensor frame) along the
/// frame's `+z`, in the world.
pub(in crate::contact) struct PoseRays {
    pub(in crate::contact) rot: nalgebra::Matrix3<f64>,
    pub(in crate::contact) origin: Vector3<f64>,
    /// How far behind the dome surface a ray starts (mm).
    pub(in crate::contact) back: f64,
    /// The frame's `+z` in the sensor frame.
    pub(in crate::contact) axis: Vector3<f64>,
    /// The rays' direction in the world.
    pub(in crate::contact) dir: Vector3<f64>,
}

impl PoseRays {
    pub(in crate::contact) fn new(model: &ContactModel, top_mm: f64, pose: &SensorPose, frame: &ContactFrame) -> Self {
        let radius = model.dome_radius();
        let rot = pose.rotation();
        let axis = frame.to_sensor(Vector3::z());
        // Start rays behind the dome surface so that they begin outside every stimulus.
        let back = pose.depth_mm.max(0.0) + 2.0 * radius;
        Self { rot, origin: pose.origin_world(radius, top_mm), back, axis, dir: rot * axis }
    }

    /// World start of the ray of the dome point `x` (sensor frame, mm).
    pub(in crate::contact) fn start(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.origin + self.rot * (x - self.back * self.axis)
    }
}

/// [`initial_gap`] at the cells of `dome` where it is below `limit_mm`; `+inf` may stand for
/// any gap above it. The rays end there: a ray over open ground or far below the dome stops at
/// the first triangle of its column (the footprint probe only asks which cells are below a
/// threshold, and the gap of a hit is at least its distance beyond the dome, the rounding of an
/// edge adding to it). With each gap, the friction and the object of the stimulus its ray hit.
pub(in crate::contact) fn gaps_below(
    model: &ContactModel,
    scene: &Scene,
    pose: &SensorPose,
    frame: &ContactFrame,
    dome: &DomeCells,
    limit_mm: f64,
) -> Vec<CellHit> {
    let radius = model.dome_radius();
    let missed = CellHit { gap: f64::INFINITY, friction: 0.0, object: None };
    let Some(top) = scene.top_height_mm() else { return vec![missed; dome.points.len()] };
    let rays = PoseRays::new(model, top, pose, frame);
    let dir = rays.dir;
    let back = rays.back;
    let length = back + limit_mm.min(2.0 * radius);
    // Only the rays that count are cast: a cell off the dome's part in contact takes no gap,
    // and a ray that stays above the scene's top (by [`SKIP_ABOVE_TOP_MM`]) can meet nothing
    // (every triangle lies at or below the top): the footprint probe's short rays away from
    // the contact.
    let (cells, origins): (Vec<usize>, Vec<[f64; 3]>) = dome
        .points
        .iter()
        .zip(&dome.inside)
        .enumerate()
        .filter_map(|(k, (x, &inside))| {
            let p = rays.start(x);
            let lowest = p.z.min(p.z + length * dir.z);
            (inside && lowest <= top + SKIP_ABOVE_TOP_MM).then_some((k, [p.x, p.y, p.z]))
        })
        .unzip();
    let hits = scene.cast_rays(&origins, [dir.x, dir.y, dir.z], length);
    let mut out = vec![missed; dome.points.len()];
    for ((k, o), hit) in cells.iter().zip(&origins).zip(hits) {
        if let Some((toi, id)) = hit {
            let stimulus = &scene.objects()[id].stimulus;
            out[*k] = CellHit {
                gap: toi - back + rounding_mm(scene, id, o, dir, toi),
                friction: stimulus.entry.friction,
                object: Some(id),
            };
        }
    }
    out
}

/// How far (mm) above the scene's top a ray may end and still be cast ([`gaps_below`]): far
/// above the rays' `f32` rounding (about 1e-5 mm), so that no ray left out could have met a
/// triangle.
const SKIP_ABOVE_TOP_MM: f64 = 0.01;

/// How much further (mm, along the ray `dir` from `origin`) the rounded edge of object `id`
/// lies than the sharp top face the ray hit at `toi` (mm): the drop below the top face at
/// the hit point over the ray's downward slope (exact for rays straight down).
fn rounding_mm(scene: &Scene, id: usize, origin: &[f64; 3], dir: Vector3<f64>, toi: f64) -> f64 {
    let stimulus = &scene.objects()[id].stimulus;
    if stimulus.entry.edge_radius_mm <= 0.0 || dir.z >= -1e-6 {
        return 0.0;
    }
    let (x, y) = (origin[0] + toi * dir.x, origin[1] + toi * dir.y);
    stimulus.drop_below_top_mm(scene.edge(id, x, y).signed_distance_mm) / -dir.z
}

/// The rays' hits at points of the contact plane (grid frame, mm; with whether each counts,
/// as [`DomeCells::inside`]) under `pose`: a cut cell's load point, a sub-cell's centre.
pub(in crate::contact) fn hits_at(
    model: &ContactModel,
    scene: &Scene,
    frame: &ContactFrame,
    pose: &SensorPose,
    at: impl Iterator<Item = ([f64; 2], bool)>,
) -> Vec<CellHit> {
    let (points, inside) = at.map(|(c, inside)| (frame.to_sensor(surface_point(model, c)), inside)).unzip();
    gaps_below(model, scene, pose, frame, &DomeCells { points, inside }, f64::INFINITY)
}

/// Rigid slip increment (mm) of the skin over the stimulus per cell (contact frame), from
/// `previous` to `pose`: each cell's dome point `x` (sensor frame) moves by
/// `x - R_new^T (R_old x + o_old - o_new)` relative to the stimulus.
pub(in crate::contact) fn rigid_slip(
    model: &ContactModel,
    scene: &Scene,
    frame: &ContactFrame,
    dome: &DomeCells,
    (pose, previous): (&SensorPose, &SensorPose),
) -> (Vec<f64>, Vec<f64>) {
    let top = scene.top_height_mm().unwrap_or(0.0);
    let radius = model.dome_radius();
    let (r_new, r_old) = (pose.rotation(), previous.rotation());
    let (o_new, o_old) = (pose.origin_world(radius, top), previous.origin_world(radius, top));
    dome.points
        .iter()
        .map(|x| {
            let w = frame.to_contact(x - r_new.transpose() * (r_old * x + o_old - o_new));
            (w.x, w.y)
        })
        .unzip()
}
