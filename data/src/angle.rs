//! Angles in labels and readings: one wrap for every crate.

/// Wraps an angle into `(-180, 180]` degrees.
pub fn wrap_deg(a: f64) -> f64 {
    let w = (a + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 { 180.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_wrap_into_the_half_open_turn() {
        for (a, w) in [(0.0, 0.0), (180.0, 180.0), (-180.0, 180.0), (190.0, -170.0), (-190.0, 170.0), (720.5, 0.5)] {
            assert!((wrap_deg(a) - w).abs() < 1e-12, "{a} -> {}", wrap_deg(a));
        }
    }
}
