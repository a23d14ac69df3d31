//! Dataset recipes: which shapes, how many poses and instances, the ranges they are drawn
//! from, and the split. Every field has a default (the paper's protocol) and unknown fields
//! are errors. Units: mm and degrees.

use serde::{Deserialize, Serialize};

use crate::check::{Check, Validate, load_toml};
use crate::contact::{MAX_STEP_MM, MIN_STEP_MM};
use crate::error::{Result, SimError};
use crate::rig::{Press, RigFrame};
use crate::sensor::SkinModel;
use crate::stimulus::MAX_FRICTION;

/// A dataset recipe (`scenarios/datasets/*.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Recipe {
    /// Name, shown in progress and recorded in `meta.json`.
    pub name: String,
    /// Seed of every random draw.
    pub seed: u64,
    /// Image side (px).
    pub image_size: u32,
    /// Cells across the contact footprint (odd), overriding the sensor's `skin.cells_across`:
    /// the accuracy/speed knob (`tacsim bench` gives the error of each).
    pub cells_across: Option<usize>,
    /// Elastic model behind the skin, overriding the sensor's `skin.model`.
    pub skin: Option<SkinModel>,
    /// The sensor the recipe is written for: a built-in preset's name (`tactip-331-edge2d`,
    /// see `tacsim_sim::sensor::PRESETS`) or a sensor file, relative to the recipe's
    /// directory; default: the calibrated TacTip. `tacsim generate --sensor` overrides it.
    pub sensor: Option<String>,
    /// The stimuli, each pressed around its contact location.
    pub shapes: Vec<RecipeShape>,
    /// Poses per shape and the ranges they are drawn from.
    pub poses: PoseSpec,
    /// Tap instances per pose.
    pub taps: TapSpec,
    /// Slide instances per pose.
    pub slides: SlideSpec,
    /// Split by pose.
    pub split: SplitSpec,
    /// Domain randomisation: per-sample draws of sensor and image parameters (off by
    /// default).
    pub randomise: RandomiseSpec,
    /// The lab rig the labels are written for (default: none, the labels are the sensor
    /// poses).
    pub rig: RigSpec,
}

/// A stimulus of the recipe.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecipeShape {
    /// Catalogue name (`tacsim shapes`).
    pub name: String,
    /// Contact location (object frame, mm) the poses are relative to; default: the catalogue's
    /// (a point on the edge), or the object's origin when it has none.
    #[serde(default)]
    pub contact_mm: Option<[f64; 2]>,
    /// Coulomb friction between skin and stimulus, overriding the catalogue's (as fitted by
    /// `tacsim calibrate` for a lab's surface).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Rounding radius (mm) of the top face's edge, overriding the catalogue's (0: sharp;
    /// [`crate::stimulus::Stimulus::with_edge_radius`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_radius_mm: Option<f64>,
}

/// Most poses per shape a recipe may draw.
pub const MAX_PER_SHAPE: usize = 1_000_000;
/// Most taps (or slides) per pose.
pub const MAX_PER_POSE: usize = 10_000;
/// Most images one recipe may make (shapes x poses x samples per pose).
pub const MAX_SAMPLES: usize = 10_000_000;

/// The frame the pose labels (and the slides' touch-down offsets) are given in: one type
/// with the dataset's `meta.json` reader.
pub use tacsim_data::PoseFrame;

/// Pose ranges, relative to the contact location. Each range is `[low, high]`, drawn
/// uniformly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PoseSpec {
    /// Poses per shape.
    pub per_shape: usize,
    /// Frame of the labels.
    pub frame: PoseFrame,
    /// Draw each pose's contact point uniformly along the shape's whole contour (by arc
    /// length) instead of taking the shape's contact location; edge frame only.
    pub around_contour: bool,
    /// Lateral x (mm).
    pub x_mm: [f64; 2],
    /// Lateral y (mm).
    pub y_mm: [f64; 2],
    /// Depth below the stimulus's top face (mm).
    pub depth_mm: [f64; 2],
    /// Yaw about the sensor axis (deg).
    pub yaw_deg: [f64; 2],
    /// Tilt about x (deg).
    pub rx_deg: [f64; 2],
    /// Tilt about y (deg).
    pub ry_deg: [f64; 2],
    /// Keep samples whose sensor touches nothing (undeformed images, labelled as drawn; the
    /// count is reported), as a lab's own recordings beside an edge do. Without it such a
    /// sample is an error before any work: a range off the shape is a mistake more often.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub allow_no_contact: bool,
}

/// Taps: pressed straight down onto the pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TapSpec {
    /// Instances per pose.
    pub per_pose: usize,
    /// Spread of the tap depth (mm): each tap's depth is the pose's plus a uniform draw from
    /// `[-jitter/2, jitter/2]`.
    pub depth_jitter_mm: f64,
}

/// Which lateral axes a slide's touch-down offset uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axes {
    /// Offset along x only.
    X,
    /// Offset along y only.
    Y,
    /// Offset along both.
    Both,
}

/// Domain randomisation ranges: each sample draws every parameter uniformly from its
/// `[low, high]` (from its own seeded stream, so the poses, taps and slides are the same
/// draws as without it) and records the draw in `targets.csv` (`dr_*` columns). The defaults
/// are the nominal sensor and renderer: no randomisation. Friction is not varied (taps do not
/// slide; slides keep the catalogue's friction).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RandomiseSpec {
    /// Shift of the pin field in the image, each of right and down (px at `image_size`).
    pub camera_shift_px: [f64; 2],
    /// Roll of the pins about the camera axis (deg).
    pub camera_roll_deg: [f64; 2],
    /// Factor on the pin tips' radius.
    pub pin_scale: [f64; 2],
    /// Added to the pressed depth, the label unchanged (mm): the rig's depth zero.
    pub depth_offset_mm: [f64; 2],
    /// Gaussian blur of the pin coverage before the threshold (px at `image_size`).
    pub blur_px: [f64; 2],
    /// Coverage at which a pixel turns white (0.5: the binary renderer).
    pub threshold: [f64; 2],
    /// Number of bright specks over the pin field.
    pub specks: [u32; 2],
    /// Standard deviation of each pin's random image offset, each axis (px at `image_size`).
    pub pin_jitter_px: [f64; 2],
}

impl Default for RandomiseSpec {
    fn default() -> Self {
        Self {
            camera_shift_px: [0.0, 0.0],
            camera_roll_deg: [0.0, 0.0],
            pin_scale: [1.0, 1.0],
            depth_offset_mm: [0.0, 0.0],
            blur_px: [0.0, 0.0],
            threshold: [0.5, 0.5],
            specks: [0, 0],
            pin_jitter_px: [0.0, 0.0],
        }
    }
}

impl RandomiseSpec {
    /// Whether any parameter varies or departs from the nominal.
    pub fn is_on(&self) -> bool {
        *self != Self::default()
    }
}

/// The lab rig a recipe's labels are written for, as `tacsim calibrate` fits it (its
/// report's label frame and press; [`crate::RigFrame`]): each sample's labels are drawn in the
/// lab's frame and the sensor goes where that rig would have taken it (offsets and tilts
/// turned into the sensor's frame, the depth zero shifted, depth and tilt lost to the rig's
/// yield, the apex lifted by a tilt about the pivot). Modelled for flat surfaces. The default
/// is no rig: the labels are the sensor poses.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigSpec {
    /// Rotation of the labels' lateral axes into the sensor's (deg).
    pub rotation_deg: f64,
    /// Whether the labels' `y` is mirrored first.
    pub mirrored: bool,
    /// Whether the labels' tilts turn against the rotation-vector convention.
    pub tilts_reversed: bool,
    /// Added to the labelled depth (mm).
    pub depth_offset_mm: f64,
    /// Tilt pivot above the dome apex (mm).
    pub pivot_mm: f64,
    /// Depth lost under load: `c^1.5` times this, for a commanded indentation `c` (mm^-0.5).
    pub depth_compliance: f64,
    /// Tilt kept under load: `1 - k c` (1/mm).
    pub tilt_relaxation_per_mm: f64,
    /// The pivot's offset off the sensor's axis (mm, sensor frame `x`, `y`): a tilt then
    /// raises the apex in proportion to it.
    pub pivot_offset_mm: [f64; 2],
    /// The rig's play in tilt (deg): taken off each labelled tilt's size. Left out of the
    /// written recipe where 0, so that a dataset made before the field existed is still the
    /// same dataset (`meta.json`) to `--resume` and `sim2real`'s work folders.
    #[serde(skip_serializing_if = "crate::sensor::is_zero")]
    pub tilt_play_deg: f64,
}

impl RigSpec {
    /// The rig's label frame.
    pub fn frame(&self) -> RigFrame {
        RigFrame::new(self.rotation_deg, self.mirrored).with_tilts_reversed(self.tilts_reversed)
    }

    /// The rig's press.
    pub fn press(&self) -> Press {
        Press::new(self.depth_offset_mm, self.pivot_mm, self.depth_compliance, self.tilt_relaxation_per_mm)
            .with_pivot_offset(self.pivot_offset_mm)
            .with_tilt_play(self.tilt_play_deg)
    }
}

/// Slides: touch down at `pose + offset` (and twist), slide to the pose, capture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlideSpec {
    /// Instances per pose.
    pub per_pose: usize,
    /// Range of each used offset component (mm).
    pub offset_mm: [f64; 2],
    /// Axis choices, one drawn uniformly per slide.
    pub axes: Vec<Axes>,
    /// Range of the yaw offset at touch-down (deg): rotational shear; `[0, 0]` for none.
    pub twist_deg: [f64; 2],
    /// Largest lateral step along the slide (mm, 0.01 to 10); accuracy/speed knob (`tacsim
    /// bench`).
    pub step_mm: f64,
    /// Largest yaw step along the slide (deg, 0.01 to 45).
    pub step_deg: f64,
}

/// Split by pose, and the paired (supervised) part of the training poses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SplitSpec {
    /// Fraction of each shape's poses for training.
    pub train: f64,
    /// Fraction for validation.
    pub val: f64,
    /// Fraction for testing.
    pub test: f64,
    /// Fraction of the training poses whose tap/slide pairs stay paired (at least one when
    /// positive); the rest form the unpaired subset.
    pub paired_fraction: f64,
}

impl Default for Recipe {
    fn default() -> Self {
        Self {
            name: "paper".into(),
            seed: 0,
            image_size: 256,
            cells_across: None,
            skin: None,
            sensor: None,
            shapes: ["disk", "clover", "teardrop"]
                .into_iter()
                .map(|n| RecipeShape { name: n.into(), contact_mm: None, friction: None, edge_radius_mm: None })
                .collect(),
            poses: PoseSpec::default(),
            taps: TapSpec::default(),
            slides: SlideSpec::default(),
            split: SplitSpec::default(),
            randomise: RandomiseSpec::default(),
            rig: RigSpec::default(),
        }
    }
}

impl Default for PoseSpec {
    fn default() -> Self {
        Self {
            per_shape: 200,
            frame: PoseFrame::Scene,
            around_contour: false,
            allow_no_contact: false,
            x_mm: [-5.0, 5.0],
            y_mm: [-5.0, 5.0],
            depth_mm: [1.0, 6.0],
            yaw_deg: [-45.0, 45.0],
            rx_deg: [0.0, 0.0],
            ry_deg: [0.0, 0.0],
        }
    }
}

impl Default for TapSpec {
    fn default() -> Self {
        Self { per_pose: 50, depth_jitter_mm: 1.0 }
    }
}

impl Default for SlideSpec {
    fn default() -> Self {
        Self {
            per_pose: 150,
            offset_mm: [-2.5, 2.5],
            axes: vec![Axes::X, Axes::Y, Axes::Both],
            twist_deg: [0.0, 0.0],
            step_mm: 0.25,
            step_deg: 1.0,
        }
    }
}

impl Default for SplitSpec {
    fn default() -> Self {
        Self { train: 0.6, val: 0.2, test: 0.2, paired_fraction: 0.1 }
    }
}

impl Recipe {
    /// Parses and validates a recipe; `source_name` names it in errors. A recipe that sets
    /// nothing is an error (it would silently be the 120,000-image `paper` recipe).
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        load_toml(text, source_name)
    }

    /// The recipe file `arg`, else the built-in recipe of that name
    /// ([`crate::embedded::RECIPES`]); with its source name for errors.
    pub fn file_or_builtin(arg: &str) -> Result<(Self, String)> {
        let path = std::path::Path::new(arg);
        if path.exists() {
            return Ok((Self::load(path)?, path.display().to_string()));
        }
        Self::builtin(arg)
    }

    /// The built-in recipe `name` ([`crate::embedded::RECIPES`]), whatever files there are;
    /// with its source name for errors.
    pub fn builtin(name: &str) -> Result<(Self, String)> {
        match crate::embedded::RECIPES.iter().find(|(n, _)| *n == name) {
            Some((name, text)) => {
                let source = format!("built-in recipe {name} (scenarios/datasets/{name}.toml)");
                Ok((Self::from_toml_str(text, &source)?, source))
            }
            None => Err(SimError::Unknown {
                kind: "recipe (neither a file nor a built-in recipe)",
                name: name.to_owned(),
                known: crate::embedded::RECIPES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// This recipe with a run's overrides (`--seed`, `--size`, `--cells`) where given.
    pub fn with_overrides(mut self, seed: Option<u64>, image_size: Option<u32>, cells_across: Option<usize>) -> Self {
        self.seed = seed.unwrap_or(self.seed);
        self.image_size = image_size.unwrap_or(self.image_size);
        self.cells_across = cells_across.or(self.cells_across);
        self
    }

    /// Loads and validates a recipe file.
    pub fn load(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SimError::io(path, "read", e))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Checks every value, naming the field of the first bad one. Shape names are checked
    /// against the catalogue when the plan is made. One stage per table, in the file's order.
    pub fn validate(&self, src: &str) -> Result<()> {
        let check = Check(src);
        self.validate_image(&check)?;
        self.validate_shapes(&check)?;
        self.validate_poses(&check)?;
        self.validate_slides(&check)?;
        self.validate_randomise(&check)?;
        self.validate_rig(&check)?;
        self.validate_split(&check)
    }

    /// `image_size` and `cells_across`.
    fn validate_image(&self, check: &Check) -> Result<()> {
        check.within("image_size", f64::from(self.image_size), 16.0, 2048.0, " px")?;
        if let Some(n) = self.cells_across
            && (!(5..=401).contains(&n) || n % 2 == 0)
        {
            return check.bad("cells_across", format!("must be odd and in [5, 401], got {n}"));
        }
        Ok(())
    }

    /// The `[[shapes]]`: at least one, each override in range.
    fn validate_shapes(&self, check: &Check) -> Result<()> {
        if self.shapes.is_empty() {
            return check.bad("shapes", "must list at least one shape".into());
        }
        for (i, s) in self.shapes.iter().enumerate() {
            if let Some(c) = s.contact_mm
                && !c.iter().all(|v| v.is_finite())
            {
                return check.bad(&format!("shapes[{i}].contact_mm"), format!("must be finite, got {c:?}"));
            }
            if let Some(f) = s.friction {
                check.within(&format!("shapes[{i}].friction"), f, 0.0, MAX_FRICTION, "")?;
            }
            if let Some(r) = s.edge_radius_mm {
                crate::stimulus::check_edge_radius(r, check.0, &format!("shapes[{i}].edge_radius_mm"))?;
            }
        }
        Ok(())
    }

    /// `[poses]` and `[taps]`, and the total the recipe makes.
    fn validate_poses(&self, check: &Check) -> Result<()> {
        let (p, t, s) = (&self.poses, &self.taps, &self.slides);
        if p.per_shape == 0 || p.per_shape > MAX_PER_SHAPE {
            return check.bad("poses.per_shape", format!("must be in [1, {MAX_PER_SHAPE}], got {}", p.per_shape));
        }
        if p.around_contour && p.frame != PoseFrame::Edge {
            return check
                .bad("poses.around_contour", "needs frame = \"edge\" (a label frame per contact point)".into());
        }
        check.range("poses.x_mm", p.x_mm, -50.0, 50.0)?;
        check.range("poses.y_mm", p.y_mm, -50.0, 50.0)?;
        check.range("poses.yaw_deg", p.yaw_deg, -360.0, 360.0)?;
        check.range("poses.rx_deg", p.rx_deg, -45.0, 45.0)?;
        check.range("poses.ry_deg", p.ry_deg, -45.0, 45.0)?;
        if !(t.depth_jitter_mm.is_finite() && t.depth_jitter_mm >= 0.0) {
            return check.bad("taps.depth_jitter_mm", format!("must be >= 0 mm, got {}", t.depth_jitter_mm));
        }
        check.range("poses.depth_mm", p.depth_mm, 0.0, f64::INFINITY)?;
        let half_jitter = 0.5 * self.tap_jitter_mm();
        if p.depth_mm[0] <= half_jitter {
            return check.bad(
                "poses.depth_mm",
                format!(
                    "must have its low end above half the tap depth jitter ({half_jitter} mm), so that every press is in contact, got {:?}",
                    p.depth_mm
                ),
            );
        }
        if t.per_pose == 0 && s.per_pose == 0 {
            return check.bad("taps.per_pose", "taps.per_pose and slides.per_pose cannot both be 0".into());
        }
        for (field, n) in [("taps.per_pose", t.per_pose), ("slides.per_pose", s.per_pose)] {
            if n > MAX_PER_POSE {
                return check.bad(field, format!("must be at most {MAX_PER_POSE}, got {n}"));
            }
        }
        let total = self.shapes.len() * p.per_shape * (t.per_pose + s.per_pose);
        if total > MAX_SAMPLES {
            return check.bad(
                "poses.per_shape",
                format!(
                    "{} shapes x {} poses x {} samples per pose = {total} images, more than the {MAX_SAMPLES} a \
                     recipe may make (the paper recipe makes 120000): split it into recipes or shards",
                    self.shapes.len(),
                    p.per_shape,
                    t.per_pose + s.per_pose
                ),
            );
        }
        Ok(())
    }

    /// `[slides]`.
    fn validate_slides(&self, check: &Check) -> Result<()> {
        let s = &self.slides;
        check.range("slides.offset_mm", s.offset_mm, -20.0, 20.0)?;
        check.range("slides.twist_deg", s.twist_deg, -90.0, 90.0)?;
        if s.axes.is_empty() {
            return check.bad("slides.axes", "must list at least one of \"x\", \"y\", \"both\"".into());
        }
        check.within("slides.step_mm", s.step_mm, MIN_STEP_MM, MAX_STEP_MM, " mm")?;
        check.within("slides.step_deg", s.step_deg, 0.01, 45.0, " deg")
    }

    /// The tap depth jitter that applies (mm): none where the recipe makes no taps, whose
    /// slides press at the pose's depth. Counted for a slides-only recipe, the default jitter
    /// refused shallow poses and blamed `randomise.depth_offset_mm` in a recipe without
    /// `[randomise]`.
    fn tap_jitter_mm(&self) -> f64 {
        if self.taps.per_pose == 0 { 0.0 } else { self.taps.depth_jitter_mm }
    }

    /// `[randomise]`: each draw's range, and that no depth offset lifts a tap off.
    fn validate_randomise(&self, check: &Check) -> Result<()> {
        let (d, p) = (&self.randomise, &self.poses);
        let side = f64::from(self.image_size);
        check.range("randomise.camera_shift_px", d.camera_shift_px, -side / 8.0, side / 8.0)?;
        check.range("randomise.camera_roll_deg", d.camera_roll_deg, -180.0, 180.0)?;
        check.range("randomise.pin_scale", d.pin_scale, 0.25, 4.0)?;
        check.range("randomise.depth_offset_mm", d.depth_offset_mm, -5.0, 5.0)?;
        check.range("randomise.blur_px", d.blur_px, 0.0, side / 16.0)?;
        check.range("randomise.threshold", d.threshold, 0.01, 0.99)?;
        check.range("randomise.pin_jitter_px", d.pin_jitter_px, 0.0, side / 32.0)?;
        if d.specks[0] > d.specks[1] || d.specks[1] > 1000 {
            return check
                .bad("randomise.specks", format!("must be [low, high] with low <= high <= 1000, got {:?}", d.specks));
        }
        if p.depth_mm[0] - 0.5 * self.tap_jitter_mm() + d.depth_offset_mm[0] <= 0.0 {
            return check.bad(
                "randomise.depth_offset_mm",
                format!(
                    "has its low end at {} mm, which lifts the shallowest press ({} mm, less half the jitter) out of contact: keep depth + offset above 0",
                    d.depth_offset_mm[0], p.depth_mm[0]
                ),
            );
        }
        Ok(())
    }

    /// `[rig]`.
    fn validate_rig(&self, check: &Check) -> Result<()> {
        let r = &self.rig;
        let one = |field: &str, v: f64, lo: f64, hi: f64| check.range(field, [v, v], lo, hi);
        one("rig.rotation_deg", r.rotation_deg, -360.0, 360.0)?;
        one("rig.depth_offset_mm", r.depth_offset_mm, -5.0, 5.0)?;
        one("rig.pivot_mm", r.pivot_mm, 0.0, 200.0)?;
        one("rig.depth_compliance", r.depth_compliance, 0.0, 1.0)?;
        one("rig.tilt_relaxation_per_mm", r.tilt_relaxation_per_mm, 0.0, 0.2)?;
        one("rig.pivot_offset_mm[0]", r.pivot_offset_mm[0], -10.0, 10.0)?;
        one("rig.pivot_offset_mm[1]", r.pivot_offset_mm[1], -10.0, 10.0)?;
        let [lo, hi] = crate::rig::TILT_PLAY_RANGE_DEG;
        one("rig.tilt_play_deg", r.tilt_play_deg, lo, hi)
    }

    /// `[split]`: fractions summing to 1.
    fn validate_split(&self, check: &Check) -> Result<()> {
        let sp = &self.split;
        for (field, v) in [("split.train", sp.train), ("split.val", sp.val), ("split.test", sp.test)] {
            check.fraction(field, v)?;
        }
        if ((sp.train + sp.val + sp.test) - 1.0).abs() > 1e-9 {
            return check
                .bad("split", format!("train + val + test must be 1, got {} + {} + {}", sp.train, sp.val, sp.test));
        }
        check.fraction("split.paired_fraction", sp.paired_fraction)
    }

    /// Samples per pose.
    pub fn per_pose(&self) -> usize {
        self.taps.per_pose + self.slides.per_pose
    }
}

impl Validate for Recipe {
    const EMPTY: (&'static str, &'static str) = (
        "recipe",
        "sets nothing: write the fields that differ from the defaults, or name a built-in recipe (paper, \
         quick, ...) instead of a file",
    );

    fn validate(&self, source_name: &str) -> Result<()> {
        Recipe::validate(self, source_name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_protocol() {
        let r = Recipe::default();
        r.validate("default").expect("valid");
        assert_eq!(r.shapes.len() * r.poses.per_shape * r.taps.per_pose, 30_000);
        assert_eq!(r.shapes.len() * r.poses.per_shape * r.slides.per_pose, 90_000);
    }

    #[test]
    fn bad_recipes_name_the_field() {
        for (text, field) in [
            ("[poses]\nx_mm = [5.0, -5.0]\n", "poses.x_mm"),
            ("[poses]\ndepth_mm = [1.0, nan]\n", "poses.depth_mm"),
            ("[poses]\nper_shape = 0\n", "poses.per_shape"),
            ("", "sets nothing"),
            ("# only a comment\n", "sets nothing"),
            ("[poses]\nper_shape = 1000000000000\n", "poses.per_shape"),
            ("[taps]\nper_pose = 18446744073709551615\n", "taps.per_pose"),
            ("[poses]\nper_shape = 1000000\n[taps]\nper_pose = 100\n", "poses.per_shape"),
            ("[poses]\nper_shape = -3\n", "per_shape"),
            ("[taps]\nper_pose = 0\n[slides]\nper_pose = 0\n", "taps.per_pose"),
            ("[slides]\nstep_mm = 0.0\n", "slides.step_mm"),
            ("[slides]\nstep_mm = 1e-300\n", "slides.step_mm"),
            ("[slides]\nstep_mm = 1e300\n", "slides.step_mm"),
            ("[slides]\nstep_deg = 1e-300\n", "slides.step_deg"),
            ("[split]\ntrain = 0.7\n", "split"),
            ("colour = 3\n", "colour"),
            ("[slides]\naxes = [\"z\"]\n", "axes"),
            ("shapes = []\n", "shapes"),
            ("image_size = 4\n", "image_size"),
            ("cells_across = 12\n", "cells_across"),
            ("[poses]\naround_contour = true\n", "poses.around_contour"),
            ("[poses]\nframe = \"sensor\"\n", "frame"),
            ("[randomise]\npin_scale = [1.2, 0.8]\n", "randomise.pin_scale"),
            ("[randomise]\nthreshold = [0.0, 0.5]\n", "randomise.threshold"),
            ("[randomise]\ncamera_shift_px = [-64.0, 64.0]\n", "randomise.camera_shift_px"),
            ("[randomise]\nblur_px = [0.0, inf]\n", "randomise.blur_px"),
            ("[randomise]\nspecks = [5, 2]\n", "randomise.specks"),
            ("[randomise]\npin_jitter_px = [0.0, 9.0]\n", "randomise.pin_jitter_px"),
            ("[randomise]\npin_jitter_px = [-0.5, 0.5]\n", "randomise.pin_jitter_px"),
            ("[randomise]\ndepth_offset_mm = [-2.0, 0.0]\n", "randomise.depth_offset_mm"),
            ("[randomise]\nfriction = [0.2, 0.8]\n", "friction"),
            ("[rig]\ndepth_compliance = -0.1\n", "rig.depth_compliance"),
            ("[rig]\npivot_mm = nan\n", "rig.pivot_mm"),
            ("[rig]\nrotation_deg = 1e300\n", "rig.rotation_deg"),
            ("[rig]\ntilt_relaxation_per_mm = 0.5\n", "rig.tilt_relaxation_per_mm"),
            ("[rig]\nscale = 2.0\n", "scale"),
            ("[rig]\npivot_offset_mm = [0.0, -12.0]\n", "rig.pivot_offset_mm[1]"),
            ("[rig]\ntilt_play_deg = 12.0\n", "rig.tilt_play_deg"),
            ("[[shapes]]\nname = \"disk\"\nfriction = 3.0\n", "shapes[0].friction"),
            ("[[shapes]]\nname = \"square\"\nedge_radius_mm = 11.0\n", "shapes[0].edge_radius_mm"),
            ("[[shapes]]\nname = \"square\"\nedge_radius_mm = -0.5\n", "shapes[0].edge_radius_mm"),
        ] {
            let e = Recipe::from_toml_str(text, "r.toml").expect_err(text).to_string();
            assert!(e.contains("r.toml") && e.contains(field), "{text}: {e}");
        }
    }

    /// What broke: a slides-only recipe with shallow poses and no `[randomise]` was refused
    /// for `randomise.depth_offset_mm`, the taps' default depth jitter counted for slides.
    #[test]
    fn a_slides_only_recipe_is_not_refused_for_the_tap_jitter() {
        for depth in ["0.3", "0.5"] {
            let slides_only = format!("[taps]\nper_pose = 0\n[poses]\ndepth_mm = [{depth}, 1.0]\n");
            Recipe::from_toml_str(&slides_only, "r.toml").expect("slides press at the pose's depth");
            // With taps, half the default 1 mm jitter lifts the shallowest off, and the message
            // names the poses' depth, not the randomisation the recipe does not have.
            let taps = format!("[poses]\ndepth_mm = [{depth}, 1.0]\n");
            let e = Recipe::from_toml_str(&taps, "r.toml").expect_err("jitter").to_string();
            assert!(e.contains("poses.depth_mm") && e.contains("jitter"), "{e}");
        }
    }

    /// What broke: the rig's play (33ec276) was written into every dataset's `meta.json` as
    /// `tilt_play_deg: 0.0`, so a work folder made before it "held a different dataset" and
    /// could not be resumed (a `sim2real --finetune` on a finished run was refused).
    #[test]
    fn a_rig_without_play_is_written_as_before_the_play_existed() {
        let rig = RigSpec { depth_offset_mm: -2.252, depth_compliance: 0.05, ..RigSpec::default() };
        let written = serde_json::to_value(&rig).expect("json");
        assert!(written.get("tilt_play_deg").is_none(), "{written}");
        assert_eq!(written.as_object().map(|o| o.len()), Some(8), "{written}");
        let played = serde_json::to_value(RigSpec { tilt_play_deg: 1.5, ..rig.clone() }).expect("json");
        assert_eq!(played.get("tilt_play_deg").and_then(|v| v.as_f64()), Some(1.5));
        let back: RigSpec = serde_json::from_value(written).expect("read back");
        assert_eq!(back, rig);
    }
}
