//! Throughput: taps and slides per second on all threads, where a tap's time goes, and what
//! the engine's skips save.

use std::time::Instant;

use rayon::prelude::*;

use super::report::{Breakdown, PassRates, Skips};
use super::samples::{STEP_MM, disk_scene};
use crate::contact::{ContactModel, Simulation};
use crate::error::Result;
use crate::{ObjectPose, PinRenderer, Scene, SensorParams, SensorPath, SensorPose};

/// Taps/s and slides/s on all threads, over the same samples several times.
///
/// A pass of 200 taps takes about 0.15 s on 2 threads, and a new model's first samples pay
/// what a dataset's thousands share: the tables a model keeps (the fine grid of the sub-cells
/// along an edge, once per grid shape: about 40 ms on one core at 25 cells), the first touches
/// of the workers' memory. One pass read 1,085-1,131 taps/s where 1,000 samples read
/// 1,320-1,436 (issue 31). The rates reported are the median of [`WARM_PASSES`] passes after
/// the first, the rate a run holds (this machine's speed also swings by 15% within seconds);
/// the first pass is kept beside them.
pub(super) struct Rates {
    /// Each rate's median over the warm passes.
    pub warm: PassRates,
    /// The first pass (taps first, on a new model).
    pub first: PassRates,
    /// Mean contact cells of the taps.
    pub mean_contact_cells: f64,
}

/// Timed passes after the first ([`Rates`]).
const WARM_PASSES: usize = 3;

impl Rates {
    pub(super) fn measure(
        model: &ContactModel,
        scene: &Scene,
        renderer: &PinRenderer,
        poses: &[(SensorPose, [f64; 2])],
    ) -> Result<Self> {
        let pass = || -> Result<(PassRates, f64)> {
            let (tap_frames_per_s, cells) = tap_rate(model, scene, renderer, poses)?;
            let slide_samples_per_s = slide_rate(model, scene, renderer, poses, STEP_MM)?;
            Ok((PassRates { tap_frames_per_s, slide_samples_per_s }, cells))
        };
        let (first, mean_contact_cells) = pass()?;
        let warm: Vec<PassRates> = (0..WARM_PASSES).map(|_| Ok(pass()?.0)).collect::<Result<_>>()?;
        let median = |rate: fn(&PassRates) -> f64| {
            let mut v: Vec<f64> = warm.iter().map(rate).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let warm = PassRates {
            tap_frames_per_s: median(|r| r.tap_frames_per_s),
            slide_samples_per_s: median(|r| r.slide_samples_per_s),
        };
        Ok(Self { warm, first, mean_contact_cells })
    }
}

fn tap_rate(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    poses: &[(SensorPose, [f64; 2])],
) -> Result<(f64, f64)> {
    let start = Instant::now();
    let cells: Vec<usize> = poses
        .par_iter()
        .map(|(pose, _)| {
            let frames = captured(model, scene, &SensorPath::tap(*pose), renderer)?;
            Ok(frames.first().map_or(0, |f| f.report.contact_cells))
        })
        .collect::<Result<_>>()?;
    let rate = poses.len() as f64 / start.elapsed().as_secs_f64();
    Ok((rate, cells.iter().sum::<usize>() as f64 / cells.len().max(1) as f64))
}

/// A path run and each captured frame rendered, as a dataset sample is (the images are
/// timed, not kept).
pub(super) fn captured(
    model: &ContactModel,
    scene: &Scene,
    path: &SensorPath,
    renderer: &PinRenderer,
) -> crate::Result<Vec<crate::Capture>> {
    let frames = path.run(model, scene)?;
    for f in &frames {
        std::hint::black_box(renderer.render(&f.pins));
    }
    Ok(frames)
}

fn slide_rate(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    poses: &[(SensorPose, [f64; 2])],
    step: f64,
) -> Result<f64> {
    let start = Instant::now();
    poses.par_iter().try_for_each(|(pose, from)| -> Result<()> {
        captured(model, scene, &SensorPath::slide(*pose, *from, step)?, renderer)?;
        Ok(())
    })?;
    Ok(poses.len() as f64 / start.elapsed().as_secs_f64())
}

pub(super) fn ms_single<T>(n: usize, mut f: impl FnMut(usize) -> Result<T>) -> Result<f64> {
    let start = Instant::now();
    for i in 0..n {
        f(i)?;
    }
    Ok(start.elapsed().as_secs_f64() * 1e3 / n as f64)
}

/// Where a tap's time goes (ms per tap, in the calling thread's pool): footprint grid, gap
/// and solve (with the solvers' mean iterations), pins, render.
pub(super) fn tap_breakdown(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    taps: &[(SensorPose, [f64; 2])],
) -> Result<Breakdown> {
    let (mut footprint, mut solve, mut pins_t, mut render_t) = (0.0, 0.0, 0.0, 0.0);
    let mut iterations = [0usize; 2];
    for (pose, _) in taps {
        let t = Instant::now();
        let mut sim = Simulation::new(model, scene, &[*pose]);
        footprint += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let report = sim.step(*pose)?;
        iterations[0] += report.normal_iterations;
        iterations[1] += report.tangential_iterations;
        // The sub-cells along an edge, found when first asked for, are the solve's.
        std::hint::black_box(sim.refined_cells());
        solve += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pins = sim.pins();
        pins_t += t.elapsed().as_secs_f64();
        let t = Instant::now();
        std::hint::black_box(renderer.render(&pins));
        render_t += t.elapsed().as_secs_f64();
    }
    let per = |s: f64| s * 1e3 / taps.len() as f64;
    let mean = |n: usize| n as f64 / taps.len() as f64;
    Ok(Breakdown {
        footprint_ms: per(footprint),
        solve_ms: per(solve),
        pins_ms: per(pins_t),
        render_ms: per(render_t),
        normal_iterations: mean(iterations[0]),
        tangential_iterations: mean(iterations[1]),
    })
}

pub(super) fn measure_skips(sensor: &SensorParams, scene: &Scene, poses: &[(SensorPose, [f64; 2])]) -> Result<Skips> {
    let model = ContactModel::new(sensor)?;
    let n = poses.len();
    let mean = |total: f64| total * 1e3 / n as f64;
    let (mut off, mut tap, mut slide) = (0.0, 0.0, 0.0);
    for (pose, from) in poses {
        let target = *pose;
        let start = SensorPose { x_mm: pose.x_mm + 0.1 * from[0], y_mm: pose.y_mm + 0.1 * from[1], ..*pose };
        let mut sim = Simulation::new(&model, scene, &[start, target]);
        let t = Instant::now();
        sim.step(SensorPose { depth_mm: -1.0, ..target })?;
        off += t.elapsed().as_secs_f64();
        let t = Instant::now();
        sim.step(start)?;
        tap += t.elapsed().as_secs_f64();
        let t = Instant::now();
        sim.step(target)?;
        slide += t.elapsed().as_secs_f64();
    }
    // Far stimuli: the same scene plus 48 disks on a 300 mm lattice.
    let catalogue = crate::builtin_catalogue()?;
    let mut crowded = disk_scene()?;
    for i in 0..7i32 {
        for j in 0..7i32 {
            if (i, j) != (3, 3) {
                let position_mm = [300.0 * (i - 3) as f64, 300.0 * (j - 3) as f64, 0.0];
                crowded.add(catalogue.get("disk")?, ObjectPose { position_mm, yaw_deg: 0.0 })?;
            }
        }
    }
    let probe = |s: &Scene| -> f64 {
        let t = Instant::now();
        for (pose, _) in poses {
            let mut sim = Simulation::new(&model, s, &[*pose]);
            std::hint::black_box(sim.step(SensorPose { depth_mm: -1.0, ..*pose }).map(|r| r.in_contact).ok());
        }
        mean(t.elapsed().as_secs_f64())
    };
    let far = [probe(scene), probe(&crowded)];
    // Footprint grid against a whole-dome grid of the same cell size.
    let tap_ms = |cells: usize| -> Result<f64> {
        let mut s = sensor.clone();
        s.skin.cells_across = cells;
        let m = ContactModel::new(&s)?;
        let t = Instant::now();
        for (pose, _) in poses {
            let mut sim = Simulation::new(&m, scene, &[*pose]);
            sim.step(*pose)?;
        }
        Ok(mean(t.elapsed().as_secs_f64()))
    };
    // Mean footprint over these taps is about 22 mm across against 38 mm of dome: 25 -> 43 cells.
    let footprint = [tap_ms(sensor.skin.cells_across)?, tap_ms(43)?];
    // Rendering only when asked.
    let renderer = PinRenderer::new(sensor, 256)?;
    let (mut pins_only, mut with_render) = (0.0, 0.0);
    for (pose, _) in poses {
        let mut sim = Simulation::new(&model, scene, &[*pose]);
        sim.step(*pose)?;
        let t = Instant::now();
        let pins = sim.pins();
        pins_only += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pins2 = sim.pins();
        std::hint::black_box(renderer.render(&pins2));
        with_render += t.elapsed().as_secs_f64();
        std::hint::black_box(pins);
    }
    Ok(Skips {
        no_contact_step_ms: [mean(off), mean(tap)],
        tap_without_tangential_ms: [mean(tap), mean(slide)],
        far_stimuli_ms: far,
        footprint_grid_ms: footprint,
        no_render_ms: [mean(pins_only), mean(with_render)],
    })
}
