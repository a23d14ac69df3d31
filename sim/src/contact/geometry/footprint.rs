//! The footprint of a path: the square grid on its contact plane covering every pose's
//! contact, found by probing the scene with rays.

use crate::contact::geometry::frame::ContactFrame;
use crate::contact::geometry::gap::{DomeCells, cell_limit, gaps_below, profile_radius, tightest_radius};
use crate::contact::geometry::grid::Grid;
use crate::contact::model::ContactModel;
use crate::contact::pose::SensorPose;
use crate::scene::Scene;

/// Cells of the coarse probe used to find the footprint, per side.
const PROBE_CELLS: usize = 15;

/// How far (mm) beyond its threshold a footprint probe's rays reach: any gap that far above
/// the threshold is as good as `+inf` to the probe, and the margin keeps every hit within
/// f32 rounding of the threshold (about 1e-5 mm) found exactly as by a ray of full length.
const PROBE_REACH_MARGIN_MM: f64 = 1.0;

/// Where a path's contact is solved: its [`ContactFrame`] and the footprint grid in that
/// frame (`footprint_grid`). Finding it probes the scene with rays (hundreds per pose), so
/// a caller that has already found it (a dataset checks every sample's before any work)
/// hands it to `Simulation::on_footprint` instead of probing again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// The path's frame.
    pub frame: ContactFrame,
    /// The grid covering every pose's footprint, `None` when no pose touches anything.
    pub grid: Option<Grid>,
}

impl Footprint {
    /// The footprint of the path through `poses` over `scene`.
    pub fn of_path(model: &ContactModel, scene: &Scene, poses: &[SensorPose]) -> Self {
        let frame = ContactFrame::of_poses(poses);
        Self { frame, grid: footprint_grid(model, scene, poses, &frame) }
    }

    /// The footprint of the path through `poses` whose grid [`Footprint::of_path`] found before
    /// (the frame, cheap, found again).
    pub fn on_grid(poses: &[SensorPose], grid: Option<Grid>) -> Self {
        Self { frame: ContactFrame::of_poses(poses), grid }
    }
}

/// The contact grid for a path: square, in `frame`, covering the union over `poses` of the
/// cells where the undeformed dome is inside a stimulus (found by a coarse then a fine ray
/// probe), plus one fine probe cell of margin, with `cells_across` cells per side. `None`
/// when no pose touches anything.
pub fn footprint_grid(model: &ContactModel, scene: &Scene, poses: &[SensorPose], frame: &ContactFrame) -> Option<Grid> {
    let r = cell_limit(model);
    let mut bounds: Option<[f64; 4]> = None;
    // Coarse probe: keep cells close enough to touching that a footprint could hide between
    // probe points (a sphere's gap rises by at most s^2 / (4 R) over half a cell diagonal, R
    // the tighter of the dome and the gap profile),
    // then probe their box finely and keep the cells that overlap. The coarse grid is the
    // same for every pose.
    let s = 2.0 * r / PROBE_CELLS as f64;
    let coarse = Grid::square(PROBE_CELLS, s);
    let coarse_dome = DomeCells::new(model, frame, &coarse);
    let threshold = s * s / (4.0 * tightest_radius(model)) * 1.01;
    for pose in poses {
        let Some(b) = probe_box(model, scene, pose, frame, (&coarse, &coarse_dome), threshold, s) else { continue };
        let side = (b[2] - b[0]).max(b[3] - b[1]);
        let fine_s = side / PROBE_CELLS as f64;
        let fine = Grid {
            nx: PROBE_CELLS,
            ny: PROBE_CELLS,
            cell_mm: fine_s,
            centre_mm: [0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3])],
        };
        let fine_dome = DomeCells::new(model, frame, &fine);
        let Some(b) = probe_box(model, scene, pose, frame, (&fine, &fine_dome), 0.0, fine_s) else { continue };
        bounds = Some(match bounds {
            None => b,
            Some(a) => [a[0].min(b[0]), a[1].min(b[1]), a[2].max(b[2]), a[3].max(b[3])],
        });
    }
    let b = bounds?;
    let n = model.sensor.skin.cells_across;
    let side = (b[2] - b[0]).max(b[3] - b[1]);
    Some(Grid { nx: n, ny: n, cell_mm: side / n as f64, centre_mm: [0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3])] })
}

/// A square grid centred on the apex covering the footprint of a flat surface pressed
/// `depth_mm` deep (the circle of radius `sqrt(2 R depth)`, `R` the profile the gap is
/// measured on) plus a tenth, within the gap cells' limit; `cells_across` from the sensor.
/// Every untilted contact up to that depth lies inside.
pub fn contact_disk_grid(model: &ContactModel, depth_mm: f64) -> Grid {
    let r = profile_radius(model);
    let half = ((2.0 * r * depth_mm.max(0.01)).sqrt() * 1.1).min(cell_limit(model));
    let n = model.sensor.skin.cells_across;
    Grid { nx: n, ny: n, cell_mm: 2.0 * half / n as f64, centre_mm: [0.0, 0.0] }
}

/// Box `[x0, y0, x1, y1]` of the probe cells (the grid and its dome) with gap below
/// `threshold`, grown by `margin`.
fn probe_box(
    model: &ContactModel,
    scene: &Scene,
    pose: &SensorPose,
    frame: &ContactFrame,
    (probe, dome): (&Grid, &DomeCells),
    threshold: f64,
    margin: f64,
) -> Option<[f64; 4]> {
    let gaps = gaps_below(model, scene, pose, frame, dome, threshold + PROBE_REACH_MARGIN_MM);
    let mut b: Option<[f64; 4]> = None;
    for (k, g) in gaps.iter().enumerate() {
        if g.gap < threshold {
            let c = probe.centre(k);
            b = Some(match b {
                None => [c[0], c[1], c[0], c[1]],
                Some(a) => [a[0].min(c[0]), a[1].min(c[1]), a[2].max(c[0]), a[3].max(c[1])],
            });
        }
    }
    let r = cell_limit(model);
    b.map(|a| [(a[0] - margin).max(-r), (a[1] - margin).max(-r), (a[2] + margin).min(r), (a[3] + margin).min(r)])
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::scene::ObjectPose;
    use crate::sensor::SensorParams;

    /// The footprint probe's rays end a margin past its threshold ([`PROBE_REACH_MARGIN_MM`]):
    /// every cell must fall on the same side of the threshold as with rays of full length, and
    /// every gap below it be the same bits, so the footprint grid and every image are
    /// unchanged. Every built-in stimulus, sharp and with a rounded edge, poses over its top,
    /// across its edge and off it, untilted (rays down the columns) and tilted (parry's BVH),
    /// on the coarse and on a fine probe grid. The short rays that stay above the scene's top
    /// are not cast at all ([`SKIP_ABOVE_TOP_MM`]), nor those of cells off the dome's part in
    /// contact: the same cells and bits.
    #[test]
    fn short_probe_rays_sort_the_cells_as_full_rays_do() {
        let catalogue = crate::builtin_catalogue().expect("shapes");
        let model = ContactModel::new(&SensorParams::half_space()).expect("contact model");
        let r = cell_limit(&model);
        let s = 2.0 * r / PROBE_CELLS as f64;
        let coarse = (Grid::square(PROBE_CELLS, s), s * s / (4.0 * tightest_radius(&model)) * 1.01);
        let fine = (Grid { nx: PROBE_CELLS, ny: PROBE_CELLS, cell_mm: 0.4, centre_mm: [0.7, -0.3] }, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut uniform = |lo: f64, hi: f64| rng.random_range(lo..hi);
        let mut below = 0;
        for name in catalogue.names() {
            for edge_radius_mm in [0.0, 1.5] {
                let stimulus = catalogue.get(&name).expect("a built-in").with_edge_radius(Some(edge_radius_mm));
                let (lo, hi) = stimulus.mesh.bounds();
                let mut scene = Scene::new();
                scene.add(stimulus, ObjectPose::default()).expect("placed");
                for k in 0..24 {
                    let mut pose = SensorPose::new(
                        uniform(lo[0] - 5.0, hi[0] + 5.0),
                        uniform(lo[1] - 5.0, hi[1] + 5.0),
                        uniform(0.2, 5.0),
                        uniform(-90.0, 90.0),
                    );
                    if k % 3 == 0 {
                        (pose.rx_deg, pose.ry_deg) = (uniform(-15.0, 15.0), uniform(-15.0, 15.0));
                    }
                    let frame = ContactFrame::of_poses(&[pose]);
                    for (grid, threshold) in [&coarse, &fine] {
                        let dome = DomeCells::new(&model, &frame, grid);
                        let full = gaps_below(&model, &scene, &pose, &frame, &dome, f64::INFINITY);
                        let short = gaps_below(&model, &scene, &pose, &frame, &dome, threshold + PROBE_REACH_MARGIN_MM);
                        for (f, s) in full.iter().zip(&short) {
                            assert_eq!(f.gap < *threshold, s.gap < *threshold, "{name}: {pose:?}: {f:?} vs {s:?}");
                            if f.gap < *threshold {
                                assert_eq!(f.gap.to_bits(), s.gap.to_bits(), "{name}: {pose:?}");
                                below += 1;
                            }
                        }
                    }
                }
            }
        }
        assert!(below > 1000, "the poses must touch: {below} cells below the thresholds");
    }
}
