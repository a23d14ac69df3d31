//! A lab's rig: how the poses its recordings are labelled with became the sensor poses the
//! robot reached. `tacsim calibrate` fits it from a lab folder ([`crate::calibrate`]); a
//! recipe's `[rig]` replays it so that simulated images carry the lab's labels
//! ([`crate::dataset::RigSpec`]).
//!
//! The labels live in the robot's frame; a [`RigFrame`] maps their lateral axes to the
//! sensor's. Tilts are rotation vectors: under an orthogonal map `M` their lateral part maps
//! by `det(M) M` and the twist by `det(M)`, times the frame's tilt sign: `-1` where the
//! labels' tilts turn the other way (the surface recordings do: a tilt moves the contact, and
//! with it the deformed pins, across the image opposite to the rotation-vector convention in
//! the frame their slides give). The [`Press`] says how the commanded depth and tilt were
//! executed under load.

use serde::{Deserialize, Serialize};

use crate::SensorPose;

/// How the rig pressed: depth zero, tilt pivot and yield under load.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Press {
    /// Added to the labelled depth (mm): where the robot's zero sits against first touch.
    pub depth_offset_mm: f64,
    /// Height (mm) above the dome apex, on the sensor's axis, of the point the robot tilts
    /// the sensor about (0: the apex).
    pub pivot_mm: f64,
    /// The rig's yield under load (mm^-0.5): a commanded indentation `c` (mm) loses
    /// `depth_compliance c^1.5`.
    pub depth_compliance: f64,
    /// The tilt's relaxation under load (1/mm): a tilt `t` becomes `t (1 - k c)` at a
    /// commanded indentation `c` (mm).
    pub tilt_relaxation_per_mm: f64,
    /// Where the pivot sits off the sensor's axis (mm, sensor frame `x`, `y`): a tool point
    /// a little off the dome's axis makes a tilt raise or lower the apex in proportion to the
    /// tilt, one way for one direction and the other way for the opposite one.
    #[serde(default)]
    pub pivot_offset_mm: [f64; 2],
    /// The rig's play in tilt (deg): the contact's off-axis load takes it up, turning the
    /// sensor back towards upright, so a labelled tilt of size `|t|` reaches the contact as
    /// `max(|t| - play, 0)` about the same axis (then relaxed by
    /// [`Press::tilt_relaxation_per_mm`]); a sensor above the surface keeps its full tilt.
    #[serde(default)]
    pub tilt_play_deg: f64,
}

impl Press {
    /// A press with these parameters (fields in order), the pivot on the sensor's axis.
    pub const fn new(depth_offset_mm: f64, pivot_mm: f64, depth_compliance: f64, tilt_relaxation_per_mm: f64) -> Self {
        Self {
            depth_offset_mm,
            pivot_mm,
            depth_compliance,
            tilt_relaxation_per_mm,
            pivot_offset_mm: [0.0; 2],
            tilt_play_deg: 0.0,
        }
    }

    /// This press with the pivot `offset_mm` off the sensor's axis (sensor frame, mm).
    pub const fn with_pivot_offset(self, offset_mm: [f64; 2]) -> Self {
        Self { pivot_offset_mm: offset_mm, ..self }
    }

    /// This press with `play_deg` of play in tilt ([`Press::tilt_play_deg`]).
    pub const fn with_tilt_play(self, play_deg: f64) -> Self {
        Self { tilt_play_deg: play_deg, ..self }
    }

    /// The share of a labelled tilt of size `tilt_deg` (deg) left after the play:
    /// `max(|t| - play, 0) / |t|` (1 without play or tilt).
    pub fn kept_by_play(&self, tilt_deg: f64) -> f64 {
        let t = tilt_deg.abs();
        if self.tilt_play_deg <= 0.0 || t == 0.0 { 1.0 } else { (t - self.tilt_play_deg).max(0.0) / t }
    }
}

/// The play in tilt a rig may have (deg, [`Press::tilt_play_deg`]): a recipe's `[rig]
/// tilt_play_deg` and `cargo xtask real-compare --tilt-play` are held to it.
pub const TILT_PLAY_RANGE_DEG: [f64; 2] = [0.0, 10.0];

/// The indentation (mm) a rig that yields `depth_compliance` (mm^-0.5) reaches when
/// commanded `commanded_mm`: `c - depth_compliance max(c, 0)^1.5` ([`Press::depth_compliance`]).
pub fn yielded_depth_mm(commanded_mm: f64, depth_compliance: f64) -> f64 {
    commanded_mm - depth_compliance * commanded_mm.max(0.0).powf(1.5)
}

/// An orthogonal map from the labels' lateral axes to the sensor's (row-major).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigFrame {
    /// `sensor = m * label` for lateral vectors.
    pub m: [[f64; 2]; 2],
    /// `1` where the labels' tilts are rotation vectors in that frame, `-1` where they turn
    /// the other way.
    pub tilt_sign: f64,
}

impl RigFrame {
    /// The identity.
    pub const IDENTITY: RigFrame = RigFrame { m: [[1.0, 0.0], [0.0, 1.0]], tilt_sign: 1.0 };

    /// Rotation by `deg`, mirrored (`y -> -y` first) when `mirrored`; tilts as rotation
    /// vectors.
    pub fn new(deg: f64, mirrored: bool) -> Self {
        let (s, c) = deg.to_radians().sin_cos();
        let f = if mirrored { -1.0 } else { 1.0 };
        RigFrame { m: [[c, -s * f], [s, c * f]], tilt_sign: 1.0 }
    }

    /// This frame with the tilts reversed when `reversed`.
    pub fn with_tilts_reversed(self, reversed: bool) -> Self {
        Self { tilt_sign: if reversed { -1.0 } else { 1.0 }, ..self }
    }

    fn det(&self) -> f64 {
        self.m[0][0] * self.m[1][1] - self.m[0][1] * self.m[1][0]
    }

    fn apply(&self, v: [f64; 2]) -> [f64; 2] {
        [self.m[0][0] * v[0] + self.m[0][1] * v[1], self.m[1][0] * v[0] + self.m[1][1] * v[1]]
    }

    /// Touch-down and target sensor poses (mm, deg) of a recording labelled `pose` and `shear`
    /// (`[x, y, z, Rx, Ry, Rz]`, the labels' frame) pressed as `press` says; lateral positions
    /// relative to the labels' origin, depth below a flat top face.
    ///
    /// The robot tilts the sensor about a pivot `h = press.pivot_mm` above the apex on the
    /// sensor's axis, which stays where it is at zero tilt; so a tilt `(rx, ry)` raises the
    /// apex by `h (1 - cos rx cos ry)` (mm) and the flat surface's indentation (the dome's
    /// lowest point, radius `R`) is `z + (R - h)(1 - cos rx cos ry)`. A pivot off the axis by
    /// `(p_x, p_y)` (sensor frame, `press.pivot_offset_mm`) raises the apex by a further
    /// `p_x sin ry - p_y sin rx` (the vertical part of the apex's turn about the pivot). The
    /// pivot's lateral motion does not matter on a flat surface (on an edge it would: the rig
    /// is modelled for flat surfaces).
    ///
    /// The rig yields under the contact load (the robot's joints, the sensor's mount and
    /// body): of a commanded indentation `c = z + depth offset` (mm) the sensor loses
    /// `press.depth_compliance c^1.5` (the load of a sphere pressed into a half-space grows as
    /// `c^1.5`), and its tilt relaxes to `t (1 - press.tilt_relaxation_per_mm c)`, the
    /// off-axis load turning it back towards upright; before that, the rig's play in tilt
    /// (`press.tilt_play_deg`) is taken off the tilt's size ([`Press::kept_by_play`]).
    pub fn poses(&self, pose: &[f64; 6], shear: &[f64; 6], press: &Press) -> (SensorPose, SensorPose) {
        let d = self.det();
        let commanded = pose[2] + press.depth_offset_mm;
        let loaded = commanded.max(0.0);
        // Unloaded (above the surface) the rig neither yields nor takes up its play.
        let play = if loaded > 0.0 { press.kept_by_play(pose[3].hypot(pose[4])) } else { 1.0 };
        let relaxed = (1.0 - press.tilt_relaxation_per_mm * loaded).max(0.0) * play;
        let tilt = self.apply([pose[3], pose[4]]).map(|v| self.tilt_sign * relaxed * v);
        let offset = self.apply([shear[0], shear[1]]);
        let (rx, ry) = ((d * tilt[0]).to_radians(), (d * tilt[1]).to_radians());
        let [px, py] = press.pivot_offset_mm;
        let lift = press.pivot_mm * (1.0 - rx.cos() * ry.cos()) + px * ry.sin() - py * rx.sin();
        let at = self.apply([pose[0], pose[1]]);
        let target = SensorPose {
            x_mm: at[0],
            y_mm: at[1],
            depth_mm: yielded_depth_mm(commanded, press.depth_compliance) - lift,
            yaw_deg: d * pose[5],
            rx_deg: d * tilt[0],
            ry_deg: d * tilt[1],
        };
        let start = SensorPose {
            x_mm: at[0] + offset[0],
            y_mm: at[1] + offset[1],
            yaw_deg: target.yaw_deg + d * shear[5],
            ..target
        };
        (start, target)
    }
}
