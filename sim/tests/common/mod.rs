//! Helpers shared by the integration tests.

use std::path::PathBuf;

/// `rel` under the shared data folder ([`tacsim_sim::shared_for_test`]: `TACSIM_SHARED`,
/// default `../shared` next to the repository), or `None` after printing why the test skips;
/// under `CI=true` a missing folder fails the test.
pub fn shared(rel: &str) -> Option<PathBuf> {
    tacsim_sim::shared_for_test(rel)
}
