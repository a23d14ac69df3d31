//! Calibrating the deformation model against real recordings: track the real pins
//! ([`Observations`]), find the labels' frame from the data ([`best_frame`]), simulate the
//! same recordings with that label frame and deformation parameters ([`Deformation`]), measure
//! the difference ([`Simulator`]; `cargo xtask real-compare` prints it), fit the parameters on
//! 80% of the recordings ([`fit`], [`RecordingSplit`]) and report on the held-out 20%
//! ([`held_out`], [`markdown`]; `tacsim calibrate` runs both). [`Reference`] finds the
//! undeformed layout (an undeformed image, or the consensus of the most alike shallow
//! recordings) and cuts non-square images square; [`fit_camera_only`] fits a sensor's camera,
//! ring layout and framing to that reference alone ([`ring_profile`], [`fit_camera`]: the
//! rings of one image); [`edge_scene`] and [`tap_errors`] do the same for taps on a
//! stimulus's edge.

mod camera;
mod dome;
pub mod edge;
mod evaluate;
mod fitting;
mod frame;
mod model;
mod observe;
mod reference;
mod report;
pub(crate) mod rings;

pub use crate::motion::SPACING_PX420;
pub use camera::{CameraFit, fit_camera_only, fit_pin_offsets};
pub use dome::{DOME_STEPS, DomePoint, DomeScore, DomeSearch, DomeTrial, GEL_RATIO_RANGE, dome_start, search_dome};
pub use edge::{
    EdgeLabels, MAX_DEPTH_COMPLIANCE, Signs, edge_scene, edge_sensor_pose, fit_labels, pooled_error, start_labels,
    tap_errors,
};
pub use evaluate::{Field, Simulator};
pub use fitting::{Calibration, Candidate, FitOptions, Problem, RecordingSplit, calibrate as fit};
pub use frame::{FrameFit, ImageMap, ShiftSample, best_frame, label_frame, shift_samples};
pub use model::{Deformation, SampleError};
pub use observe::{Observation, Observations};
pub use reference::{
    CONSENSUS_MIN, CONSENSUS_POOL, ConsensusRule, DEFAULT_REFERENCE, PinField, Reference, ReferenceSource, SquareCrop,
};
pub use report::{
    DIRECTION_MIN_SHIFT_PX420, FrameReport, GRID_SAMPLES, Means, Report, TARGET_DIRECTION_DEG, TARGET_RELATIVE_ERROR,
    comparison_row, held_out, markdown,
};
pub use rings::{
    Comparison, RingProfile, RingStats, compare_sensor, fit_camera, fit_camera_at, fit_framing, fit_realism,
    fit_ring_angles, ring_profile, ring_table,
};
