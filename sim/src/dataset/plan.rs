//! The deterministic plan of a recipe: every pose and every sample with its labels, drawn from
//! ChaCha8 streams keyed by the seed and the item's own indices, so that a sample does not
//! depend on which others are generated, in what order or on how many threads.
//!
//! Sample `i` (image `image_{i+1}.png`) is instance `i mod per_pose` of pose `i / per_pose`:
//! its taps first, then its slides. Poses are numbered shape by shape.
//!
//! Labels are in each pose's [`LabelFrame`]: the scene's axes at the shape's contact location,
//! or the edge frame at the pose's contact point ([`Frame`]).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tacsim_data::{Kind, Row, Split};

use super::recipe::{Axes, PoseFrame, Recipe};
use crate::SensorPose;
use crate::error::{Result, SimError};
use crate::stimulus::Catalogue;
use crate::stimulus::Contour;
use crate::variation::Variation;

/// Where a pose's labels are measured from: the label `(x, y)` is the point
/// `origin + x X + y Y` with `X` the unit vector at `x_axis_deg` from the scene's `x` and `Y`
/// it turned +90 deg; the label yaw is the sensor's yaw minus `yaw_zero_deg`. The scene
/// frame has both angles 0; the edge frame at a contour point with tangent angle `t` has
/// `x_axis_deg = t - 90` (the outward normal) and `yaw_zero_deg = t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelFrame {
    /// Origin (scene frame, mm).
    pub origin_mm: [f64; 2],
    /// Direction of the label `x` axis from the scene's `x` (deg).
    pub x_axis_deg: f64,
    /// Sensor yaw at label yaw 0 (deg).
    pub yaw_zero_deg: f64,
}

impl LabelFrame {
    /// The edge frame at contour point `point` with unit tangent `tangent` (material on its
    /// left).
    pub fn edge(point: [f64; 2], tangent: [f64; 2]) -> Self {
        let t = tangent[1].atan2(tangent[0]).to_degrees();
        Self { origin_mm: point, x_axis_deg: t - 90.0, yaw_zero_deg: t }
    }

    /// The scene vector (mm) of label components `x`, `y` (mm).
    pub fn vector(&self, x: f64, y: f64) -> [f64; 2] {
        let (s, c) = self.x_axis_deg.to_radians().sin_cos();
        [c * x - s * y, s * x + c * y]
    }

    /// The scene point (mm) of label offsets `x`, `y` (mm).
    pub fn point(&self, x: f64, y: f64) -> [f64; 2] {
        let v = self.vector(x, y);
        [self.origin_mm[0] + v[0], self.origin_mm[1] + v[1]]
    }
}

/// The point at arc length `u * perimeter` along `contour`'s loops (`u` in `[0, 1)`) and the
/// unit tangent of its segment (material on the left).
fn point_along(contour: &Contour, u: f64) -> ([f64; 2], [f64; 2]) {
    let total = contour.perimeter_mm();
    let mut s = u * total;
    for lp in &contour.loops {
        for i in 0..lp.len() {
            let (a, b) = (lp[i], lp[(i + 1) % lp.len()]);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            if len > 0.0 && s <= len {
                let t = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
                return ([a[0] + s * t[0], a[1] + s * t[1]], t);
            }
            s -= len;
        }
    }
    // Rounding past the end: the last loop's start.
    let lp = contour.loops.last().map(|l| l.as_slice()).unwrap_or(&[]);
    match lp {
        [a, b, ..] => {
            let len = (b[0] - a[0]).hypot(b[1] - a[1]).max(1e-300);
            (*a, [(b[0] - a[0]) / len, (b[1] - a[1]) / len])
        }
        _ => ([0.0; 2], [1.0, 0.0]),
    }
}

/// A pose of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct PosePlan {
    /// Index of the shape in the recipe.
    pub shape: usize,
    /// `[x, y, depth, Rx, Ry, Rz]` in `frame` (mm, deg).
    pub pose: [f64; 6],
    /// The frame of the labels.
    pub frame: LabelFrame,
    /// Split of the pose.
    pub split: Split,
    /// In the paired (supervised) training subset.
    pub paired: bool,
}

/// One sample: what to simulate and its labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Index in the plan.
    pub index: usize,
    /// Pose index.
    pub pose_id: usize,
    /// Tap or slide.
    pub kind: Kind,
    /// Label pose `[x, y, z, Rx, Ry, Rz]` (a tap's includes its depth jitter).
    pub pose: [f64; 6],
    /// Label shear `[x, y, z, Rx, Ry, Rz]`: the touch-down offset of a slide.
    pub shear: [f64; 6],
    /// Domain randomisation draw ([`Variation::NOMINAL`] without `[randomise]`).
    pub variation: Variation,
}

/// The plan of a recipe.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The recipe.
    pub recipe: Recipe,
    /// Per shape: name and contact location (object frame, mm).
    pub shapes: Vec<(String, [f64; 2])>,
    /// The poses, shape by shape.
    pub poses: Vec<PosePlan>,
}

/// A ChaCha8 stream for the item with the given indices.
fn stream(seed: u64, parts: &[u64]) -> ChaCha8Rng {
    // SplitMix64 over the parts: distinct tuples give unrelated seeds.
    let h = parts.iter().fold(seed, |h, &p| tacsim_data::splitmix64(h.wrapping_add(p)));
    ChaCha8Rng::seed_from_u64(h)
}

fn draw(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    let u: f64 = rng.random();
    r[0] + (r[1] - r[0]) * u
}

impl Plan {
    /// The plan of a (validated) recipe, with contact locations from `catalogue`.
    pub fn new(recipe: &Recipe, catalogue: &Catalogue, source_name: &str) -> Result<Self> {
        let mut shapes = Vec::new();
        let mut contours = Vec::new();
        for (i, s) in recipe.shapes.iter().enumerate() {
            let stim = catalogue
                .get(&s.name)
                .map_err(|e| SimError::invalid(source_name, format!("shapes[{i}].name"), format!("{e}")))?;
            let contact = s.contact_mm.or(stim.entry.contact_mm).unwrap_or([0.0, 0.0]);
            if recipe.poses.frame == PoseFrame::Edge && stim.contour.loops.is_empty() {
                return Err(SimError::invalid(
                    source_name,
                    format!("shapes[{i}].name"),
                    format!("{} has no top-face contour, so no edge frame: use frame = \"scene\"", s.name),
                ));
            }
            shapes.push((s.name.clone(), contact));
            contours.push(stim.contour.clone());
        }
        let n = recipe.poses.per_shape;
        let p = &recipe.poses;
        let sp = &recipe.split;
        let mut poses = Vec::with_capacity(n * shapes.len());
        for shape in 0..shapes.len() {
            // Split by pose: a seeded permutation of the shape's poses, cut 60:20:20 (rounded),
            // the first part of the training poses paired.
            let mut order: Vec<usize> = (0..n).collect();
            let mut rng = stream(recipe.seed, &[2, shape as u64]);
            for k in (1..n).rev() {
                order.swap(k, rng.random_range(0..=k));
            }
            let n_train = (sp.train * n as f64).round() as usize;
            let n_val = ((sp.val * n as f64).round() as usize).min(n - n_train);
            let n_paired = if sp.paired_fraction > 0.0 && n_train > 0 {
                ((sp.paired_fraction * n_train as f64).round() as usize).clamp(1, n_train)
            } else {
                0
            };
            let mut rank = vec![0; n];
            for (r, &k) in order.iter().enumerate() {
                rank[k] = r;
            }
            for (k, &r) in rank.iter().enumerate() {
                let id = shape * n + k;
                let mut rng = stream(recipe.seed, &[1, id as u64]);
                let pose = [
                    draw(&mut rng, p.x_mm),
                    draw(&mut rng, p.y_mm),
                    draw(&mut rng, p.depth_mm),
                    draw(&mut rng, p.rx_deg),
                    draw(&mut rng, p.ry_deg),
                    draw(&mut rng, p.yaw_deg),
                ];
                let frame = match (p.frame, p.around_contour) {
                    (PoseFrame::Scene, _) => {
                        LabelFrame { origin_mm: shapes[shape].1, x_axis_deg: 0.0, yaw_zero_deg: 0.0 }
                    }
                    (PoseFrame::Edge, false) => {
                        let e = contours[shape].nearest(shapes[shape].1);
                        LabelFrame::edge(e.point, e.tangent)
                    }
                    (PoseFrame::Edge, true) => {
                        let mut rng = stream(recipe.seed, &[5, id as u64]);
                        let (point, tangent) = point_along(&contours[shape], rng.random::<f64>());
                        LabelFrame::edge(point, tangent)
                    }
                };
                let split = if r < n_train {
                    Split::Train
                } else if r < n_train + n_val {
                    Split::Val
                } else {
                    Split::Test
                };
                poses.push(PosePlan { shape, pose, frame, split, paired: r < n_paired });
            }
        }
        Ok(Self { recipe: recipe.clone(), shapes, poses })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.poses.len() * self.recipe.per_pose()
    }

    /// Whether the plan has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of taps and of slides.
    pub fn counts(&self) -> (usize, usize) {
        (self.poses.len() * self.recipe.taps.per_pose, self.poses.len() * self.recipe.slides.per_pose)
    }

    /// Sample `index` (< `len()`).
    pub fn sample(&self, index: usize) -> Sample {
        let per = self.recipe.per_pose();
        let (pose_id, k) = (index / per, index % per);
        let base = self.poses[pose_id].pose;
        let taps = self.recipe.taps.per_pose;
        if k < taps {
            let mut rng = stream(self.recipe.seed, &[3, pose_id as u64, k as u64]);
            let j = self.recipe.taps.depth_jitter_mm;
            let mut pose = base;
            pose[2] += draw(&mut rng, [-0.5 * j, 0.5 * j]);
            Sample { index, pose_id, kind: Kind::Tap, pose, shear: [0.0; 6], variation: self.variation(index) }
        } else {
            let s = &self.recipe.slides;
            let mut rng = stream(self.recipe.seed, &[4, pose_id as u64, (k - taps) as u64]);
            let axes = s.axes[rng.random_range(0..s.axes.len())];
            let dx = draw(&mut rng, s.offset_mm);
            let dy = draw(&mut rng, s.offset_mm);
            let twist = draw(&mut rng, s.twist_deg);
            let (sx, sy) = match axes {
                Axes::X => (dx, 0.0),
                Axes::Y => (0.0, dy),
                Axes::Both => (dx, dy),
            };
            Sample {
                index,
                pose_id,
                kind: Kind::Slide,
                pose: base,
                shear: [sx, sy, 0.0, 0.0, 0.0, twist],
                variation: self.variation(index),
            }
        }
    }

    /// Sample `index`'s domain randomisation draw, from its own stream (so the other draws
    /// are those of the recipe without `[randomise]`).
    fn variation(&self, index: usize) -> Variation {
        let d = &self.recipe.randomise;
        if !d.is_on() {
            return Variation::NOMINAL;
        }
        let mut rng = stream(self.recipe.seed, &[5, index as u64]);
        Variation {
            shift_px: [draw(&mut rng, d.camera_shift_px), draw(&mut rng, d.camera_shift_px)],
            roll_deg: draw(&mut rng, d.camera_roll_deg),
            pin_scale: draw(&mut rng, d.pin_scale),
            depth_offset_mm: draw(&mut rng, d.depth_offset_mm),
            blur_px: draw(&mut rng, d.blur_px),
            threshold: draw(&mut rng, d.threshold),
            specks: rng.random_range(d.specks[0]..=d.specks[1]),
            speck_seed: rng.random(),
            // Drawn last: a recipe without jitter keeps every other draw it had.
            pin_jitter_px: draw(&mut rng, d.pin_jitter_px),
            jitter_seed: rng.random(),
        }
    }

    /// The sensor poses (scene frame) of a sample: touch-down and target (equal for a tap),
    /// pressed by the variation's depth offset beyond the label, where the recipe's `[rig]`
    /// takes the labels ([`crate::rig::RigFrame::poses`]; the identity without one).
    /// The touch-down offset is in the pose's label frame too.
    pub fn sensor_poses(&self, s: &Sample) -> (SensorPose, SensorPose) {
        let f = &self.poses[s.pose_id].frame;
        let mut pose = s.pose;
        pose[2] += s.variation.depth_offset_mm;
        let rig = &self.recipe.rig;
        let (start, target) = rig.frame().poses(&pose, &s.shear, &rig.press());
        let [tx, ty] = f.point(target.x_mm, target.y_mm);
        let [sx, sy] = f.vector(start.x_mm - target.x_mm, start.y_mm - target.y_mm);
        let twist = start.yaw_deg - target.yaw_deg;
        let target = SensorPose { x_mm: tx, y_mm: ty, yaw_deg: f.yaw_zero_deg + target.yaw_deg, ..target };
        let start = SensorPose { x_mm: tx + sx, y_mm: ty + sy, yaw_deg: target.yaw_deg + twist, ..target };
        (start, target)
    }

    /// The `targets.csv` row of a sample.
    pub fn row(&self, s: &Sample) -> Row {
        let p = &self.poses[s.pose_id];
        let [pose_x, pose_y, pose_z, pose_rx, pose_ry, pose_rz] = s.pose;
        let [shear_x, shear_y, shear_z, shear_rx, shear_ry, shear_rz] = s.shear;
        let v = &s.variation;
        let on = self.recipe.randomise.is_on();
        let dr = |value: f64| on.then_some(value);
        Row {
            sensor_image: image_name(s.index),
            pose_x,
            pose_y,
            pose_z,
            pose_rx,
            pose_ry,
            pose_rz,
            shear_x,
            shear_y,
            shear_z,
            shear_rx,
            shear_ry,
            shear_rz,
            kind: s.kind,
            shape: self.shapes[p.shape].0.clone(),
            pose_id: s.pose_id,
            split: p.split,
            paired: p.paired,
            dr_shift_x_px: dr(v.shift_px[0]),
            dr_shift_y_px: dr(v.shift_px[1]),
            dr_roll_deg: dr(v.roll_deg),
            dr_pin_scale: dr(v.pin_scale),
            dr_pin_jitter_px: dr(v.pin_jitter_px),
            dr_depth_offset_mm: dr(v.depth_offset_mm),
            dr_blur_px: dr(v.blur_px),
            dr_threshold: dr(v.threshold),
            dr_specks: on.then_some(v.specks),
        }
    }
}

/// File name of sample `index`'s image (the lab's numbering: `image_0.png` is the reference).
pub fn image_name(index: usize) -> String {
    format!("image_{}.png", index + 1)
}

/// File name of the undeformed reference image.
pub const REFERENCE_IMAGE: &str = "image_0.png";
