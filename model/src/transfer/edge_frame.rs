//! Reading in the edge's frame (`tacsim sim2real --edge-frame`): two networks in turn. The
//! first (the simulator-trained network, trained on every yaw) reads the yaw; each image is
//! then turned about its centre by minus that yaw, so that its edge lies as at yaw 0, and a
//! second network, trained on the simulated images each turned by minus its own yaw, reads the
//! labels a turn leaves alone (the lateral offset, the position along the edge, the depth):
//!
//! ```text
//! yaw = first(image),   v = second(turn(image, -s yaw))   (v: pose_x, pose_y, pose_z),
//! ```
//!
//! `s` the yaw's sense under a turn of the image (found as for [`Turns`](super::Turns)). The second network sees
//! one direction of the edge only, so it need not learn how the lateral and the depth look at
//! every yaw; where the first network's yaw is off by `e`, the second reads an edge turned by
//! `e`. How to turn an image is the caller's, as for [`Turns`](super::Turns).
//!
//! The network trained on the lab's fitting part is read the same way, for a like-for-like
//! reference: its own second network, trained on the fitting images each turned by minus its
//! labelled yaw ([`lab_in_edge_frame`], the lab's sense from [`lab_yaw_sense`]), reads the
//! held-out images turned by minus the yaw it read.
//!
//! With [`EdgeStage::match_motion`] each lab image, once turned, is matched pixel by pixel to
//! the simulated images in the same frame ([`Matching`]): every value's mean and spread over the
//! lab's fitting images taken to the simulated training images' (labels unused),
//!
//! ```text
//! v' = m_sim + (v - m_lab) s_sim / s_lab   (each pixel; left as it is where s_lab < 1e-3),
//! ```
//!
//! unsupervised adaptation of the input, as `--adapt-norms` is of the batch norms. In the
//! edge's frame the two sets' poses spread alike (the lateral and the depth over the same
//! spans), so a pixel's mean and spread differ where the motion does, not where the poses do.

use std::path::Path;

use burn::tensor::Device;

use super::LabelMap;
use super::turns::{KEPT, TurnImage, check_labels, sense_on};
use crate::backend::Backend;
use crate::data::Corpus;
use crate::error::{ModelError, Result};
use crate::eval::{corpus_images, predict_poses};
use crate::images::ImageSet;
use crate::infer::load_posenet;
use crate::posenet::{Column, Pose, PoseNet, PoseScale};

/// The second network of [`score`](super::score)'s reading in the edge's frame: its run and
/// the yaw's sense under a turn of the image ([`yaw_sense`]).
#[derive(Clone, Copy, Debug)]
pub struct EdgeStage<'a> {
    /// The run of the network trained on the simulated images turned into the edge's frame
    /// ([`in_edge_frame`]).
    pub run: &'a Path,
    /// +1 or -1: turning an image by `+a` reads its yaw `s a` larger.
    pub sense: f64,
    /// Turns an image (the network's values, side px) by an angle (rad) about its centre.
    pub turn: TurnImage,
    /// Match each turned lab image's pixels to the simulated images' mean and spread
    /// ([`Matching`]).
    pub match_motion: bool,
}

/// The labels the second network reads: those of `sim_labels` a turn leaves alone. Refuses
/// a set whose labels a turn would move other than the yaw, or without the yaw, as
/// [`Turns::check`](super::Turns::check) does, and one with nothing left to read.
pub fn edge_frame_labels(sim_labels: &[Column]) -> Result<Vec<Column>> {
    check_labels(sim_labels, "--edge-frame")?;
    let kept: Vec<Column> = sim_labels.iter().copied().filter(|c| KEPT.contains(c)).collect();
    if kept.is_empty() {
        return Err(ModelError::Config {
            field: "--edge-frame".into(),
            reason: "the simulated set varies the yaw only: nothing is left to read in the edge's frame".into(),
        });
    }
    Ok(kept)
}

/// The yaw's sense under a turn of the image, found with the network of `run` on up to 256 of
/// `rows` of `sim`, as for [`Turns`](super::Turns) (an error where that network does not read the yaw).
pub fn yaw_sense(
    backend: Backend,
    side: usize,
    run: &Path,
    sim: &Corpus,
    rows: &[usize],
    turn: TurnImage,
) -> Result<f64> {
    let device = backend.device();
    let (net, _, scale) = load_posenet(run, &device)?;
    sense_on(&net, &scale, sim, rows, side, &device, turn, "--edge-frame")
}

/// `corpus` with the images of `rows` (None: every row) turned about their centres by minus
/// `sense` times their own yaw labels, so that their edges lie as at yaw 0, and matched where
/// `matching` is given; every other image as it is and the labels unchanged (the second
/// network does not read the yaw). Values are rounded to the image's 8 bits as stored.
pub fn in_edge_frame(
    corpus: &Corpus,
    rows: Option<&[usize]>,
    (sense, turn): (f64, TurnImage),
    matching: Option<&Matching>,
) -> Result<Corpus> {
    use rayon::prelude::*;
    let n = corpus.dataset.rows.len();
    let mut chosen = vec![rows.is_none(); n];
    for &r in rows.unwrap_or(&[]) {
        chosen[r] = true;
    }
    let images: Vec<Vec<u8>> = (0..n)
        .into_par_iter()
        .map(|r| match chosen[r] {
            true => stored_turn(corpus, r, (sense, turn), matching),
            false => corpus.images.image(r).to_vec(),
        })
        .collect();
    Ok(Corpus { dataset: corpus.dataset.clone(), images: ImageSet::from_raw(corpus.side(), &images)? })
}

/// The lab's yaw sense under a turn of its images: the simulator's `sim_sense` times the sign
/// of `map`'s link from the simulated yaw to the lab's (`real = sign sim + offset`).
pub(super) fn lab_sense(map: &LabelMap, sim_sense: f64) -> Result<f64> {
    map.links.iter().find(|l| l.real.is_angle() && l.sim == Column::PoseRz).map(|l| sim_sense * l.sign).ok_or_else(
        || ModelError::Config {
            field: "--edge-frame".into(),
            reason: "the label map links no lab label to the simulated yaw (pose_Rz): nothing to turn the images by"
                .into(),
        },
    )
}

/// The lab's yaw sense under a turn of its images as the fine-tuning curve's from-scratch arm
/// takes it ([`Curve`](super::Curve)): the label map fitted on the simulator-trained network's
/// (`sim_run`) readings of the lab's `rows`, the images as they are; the sense is `sim_sense`
/// times the sign of the map's link from the simulated yaw to the lab's. `side`: the networks'
/// image side (px).
pub fn lab_yaw_sense(
    (backend, side): (Backend, usize),
    sim_run: &Path,
    real: &Corpus,
    rows: &[usize],
    labels: &[Column],
    sim_sense: f64,
) -> Result<f64> {
    let device = backend.device();
    let (net, _, scale) = load_posenet(sim_run, &device)?;
    let read = predict_poses(&net, &scale, &corpus_images(real, rows), side, &device);
    let truth: Vec<Pose> = rows.iter().map(|&r| real.pose(r)).collect();
    lab_sense(&LabelMap::fit(&read, &scale.columns(), &truth, labels)?, sim_sense)
}

/// The lab's corpus with `rows` its only training rows ([`Corpus::training_only`], in the lab's
/// labels `labels`), their images turned into the edge's frame by their labelled yaws (`sense`:
/// the lab's, [`lab_yaw_sense`]): what a network on the lab's own labels learns the edge's
/// frame from (`tacsim sim2real --edge-frame`'s real-trained second network, and the
/// fine-tuning curve's from-scratch arm on the same rows).
pub fn lab_in_edge_frame(real: &Corpus, rows: &[usize], labels: &[Column], turn: (f64, TurnImage)) -> Result<Corpus> {
    in_edge_frame(&real.training_only(rows, |pose| *pose, labels), Some(rows), turn, None)
}

/// Row `r`'s image of `corpus` turned by minus `sense` times its yaw label (matched where
/// `matching` is given), in 8 bits.
fn stored_turn(corpus: &Corpus, r: usize, (sense, turn): (f64, TurnImage), matching: Option<&Matching>) -> Vec<u8> {
    let values: Vec<f32> = corpus.images.image(r).iter().map(|&v| f32::from(v) / 255.0).collect();
    let turned = turn(&values, corpus.side(), (-sense * corpus.pose(r).yaw_deg()).to_radians());
    stored(match matching {
        Some(m) => m.apply(&turned),
        None => turned,
    })
}

/// An image's values (0..1, clamped) in the 8 bits a corpus stores.
fn stored(values: Vec<f32>) -> Vec<u8> {
    values.into_iter().map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8).collect()
}

/// Each pixel's mean and spread over a set of images (population spread).
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    /// Mean of each pixel.
    pub mean: Vec<f32>,
    /// Standard deviation of each pixel.
    pub spread: Vec<f32>,
}

impl Moments {
    /// The moments of `images` (all of one length; none: empty).
    pub fn of<'a>(images: impl IntoIterator<Item = &'a [f32]>) -> Self {
        let (mut sum, mut sq, mut n) = (Vec::<f64>::new(), Vec::<f64>::new(), 0.0);
        for img in images {
            if sum.is_empty() {
                (sum, sq) = (vec![0.0; img.len()], vec![0.0; img.len()]);
            }
            for (i, &v) in img.iter().enumerate().take(sum.len()) {
                sum[i] += f64::from(v);
                sq[i] += f64::from(v) * f64::from(v);
            }
            n += 1.0;
        }
        let mean: Vec<f64> = sum.iter().map(|s| s / n).collect();
        Self {
            spread: sq.iter().zip(&mean).map(|(q, m)| (q / n - m * m).max(0.0).sqrt() as f32).collect(),
            mean: mean.into_iter().map(|m| m as f32).collect(),
        }
    }
}

/// A pixel whose spread over the lab's images is below this is left as it is.
const MATCH_MIN_SPREAD: f32 = 1e-3;

/// The lab's images matched pixel by pixel to the simulated ones (see the module
/// documentation): `v' = sim.mean + (v - lab.mean) sim.spread / lab.spread`, clamped to 0..1.
#[derive(Clone, Debug, PartialEq)]
pub struct Matching {
    /// The lab's fitting images' moments.
    pub lab: Moments,
    /// The simulated training images' moments.
    pub sim: Moments,
}

impl Matching {
    /// `image` matched.
    pub fn apply(&self, image: &[f32]) -> Vec<f32> {
        image
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                match (self.lab.mean.get(i), self.lab.spread.get(i), self.sim.mean.get(i), self.sim.spread.get(i)) {
                    (Some(&ml), Some(&sl), Some(&ms), Some(&ss)) if sl >= MATCH_MIN_SPREAD => {
                        (ms + (v - ml) * ss / sl).clamp(0.0, 1.0)
                    }
                    _ => v,
                }
            })
            .collect()
    }
}

/// Each of `images` turned about its centre by minus `sense` times the yaw of its pose in
/// `poses` (deg; a reading or a label).
pub(super) fn turned_by(
    images: &[Vec<f32>],
    poses: &[Pose],
    (sense, turn): (f64, TurnImage),
    side: usize,
) -> Vec<Vec<f32>> {
    images.iter().zip(poses).map(|(img, p)| turn(img, side, (-sense * p.yaw_deg()).to_radians())).collect()
}

/// The second network loaded, ready to read images whose yaw the first has read.
pub(super) struct EdgeReader {
    net: PoseNet,
    scale: PoseScale,
    sense: f64,
    turn: TurnImage,
    matching: Option<Matching>,
}

/// The lab's fitting images and the first network's readings of them: what the second
/// network's input is matched to ([`EdgeStage::match_motion`]) and its batch norms adapted on.
pub(super) struct Fitting<'a> {
    pub(super) images: &'a [Vec<f32>],
    pub(super) first: &'a [Pose],
    /// Re-estimate the second network's batch norms on them (`--adapt-norms`).
    pub(super) adapt_norms: bool,
}

/// The matching of the lab's fitting images, each already turned by minus `sense` times the
/// yaw the first network read of it ([`turned_by`]), to `sim`'s training rows turned by their
/// own yaws ([`EdgeStage::match_motion`]).
pub(super) fn lab_matching(
    (sense, turn): (f64, TurnImage),
    (sim, sim_rows): (&Corpus, &[usize]),
    turned_fitting: &[Vec<f32>],
) -> Matching {
    let sim_images: Vec<Vec<f32>> = sim_rows
        .iter()
        .map(|&r| stored_turn(sim, r, (sense, turn), None).into_iter().map(|v| f32::from(v) / 255.0).collect())
        .collect();
    Matching {
        lab: Moments::of(turned_fitting.iter().map(Vec::as_slice)),
        sim: Moments::of(sim_images.iter().map(Vec::as_slice)),
    }
}

impl EdgeReader {
    /// The network of `run`, reading images turned by minus `sense` times the yaw read and
    /// matched by `matching` where given.
    pub(super) fn new(
        run: &Path,
        (sense, turn): (f64, TurnImage),
        matching: Option<Matching>,
        device: &Device,
    ) -> Result<Self> {
        let (net, _, scale) = load_posenet(run, device)?;
        Ok(Self { net, scale, sense, turn, matching })
    }

    /// Loads `stage`'s network; with [`EdgeStage::match_motion`], the matching of the lab's
    /// fitting images turned by their yaws read to `sim`'s training rows turned by their own
    /// yaws; with `fit.adapt_norms`, its batch norms re-estimated on the fitting images as it
    /// will read them.
    pub(super) fn load(
        stage: &EdgeStage<'_>,
        sim: (&Corpus, &[usize]),
        fit: &Fitting<'_>,
        side: usize,
        device: &Device,
    ) -> Result<Self> {
        let mut reader = Self::new(stage.run, (stage.sense, stage.turn), None, device)?;
        if !(stage.match_motion || fit.adapt_norms) {
            return Ok(reader);
        }
        // The fitting images turned once (not yet matched): the lab's moments, then what the
        // batch norms adapt on.
        let turned = reader.turned(fit.images, fit.first, side);
        if stage.match_motion {
            reader.matching = Some(lab_matching((stage.sense, stage.turn), sim, &turned));
        }
        if fit.adapt_norms {
            let input: Vec<Vec<f32>> = match &reader.matching {
                Some(m) => turned.iter().map(|v| m.apply(v)).collect(),
                None => turned,
            };
            reader.net = reader.net.adapt_norms(&input, side, device);
        }
        Ok(reader)
    }

    /// `images` turned by minus the yaws read, matched where the reader matches.
    fn turned(&self, images: &[Vec<f32>], first: &[Pose], side: usize) -> Vec<Vec<f32>> {
        let turned = turned_by(images, first, (self.sense, self.turn), side);
        match &self.matching {
            None => turned,
            Some(m) => turned.iter().map(|v| m.apply(v)).collect(),
        }
    }

    /// `first` (the first network's readings of `images`) with the labels the second network
    /// reads taken from it, each image turned by minus its yaw read.
    pub(super) fn read(&self, images: &[Vec<f32>], first: &[Pose], side: usize, device: &Device) -> Vec<Pose> {
        let second = predict_poses(&self.net, &self.scale, &self.turned(images, first, side), side, device);
        let columns = self.scale.columns();
        first
            .iter()
            .zip(second)
            .map(|(p, q)| {
                let mut out = *p;
                for &c in &columns {
                    out.set(c, q.get(c));
                }
                out
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matched_images_take_the_simulated_moments_and_still_pixels_stay() {
        // Three lab images of four pixels: the last never moves. The simulated set: other
        // means and spreads.
        let lab = [vec![0.2f32, 0.5, 0.4, 0.5], vec![0.4, 0.7, 0.4, 0.5], vec![0.6, 0.6, 0.4, 0.5]];
        let sim = [vec![0.5f32, 0.1, 0.9, 0.5], vec![0.3, 0.3, 0.1, 0.5]];
        let m = Matching {
            lab: Moments::of(lab.iter().map(Vec::as_slice)),
            sim: Moments::of(sim.iter().map(Vec::as_slice)),
        };
        assert!((m.lab.mean[0] - 0.4).abs() < 1e-6 && (m.sim.spread[1] - 0.1).abs() < 1e-6, "{m:?}");
        let matched: Vec<Vec<f32>> = lab.iter().map(|v| m.apply(v)).collect();
        let after = Moments::of(matched.iter().map(Vec::as_slice));
        for i in 0..2 {
            assert!((after.mean[i] - m.sim.mean[i]).abs() < 1e-6, "pixel {i}: {after:?}");
            assert!((after.spread[i] - m.sim.spread[i]).abs() < 1e-6, "pixel {i}: {after:?}");
        }
        // A pixel with no spread over the lab's images is left as it is, whatever the set's.
        assert!(matched.iter().zip(&lab).all(|(a, b)| a[2] == b[2] && a[3] == b[3]), "{matched:?}");
        // Values are kept within 0..1.
        assert_eq!(m.apply(&[5.0, -5.0, 0.4, 0.5])[..2], [1.0, 0.0]);
    }

    #[test]
    fn the_second_network_reads_what_a_turn_leaves_alone() {
        let all = [Column::PoseX, Column::PoseZ, Column::PoseRz];
        assert_eq!(edge_frame_labels(&all).expect("labels"), vec![Column::PoseX, Column::PoseZ]);
        let e = edge_frame_labels(&[Column::PoseRz]).expect_err("yaw only");
        assert!(e.to_string().contains("--edge-frame") && e.to_string().contains("yaw only"), "{e}");
        let e = edge_frame_labels(&[Column::PoseX, Column::PoseZ]).expect_err("no yaw");
        assert!(e.to_string().contains("--edge-frame") && e.to_string().contains("pose_Rz"), "{e}");
        let e = edge_frame_labels(&[Column::PoseX, Column::PoseRx, Column::PoseRz]).expect_err("tilt");
        assert!(e.to_string().contains("--edge-frame") && e.to_string().contains("pose_Rx"), "{e}");
    }
}
