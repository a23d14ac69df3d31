//! The real recordings of `../shared/data/real-tactip-surface3d`: how many pins are tracked,
//! and the simulated undeformed pins against the real reference. Skips, saying so, where the
//! shared data is absent (set `TACSIM_SHARED`). `cargo xtask real-compare` prints the
//! comparison of the deformed pins.

mod common;

use std::path::PathBuf;

use tacsim_data::LabFolder;
use tacsim_sim::calibrate::observe::Observations;

fn folder() -> Option<PathBuf> {
    common::shared("data/real-tactip-surface3d")
}

#[test]
fn real_pins_are_tracked_and_the_label_frame_is_found() {
    let Some(dir) = folder() else { return };
    let lab = LabFolder::open(&dir).expect("lab folder");
    let obs = Observations::track(&lab, "image_0.png").expect("tracking");
    let n = obs.reference.len();
    let tracked: Vec<usize> = obs.samples.iter().map(|o| n - o.tracking.unmatched()).collect();
    let mean = tracked.iter().sum::<usize>() as f64 / tracked.len() as f64;
    let min = tracked.iter().min().copied().unwrap_or(0);
    println!("{} reference pins; tracked per sample: mean {mean:.1}, min {min}", n);
    let shifts: Vec<f64> =
        obs.samples.iter().map(|o| o.tracking.global_shift[0].hypot(o.tracking.global_shift[1])).collect();
    println!("global shift: max {:.1} px", shifts.iter().fold(0.0f64, |m, v| m.max(*v)));
    // Most pins are tracked in every sample; those that move more than the match radius near
    // a deep contact are reported unmatched, not guessed.
    assert!(mean > 250.0 && min > 150, "mean {mean}, min {min}");
    // The undeformed simulated pins sit within 1 px RMS of the real reference's.
    let cat = tacsim_sim::stimulus::Catalogue::load_dir(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes"))
        .expect("catalogue");
    let base = tacsim_sim::SensorParams::default();
    let d = tacsim_sim::calibrate::model::Deformation::of(&base, 0.5);
    let disk = cat.get("disk").expect("disk");
    let sim = tacsim_sim::calibrate::evaluate::Simulator::new(&base, &d, 13, &obs, &disk).expect("simulator");
    let (rms, matched) = sim.undeformed_rms(&obs);
    println!("undeformed: {matched} of {n} reference pins matched, RMS {rms:.2} px");
    assert_eq!(matched, n);
    assert!(rms < 1.0, "{rms}");
}
