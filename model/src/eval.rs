//! Evaluation that regenerates the paper's tables on a dataset's test split: image similarity
//! of unsheared images (SSIM, MS-SSIM, MSE), the disentanglement ablations, pose MAE on tap,
//! sheared and unsheared images, the label-fraction sweep and the patch-loss ablation, side by
//! side with the paper's numbers; written as `report.json`, `report.md`, image grids and the
//! pose network's per-image predictions (`poses.csv`).

use std::path::{Path, PathBuf};

use burn::tensor::{Device, Tensor};
use image::{GrayImage, Luma};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tacsim_data::{Split, Subset};

use crate::backend::Backend;
use crate::checkpoint::{read_json, write_atomic, write_json};
use crate::config::{Mode, PoseConfig, UnshearConfig};
use crate::data::Corpus;
use crate::error::{ModelError, Result};
use crate::images::{stack, to_images};
use crate::infer;
use crate::metrics;
use crate::posenet::{Column, Pose, PoseNet, PoseScale, decode_batch};

/// Mean image similarity over a set of image pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Similarity {
    /// Mean SSIM.
    pub ssim: f64,
    /// Mean MS-SSIM.
    pub ms_ssim: f64,
    /// Mean squared error (images in `[0, 1]`).
    pub mse: f64,
}

/// Mean similarity of `a[k]` and `b[k]`, images of side `side`.
pub fn similarity(a: &[Vec<f32>], b: &[Vec<f32>], side: usize) -> Result<Similarity> {
    let per: Vec<(f64, f64, f64)> = a
        .par_iter()
        .zip(b)
        .map(|(x, y)| {
            let s = metrics::ssim(x, y, side, side)?;
            let (ms, _) = metrics::ms_ssim(x, y, side, side)?;
            Ok((s, ms, metrics::mse(x, y)))
        })
        .collect::<Result<_>>()?;
    let n = per.len().max(1) as f64;
    Ok(Similarity {
        ssim: per.iter().map(|p| p.0).sum::<f64>() / n,
        ms_ssim: per.iter().map(|p| p.1).sum::<f64>() / n,
        mse: per.iter().map(|p| p.2).sum::<f64>() / n,
    })
}

/// Pose mean absolute errors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseError {
    /// MAE of x (mm): the paper's horizontal position error tau_x (Table I). In the edge
    /// frame x runs across the edge; in the scene frame, across the edge of the disk and the
    /// clover at their contact locations.
    pub x_mm: f64,
    /// MAE of y (mm), which the paper does not report: along the edge, where a locally
    /// straight edge does not reveal it.
    pub y_mm: f64,
    /// MAE of yaw (deg).
    pub yaw_deg: f64,
}

/// Bands of press depth (mm; lower bound included, upper excluded, none: no upper bound) that
/// split the pose errors (`Report::pose_by_depth`): a shallow press shows a small, faint
/// contact patch, which shear removal blurs first.
pub const DEPTH_BANDS_MM: [(f64, Option<f64>); 3] = [(0.0, Some(2.0)), (2.0, Some(3.0)), (3.0, None)];

/// Pose MAE of one set of images within one band of press depth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseByDepth {
    /// The images: `tap`, `sheared` or `unsheared <run>` (as the rows of `poses.csv`).
    pub images: String,
    /// Lower bound of the band (mm, included).
    pub from_mm: f64,
    /// Upper bound of the band (mm, excluded; none: no upper bound).
    pub to_mm: Option<f64>,
    /// Images in the band.
    pub count: usize,
    /// Their pose MAE.
    pub error: PoseError,
}

/// Pose errors of `predicted` against `truth` by band of press depth (`depth_mm`, the same
/// order) in each of [`DEPTH_BANDS_MM`], empty bands left out.
pub fn pose_by_depth(images: &str, predicted: &[Pose], truth: &[Pose], depth_mm: &[f64]) -> Vec<PoseByDepth> {
    DEPTH_BANDS_MM
        .iter()
        .filter_map(|&(from_mm, to_mm)| {
            let (p, t): (Vec<Pose>, Vec<Pose>) = predicted
                .iter()
                .zip(truth)
                .zip(depth_mm)
                .filter(|&(_, &d)| d >= from_mm && to_mm.is_none_or(|to| d < to))
                .map(|((p, t), _)| (*p, *t))
                .unzip();
            (!p.is_empty()).then(|| PoseByDepth {
                images: images.to_owned(),
                from_mm,
                to_mm,
                count: p.len(),
                error: pose_error(&p, &t),
            })
        })
        .collect()
}

/// Scores of one shear-removal model on the test pairs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UnshearScores {
    /// Run directory name.
    pub run: String,
    /// Training mode.
    pub mode: Mode,
    /// Label fraction of the supervised phase (1 for the baseline, 0 without supervision).
    pub label_fraction: f64,
    /// Patch-loss weight.
    pub patch_weight: f64,
    /// `U_rec = M(S_inp)` against the tap image `U_GT`.
    pub rec_vs_gt: Similarity,
    /// `U_rec` against the sheared input `S_inp` (low: the shear was removed).
    pub rec_vs_input: Similarity,
    /// `N(S_inp)` against `S_inp` (sheared reconstruction from both codes).
    pub sheared_reconstruction: Similarity,
    /// Ablation: `D_T(shear code)` against `U_GT`.
    pub unsheared_from_shear_code: Similarity,
    /// Ablation: `D_S(pose code, 0)` against `S_inp`.
    pub sheared_from_pose_code: Similarity,
    /// Pose MAE of the pose network on `U_rec`.
    pub pose: Option<PoseError>,
}

/// The whole evaluation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Dataset directory.
    pub dataset: String,
    /// Image side (px).
    pub size: usize,
    /// Test pairs evaluated.
    pub test_pairs: usize,
    /// Frame of the dataset's pose labels (`poses.frame` of its recipe: `scene` or `edge`).
    #[serde(default)]
    pub label_frame: tacsim_data::PoseFrame,
    /// Whether each pose's contact point was drawn around the shape's whole contour
    /// (`poses.around_contour` of its recipe), with y = 0 on it: the edge frame then sits
    /// under the sensor, and x and yaw are what a tap shows.
    #[serde(default)]
    pub around_contour: bool,
    /// MS-SSIM scales used at this size (5 from 176 px up).
    pub ms_ssim_scales: usize,
    /// `S_inp` against `U_GT`: the similarity before any shear removal.
    pub input_vs_gt: Similarity,
    /// Each shear-removal model.
    pub models: Vec<UnshearScores>,
    /// Pose MAE on the tap images `U_GT`.
    pub pose_tap: Option<PoseError>,
    /// Pose MAE on the sheared images `S_inp`.
    pub pose_sheared: Option<PoseError>,
    /// Pose MAE of every set of images by band of press depth (`pose_by_depth`).
    #[serde(default)]
    pub pose_by_depth: Vec<PoseByDepth>,
    /// The paper's claims checked on these numbers.
    pub checks: Vec<Check>,
}

/// One of the paper's claims, checked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Check {
    /// The claim.
    pub claim: String,
    /// The numbers behind it.
    pub evidence: String,
    /// Whether it holds here.
    pub holds: bool,
}

/// The test split's true pairs, at most `max` of them spread evenly (0: all).
pub fn test_pairs(corpus: &Corpus, max: usize) -> Vec<(usize, usize)> {
    let all = corpus.dataset.true_pairs(Split::Test, Subset::All);
    if max == 0 || all.len() <= max {
        return all;
    }
    (0..max).map(|k| all[k * all.len() / max]).collect()
}

/// Runs `f` over batches of images and gathers its image outputs.
fn map_images(images: &[Vec<f32>], side: usize, device: &Device, f: impl Fn(Tensor<4>) -> Tensor<4>) -> Vec<Vec<f32>> {
    let mut out = Vec::with_capacity(images.len());
    for chunk in images.chunks(32) {
        out.extend(to_images(f(stack(chunk, side, device))));
    }
    out
}

/// The images of `rows` as network inputs (values in [0, 1]).
pub fn corpus_images(corpus: &Corpus, rows: &[usize]) -> Vec<Vec<f32>> {
    rows.iter().map(|&r| corpus.images.image(r).iter().map(|&v| f32::from(v) / 255.0).collect()).collect()
}

/// The pose network's predictions for `images`.
pub fn predict_poses(net: &PoseNet, scale: &PoseScale, images: &[Vec<f32>], side: usize, device: &Device) -> Vec<Pose> {
    let mut out = Vec::with_capacity(images.len());
    for chunk in images.chunks(32) {
        out.extend(decode_batch(scale, net.forward(stack(chunk, side, device))));
    }
    out
}

/// Absolute yaw difference (deg) on the circle, in `[0, 180]`.
pub fn yaw_difference_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).abs() % 360.0;
    if d > 180.0 { 360.0 - d } else { d }
}

/// Pose MAE of `predicted` against `truth` (same order).
pub fn pose_error(predicted: &[Pose], truth: &[Pose]) -> PoseError {
    let mut sums = [0.0f64; 3];
    for (p, t) in predicted.iter().zip(truth) {
        sums[0] += (p.x_mm() - t.x_mm()).abs();
        sums[1] += (p.y_mm() - t.y_mm()).abs();
        sums[2] += yaw_difference_deg(p.yaw_deg(), t.yaw_deg());
    }
    let n = predicted.len().min(truth.len()).max(1) as f64;
    PoseError { x_mm: sums[0] / n, y_mm: sums[1] / n, yaw_deg: sums[2] / n }
}

/// `poses.csv`: one line per evaluated image with the true and predicted pose, so that errors
/// can be broken down (by shape, depth, offset, ...) by joining `row` with `targets.csv`.
fn poses_csv(corpus: &Corpus, rows: &[usize], sets: &[(String, Vec<Pose>)]) -> String {
    let mut s = String::from(
        "images,row,sensor_image,shape,depth_mm,x_mm,y_mm,yaw_deg,pred_x_mm,pred_y_mm,pred_yaw_deg,yaw_error_deg\n",
    );
    for (name, predicted) in sets {
        for (&r, p) in rows.iter().zip(predicted) {
            let (row, t) = (&corpus.dataset.rows[r], corpus.pose(r));
            s.push_str(&format!(
                "{name},{r},{},{},{:.4},{:.4},{:.4},{:.3},{:.4},{:.4},{:.3},{:.3}\n",
                row.sensor_image,
                row.shape,
                row.pose_z,
                t.x_mm(),
                t.y_mm(),
                t.yaw_deg(),
                p.x_mm(),
                p.y_mm(),
                p.yaw_deg(),
                yaw_difference_deg(p.yaw_deg(), t.yaw_deg())
            ));
        }
    }
    s
}

/// A trained run found in a directory.
enum Run {
    Unshear(String, UnshearConfig, PathBuf),
    Pose(PoseConfig, PathBuf),
}

fn find_run(dir: &Path) -> Result<Run> {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    infer::weights_of(dir)?;
    let config = dir.join("config.json");
    if infer::is_posenet_run(dir) {
        Ok(Run::Pose(read_json(&config)?, dir.to_owned()))
    } else {
        Ok(Run::Unshear(name, read_json(&config)?, dir.to_owned()))
    }
}

/// The image side (px) a run directory was trained at.
pub fn run_size(dir: &Path) -> Result<usize> {
    Ok(match find_run(dir)? {
        Run::Pose(cfg, _) => cfg.size,
        Run::Unshear(_, cfg, _) => cfg.size,
    })
}

/// Evaluates every run in `runs` (shear-removal models and at most one pose network) on the
/// test split of `corpus`, writing `report.json`, `report.md` and `grid.png` into `out`.
pub fn evaluate(corpus: &Corpus, runs: &[PathBuf], backend: Backend, max_pairs: usize, out: &Path) -> Result<Report> {
    std::fs::create_dir_all(out).map_err(|e| ModelError::io(out, "create", e))?;
    let device = backend.device();
    let side = corpus.side();
    let pairs = test_pairs(corpus, max_pairs);
    if pairs.is_empty() {
        return Err(ModelError::Insufficient(format!(
            "{} has no test pairs: generate with a test split",
            corpus.dataset.dir.display()
        )));
    }
    let taps: Vec<usize> = pairs.iter().map(|p| p.0).collect();
    let slides: Vec<usize> = pairs.iter().map(|p| p.1).collect();
    let (gt, input) = (corpus_images(corpus, &taps), corpus_images(corpus, &slides));
    let (posenet, unshear) = load_runs(runs, side, &device)?;
    let mut poses = PoseScorer {
        posenet,
        truth: slides.iter().map(|&r| corpus.pose(r)).collect(),
        side,
        device: &device,
        sets: Vec::new(),
    };
    let (pose_tap, pose_sheared) = (poses.score("tap", &gt), poses.score("sheared", &input));
    let mut models = Vec::new();
    let mut grid_columns: Vec<(String, Vec<Vec<f32>>)> = vec![("S_inp".into(), input.clone())];
    for (name, cfg, dir) in &unshear {
        let (scores, rec) = score_unshear(name, cfg, dir, &gt, &input, &mut poses)?;
        models.push(scores);
        grid_columns.push((format!("U_rec {name}"), rec));
    }
    grid_columns.push(("U_GT".into(), gt.clone()));
    let (_, scales) = metrics::ms_ssim(&gt[0], &gt[0], side, side)?;
    let depth_mm: Vec<f64> = slides.iter().map(|&r| corpus.dataset.rows[r].pose_z).collect();
    let pose_by_depth = poses
        .sets
        .iter()
        .flat_map(|(name, predicted)| self::pose_by_depth(name, predicted, &poses.truth, &depth_mm))
        .collect();
    let mut report = Report {
        dataset: corpus.dataset.dir.display().to_string(),
        label_frame: corpus.dataset.meta.pose_frame()?,
        around_contour: corpus.dataset.meta.around_contour(),
        size: side,
        test_pairs: pairs.len(),
        ms_ssim_scales: scales,
        input_vs_gt: similarity(&input, &gt, side)?,
        models,
        pose_tap,
        pose_sheared,
        pose_by_depth,
        checks: Vec::new(),
    };
    report.checks = checks(&report);
    write_json(&out.join("report.json"), &report)?;
    write_atomic(&out.join("report.md"), markdown(&report).as_bytes())?;
    write_grid(&out.join("grid.png"), &grid_columns, side, 12)?;
    if !poses.sets.is_empty() {
        write_atomic(&out.join("poses.csv"), poses_csv(corpus, &slides, &poses.sets).as_bytes())?;
    }
    Ok(report)
}

/// A loaded pose network and its label scale.
type LoadedPoseNet = (PoseNet, PoseScale);

/// A shear-removal run: its name, config and directory.
type UnshearRun = (String, UnshearConfig, PathBuf);

/// The runs to evaluate, sorted: at most one pose network (it must read x, y and yaw), and
/// the shear-removal models with their names and configs; each trained at the data's `side`.
fn load_runs(runs: &[PathBuf], side: usize, device: &Device) -> Result<(Option<LoadedPoseNet>, Vec<UnshearRun>)> {
    let mut posenet = None;
    let mut unshear = Vec::new();
    for dir in runs {
        match find_run(dir)? {
            Run::Pose(cfg, dir) => {
                check_size(cfg.size, side, &dir)?;
                let (net, _, scale) = infer::load_posenet(&dir, device)?;
                scale.require(&[Column::PoseX, Column::PoseY, Column::PoseRz], &dir, "the paper's scores")?;
                posenet = Some((net, scale));
            }
            Run::Unshear(name, cfg, dir) => unshear.push((name, cfg, dir)),
        }
    }
    Ok((posenet, unshear))
}

/// A run trained at `trained` px cannot read `side` px data.
fn check_size(trained: usize, side: usize, dir: &Path) -> Result<()> {
    if trained != side {
        return Err(ModelError::config(
            "size",
            format!("{} was trained at {trained} px, the data is {side} px", dir.display()),
        ));
    }
    Ok(())
}

/// The pose network's readings of image sets against the slides' poses, each set kept under
/// its name for poses.csv and the depth bands.
struct PoseScorer<'a> {
    posenet: Option<LoadedPoseNet>,
    truth: Vec<Pose>,
    side: usize,
    device: &'a Device,
    sets: Vec<(String, Vec<Pose>)>,
}

impl PoseScorer<'_> {
    /// The pose error of the network reading `images` (none without a pose network).
    fn score(&mut self, name: &str, images: &[Vec<f32>]) -> Option<PoseError> {
        let (net, scale) = self.posenet.as_ref()?;
        let predicted = predict_poses(net, scale, images, self.side, self.device);
        let e = pose_error(&predicted, &self.truth);
        self.sets.push((name.to_owned(), predicted));
        Some(e)
    }
}

/// One shear-removal model's scores on the test pairs (`gt` taps, `input` slides) and its
/// unsheared images `U_rec`.
fn score_unshear(
    name: &str,
    cfg: &UnshearConfig,
    dir: &Path,
    gt: &[Vec<f32>],
    input: &[Vec<f32>],
    poses: &mut PoseScorer<'_>,
) -> Result<(UnshearScores, Vec<Vec<f32>>)> {
    let (side, device) = (poses.side, poses.device);
    check_size(cfg.size, side, dir)?;
    let (model, _) = infer::load_unshear(dir, device)?;
    let rec = map_images(input, side, device, |x| model.unshear(x));
    let srec = map_images(input, side, device, |x| model.reconstruct(x));
    let u_shear = map_images(input, side, device, |x| model.unshear_from_shear_code(x));
    let s_pose = map_images(input, side, device, |x| model.reconstruct_from_pose_code(x));
    let scores = UnshearScores {
        run: name.to_owned(),
        mode: cfg.mode,
        label_fraction: match cfg.mode {
            Mode::SemiSupervised => cfg.label_fraction,
            Mode::Baseline => 1.0,
            Mode::SelfSupervised => 0.0,
        },
        patch_weight: cfg.patch_weight,
        rec_vs_gt: similarity(&rec, gt, side)?,
        rec_vs_input: similarity(&rec, input, side)?,
        sheared_reconstruction: similarity(&srec, input, side)?,
        unsheared_from_shear_code: similarity(&u_shear, gt, side)?,
        sheared_from_pose_code: similarity(&s_pose, input, side)?,
        pose: poses.score(&format!("unsheared {name}"), &rec),
    };
    Ok((scores, rec))
}

/// The semi-supervised model at the paper's 10% with the patch loss, if evaluated.
fn main_model(r: &Report) -> Option<&UnshearScores> {
    let semi: Vec<&UnshearScores> =
        r.models.iter().filter(|m| m.mode == Mode::SemiSupervised && m.patch_weight > 0.0).collect();
    semi.iter().copied().max_by(|a, b| a.label_fraction.total_cmp(&b.label_fraction))
}

fn baseline(r: &Report) -> Option<&UnshearScores> {
    r.models.iter().find(|m| m.mode == Mode::Baseline)
}

fn checks(r: &Report) -> Vec<Check> {
    let mut out = Vec::new();
    let mut check =
        |claim: &str, evidence: String, holds: bool| out.push(Check { claim: claim.into(), evidence, holds });
    if let Some(m) = main_model(r) {
        check(
            "SSIM(U_rec, U_GT) well above SSIM(S_inp, U_GT)",
            format!("{:.3} against {:.3}", m.rec_vs_gt.ssim, r.input_vs_gt.ssim),
            m.rec_vs_gt.ssim > r.input_vs_gt.ssim + 0.05,
        );
        if let Some(b) = baseline(r) {
            check(
                "semi-supervised within 2% SSIM of supervised",
                format!("{:.3} against {:.3}", m.rec_vs_gt.ssim, b.rec_vs_gt.ssim),
                m.rec_vs_gt.ssim >= b.rec_vs_gt.ssim - 0.02,
            );
        }
        check(
            "ablation: U decoded from the shear code is far worse",
            format!(
                "MSE {:.4} against {:.4}, SSIM {:.3} against {:.3}",
                m.unsheared_from_shear_code.mse, m.rec_vs_gt.mse, m.unsheared_from_shear_code.ssim, m.rec_vs_gt.ssim
            ),
            m.unsheared_from_shear_code.mse > 2.0 * m.rec_vs_gt.mse
                && m.unsheared_from_shear_code.ssim < m.rec_vs_gt.ssim,
        );
        check(
            "ablation: S decoded from the pose code alone is far worse",
            format!(
                "MSE {:.4} against {:.4}, SSIM {:.3} against {:.3}",
                m.sheared_from_pose_code.mse,
                m.sheared_reconstruction.mse,
                m.sheared_from_pose_code.ssim,
                m.sheared_reconstruction.ssim
            ),
            m.sheared_from_pose_code.mse > 2.0 * m.sheared_reconstruction.mse
                && m.sheared_from_pose_code.ssim < m.sheared_reconstruction.ssim,
        );
    }
    // The paper's Table I gives the unsheared pose error for both models: one check each.
    let pose_models = [("semi-supervised", main_model(r)), ("supervised baseline", baseline(r))];
    for (who, m) in pose_models {
        if let (Some(p), Some(s)) = (m.and_then(|m| m.pose), r.pose_sheared) {
            check(
                &format!("pose MAE on images unsheared by the {who} model at least 3x lower than on sheared ones"),
                format!(
                    "horizontal x {:.2} against {:.2} mm ({:.1}x), yaw {:.1} against {:.1} deg ({:.1}x)",
                    p.x_mm,
                    s.x_mm,
                    s.x_mm / p.x_mm,
                    p.yaw_deg,
                    s.yaw_deg,
                    s.yaw_deg / p.yaw_deg
                ),
                3.0 * p.x_mm <= s.x_mm && 3.0 * p.yaw_deg <= s.yaw_deg,
            );
        }
    }
    out
}

fn pct(v: f64) -> String {
    format!("{:.1}%", 100.0 * v)
}

fn pose_cells(p: Option<PoseError>) -> String {
    match p {
        Some(p) => format!("{:.2} | {:.2} | {:.2}", p.x_mm, p.yaw_deg, p.y_mm),
        None => "- | - | -".into(),
    }
}

/// The pose errors by press depth as a markdown section (empty without a pose network).
fn depth_table(bands: &[PoseByDepth]) -> String {
    if bands.is_empty() {
        return String::new();
    }
    let label = |(from, to): (f64, Option<f64>)| match to {
        Some(to) if from == 0.0 => format!("below {to} mm"),
        Some(to) => format!("{from}-{to} mm"),
        None => format!("{from} mm and deeper"),
    };
    let mut s = String::from("\n### Pose MAE by press depth: horizontal x (mm) / yaw (deg) (images)\n\n| images |");
    s.push_str(&DEPTH_BANDS_MM.iter().map(|&b| format!(" {} |", label(b))).collect::<String>());
    s.push_str(&format!("\n|---|{}\n", "---|".repeat(DEPTH_BANDS_MM.len())));
    // Bands come grouped by images, in the order of the pose table.
    for group in bands.chunk_by(|a, b| a.images == b.images) {
        s.push_str(&format!("| {} |", group[0].images));
        for &(from, to) in &DEPTH_BANDS_MM {
            match group.iter().find(|b| b.from_mm == from && b.to_mm == to) {
                Some(b) => s.push_str(&format!(" {:.2} / {:.1} ({}) |", b.error.x_mm, b.error.yaw_deg, b.count)),
                None => s.push_str(" - |"),
            }
        }
        s.push('\n');
    }
    s
}

/// The report as markdown, the paper's numbers beside ours.
pub fn markdown(r: &Report) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "# Shear removal: evaluation\n\nDataset `{}`, {} px, {} test pairs (tap `U_GT`, slide `S_inp` of the same pose). MS-SSIM uses {} scale(s) at this size{}.\n\n",
        r.dataset,
        r.size,
        r.test_pairs,
        r.ms_ssim_scales,
        if r.ms_ssim_scales < 5 { " (fewer than the standard 5: the image is too small for 5)" } else { "" }
    ));
    s.push_str("## Shear removal (paper, Results: MS-SSIM 92.5% semi-supervised at 10% labels, 93% supervised, 74% without labels; 32% against the sheared input)\n\n");
    s.push_str("| model | labels | patch | SSIM(U_rec, U_GT) | MS-SSIM(U_rec, U_GT) | MSE(U_rec, U_GT) | SSIM(U_rec, S_inp) | MS-SSIM(U_rec, S_inp) |\n|---|---|---|---|---|---|---|---|\n");
    s.push_str(&format!(
        "| input S_inp (no model) | - | - | {} | {} | {:.4} | 100% | 100% |\n",
        pct(r.input_vs_gt.ssim),
        pct(r.input_vs_gt.ms_ssim),
        r.input_vs_gt.mse
    ));
    for m in &r.models {
        s.push_str(&format!(
            "| {} ({:?}) | {} | {} | {} | {} | {:.4} | {} | {} |\n",
            m.run,
            m.mode,
            pct(m.label_fraction),
            m.patch_weight,
            pct(m.rec_vs_gt.ssim),
            pct(m.rec_vs_gt.ms_ssim),
            m.rec_vs_gt.mse,
            pct(m.rec_vs_input.ssim),
            pct(m.rec_vs_input.ms_ssim)
        ));
    }
    s.push_str("\nPaper, label sweep: 20% fewer labels cost about 2% (supervised, from 93%) and 0.5% (semi-supervised, from 92.5%); without the patch loss 91.5% instead of 93% at 10% labels.\n\n");
    s.push_str("## Disentanglement ablations (paper: U from the shear code MSE 0.11 against 0.024, SSIM 18% against 92.5%; S from the pose code alone 60x the MSE, SSIM 18% against 93%)\n\n");
    s.push_str("| model | MSE U_rec | MSE U from shear code | SSIM U_rec | SSIM U from shear code | MSE S_rec | MSE S from pose code | SSIM S_rec | SSIM S from pose code |\n|---|---|---|---|---|---|---|---|---|\n");
    for m in &r.models {
        s.push_str(&format!(
            "| {} | {:.4} | {:.4} | {} | {} | {:.4} | {:.4} | {} | {} |\n",
            m.run,
            m.rec_vs_gt.mse,
            m.unsheared_from_shear_code.mse,
            pct(m.rec_vs_gt.ssim),
            pct(m.unsheared_from_shear_code.ssim),
            m.sheared_reconstruction.mse,
            m.sheared_from_pose_code.mse,
            pct(m.sheared_reconstruction.ssim),
            pct(m.sheared_from_pose_code.ssim)
        ));
    }
    s.push_str("\n## Pose MAE (paper, Table I: tap 0.43 mm / 2.13 deg; sheared 2.72 / 22.20; unsheared supervised 0.64 / 4.38; unsheared semi-supervised 0.71 / 4.81)\n\n");
    s.push_str(if r.around_contour {
        "Horizontal x is the paper's tau_x: labels are in the edge frame at each pose's own contact point, drawn around the whole contour: x across the edge, yaw from its tangent, and y = 0 (its column measures nothing).\n\n"
    } else if r.label_frame == tacsim_data::PoseFrame::Edge {
        "Horizontal x is the paper's tau_x: labels are in the edge frame, x across the edge at each pose's contact point; y, which the paper does not report, runs along the edge, and a locally straight edge does not reveal it.\n\n"
    } else {
        "Horizontal x is the paper's tau_x (across the edge of the disk and the clover at their contact locations); y, which the paper does not report, runs along those edges, and a locally straight edge does not reveal it.\n\n"
    });
    s.push_str("| images | horizontal x (mm) | yaw (deg) | y along the edge (mm) |\n|---|---|---|---|\n");
    s.push_str(&format!("| tap U_GT | {} |\n", pose_cells(r.pose_tap)));
    s.push_str(&format!("| sheared S_inp | {} |\n", pose_cells(r.pose_sheared)));
    for m in &r.models {
        s.push_str(&format!("| unsheared by {} | {} |\n", m.run, pose_cells(m.pose)));
    }
    s.push_str(&depth_table(&r.pose_by_depth));
    s.push_str("\n## The paper's claims on these numbers\n\n");
    for c in &r.checks {
        s.push_str(&format!("- {} {}: {}\n", if c.holds { "[holds]" } else { "[does not hold]" }, c.claim, c.evidence));
    }
    s.push_str("\n`grid.png`: rows are test pairs; columns S_inp, U_rec of each model (in the order above), U_GT.\n");
    s
}

/// Writes an image grid: `rows` samples down, one column per entry.
pub fn write_grid(path: &Path, columns: &[(String, Vec<Vec<f32>>)], side: usize, rows: usize) -> Result<()> {
    let n = columns.first().map(|c| c.1.len()).unwrap_or(0).min(rows);
    let gap = 4;
    let (w, h) = (columns.len() * (side + gap) + gap, n * (side + gap) + gap);
    let mut img = GrayImage::from_pixel(w as u32, h as u32, Luma([128]));
    for (c, (_, col)) in columns.iter().enumerate() {
        for r in 0..n {
            let k = r * col.len() / n.max(1);
            for y in 0..side {
                for x in 0..side {
                    let v = (col[k][y * side + x].clamp(0.0, 1.0) * 255.0).round() as u8;
                    img.put_pixel((gap + c * (side + gap) + x) as u32, (gap + r * (side + gap) + y) as u32, Luma([v]));
                }
            }
        }
    }
    let mut bytes = Vec::new();
    image::DynamicImage::ImageLuma8(img)
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| ModelError::checkpoint(path, format!("could not encode the grid: {e}")))?;
    write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_errors_are_measured_on_the_circle() {
        assert_eq!(yaw_difference_deg(170.0, -170.0), 20.0);
        assert_eq!(yaw_difference_deg(-44.0, 46.0), 90.0);
        assert_eq!(yaw_difference_deg(10.0, 370.0), 0.0);
        let p = |x_mm, yaw_deg| Pose::planar(x_mm, 0.0, yaw_deg);
        let e = pose_error(&[p(1.0, 179.0), p(-1.0, 0.0)], &[p(0.0, -179.0), p(0.0, 4.0)]);
        assert_eq!((e.x_mm, e.y_mm, e.yaw_deg), (1.0, 0.0, 3.0));
    }

    #[test]
    fn pose_errors_split_by_press_depth() {
        let p = |x_mm, yaw_deg| Pose::planar(x_mm, 0.0, yaw_deg);
        let truth = [p(0.0, 0.0); 4];
        let predicted = [p(1.0, 10.0), p(3.0, 30.0), p(0.5, 2.0), p(0.1, 1.0)];
        let bands = pose_by_depth("tap", &predicted, &truth, &[1.2, 1.9, 2.0, 4.5]);
        let got: Vec<_> = bands.iter().map(|b| (b.from_mm, b.to_mm, b.count, b.error.x_mm, b.error.yaw_deg)).collect();
        assert_eq!(got, [(0.0, Some(2.0), 2, 2.0, 20.0), (2.0, Some(3.0), 1, 0.5, 2.0), (3.0, None, 1, 0.1, 1.0)]);
        let table = depth_table(&bands);
        assert!(table.contains("| tap | 2.00 / 20.0 (2) | 0.50 / 2.0 (1) | 0.10 / 1.0 (1) |"), "{table}");
        assert!(table.contains("below 2 mm | 2-3 mm | 3 mm and deeper"), "{table}");
    }
}
