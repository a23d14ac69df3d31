//! tacsim-sim: the TacTip simulator.
//!
//! Data flows one way: [`SensorParams`] -> [`PinLayout`] -> the [`contact`] engine
//! ([`SensorPath`]s of [`SensorPose`]s over a [`Scene`] of [`stimulus`] objects, giving
//! [`PinPose`]s) -> [`Camera`] projection -> binary image ([`PinRenderer`]), optionally through
//! [`Realism`] and the lab's [`LabProcessing`]. [`dataset`] strings it into recipes of taps and
//! slides; [`detect_blobs`], [`track`] and [`calibrate`] read pins back from images (real or
//! simulated) and fit the sensor to a lab's recordings.
//!
//! Modules are private; this list and the four namespaces ([`calibrate`], [`contact`],
//! [`dataset`], [`stimulus`]) are the surface. Frames of reference are defined once: the sensor
//! frame in [`SensorParams`], image coordinates in [`Camera`], the world frame in [`Scene`], the
//! sensor pose in [`SensorPose`].

mod atomic;
mod camera;
mod check;
mod columns;
mod detect;
mod embedded;
mod error;
mod fit;
#[cfg(feature = "wgpu")]
mod gpu;
mod motion;
mod pins;
mod png_io;
mod processing;
mod raster;
mod realism;
mod render;
mod rig;
mod scene;
mod sensor;
mod shared;
mod tracking;
mod variation;

pub mod bench;
pub mod calibrate;
pub mod contact;
pub mod dataset;
pub mod stimulus;

pub use camera::{Camera, Disc};
pub use contact::pose::SensorPose;
pub use contact::trajectory::{Capture, SensorPath};
pub use detect::{Blob, detect_blobs, match_reference, pin_centres};
pub use embedded::{RECIPES, SHAPE_FILES, catalogue as builtin_catalogue};
pub use error::{Result, SimError};
#[cfg(feature = "wgpu")]
pub use gpu::Gpu;
#[cfg(feature = "wgpu")]
#[doc(hidden)]
pub use gpu::for_tests as gpu_for_tests;
pub use motion::{MIN_MOTION_FIELD, MOTION_FIELD, PinMotion, turn_motion};
pub use pins::{Pin, PinLayout, PinPose};
pub use png_io::{PngDepth, decode_png, read_png, write_png};
pub use processing::LabProcessing;
pub use realism::Realism;
pub use render::PinRenderer;
pub use rig::{Press, RigFrame, TILT_PLAY_RANGE_DEG};
pub use scene::{NearEdges, ObjectId, ObjectPose, Scene, SceneObject, SurfaceHit, flat_scene};
pub use sensor::{
    CameraParams, DEFAULT_EDGE_SUBCELLS, DomeParams, FramingParams, MAX_EDGE_SUBCELLS, MAX_IMAGE_OFFSET, PRESETS,
    PinParams, SensorParams, SkinModel, SkinParams, pin_count,
};
pub use shared::{SHARED_ENV, shared_folder, shared_for_test};
pub use tracking::{Tracking, Warp, global_shift, global_warp, nearest_neighbours, track};
pub use variation::Variation;
