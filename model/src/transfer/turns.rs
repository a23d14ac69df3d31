//! Test-time turns (`tacsim sim2real --turns N`): the simulator-trained network reads each
//! image `N` times, turned about its centre by `a_k = 360 k / N` deg (`k = 0..N`), and the
//! readings are averaged, the yaw turned back:
//!
//! ```text
//! yaw = arg sum_k exp(i (yaw_k - s a_k)),   v = (1/N) sum_k v_k   (every other label),
//! ```
//!
//! `s` the yaw's sense under a turn of the image ([`sense_on`]: +1 where turning the image
//! by `+a` reads the yaw `a` larger). The simulated sensor turns with its yaw about its axis,
//! so a network trained on it should read a turned image as the same tap at another yaw;
//! where it reads a lab's images with an error that depends on the direction (a bias towards
//! one yaw), the average over the turns cancels what changes with the direction and keeps what
//! does not. Only labels a turn leaves alone may be averaged: in an edge's frame its lateral
//! offset, the position along it and the depth ([`KEPT`]); the yaw is read and turned back.
//! How to turn an image is the caller's (it knows what the image holds: the pin motion's two
//! grids, `tacsim_sim::turn_motion`).

use super::difference;
use crate::data::Corpus;
use crate::error::{ModelError, Result};
use crate::eval::{corpus_images, predict_poses};
use crate::posenet::{Column, Pose, PoseNet, PoseScale};
use burn::tensor::Device;

/// Turns an image (a network's values, side px) by an angle (rad) about its centre.
pub type TurnImage = fn(&[f32], usize, f64) -> Vec<f32>;

/// The labels a turn of the image about the sensor's axis leaves alone, in an edge's frame:
/// the lateral offset from the edge, the position along it and the depth (mm).
pub const KEPT: [Column; 3] = [Column::PoseX, Column::PoseY, Column::PoseZ];

/// The most turns [`Turns::count`] takes.
pub const MAX_TURNS: usize = 64;

/// The turn that finds the yaw's sense ([`sense_on`]), a quarter turn: a reading near the
/// truth turned one way lies 180 deg from the truth turned the other.
const SENSE_TURN_DEG: f64 = 90.0;

/// The simulated images [`sense_on`] reads at most.
const SENSE_SAMPLES: usize = 256;

/// How a network's readings are averaged over turns of its input.
#[derive(Clone, Copy, Debug)]
pub struct Turns {
    /// How many readings, at `360 / count` deg steps (1: the image as it is).
    pub count: usize,
    /// Turns an image (the network's values, side px) by an angle (rad) about its centre.
    pub turn: TurnImage,
}

impl Turns {
    /// The turns' angles (deg): `360 k / count`.
    pub fn angles_deg(&self) -> Vec<f64> {
        (0..self.count).map(|k| 360.0 * k as f64 / self.count as f64).collect()
    }

    /// Refuses a count outside `1..=MAX_TURNS` and a network whose labels a turn would move
    /// other than its yaw (tilts, slide offsets), or that does not read the yaw
    /// (`check_labels`).
    pub fn check(&self, columns: &[Column]) -> Result<()> {
        if !(1..=MAX_TURNS).contains(&self.count) {
            return Err(ModelError::Config {
                field: "--turns".into(),
                reason: format!("{} turns: give 1 to {MAX_TURNS}", self.count),
            });
        }
        check_labels(columns, "--turns")
    }

    /// `images` read at every turn and averaged (`combine`); `sense` the yaw's sense under a turn
    /// of the image, as `sim2real` finds it on the simulated images.
    pub fn read(
        &self,
        net: &PoseNet,
        scale: &PoseScale,
        images: &[Vec<f32>],
        side: usize,
        device: &Device,
        sense: f64,
    ) -> Vec<Pose> {
        let angles = self.angles_deg();
        let readings: Vec<Vec<Pose>> = angles
            .iter()
            .map(|&a| {
                if a == 0.0 {
                    return predict_poses(net, scale, images, side, device);
                }
                let turned: Vec<Vec<f32>> = images.iter().map(|img| (self.turn)(img, side, a.to_radians())).collect();
                predict_poses(net, scale, &turned, side, device)
            })
            .collect();
        combine(&readings, &angles, sense)
    }
}

/// Refuses a network whose labels a turn of its images would move other than its yaw (tilts,
/// slide offsets), or that does not read the yaw; `flag` is the option that turns them
/// (`--turns`, `--edge-frame`), named in the error.
pub(super) fn check_labels(columns: &[Column], flag: &str) -> Result<()> {
    let moved: Vec<&str> =
        columns.iter().filter(|c| **c != Column::PoseRz && !KEPT.contains(c)).map(|c| c.name()).collect();
    if !columns.contains(&Column::PoseRz) || !moved.is_empty() {
        return Err(ModelError::Config {
            field: flag.into(),
            reason: format!(
                "the network reads {}: turned images need the yaw (pose_Rz) and otherwise only labels a turn \
                 leaves alone (an edge's frame: pose_x, pose_y, pose_z), not {}",
                columns.iter().map(|c| c.name()).collect::<Vec<_>>().join(", "),
                if moved.is_empty() { "a network without the yaw".to_owned() } else { moved.join(", ") }
            ),
        });
    }
    Ok(())
}

/// The yaw's sense under a turn of the image (`turn`), from up to 256 of the simulated set's
/// `rows`, whose yaw is known: each image turned by a quarter turn and read by `net`; +1 where
/// the readings lie nearer `truth + 90` than `truth - 90` deg (mean difference on the circle),
/// else -1 ([`sense_of`]). An error naming `flag` where neither lies within 45 deg on average:
/// the network does not read the yaw well enough to turn its images by it.
#[allow(clippy::too_many_arguments)]
pub(super) fn sense_on(
    net: &PoseNet,
    scale: &PoseScale,
    sim: &Corpus,
    rows: &[usize],
    side: usize,
    device: &Device,
    turn: TurnImage,
    flag: &str,
) -> Result<f64> {
    let probe = &rows[..rows.len().min(SENSE_SAMPLES)];
    let truth: Vec<Pose> = probe.iter().map(|&r| sim.pose(r)).collect();
    let turned: Vec<Vec<f32>> =
        corpus_images(sim, probe).iter().map(|img| turn(img, side, SENSE_TURN_DEG.to_radians())).collect();
    sense_of(&predict_poses(net, scale, &turned, side, device), &truth, SENSE_TURN_DEG, flag)
}

/// The sense of the yaw under a turn of `turn_deg`: +1 where `read` lies nearer `truth +
/// turn_deg` on average, -1 where nearer `truth - turn_deg`; an error naming `flag` where the
/// nearer is more than 45 deg off on average.
fn sense_of(read: &[Pose], truth: &[Pose], turn_deg: f64, flag: &str) -> Result<f64> {
    let off = |s: f64| {
        let n = read.len().min(truth.len()).max(1) as f64;
        read.iter()
            .zip(truth)
            .map(|(r, t)| difference(Column::PoseRz, r.yaw_deg(), t.yaw_deg() + s * turn_deg))
            .sum::<f64>()
            / n
    };
    let (plus, minus) = (off(1.0), off(-1.0));
    if plus.min(minus) > 45.0 || read.is_empty() {
        return Err(ModelError::Insufficient(format!(
            "{flag}: the simulator-trained network reads its own images turned by {turn_deg} deg {plus:.1} / \
             {minus:.1} deg off the yaw turned either way: it does not read the yaw well enough to turn its images \
             by it (train it longer, or drop {flag})"
        )));
    }
    Ok(if plus <= minus { 1.0 } else { -1.0 })
}

/// The readings at each turn (`readings[k]`, the images turned by `angles_deg[k]`) averaged:
/// the yaw turned back by `sense * angle` and averaged on the circle, the labels of [`KEPT`]
/// averaged plainly; every other label as read without a turn (the first reading).
pub fn combine(readings: &[Vec<Pose>], angles_deg: &[f64], sense: f64) -> Vec<Pose> {
    let Some(first) = readings.first() else { return Vec::new() };
    let n = readings.len() as f64;
    (0..first.len())
        .map(|i| {
            let mut p = first[i];
            for c in KEPT {
                p.set(c, readings.iter().map(|r| r[i].get(c)).sum::<f64>() / n);
            }
            let (sin, cos) = readings.iter().zip(angles_deg).fold((0.0, 0.0), |(s, c), (r, a)| {
                let y = (r[i].yaw_deg() - sense * a).to_radians();
                (s + y.sin(), c + y.cos())
            });
            p.set(Column::PoseRz, sin.atan2(cos).to_degrees());
            p
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tap(x: f64, z: f64, yaw: f64) -> Pose {
        let mut p = Pose::planar(x, 0.0, yaw);
        p.set(Column::PoseZ, z);
        p
    }

    #[test]
    fn turned_readings_average_to_the_yaw_turned_back_across_the_wrap() {
        // One tap at yaw 175 deg, read at four turns with sense -1 (the yaw reads smaller as
        // the image turns), each reading 2 deg off in turn, the lateral and depth noisy.
        let angles = [0.0, 90.0, 180.0, 270.0];
        let offs = [2.0, -2.0, 2.0, -2.0];
        let readings: Vec<Vec<Pose>> = angles
            .iter()
            .zip(offs)
            .enumerate()
            .map(|(k, (a, o))| vec![tap(1.0 + 0.1 * k as f64, 4.0 - 0.1 * k as f64, 175.0 - a + o)])
            .collect();
        let p = combine(&readings, &angles, -1.0)[0];
        assert!(difference(Column::PoseRz, p.yaw_deg(), 175.0) < 1e-9, "yaw {}", p.yaw_deg());
        assert!((p.x_mm() - 1.15).abs() < 1e-12 && (p.get(Column::PoseZ) - 3.85).abs() < 1e-12);
        // One turn is the reading itself.
        let one = vec![vec![tap(0.3, 3.5, -179.0)]];
        let q = combine(&one, &[0.0], 1.0)[0];
        assert!((q.yaw_deg() + 179.0).abs() < 1e-9 && q.x_mm() == 0.3);
    }

    #[test]
    fn the_yaws_sense_is_the_side_the_turned_readings_fall_on() {
        let truth: Vec<Pose> = (0..8).map(|k| tap(0.0, 4.0, -170.0 + 45.0 * k as f64)).collect();
        let plus: Vec<Pose> = truth.iter().map(|t| tap(0.0, 4.0, t.yaw_deg() + 95.0)).collect();
        let minus: Vec<Pose> = truth.iter().map(|t| tap(0.0, 4.0, t.yaw_deg() - 80.0)).collect();
        assert_eq!(sense_of(&plus, &truth, 90.0, "--turns").expect("sense"), 1.0);
        assert_eq!(sense_of(&minus, &truth, 90.0, "--turns").expect("sense"), -1.0);
        // Readings at chance: refused, saying why.
        let lost: Vec<Pose> = truth.iter().map(|t| tap(0.0, 4.0, t.yaw_deg() + 180.0)).collect();
        let e = sense_of(&lost, &truth, 90.0, "--turns").expect_err("refused").to_string();
        assert!(e.contains("--turns") && e.contains("does not read the yaw"), "{e}");
    }

    #[test]
    fn turns_refuse_labels_a_turn_moves_and_counts_out_of_range() {
        let turn: TurnImage = |v, _, _| v.to_vec();
        let ok = Turns { count: 8, turn };
        assert!(ok.check(&[Column::PoseX, Column::PoseZ, Column::PoseRz]).is_ok());
        let e = ok.check(&[Column::PoseZ, Column::PoseRx, Column::PoseRz]).expect_err("tilt").to_string();
        assert!(e.contains("--turns") && e.contains("pose_Rx"), "{e}");
        let e = ok.check(&[Column::PoseX, Column::PoseZ]).expect_err("no yaw").to_string();
        assert!(e.contains("without the yaw"), "{e}");
        for count in [0, MAX_TURNS + 1] {
            let e = Turns { count, turn }.check(&[Column::PoseRz]).expect_err("count").to_string();
            assert!(e.contains("--turns") && e.contains("1 to 64"), "{e}");
        }
        assert_eq!(Turns { count: 4, turn }.angles_deg(), vec![0.0, 90.0, 180.0, 270.0]);
    }
}
