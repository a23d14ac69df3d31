//! The tacsim dataset format and its loader, shared by the generator (`tacsim-sim`) and the
//! learning crate (which never depends on the simulator).
//!
//! A dataset directory holds:
//! - `images/image_0.png`: the undeformed reference; `images/image_N.png` (N >= 1): samples;
//! - `targets.csv`: one [`Row`] per sample, in the lab's column style (`sensor_image`,
//!   `pose_x..pose_Rz`, `shear_x..shear_Rz`) plus `kind`, `shape`, `pose_id`, `split`,
//!   `paired`;
//! - `meta.json`: the [`Meta`]: recipe, sensor, seed, tool version, counts;
//! - `SHA256SUMS`: every file's SHA-256 (`sha256sum`'s format), written when the run finishes
//!   (see [`verify`]).
//!
//! Units: mm and degrees. `pose_*` is the sensor pose relative to the shape's contact location
//! (depth `pose_z` below the stimulus's top face); `shear_*` is the touch-down offset of a
//! slide (the sensor touched down at `pose + shear` and slid to `pose`), zero for taps.

mod angle;
mod atomic;
mod checksum;
mod column;
mod error;
mod hash;
mod lab;
mod loader;
mod meta;
mod row;

pub use angle::wrap_deg;
pub use atomic::{is_temp_name, temp_path, write_atomic, write_atomic_unsynced};
pub use checksum::{
    CHECKSUMS_FILE, JOURNAL_FILE, Journal, Verification, expected_entries, image_entry, read_checksums,
    recorded_checksums, sha256_hex, verify, write_checksums,
};
pub use column::Column;
pub use error::{DataError, Result};
pub use hash::{Fnv1a, SplitMix64, fnv1a, splitmix64};
pub use lab::{LAB_IMAGE_SIDE_PX, LabFolder, LabSample, MAX_LABEL, check_lab_image_alike, check_lab_image_size};
pub use loader::{Dataset, Subset};
pub use meta::{Meta, PoseFrame, Shard};
pub use row::{Kind, Row, Split, read_csv, to_csv};
