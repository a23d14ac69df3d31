//! The parametric TacTip: dome, pins and camera, with defaults, units, TOML loading and
//! validation. This is the one place where sensor dimensions are defined.
//!
//! # Sensor frame (S)
//! Origin at the centre of the dome's hemisphere. `+z` points from the camera towards the dome
//! apex (the direction the sensor presses in). `+x` is image right and `+y` is image down, so
//! (x, y, z) is right-handed and the camera looks along `+z`. Lengths in mm, angles in deg in
//! the parameters and rad in code.
//!
//! # Geometry
//! The skin is a hemispherical shell of outer radius `R = dome.outer_radius_mm` and thickness
//! `t = dome.skin_thickness_mm`. Pins are short stiff posts on the inner skin surface (radius
//! `R - t`), pointing along the inward normal; the tip centre sits at radius
//! `rho_tip = R - t - pins.length_mm`. Ring `k = 1..=K` (K = `pins.rings`) carries `6k` pins
//! at polar angle `theta_k` (from `+z`) and azimuths `phase + 2 pi j / (6k)`; the centre pin
//! sits on the axis. So the pin count is `1 + 3 K (K + 1)`: 331 for K = 10, 127 for K = 6.

use serde::{Deserialize, Serialize};

use crate::check::{Check, Validate, load_toml};
use crate::error::{Result, SimError};

/// Complete description of a TacTip sensor. Load with [`SensorParams::from_toml_str`] or
/// [`SensorParams::load`]; [`Default`] is the TacTip of the lab's flat-surface recordings with
/// its finite-element dome (preset `sim/presets/tactip-331-dome.toml`, `tacsim calibrate
/// --dome`), [`SensorParams::half_space`] the same TacTip over an elastic half-space (preset
/// `sim/presets/tactip-331-calibrated.toml`, `tacsim calibrate`): camera, ring layout, pin
/// length, skin thickness and Poisson's ratio fitted to the pin displacement fields of 489
/// recordings. The camera-only fit, to the undeformed reference image alone (`cargo xtask
/// fit-camera`), is `sim/presets/tactip-331-camera.toml` and the starting point of that
/// calibration.
///
/// ```
/// use tacsim_sim::{SensorParams, SkinModel};
///
/// // The calibrated TacTip (its dome), or a sensor file that changes any of its fields.
/// let sensor = SensorParams::default();
/// assert_eq!(sensor.pins.rings, 10);
/// let text = "[skin]\nmodel = \"skin-on-gel\"\ngel_youngs_modulus_mpa = 0.02\n";
/// let soft = SensorParams::from_toml_str(text, "soft.toml")?;
/// assert_eq!(soft.skin.model, SkinModel::SkinOnGel);
/// // An absurd value is refused before any work, naming the file and the field.
/// let err = SensorParams::from_toml_str("[skin]\ncells_across = 1\n", "bad.toml").unwrap_err();
/// assert!(err.to_string().contains("bad.toml") && err.to_string().contains("cells_across"));
/// # Ok::<(), tacsim_sim::SimError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
// A file's missing fields are the half-space preset's (the documented starting point for a
// sensor file), whatever the default sensor's body.
#[serde(deny_unknown_fields, default = "SensorParams::half_space")]
pub struct SensorParams {
    /// Free-form name, shown in reports.
    pub name: String,
    /// The hemispherical skin.
    pub dome: DomeParams,
    /// The pins on the inside of the skin.
    pub pins: PinParams,
    /// The camera inside the dome.
    pub camera: CameraParams,
    /// Elastic model of the skin and the contact grid.
    pub skin: SkinParams,
    /// How the lab's processed images frame the pin field (rim ring, circular mask). Left out
    /// of written files when nothing is drawn.
    #[serde(skip_serializing_if = "FramingParams::draws_nothing")]
    pub framing: FramingParams,
}

/// How a lab's processed images frame the pin field, in the image (not the sensor): the
/// sensor's rim as a white ring and the circular mask outside which the lab's processing
/// blacks the image. Both are circles about the principal point (`camera.principal_offset`).
/// Radii and widths are fractions of the image size (size-independent, like `camera.fov_deg`):
/// a 128 px image with `rim_radius = 0.46` draws the rim's centre line 58.9 px from the
/// principal point. Unset fields draw nothing: the default, as the surface recordings (their
/// rim is masked off) show.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FramingParams {
    /// Radius of the rim ring's centre line (fraction of the image size), in (0, 0.75].
    pub rim_radius: Option<f64>,
    /// Width of the rim ring (fraction of the image size), in (0, 0.1]; set with `rim_radius`.
    pub rim_width: Option<f64>,
    /// Radius of the mask (fraction of the image size), in (0, 0.75]: pixels whose centre lies
    /// farther from the principal point are black.
    pub mask_radius: Option<f64>,
}

impl FramingParams {
    /// Whether no field is set (the default: nothing drawn).
    pub fn draws_nothing(&self) -> bool {
        *self == Self::default()
    }
}

/// Largest rim or mask radius (fraction of the image size): past the image's corners.
pub const FRAMING_RADIUS_MAX: f64 = 0.75;
/// Largest rim width (fraction of the image size).
pub const RIM_WIDTH_MAX: f64 = 0.1;

/// Elastic influence model of the skin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SkinModel {
    /// Elastic half-space of the skin material with exact rectangle influence coefficients.
    /// The default until the calibration against real recordings settles the model: it is the
    /// validated one (Hertz, Cattaneo), but keeps shear local (pins far from the contact barely
    /// move). Pins sit at their depth below the contact plane.
    HalfSpace,
    /// One layer of the skin material, `base_depth_mm` thick, bonded to a rigid base (the
    /// camera window). Pins sit `dome.skin_thickness_mm` deep under their lateral position.
    Layer,
    /// A skin layer (`dome.skin_thickness_mm`, the skin material) over a gel layer (the gel
    /// material, down to `base_depth_mm`) on a rigid base: the real TacTip build. A stiff skin
    /// over a soft gel spreads a local shear over the dome (global shear). Pins sit at the
    /// skin's inner surface under their lateral position.
    SkinOnGel,
    /// The TacTip as it is built: a hemispherical skin shell (`dome.skin_thickness_mm`, the
    /// skin material) closed over the gel (the gel material) on a rigid base
    /// `base_depth_mm` below the apex, as a finite-element model (`contact/body/dome.rs`,
    /// tacsim-fem) at `dome_cells` and `dome_skin_layers`. The pins move with the whole dome:
    /// a press bulges the skin elsewhere and the shell carries the motion far. The contact
    /// solve uses the skin-on-gel kernels of the same materials. Not yet mesh-converged: the
    /// pins under a 1.5 mm tap change by about 0.1 mm between 8 and 10 cells
    /// (`docs/guide/fem.md`).
    Dome,
}

impl SkinModel {
    /// Every model with its name in sensor files and on the command line.
    pub const ALL: [(SkinModel, &'static str); 4] = [
        (SkinModel::HalfSpace, "half-space"),
        (SkinModel::Layer, "layer"),
        (SkinModel::SkinOnGel, "skin-on-gel"),
        (SkinModel::Dome, "dome"),
    ];
}

impl std::str::FromStr for SkinModel {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL.iter().find(|(_, name)| *name == s).map(|(m, _)| *m).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|(_, n)| *n).collect();
            format!("unknown skin model `{s}`: use one of {}", names.join(", "))
        })
    }
}

/// Elastic properties of the skin and the contact grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SkinParams {
    /// Influence model.
    pub model: SkinModel,
    /// Young's modulus (MPa). Elastomer skins: about 1 MPa. Under indentation control on a
    /// half-space the pin motion does not depend on it, only the forces do.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio, in [0, 0.5]. Default 0.436, fitted to the real recordings (was 0.5,
    /// the incompressible elastomer). At 0.5 the normal and tangential problems decouple (one
    /// normal and one tangential solve per step); below it they are alternated.
    pub poisson: f64,
    /// Cells across the contact grid (odd). The grid spans the footprint of the undeformed dome
    /// inside the stimulus plus a margin; accuracy and cost grow with it (see `tacsim bench`).
    pub cells_across: usize,
    /// Layered models: depth of the rigid base below the dome apex (mm). Default 20 mm, the
    /// camera window at the hemisphere's base plane.
    pub base_depth_mm: f64,
    /// `skin-on-gel`: Young's modulus of the gel (MPa). Default 0.1 MPa (a soft silicone gel,
    /// a tenth of the skin), an assumption until calibrated against real recordings.
    pub gel_youngs_modulus_mpa: f64,
    /// `skin-on-gel`: Poisson's ratio of the gel, in [0, 0.5]. Default 0.5.
    pub gel_poisson: f64,
    /// Factor (0 to 3) on the dome's own slope in the contact's boundary conditions; 0: the
    /// flat half-space, as if the skin faced the stimulus everywhere. The skin under a contact
    /// at polar angle `theta` is pushed along the stimulus normal, which is not its own: a
    /// stuck point pressed in by `u_n` (mm) moves `u_n tan(theta)` along the skin, away from
    /// the apex, and frictionless pressure `p` loads the skin with `p tan(theta)` along it
    /// ([`crate::contact`]'s engine). A contact off the apex (an edge beside the sensor) then
    /// drags the whole skin towards itself. 1: the dome of `dome.outer_radius_mm`; more where
    /// that radius is an effective one wider than the real dome. Fitted on edge taps
    /// (`tacsim calibrate --edge`).
    #[serde(skip_serializing_if = "is_zero")]
    pub dome_slope: f64,
    /// Radius (mm) of the outer profile the contact's initial gap is measured on: a sphere of
    /// this radius touching the dome at the contact frame's apex (its axis the frame's `+z`),
    /// so the undeformed surface `r` mm off that axis lies `rho - sqrt(rho^2 - r^2)` below the
    /// apex instead of the dome's own `R - sqrt(R^2 - r^2)`; gap cells are taken within
    /// 0.95 of the smaller of the two radii. 0 (the default): the dome's own,
    /// `dome.outer_radius_mm`. Otherwise in [`outer_radius_mm` / 4, 4 `outer_radius_mm`].
    /// A real dome is not a sphere: where an edge meets its side 5-6 mm off the apex, the lab's
    /// TacTip meets the material later than a sphere of the dome's radius does
    /// (`docs/guide/sim2real.md`). Only the gap, the cells it counts and the skin's rigid slip
    /// over the stimulus follow it; the elastic body, the pins and `dome_slope` keep the dome's
    /// own radius.
    #[serde(skip_serializing_if = "is_zero")]
    pub gap_radius_mm: f64,
    /// Whether a contact cell that a stimulus's sharp edge crosses carries its load on the
    /// part over the stimulus (its gap at that part's centroid, its stiffness that of the
    /// part, the pins feeling it there) instead of being wholly in or out by its centre. On
    /// by default: it takes the pins' error across edges 2-4x down on 13-33 cells (issue 31,
    /// `docs/experiments/contact.md`, "Cut cells"); `false` is the grid of before, each cell in or
    /// out by the gap at its centre.
    #[serde(skip_serializing_if = "is_true")]
    pub cut_edges: bool,
    /// Sub-cells per side of the loaded cells along a sharp edge, solved again for the pins
    /// (`contact/geometry/refine.rs`), in [0, 6]; 0 or 1: none. Default 3: on the bench's taps across
    /// the disk's rim it takes the pins' error at 13 cells from 0.20 to 0.088 mm (`tacsim
    /// bench --edge-subcells`, `docs/experiments/contact.md`, "Sub-cells along an edge"); the
    /// second solve's cost grows about as its square. On the bodies with a skin (`layer`,
    /// `skin-on-gel`, `dome`) the cells along the contact's own edge are solved again too: on
    /// the bench's flat dome taps the pins' error at 17 cells from 0.171 to 0.031 mm
    /// (`docs/guide/fem.md`, "The contact grid").
    #[serde(skip_serializing_if = "is_default_subcells")]
    pub edge_subcells: usize,
    /// `dome`: lattice cells from the dome's centre to its surface, in
    /// [`MIN_DOME_CELLS`, `MAX_DOME_CELLS`]: `2 dome_cells` ten-node elements span 90 deg
    /// of the surface. Default 8 (with the default skin refinement, `8x2+1`: about 185,000
    /// unknowns, 3.4 GB to build; `10x2+1` 7.9 GB, and more cells more than a laptop has:
    /// set `dome_skin_refinement = 1` for a finer lattice alone; `docs/guide/fem.md` has the
    /// pins' change with it).
    #[serde(skip_serializing_if = "is_default_dome_cells")]
    pub dome_cells: usize,
    /// `dome`: element layers through the skin, in [1, `MAX_DOME_SKIN_LAYERS`] and below
    /// `dome_cells`. Default 2.
    #[serde(skip_serializing_if = "is_default_dome_skin_layers")]
    pub dome_skin_layers: usize,
    /// `dome`: how many times finer the skin's elements are than the gel's along the
    /// surface, in [1, `MAX_DOME_SKIN_REFINEMENT`]: the skin cut from a lattice that many times
    /// as fine, tied to the gel's outer faces. Default 2: with the default 8 cells and one gel
    /// shell refined (`8x2+1`) the pins lie within 0.009 mm of the next mesh, `10x2+1`
    /// (`docs/guide/fem.md`, "The skin's own mesh"); 1 is one lattice for both (`8`: 0.025 mm
    /// from 10 cells, a fifth of the build's time and memory).
    #[serde(skip_serializing_if = "is_default_dome_skin_refinement")]
    pub dome_skin_refinement: usize,
    /// `dome`, with `dome_skin_refinement` above 1: the gel's outer lattice shells refined
    /// with the skin, in [0, `dome_cells - dome_skin_layers - 2`]. Absent (the default):
    /// [`DEFAULT_DOME_REFINED_GEL_SHELLS`] where the skin is refined and the lattice has
    /// room for it, else 0 ([`SkinParams::dome_gel_shells`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dome_refined_gel_shells: Option<usize>,
}

impl SkinParams {
    /// The gel's refined shells the dome is built with: `dome_refined_gel_shells` where given,
    /// else [`DEFAULT_DOME_REFINED_GEL_SHELLS`] with a refined skin, as many as the lattice
    /// leaves room for (`dome_cells - dome_skin_layers - 2`), and 0 with one lattice.
    pub fn dome_gel_shells(&self) -> usize {
        self.dome_refined_gel_shells.unwrap_or(if self.dome_skin_refinement > 1 {
            DEFAULT_DOME_REFINED_GEL_SHELLS.min(self.dome_cells.saturating_sub(self.dome_skin_layers + 2))
        } else {
            0
        })
    }
}

impl Default for SkinParams {
    fn default() -> Self {
        Self {
            model: SkinModel::HalfSpace,
            youngs_modulus_mpa: 1.0,
            // Calibrated: see sim/presets/tactip-331-calibrated.toml (was 0.5).
            poisson: 0.43637034658590296,
            cells_across: 25,
            base_depth_mm: 20.0,
            gel_youngs_modulus_mpa: 0.1,
            gel_poisson: 0.5,
            dome_slope: 0.0,
            gap_radius_mm: 0.0,
            cut_edges: true,
            edge_subcells: DEFAULT_EDGE_SUBCELLS,
            dome_cells: DEFAULT_DOME_CELLS,
            dome_skin_layers: DEFAULT_DOME_SKIN_LAYERS,
            dome_skin_refinement: DEFAULT_DOME_SKIN_REFINEMENT,
            dome_refined_gel_shells: None,
        }
    }
}

/// Largest [`CameraParams::distance_mm`] (mm).
pub const CAMERA_DISTANCE_MAX_MM: f64 = 1000.0;

/// Default [`SkinParams::dome_cells`].
pub const DEFAULT_DOME_CELLS: usize = 8;
/// Fewest [`SkinParams::dome_cells`].
pub const MIN_DOME_CELLS: usize = 3;
/// Most [`SkinParams::dome_cells`] (16 cells: about 400,000 unknowns, several GB to factorise).
pub const MAX_DOME_CELLS: usize = 16;
/// Default [`SkinParams::dome_skin_layers`].
pub const DEFAULT_DOME_SKIN_LAYERS: usize = 2;
/// Most [`SkinParams::dome_skin_layers`].
pub const MAX_DOME_SKIN_LAYERS: usize = 4;

fn is_default_dome_cells(v: &usize) -> bool {
    *v == DEFAULT_DOME_CELLS
}

fn is_default_dome_skin_layers(v: &usize) -> bool {
    *v == DEFAULT_DOME_SKIN_LAYERS
}

/// Default [`SkinParams::dome_skin_refinement`].
pub const DEFAULT_DOME_SKIN_REFINEMENT: usize = 2;
/// The gel's shells refined with the skin where [`SkinParams::dome_refined_gel_shells`] is
/// absent and the skin is refined (the lattice leaving room).
pub const DEFAULT_DOME_REFINED_GEL_SHELLS: usize = 1;
/// Most [`SkinParams::dome_skin_refinement`] (tacsim-fem's `MAX_SKIN_REFINEMENT`).
pub const MAX_DOME_SKIN_REFINEMENT: usize = tacsim_fem::MAX_SKIN_REFINEMENT;

fn is_default_dome_skin_refinement(v: &usize) -> bool {
    *v == DEFAULT_DOME_SKIN_REFINEMENT
}

/// Default [`SkinParams::edge_subcells`].
pub const DEFAULT_EDGE_SUBCELLS: usize = 3;

/// Largest [`SkinParams::edge_subcells`].
pub const MAX_EDGE_SUBCELLS: usize = 6;

fn is_default_subcells(v: &usize) -> bool {
    *v == DEFAULT_EDGE_SUBCELLS
}

/// Smallest and largest [`SkinParams::gap_radius_mm`] other than 0, as multiples of the dome's
/// outer radius.
pub const GAP_RADIUS_RANGE: (f64, f64) = (0.25, 4.0);

/// Largest factor on the dome's slope ([`SkinParams::dome_slope`]).
pub const MAX_DOME_SLOPE: f64 = 3.0;

/// Largest skin patch a pin turns with (mm).
pub const MAX_PATCH_RADIUS_MM: f64 = 5.0;

/// The hemispherical skin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DomeParams {
    /// Outer radius of the hemisphere (mm). TacTip: 20 mm (40 mm dome).
    pub outer_radius_mm: f64,
    /// Skin thickness (mm), between the outer surface and the pin bases.
    pub skin_thickness_mm: f64,
}

/// Pin layout and size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PinParams {
    /// Number of concentric rings K around the centre pin; pin count = 1 + 3 K (K + 1).
    pub rings: u32,
    /// Pin length from the inner skin surface to the tip centre (mm).
    pub length_mm: f64,
    /// Radius of the (spherical) white pin tip (mm).
    pub tip_radius_mm: f64,
    /// Polar angle step between rings (deg): ring k sits at `k * ring_pitch_deg`, unless
    /// `ring_polar_deg` is given.
    pub ring_pitch_deg: f64,
    /// Optional explicit polar angle of each ring (deg), K strictly increasing values in
    /// (0, 90). Overrides `ring_pitch_deg`.
    pub ring_polar_deg: Option<Vec<f64>>,
    /// Azimuth of the first pin of every ring (deg), measured from `+x` towards `+y`.
    pub phase_deg: f64,
    /// Radius (mm, 0 to 5) of the skin patch each pin moves and turns with: the base's
    /// displacement and the skin's rotation are averaged over the base and six points on a
    /// circle of this radius about it (0: the base point alone). A stiff skin bends over a
    /// length of this order where a sharp edge ends the contact, instead of kinking as the
    /// half-space beneath does; the lever then turns the pins gently rather than splitting them
    /// apart along the edge. Fitted on edge taps (`tacsim calibrate --edge`).
    #[serde(skip_serializing_if = "is_zero")]
    pub patch_radius_mm: f64,
    /// Each pin's offset in the image from where the rings put it, `[du, dv]` as fractions
    /// of the image size (right, down), one per pin in layout order (ring by ring, the centre
    /// pin first), or none: a real TacTip's pins sit off a perfect ring layout by a fraction of
    /// a pixel, and a network trained on simulated images reads that pattern too. Fitted to a
    /// lab's undeformed reference by `tacsim calibrate --pin-offsets`; at most
    /// [`MAX_IMAGE_OFFSET`] each.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub image_offsets: Vec<[f64; 2]>,
}

/// Largest per-pin image offset (fraction of the image size, either axis): 6.4 px at 128 px,
/// more than half a pin spacing.
pub const MAX_IMAGE_OFFSET: f64 = 0.05;

/// Whether `v` is zero (serde: fields left out of a file when 0).
pub(crate) fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Whether `v` is true (serde: fields left out of a file when on, their default).
fn is_true(v: &bool) -> bool {
    *v
}

/// Pinhole camera with optional radial distortion, on the dome axis looking along `+z`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraParams {
    /// Distance of the pinhole behind the dome centre (mm): the camera sits at
    /// `z = -distance_mm` in the sensor frame; in [0, `CAMERA_DISTANCE_MAX_MM`].
    pub distance_mm: f64,
    /// Full field of view across the image width (deg). Size-independent: the focal length in
    /// pixels is `(size / 2) / tan(fov / 2)`.
    pub fov_deg: f64,
    /// Principal point offset from the image centre as a fraction of the image size,
    /// `[right, down]`.
    pub principal_offset: [f64; 2],
    /// Radial distortion coefficient k1 on normalised coordinates:
    /// `x_d = x (1 + k1 r^2 + k2 r^4)`.
    pub k1: f64,
    /// Radial distortion coefficient k2 (see `k1`).
    pub k2: f64,
    /// Default output image size (px, square).
    pub image_size: u32,
}

impl SensorParams {
    /// The surface recordings' TacTip with the half-space body: the preset
    /// `tactip-331-calibrated` (camera, pins and skin fitted by `tacsim calibrate`; a 0.66 mm
    /// skin over an elastic half-space). Faster than the default dome (about a third of a tap's
    /// time), the body the half-space's analytic checks (Hertz, Cattaneo-Mindlin) are made on.
    pub fn half_space() -> Self {
        Self {
            name: "tactip-331-calibrated".to_owned(),
            dome: DomeParams::default(),
            pins: PinParams::default(),
            camera: CameraParams::default(),
            skin: SkinParams::default(),
            framing: FramingParams::default(),
        }
    }

    /// The surface recordings' TacTip over the body `model`, as fitted for it: the dome's own
    /// fit ([`SensorParams::default`]) for the dome, else [`SensorParams::half_space`] with its
    /// `skin.model` set to `model` (the layered bodies take the half-space's skin and gel
    /// fields). What `--skin` gives where no `--sensor` is named.
    pub fn calibrated_for(model: SkinModel) -> Self {
        match model {
            SkinModel::Dome => Self::default(),
            _ => {
                let mut sensor = Self::half_space();
                sensor.skin.model = model;
                sensor
            }
        }
    }
}

impl Default for SensorParams {
    /// The surface recordings' TacTip with its finite-element dome, the preset
    /// `tactip-331-dome`: [`SensorParams::half_space`]'s camera and pins over the dome `tacsim
    /// calibrate --dome` fits to those recordings (a 1.86 mm skin of 1 MPa over a gel of
    /// 0.0177 MPa, the base at the equator; the pins' tips kept, so 1.64 mm posts). It beats the
    /// half-space on the recordings per pin (held-out 0.190 against 0.216) and through a
    /// network (`docs/sim2real-surface3d/dome/`), so it is the body a sensor gets unless one
    /// is named (`docs/guide/fem.md`).
    fn default() -> Self {
        let mut sensor = Self::half_space();
        sensor.name = "tactip-331-dome".to_owned();
        sensor.dome.skin_thickness_mm = 1.860534495223869;
        sensor.pins.length_mm = 1.639465504776131;
        sensor.skin.model = SkinModel::Dome;
        sensor.skin.gel_youngs_modulus_mpa = 0.017677669529663695;
        sensor
    }
}

impl Default for DomeParams {
    fn default() -> Self {
        // Calibrated: see sim/presets/tactip-331-calibrated.toml (was 1.5 mm).
        Self { outer_radius_mm: 20.0, skin_thickness_mm: 0.6605344952238692 }
    }
}

impl Default for PinParams {
    fn default() -> Self {
        // Calibrated: see sim/presets/tactip-331-calibrated.toml (was 2.0, 0.407, 4.277).
        Self {
            rings: 10,
            length_mm: 2.839465504776131,
            tip_radius_mm: 0.43028267537923176,
            ring_pitch_deg: 4.536447148352858,
            ring_polar_deg: None,
            phase_deg: -0.3577987694874839,
            patch_radius_mm: 0.0,
            image_offsets: Vec::new(),
        }
    }
}

impl Default for CameraParams {
    fn default() -> Self {
        // Calibrated: see sim/presets/tactip-331-calibrated.toml (was 10.65 mm, 55.17 deg,
        // k1 -0.3287).
        Self {
            distance_mm: 17.41573659941609,
            fov_deg: 47.731549453531805,
            principal_offset: [0.004618913391360335, 0.00642419163850283],
            k1: -0.31513097886337244,
            k2: 0.0,
            image_size: 256,
        }
    }
}

/// The previous default sensor, fitted to the undeformed reference image alone (`cargo xtask
/// fit-camera`): `sim/presets/tactip-331-camera.toml`, the calibration's starting point.
pub const CAMERA_ONLY_PRESET: &str = include_str!("../presets/tactip-331-camera.toml");

/// The TacTip of the edge recordings (`../shared/data/real-tactip-edge2d/`): camera, ring
/// layout and framing (128 px, rim visible) fitted by `tacsim calibrate --camera-only` to the
/// consensus of its 75 shallowest taps (`--consensus shallowest`: a pressed layout, which
/// simulator-trained networks read the real taps far better with than with the layout of its
/// taps that touch nothing, `docs/guide/sim2real.md`), from `docs/calibration-edge2d/base.toml`: the calibrated
/// default's skin and pins, the dome's radius (40 mm, an effective contact radius) chosen by
/// the edge taps (`docs/guide/sim2real.md`).
pub const EDGE2D_PRESET: &str = include_str!("../presets/tactip-331-edge2d.toml");

/// The TacTip of the flat-surface recordings (`../shared/data/real-tactip-surface3d/`), as
/// `tacsim calibrate` wrote it, over an elastic half-space: equal to [`SensorParams::half_space`].
pub const CALIBRATED_PRESET: &str = include_str!("../presets/tactip-331-calibrated.toml");

/// The TacTip of the flat-surface recordings with its finite-element dome (`skin.model =
/// "dome"`), as `tacsim calibrate --dome` wrote it: [`CALIBRATED_PRESET`] with the dome's gel,
/// skin thickness and base fitted, the pins' tips kept (`docs/guide/calibration.md`): equal to
/// [`SensorParams::default`].
pub const DOME_PRESET: &str = include_str!("../presets/tactip-331-dome.toml");

/// The edge recordings' TacTip with the finite-element dome its whole-turn edge taps choose
/// (`tacsim calibrate --edge square --dome`): [`EDGE2D_PRESET`] with the dome's gel, skin
/// thickness and base fitted, the pins' tips kept (`docs/guide/calibration.md`).
pub const EDGE2D_DOME_PRESET: &str = include_str!("../presets/tactip-331-edge2d-dome.toml");

/// `(name, contents)` of the presets of `sim/presets/`, compiled in so that `--sensor` and a
/// recipe's `sensor` can name them from any directory.
pub const PRESETS: &[(&str, &str)] = &[
    ("tactip-331-calibrated", CALIBRATED_PRESET),
    ("tactip-331-camera", CAMERA_ONLY_PRESET),
    ("tactip-331-edge2d", EDGE2D_PRESET),
    ("tactip-331-dome", DOME_PRESET),
    ("tactip-331-edge2d-dome", EDGE2D_DOME_PRESET),
];

impl SensorParams {
    /// The built-in preset `name` (a file stem of `sim/presets/`, see [`PRESETS`]).
    pub fn preset(name: &str) -> Result<Self> {
        match PRESETS.iter().find(|(n, _)| *n == name) {
            Some((n, text)) => Self::from_toml_str(text, &format!("built-in preset sim/presets/{n}.toml")),
            None => Err(SimError::Unknown {
                kind: "sensor preset",
                name: name.to_owned(),
                known: PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// The sensor file `arg` (relative to `dir` where given), else the built-in preset of
    /// that name.
    pub fn file_or_preset(arg: &str, dir: Option<&std::path::Path>) -> Result<Self> {
        let path = dir.map_or_else(|| std::path::PathBuf::from(arg), |d| d.join(arg));
        if path.is_file() {
            return Self::load(&path);
        }
        match PRESETS.iter().find(|(n, _)| *n == arg) {
            Some(_) => Self::preset(arg),
            None => Err(SimError::Unknown {
                kind: "sensor (neither a file nor a built-in preset)",
                name: arg.to_owned(),
                known: PRESETS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// The edge recordings' TacTip (`EDGE2D_PRESET`).
    pub fn edge2d() -> Result<Self> {
        Self::from_toml_str(EDGE2D_PRESET, "sim/presets/tactip-331-edge2d.toml")
    }

    /// The camera-only fit (`CAMERA_ONLY_PRESET`): 1.5 mm skin, 2 mm pins, Poisson 0.5,
    /// camera 10.65 mm behind the dome centre.
    pub fn camera_only() -> Result<Self> {
        Self::from_toml_str(CAMERA_ONLY_PRESET, "sim/presets/tactip-331-camera.toml")
    }
}

/// Largest supported ring count (pin count 2791).
pub const MAX_RINGS: u32 = 30;
/// Smallest and largest supported image size (px).
pub const IMAGE_SIZE_RANGE: (u32, u32) = (8, 8192);

/// Pin count of a sensor with `rings` rings: `1 + 3 K (K + 1)`.
pub fn pin_count(rings: u32) -> usize {
    1 + 3 * rings as usize * (rings as usize + 1)
}

/// Ring count K for a centred-hexagonal pin count (331 -> 10, 127 -> 6), or `None`.
pub fn rings_for_pin_count(pins: usize) -> Option<u32> {
    (0..=MAX_RINGS).find(|&k| pin_count(k) == pins)
}

impl SensorParams {
    /// Parses and validates a sensor TOML. `source_name` (a file name) is used in errors.
    /// Missing fields take the defaults; unknown fields are errors.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        load_toml(text, source_name)
    }

    /// Reads, parses and validates a sensor TOML file.
    pub fn load(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SimError::io(path, "read", e))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Serialises to TOML (the format [`SensorParams::from_toml_str`] reads).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# serialisation failed: {e}\n"))
    }

    /// Number of pins, `1 + 3 K (K + 1)`.
    pub fn pin_count(&self) -> usize {
        pin_count(self.pins.rings)
    }

    /// Radius of the pin-tip centres from the dome centre (mm).
    pub fn tip_radius_from_centre_mm(&self) -> f64 {
        self.dome.outer_radius_mm - self.dome.skin_thickness_mm - self.pins.length_mm
    }

    /// Polar angle of each ring k = 1..=K (rad), from `+z`.
    pub fn ring_polar_rad(&self) -> Vec<f64> {
        match &self.pins.ring_polar_deg {
            Some(list) => list.iter().map(|d| d.to_radians()).collect(),
            None => (1..=self.pins.rings).map(|k| (k as f64 * self.pins.ring_pitch_deg).to_radians()).collect(),
        }
    }

    /// The same sensor with a different centred-hexagonal pin count (127, 331, ...). The ring
    /// pitch is rescaled so the outermost ring stays at the same polar angle (the pins cover
    /// the same part of the dome); an explicit ring list is resampled linearly.
    pub fn with_pin_count(&self, pins: usize) -> Result<Self> {
        let rings = rings_for_pin_count(pins).filter(|&k| k > 0).ok_or_else(|| {
            SimError::invalid(
                &self.name,
                "pins",
                format!(
                    "{pins} is not a centred-hexagonal pin count 1 + 3K(K+1) with K in [1, {MAX_RINGS}] (7, 19, 37, 61, \
                     91, 127, 169, 217, 271, 331, ..., {})",
                    pin_count(MAX_RINGS)
                ),
            )
        })?;
        let mut out = self.clone();
        let outer = *self.ring_polar_rad().last().unwrap_or(&0.0);
        out.pins.rings = rings;
        // Per-pin offsets belong to one layout's pins.
        out.pins.image_offsets.clear();
        if self.pins.rings > 0 {
            let old = self.ring_polar_rad();
            out.pins.ring_pitch_deg = self.pins.ring_pitch_deg * self.pins.rings as f64 / rings as f64;
            if self.pins.ring_polar_deg.is_some() {
                // Ring position s in old-ring units (s = 0 is the axis), interpolated linearly.
                let at = |j: usize| if j == 0 { 0.0 } else { old[j - 1] };
                let resampled = (1..=rings)
                    .map(|k| {
                        let s = k as f64 / rings as f64 * old.len() as f64;
                        let i = (s.floor() as usize).min(old.len());
                        let theta = if i == old.len() { outer } else { at(i) + (at(i + 1) - at(i)) * (s - i as f64) };
                        theta.to_degrees()
                    })
                    .collect();
                out.pins.ring_polar_deg = Some(resampled);
            }
        }
        out.name = format!("{}-{pins}", self.name.trim_end_matches("-331"));
        out.validate(&out.name.clone())?;
        Ok(out)
    }

    /// Checks every field: finite, in range, and geometrically consistent. Errors name the
    /// field and the allowed range. One stage per table, in the file's order, then the
    /// geometry that joins them.
    pub fn validate(&self, source_name: &str) -> Result<()> {
        let check = Check(source_name);
        self.validate_dome(&check)?;
        self.validate_pins(&check)?;
        self.validate_camera(&check)?;
        self.validate_framing(&check)?;
        self.validate_skin(&check)?;
        self.validate_geometry(&check)
    }

    /// The `[dome]` table.
    fn validate_dome(&self, check: &Check) -> Result<()> {
        let d = &self.dome;
        check.finite("dome.outer_radius_mm", d.outer_radius_mm)?;
        check.finite("dome.skin_thickness_mm", d.skin_thickness_mm)?;
        if !(d.outer_radius_mm > 0.0 && d.outer_radius_mm <= 1000.0) {
            return check.bad("dome.outer_radius_mm", format!("must be in (0, 1000] mm, got {}", d.outer_radius_mm));
        }
        if !(d.skin_thickness_mm > 0.0 && d.skin_thickness_mm < 0.5 * d.outer_radius_mm) {
            return check.bad(
                "dome.skin_thickness_mm",
                format!("must be in (0, outer_radius/2 = {}) mm, got {}", 0.5 * d.outer_radius_mm, d.skin_thickness_mm),
            );
        }
        Ok(())
    }

    /// The `[pins]` table, and that the pin tips stay off the dome's centre.
    fn validate_pins(&self, check: &Check) -> Result<()> {
        let p = &self.pins;
        for (field, v) in [
            ("pins.length_mm", p.length_mm),
            ("pins.tip_radius_mm", p.tip_radius_mm),
            ("pins.ring_pitch_deg", p.ring_pitch_deg),
            ("pins.phase_deg", p.phase_deg),
            ("pins.patch_radius_mm", p.patch_radius_mm),
        ] {
            check.finite(field, v)?;
        }
        if !(0.0..=MAX_PATCH_RADIUS_MM).contains(&p.patch_radius_mm) {
            return check.bad(
                "pins.patch_radius_mm",
                format!("must be in [0, {MAX_PATCH_RADIUS_MM}] mm, got {}", p.patch_radius_mm),
            );
        }
        if p.rings > MAX_RINGS {
            return check.bad("pins.rings", format!("must be at most {MAX_RINGS}, got {}", p.rings));
        }
        if p.length_mm < 0.0 {
            return check.bad("pins.length_mm", format!("must be >= 0 mm, got {}", p.length_mm));
        }
        if p.tip_radius_mm <= 0.0 {
            return check.bad("pins.tip_radius_mm", format!("must be > 0 mm, got {}", p.tip_radius_mm));
        }
        let rho = self.tip_radius_from_centre_mm();
        if rho <= p.tip_radius_mm {
            return check.bad(
                "pins.length_mm",
                format!(
                    "pin tips would reach the dome centre: outer_radius - skin_thickness - length = {rho:.3} mm must exceed tip_radius {} mm",
                    p.tip_radius_mm
                ),
            );
        }
        let count = self.pin_count();
        if !p.image_offsets.is_empty() && p.image_offsets.len() != count {
            return check.bad(
                "pins.image_offsets",
                format!("must list one [du, dv] per pin ({count}), got {}", p.image_offsets.len()),
            );
        }
        for (i, o) in p.image_offsets.iter().enumerate() {
            for (axis, v) in o.iter().enumerate() {
                check.within(
                    &format!("pins.image_offsets[{i}][{axis}]"),
                    *v,
                    -MAX_IMAGE_OFFSET,
                    MAX_IMAGE_OFFSET,
                    " (fraction of the image size)",
                )?;
            }
        }
        if p.phase_deg.abs() > 360.0 {
            return check.bad("pins.phase_deg", format!("must be in [-360, 360] deg, got {}", p.phase_deg));
        }
        match &p.ring_polar_deg {
            Some(list) => {
                if list.len() != p.rings as usize {
                    return check.bad(
                        "pins.ring_polar_deg",
                        format!("must list {} angles (one per ring), got {}", p.rings, list.len()),
                    );
                }
                let mut prev = 0.0;
                for (i, &a) in list.iter().enumerate() {
                    check.finite(&format!("pins.ring_polar_deg[{i}]"), a)?;
                    if !(a > prev && a < 90.0) {
                        return check.bad(
                            &format!("pins.ring_polar_deg[{i}]"),
                            format!("ring angles must increase strictly within (0, 90) deg, got {a} after {prev}"),
                        );
                    }
                    prev = a;
                }
            }
            None => {
                if p.rings > 0 && !(p.ring_pitch_deg > 0.0 && p.ring_pitch_deg * p.rings as f64 <= 89.0) {
                    return check.bad(
                        "pins.ring_pitch_deg",
                        format!(
                            "must be > 0 with rings * pitch <= 89 deg (pins on the hemisphere), got {} x {}",
                            p.rings, p.ring_pitch_deg
                        ),
                    );
                }
            }
        }
        Ok(())
    }

    /// The `[camera]` table.
    fn validate_camera(&self, check: &Check) -> Result<()> {
        let c = &self.camera;
        for (field, v) in [
            ("camera.distance_mm", c.distance_mm),
            ("camera.fov_deg", c.fov_deg),
            ("camera.principal_offset[0]", c.principal_offset[0]),
            ("camera.principal_offset[1]", c.principal_offset[1]),
            ("camera.k1", c.k1),
            ("camera.k2", c.k2),
        ] {
            check.finite(field, v)?;
        }
        // Behind the dome centre: a negative distance puts the camera inside the dome, where it
        // was refused as a distortion that folds the image (naming k1).
        if !(0.0..=CAMERA_DISTANCE_MAX_MM).contains(&c.distance_mm) {
            return check.bad(
                "camera.distance_mm",
                format!("must be in [0, {CAMERA_DISTANCE_MAX_MM}] mm (behind the dome centre), got {}", c.distance_mm),
            );
        }
        if !(c.fov_deg > 1.0 && c.fov_deg < 179.0) {
            return check.bad("camera.fov_deg", format!("must be in (1, 179) deg, got {}", c.fov_deg));
        }
        for (i, o) in c.principal_offset.iter().enumerate() {
            if o.abs() > 0.5 {
                return check.bad(
                    &format!("camera.principal_offset[{i}]"),
                    format!("must be in [-0.5, 0.5] (fraction of the image size), got {o}"),
                );
            }
        }
        if c.k1.abs() > 1.0 || c.k2.abs() > 1.0 {
            return check
                .bad("camera.k1", format!("distortion coefficients must be in [-1, 1], got k1 {} k2 {}", c.k1, c.k2));
        }
        if !(IMAGE_SIZE_RANGE.0..=IMAGE_SIZE_RANGE.1).contains(&c.image_size) {
            return check.bad(
                "camera.image_size",
                format!("must be in [{}, {}] px, got {}", IMAGE_SIZE_RANGE.0, IMAGE_SIZE_RANGE.1, c.image_size),
            );
        }
        Ok(())
    }

    /// The `[framing]` table.
    fn validate_framing(&self, check: &Check) -> Result<()> {
        let f = &self.framing;
        for (field, v, max) in [
            ("framing.rim_radius", f.rim_radius, FRAMING_RADIUS_MAX),
            ("framing.rim_width", f.rim_width, RIM_WIDTH_MAX),
            ("framing.mask_radius", f.mask_radius, FRAMING_RADIUS_MAX),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0 && v <= max)
            {
                return check.bad(field, format!("must be in (0, {max}] (fraction of the image size), got {v}"));
            }
        }
        if f.rim_radius.is_some() != f.rim_width.is_some() {
            return check.bad(
                if f.rim_radius.is_some() { "framing.rim_width" } else { "framing.rim_radius" },
                "the rim needs both framing.rim_radius and framing.rim_width (fractions of the image size)".to_owned(),
            );
        }
        Ok(())
    }

    /// The `[skin]` table.
    fn validate_skin(&self, check: &Check) -> Result<()> {
        let k = &self.skin;
        check.finite("skin.youngs_modulus_mpa", k.youngs_modulus_mpa)?;
        check.finite("skin.poisson", k.poisson)?;
        if !(k.youngs_modulus_mpa > 0.0 && k.youngs_modulus_mpa <= 1.0e6) {
            return check
                .bad("skin.youngs_modulus_mpa", format!("must be in (0, 1e6] MPa, got {}", k.youngs_modulus_mpa));
        }
        if !(0.0..=0.5).contains(&k.poisson) {
            return check.bad("skin.poisson", format!("must be in [0, 0.5], got {}", k.poisson));
        }
        if !(5..=401).contains(&k.cells_across) || k.cells_across.is_multiple_of(2) {
            return check.bad("skin.cells_across", format!("must be odd and in [5, 401], got {}", k.cells_across));
        }
        if k.edge_subcells > MAX_EDGE_SUBCELLS {
            return check
                .bad("skin.edge_subcells", format!("must be in [0, {MAX_EDGE_SUBCELLS}], got {}", k.edge_subcells));
        }
        check.finite("skin.base_depth_mm", k.base_depth_mm)?;
        check.finite("skin.gel_youngs_modulus_mpa", k.gel_youngs_modulus_mpa)?;
        check.finite("skin.gel_poisson", k.gel_poisson)?;
        let t = self.dome.skin_thickness_mm;
        if !(k.base_depth_mm > 2.0 * t && k.base_depth_mm <= 10.0 * self.dome.outer_radius_mm) {
            return check.bad(
                "skin.base_depth_mm",
                format!(
                    "must be in (2 skin_thickness = {}, 10 outer_radius = {}] mm, got {}",
                    2.0 * t,
                    10.0 * self.dome.outer_radius_mm,
                    k.base_depth_mm
                ),
            );
        }
        if !(k.gel_youngs_modulus_mpa > 0.0 && k.gel_youngs_modulus_mpa <= 1.0e6) {
            return check.bad(
                "skin.gel_youngs_modulus_mpa",
                format!("must be in (0, 1e6] MPa, got {}", k.gel_youngs_modulus_mpa),
            );
        }
        if !(0.0..=0.5).contains(&k.gel_poisson) {
            return check.bad("skin.gel_poisson", format!("must be in [0, 0.5], got {}", k.gel_poisson));
        }
        if !(0.0..=MAX_DOME_SLOPE).contains(&k.dome_slope) {
            return check.bad("skin.dome_slope", format!("must be in [0, {MAX_DOME_SLOPE}], got {}", k.dome_slope));
        }
        check.finite("skin.gap_radius_mm", k.gap_radius_mm)?;
        let (lo, hi) = (GAP_RADIUS_RANGE.0 * self.dome.outer_radius_mm, GAP_RADIUS_RANGE.1 * self.dome.outer_radius_mm);
        if k.gap_radius_mm != 0.0 && !(lo..=hi).contains(&k.gap_radius_mm) {
            return check.bad(
                "skin.gap_radius_mm",
                format!(
                    "must be 0 (the dome's own radius) or in [outer_radius / 4 = {lo}, 4 outer_radius = {hi}] mm, got {}",
                    k.gap_radius_mm
                ),
            );
        }
        if !(MIN_DOME_CELLS..=MAX_DOME_CELLS).contains(&k.dome_cells) {
            return check.bad(
                "skin.dome_cells",
                format!("must be in [{MIN_DOME_CELLS}, {MAX_DOME_CELLS}], got {}", k.dome_cells),
            );
        }
        // The gel needs two of the lattice's shells (tacsim-fem's `DomeSpec::validate`).
        if !(1..=MAX_DOME_SKIN_LAYERS).contains(&k.dome_skin_layers) || k.dome_skin_layers + 2 > k.dome_cells {
            return check.bad(
                "skin.dome_skin_layers",
                format!(
                    "must be in [1, {MAX_DOME_SKIN_LAYERS}] and at most skin.dome_cells - 2 = {} (the gel needs two \
                     of the lattice's shells), got {}",
                    k.dome_cells.saturating_sub(2),
                    k.dome_skin_layers
                ),
            );
        }
        if !(1..=MAX_DOME_SKIN_REFINEMENT).contains(&k.dome_skin_refinement) {
            return check.bad(
                "skin.dome_skin_refinement",
                format!("must be in [1, {MAX_DOME_SKIN_REFINEMENT}], got {}", k.dome_skin_refinement),
            );
        }
        let shells = k.dome_gel_shells();
        if shells > 0 && k.dome_skin_refinement == 1 {
            return check.bad(
                "skin.dome_refined_gel_shells",
                format!(
                    "must be 0 unless skin.dome_skin_refinement is above 1 (the gel's shells are refined with the \
                     skin), got {shells}"
                ),
            );
        }
        if shells.saturating_add(k.dome_skin_layers + 2) > k.dome_cells {
            return check.bad(
                "skin.dome_refined_gel_shells",
                format!(
                    "must be in [0, skin.dome_cells - skin.dome_skin_layers - 2 = {}] (the coarse gel keeps two of \
                     the lattice's shells), got {shells}",
                    k.dome_cells.saturating_sub(k.dome_skin_layers + 2),
                ),
            );
        }
        let r = self.dome.outer_radius_mm;
        if k.model == SkinModel::Dome && !(r..=2.0 * r).contains(&k.base_depth_mm) {
            return check.bad(
                "skin.base_depth_mm",
                format!(
                    "with skin.model = \"dome\" must be in [outer_radius = {r}, 2 outer_radius = {}] mm (the base at \
                     or below the dome's equator), got {}",
                    2.0 * r,
                    k.base_depth_mm
                ),
            );
        }
        Ok(())
    }

    /// The pins as the camera sees them: every tip in front of it, and the distortion monotonic
    /// over the part of the field the pins use (otherwise the image folds over).
    fn validate_geometry(&self, check: &Check) -> Result<()> {
        let (c, p) = (&self.camera, &self.pins);
        let rho = self.tip_radius_from_centre_mm();
        let theta_max = self.ring_polar_rad().last().copied().unwrap_or(0.0);
        let z_min = rho * theta_max.cos() + c.distance_mm - p.tip_radius_mm;
        if z_min <= 1e-3 {
            return check.bad(
                "camera.distance_mm",
                format!(
                    "the outer pins ({:.2} mm above the dome centre) would be behind the camera: increase distance_mm",
                    rho * theta_max.cos()
                ),
            );
        }
        let r_max = rho * theta_max.sin() / (rho * theta_max.cos() + c.distance_mm);
        let slope = |r: f64| 1.0 + 3.0 * c.k1 * r * r + 5.0 * c.k2 * r.powi(4);
        if (0..=20).any(|i| slope(r_max * i as f64 / 20.0) <= 0.0) {
            return check.bad(
                "camera.k1",
                "radial distortion folds the image over within the pin field: reduce |k1|, |k2|".to_owned(),
            );
        }
        Ok(())
    }
}

impl Validate for SensorParams {
    const EMPTY: (&'static str, &'static str) = (
        "(file)",
        "sets no field: write the fields that differ from the default (see \
         sim/presets/tactip-331-calibrated.toml), or leave out the sensor for the default",
    );

    fn validate(&self, source_name: &str) -> Result<()> {
        SensorParams::validate(self, source_name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_with_331_pins() {
        let s = SensorParams::default();
        s.validate("default").expect("default sensor is valid");
        assert_eq!(s.pin_count(), 331);
        assert_eq!(rings_for_pin_count(127), Some(6));
        assert_eq!(rings_for_pin_count(128), None);
    }

    #[test]
    fn a_partial_sensor_file_fills_in_from_the_half_space_not_the_default_dome() {
        // The default sensor became the dome; partial files (`docs/calibration-edge2d/base.toml`:
        // a dome radius and pins, no [skin]) kept their meaning.
        let partial = SensorParams::from_toml_str("[dome]\nouter_radius_mm = 40.0\n", "partial.toml").expect("parses");
        assert_eq!(partial.skin, SensorParams::half_space().skin);
        assert_eq!(partial.name, "tactip-331-calibrated");
    }

    #[test]
    fn toml_round_trip_and_partial_files() {
        let s = SensorParams::default();
        let back = SensorParams::from_toml_str(&s.to_toml(), "round-trip").expect("parses");
        assert_eq!(s, back);
        let partial = SensorParams::from_toml_str("[dome]\nouter_radius_mm = 25.0\n", "partial.toml").expect("parses");
        assert_eq!(partial.dome.outer_radius_mm, 25.0);
        assert_eq!(partial.pins, PinParams::default());
    }

    #[test]
    fn errors_name_file_and_field() {
        let e = SensorParams::from_toml_str("[dome]\nouter_radius_mm = -3.0\n", "s.toml").expect_err("negative");
        let msg = e.to_string();
        assert!(msg.contains("s.toml") && msg.contains("dome.outer_radius_mm"), "{msg}");
        let e = SensorParams::from_toml_str("[dome]\nouter_radius_mm = nan\n", "s.toml").expect_err("nan");
        assert!(e.to_string().contains("finite"), "{e}");
        let e = SensorParams::from_toml_str("[dome]\nradius = 3.0\n", "s.toml").expect_err("unknown");
        assert!(e.to_string().contains("radius"), "{e}");
        let e = SensorParams::from_toml_str("[pins]\nrings = 4\nring_polar_deg = [10.0, 5.0, 20.0, 30.0]\n", "s.toml")
            .expect_err("decreasing");
        assert!(e.to_string().contains("ring_polar_deg[1]"), "{e}");
        for (text, field) in [
            ("[framing]\nmask_radius = 0.9\n", "framing.mask_radius"),
            ("[framing]\nrim_radius = 0.4\nrim_width = -0.01\n", "framing.rim_width"),
            ("[framing]\nrim_radius = 0.4\n", "framing.rim_width"),
            ("[framing]\nrim_width = 0.02\n", "framing.rim_radius"),
            ("[pins]\npatch_radius_mm = 6.0\n", "pins.patch_radius_mm"),
            ("[pins]\npatch_radius_mm = -1.0\n", "pins.patch_radius_mm"),
            ("[pins]\npatch_radius_mm = inf\n", "pins.patch_radius_mm"),
            ("[camera]\ndistance_mm = -5.0\n", "camera.distance_mm"),
            ("[camera]\ndistance_mm = 1e300\n", "camera.distance_mm"),
            ("[skin]\ndome_slope = 4.0\n", "skin.dome_slope"),
            ("[skin]\ndome_slope = -0.5\n", "skin.dome_slope"),
            ("[skin]\ndome_slope = nan\n", "skin.dome_slope"),
            ("[skin]\nedge_subcells = 7\n", "skin.edge_subcells"),
            ("[skin]\ngap_radius_mm = 4.0\n", "skin.gap_radius_mm"),
            ("[skin]\ngap_radius_mm = 81.0\n", "skin.gap_radius_mm"),
            ("[skin]\ngap_radius_mm = -20.0\n", "skin.gap_radius_mm"),
            ("[skin]\ngap_radius_mm = inf\n", "skin.gap_radius_mm"),
            (
                "[dome]\nouter_radius_mm = 40.0\n[skin]\ngap_radius_mm = 9.0\n",
                "outer_radius / 4 = 10, 4 outer_radius = 160",
            ),
            ("[skin]\ndome_cells = 2\n", "skin.dome_cells"),
            ("[skin]\ndome_cells = 17\n", "skin.dome_cells"),
            ("[skin]\ndome_skin_layers = 0\n", "skin.dome_skin_layers"),
            ("[skin]\ndome_skin_refinement = 0\n", "skin.dome_skin_refinement"),
            ("[skin]\ndome_skin_refinement = 5\n", "skin.dome_skin_refinement"),
            (
                "[skin]\ndome_skin_refinement = 2\ndome_refined_gel_shells = 5\n",
                "skin.dome_cells - skin.dome_skin_layers - 2 = 4",
            ),
            (
                "[skin]\ndome_skin_refinement = 1\ndome_refined_gel_shells = 1\n",
                "unless skin.dome_skin_refinement is above 1",
            ),
            (
                "[skin]\ndome_skin_refinement = 2\ndome_refined_gel_shells = 18446744073709551615\n",
                "skin.dome_refined_gel_shells",
            ),
            ("[skin]\ndome_cells = 4\ndome_skin_layers = 4\n", "skin.dome_skin_layers"),
            // Regression: one gel shell passed and its mesh turned inside out in the build.
            ("[skin]\ndome_cells = 3\ndome_skin_layers = 2\n", "skin.dome_cells - 2 = 1"),
            ("[skin]\ndome_cells = 5\ndome_skin_layers = 4\n", "skin.dome_cells - 2 = 3"),
            ("[skin]\nmodel = \"dome\"\nbase_depth_mm = 19\n", "skin.base_depth_mm"),
            ("[skin]\nmodel = \"dome\"\nbase_depth_mm = 41\n", "skin.base_depth_mm"),
            ("[skin]\nedge_subcells = -1\n", "edge_subcells = -1"),
            ("[skin]\ncut_edges = 1\n", "cut_edges"),
            ("[pins]\nimage_offsets = [[0.0, 0.0]]\n", "pins.image_offsets"),
            (
                "[pins]\nrings = 1\nimage_offsets = [[0, 0], [0, 0], [0, 0], [0, 0.2], [0, 0], [0, 0], [0, 0]]\n",
                "pins.image_offsets[3][1]",
            ),
            (
                "[pins]\nrings = 1\nimage_offsets = [[0, 0], [0, 0], [0, 0], [0, 0], [0, 0], [0, 0], [nan, 0]]\n",
                "pins.image_offsets[6][0]",
            ),
            // An empty file silently meant the default sensor (issue 32).
            ("", "sets no field"),
            ("# only a comment\n", "sets no field"),
        ] {
            let e = SensorParams::from_toml_str(text, "s.toml").expect_err(text).to_string();
            assert!(e.contains("s.toml") && e.contains(field), "{text}: {e}");
        }
    }

    #[test]
    fn the_edge2d_preset_renders_every_pin_and_its_rim_at_its_128_px() {
        let sensor = SensorParams::edge2d().expect("valid preset");
        assert_eq!((sensor.camera.image_size, sensor.pin_count()), (128, 331));
        let img = crate::render::PinRenderer::new(&sensor, 128).expect("renderable").render_undeformed();
        let (lo, hi) = crate::detect::pin_area_range(128);
        assert_eq!(crate::detect::detect_pins(&img, lo, hi).len(), 331);
        // The rim: a white ring near the border, black beyond it.
        assert_eq!(img.get_pixel(1, 1).0[0], 0);
        let ring = (0..6).filter(|&y| img.get_pixel(64, y).0[0] == 255).count();
        assert!(ring >= 2, "{ring}");
    }

    #[test]
    fn half_space_equals_the_calibrated_preset() {
        let preset = SensorParams::preset("tactip-331-calibrated").expect("preset parses");
        assert_eq!(
            preset,
            SensorParams::half_space(),
            "rerun `tacsim calibrate` (docs/guide/calibration.md) and copy the values"
        );
    }

    #[test]
    fn a_body_named_without_a_sensor_is_the_calibrated_tactips_fit_for_it() {
        assert_eq!(SensorParams::calibrated_for(SkinModel::Dome), SensorParams::default());
        assert_eq!(SensorParams::calibrated_for(SkinModel::HalfSpace), SensorParams::half_space());
        let layer = SensorParams::calibrated_for(SkinModel::Layer);
        assert_eq!(layer.skin.model, SkinModel::Layer);
        assert_eq!(layer.dome, SensorParams::half_space().dome, "the half-space preset's skin");
    }

    #[test]
    fn default_equals_the_dome_preset() {
        let preset = SensorParams::preset("tactip-331-dome").expect("preset parses");
        assert_eq!(preset, SensorParams::default(), "copy sim/presets/tactip-331-dome.toml's values");
        assert_eq!(SensorParams::default().skin.model, SkinModel::Dome);
    }

    #[test]
    fn the_dome_presets_are_their_tactips_with_their_domes_fitted() {
        // `tacsim calibrate --dome` changes the body, the gel, the skin's thickness (the pins'
        // length with it, the tips kept) and the base, nothing else (docs/calibration-dome).
        for (name, of) in
            [("tactip-331-dome", "tactip-331-calibrated"), ("tactip-331-edge2d-dome", "tactip-331-edge2d")]
        {
            dome_preset_is_fitted_from(name, of);
        }
    }

    fn dome_preset_is_fitted_from(name: &str, of: &str) {
        let dome = SensorParams::preset(name).expect("preset parses");
        let calibrated = SensorParams::preset(of).expect("preset parses");
        assert_eq!(dome.skin.model, SkinModel::Dome);
        let tips = |s: &SensorParams| s.dome.skin_thickness_mm + s.pins.length_mm;
        assert!((tips(&dome) - tips(&calibrated)).abs() < 1e-12, "the tips are kept");
        let mut back = dome.clone();
        back.name = calibrated.name.clone();
        back.skin.model = calibrated.skin.model;
        back.skin.gel_youngs_modulus_mpa = calibrated.skin.gel_youngs_modulus_mpa;
        back.skin.base_depth_mm = calibrated.skin.base_depth_mm;
        back.dome.skin_thickness_mm = calibrated.dome.skin_thickness_mm;
        back.pins.length_mm = calibrated.pins.length_mm;
        assert_eq!(back, calibrated, "rerun the command in sim/presets/{name}.toml");
    }

    /// The default dome is `8x2+1` (issue 85: the pins within 0.01 mm of a finer mesh); a
    /// lattice too coarse for a refined gel shell gets none instead of an error about a field
    /// its file does not name, and a shell asked for by name is checked as given.
    #[test]
    fn the_default_dome_mesh_is_the_converged_one_and_coarse_lattices_still_parse() {
        let s = SensorParams::default().skin;
        assert_eq!((s.dome_cells, s.dome_skin_refinement, s.dome_gel_shells()), (8, 2, 1));
        let parse = |extra: &str| {
            let text = format!("[skin]\nmodel = \"dome\"\nbase_depth_mm = 20.0\n{extra}");
            SensorParams::from_toml_str(&text, "s.toml")
        };
        for (extra, shells) in [
            ("dome_cells = 4\n", 0),
            ("dome_cells = 5\n", 1),
            ("dome_cells = 4\ndome_skin_layers = 1\n", 1),
            ("dome_skin_refinement = 1\n", 0),
            ("dome_refined_gel_shells = 2\n", 2),
            ("dome_refined_gel_shells = 0\n", 0),
        ] {
            let sensor = parse(extra).unwrap_or_else(|e| panic!("{extra}: {e}"));
            assert_eq!(sensor.skin.dome_gel_shells(), shells, "{extra}");
        }
        let e = parse("dome_cells = 4\ndome_refined_gel_shells = 1\n").expect_err("no room for the shell");
        assert!(e.to_string().contains("skin.dome_refined_gel_shells"), "{e}");
        // Written back, an absent field stays absent (the default), a given one as given.
        let text = toml::to_string(&parse("").expect("default dome")).expect("toml");
        assert!(!text.contains("dome_refined_gel_shells") && !text.contains("dome_skin_refinement"), "{text}");
    }

    #[test]
    fn the_previous_camera_only_default_stays_a_valid_preset() {
        let camera = SensorParams::camera_only().expect("preset parses");
        assert_eq!(camera.pin_count(), 331);
        assert_eq!((camera.camera.distance_mm * 100.0).round(), 1065.0, "the documented old camera distance");
        assert_eq!((camera.pins.length_mm, camera.skin.poisson), (2.0, 0.5));
    }

    #[test]
    fn pin_count_option_keeps_outer_ring() {
        let s = SensorParams::default();
        let s127 = s.with_pin_count(127).expect("127 pins");
        assert_eq!(s127.pin_count(), 127);
        let a = s.ring_polar_rad().last().copied().expect("rings");
        let b = s127.ring_polar_rad().last().copied().expect("rings");
        assert!((a - b).abs() < 1e-12);
        assert!(s.with_pin_count(128).is_err());
    }
}
