//! Atomic file writes (temporary file, optional fsync, rename), from `tacsim-data` where the
//! learning crate shares them; their errors become [`crate::SimError::Io`] through `?`.

pub use tacsim_data::{is_temp_name, write_atomic, write_atomic_unsynced};
