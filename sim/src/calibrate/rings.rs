//! Calibration of the camera and ring placement against a real undeformed TacTip image.
//!
//! Both images (real and simulated) are reduced to a [`RingProfile`]: detected pins, the
//! centre pin, the pins grouped into concentric rings, and each ring's mean radius, spread,
//! pin count, blob area and azimuth phase. [`compare`] reports the ring-radius RMS error and
//! the blob-area error; [`fit_camera`] fits field of view, ring pitch, radial distortion, tip
//! size, principal point and phase so the simulated profile matches the real one.

use image::GrayImage;

use crate::detect::{Blob, detect_pins, pin_area_range};
use crate::error::{Result, SimError};
use crate::fit::levenberg_marquardt;
use crate::realism::Realism;
use crate::render::PinRenderer;
use crate::sensor::SensorParams;

/// One ring of detected pins.
#[derive(Clone, Debug, PartialEq)]
pub struct RingStats {
    /// Ring index, 0 = centre pin.
    pub ring: u32,
    /// Pins found in the ring.
    pub count: usize,
    /// Mean distance of the ring's pins from the centre (px).
    pub mean_radius_px: f64,
    /// Standard deviation of those distances (px).
    pub sd_radius_px: f64,
    /// Mean blob area (px).
    pub mean_area_px: f64,
    /// Azimuth of the ring's pin pattern (deg, from image right towards image down), modulo
    /// the pin spacing `360 / 6k`.
    pub phase_deg: f64,
}

/// Pins of an undeformed image grouped into rings.
#[derive(Clone, Debug, PartialEq)]
pub struct RingProfile {
    /// Image size (px).
    pub size: u32,
    /// Centre `[u, v]` (px) of the pattern.
    pub centre: [f64; 2],
    /// Rings, centre first.
    pub rings: Vec<RingStats>,
    /// Pins assigned to a ring.
    pub pins: usize,
}

impl RingProfile {
    /// Mean blob area over all ring pins (px).
    pub fn mean_area_px(&self) -> f64 {
        let (sum, n) =
            self.rings.iter().fold((0.0, 0usize), |(s, n), r| (s + r.mean_area_px * r.count as f64, n + r.count));
        sum / n.max(1) as f64
    }

    /// Azimuth of the pin pattern (deg): ring 1's phase, refined by the count-weighted mean of
    /// every ring's phase unwrapped to the period copy nearest ring 1's.
    pub fn phase_deg(&self) -> f64 {
        let Some(first) = self.rings.get(1) else { return 0.0 };
        let (mut sum, mut n) = (0.0, 0.0);
        for r in self.rings.iter().skip(1) {
            let period = 360.0 / (6.0 * r.ring as f64);
            let unwrapped = r.phase_deg + period * ((first.phase_deg - r.phase_deg) / period).round();
            sum += r.count as f64 * unwrapped;
            n += r.count as f64;
        }
        sum / n
    }
}

/// Builds the ring profile of an undeformed binary image of `size` px. `expected_rings` is the
/// sensor's K; pins beyond ring K (rim clutter) are ignored.
pub fn ring_profile(img: &GrayImage, expected_rings: u32, source_name: &str) -> Result<RingProfile> {
    let size = img.width();
    let (min_area, max_area) = pin_area_range(size);
    let blobs: Vec<Blob> = detect_pins(img, min_area, max_area);
    let fail = |reason: String| SimError::Analysis { source_name: source_name.to_owned(), reason };
    if blobs.len() < 7 {
        return Err(fail(format!("only {} pin-sized blobs found: is this an undeformed TacTip image?", blobs.len())));
    }
    // Centre pin: the blob nearest the centroid of all pins; then refine the centre as the mean
    // of the pins of complete inner rings (symmetric, so their mean is the centre).
    let n = blobs.len() as f64;
    let mean =
        [blobs.iter().map(|b| b.centroid[0]).sum::<f64>() / n, blobs.iter().map(|b| b.centroid[1]).sum::<f64>() / n];
    let dist = |b: &Blob, c: [f64; 2]| ((b.centroid[0] - c[0]).powi(2) + (b.centroid[1] - c[1]).powi(2)).sqrt();
    let centre_pin =
        blobs.iter().min_by(|a, b| dist(a, mean).total_cmp(&dist(b, mean))).map(|b| b.centroid).unwrap_or(mean);
    let mut centre = centre_pin;
    let mut rings = Vec::new();
    for _ in 0..3 {
        rings = group_rings(&blobs, centre, expected_rings);
        let complete: Vec<&Vec<usize>> =
            rings.iter().enumerate().filter(|(k, r)| *k > 0 && r.len() == 6 * k).map(|(_, r)| r).collect();
        if complete.is_empty() {
            break;
        }
        let (mut sx, mut sy, mut c) = (0.0, 0.0, 0.0);
        for r in complete {
            for &i in r {
                sx += blobs[i].centroid[0];
                sy += blobs[i].centroid[1];
                c += 1.0;
            }
        }
        centre = [sx / c, sy / c];
    }
    if rings.len() < 2 {
        return Err(fail("no ring structure found around the centre pin".to_owned()));
    }
    let stats = rings
        .iter()
        .enumerate()
        .map(|(k, members)| {
            let radii: Vec<f64> = members.iter().map(|&i| dist(&blobs[i], centre)).collect();
            let m = radii.len().max(1) as f64;
            let mean_r = radii.iter().sum::<f64>() / m;
            let sd = (radii.iter().map(|r| (r - mean_r).powi(2)).sum::<f64>() / m).sqrt();
            let area = members.iter().map(|&i| blobs[i].area as f64).sum::<f64>() / m;
            let phase_deg = if k == 0 {
                0.0
            } else {
                let nk = 6.0 * k as f64;
                let (mut sx, mut sy) = (0.0, 0.0);
                for &i in members {
                    let b = &blobs[i];
                    let phi = (b.centroid[1] - centre[1]).atan2(b.centroid[0] - centre[0]);
                    sx += (nk * phi).cos();
                    sy += (nk * phi).sin();
                }
                sy.atan2(sx).to_degrees() / nk
            };
            RingStats {
                ring: k as u32,
                count: members.len(),
                mean_radius_px: mean_r,
                sd_radius_px: sd,
                mean_area_px: area,
                phase_deg,
            }
        })
        .collect::<Vec<_>>();
    let pins = stats.iter().map(|s| s.count).sum();
    Ok(RingProfile { size, centre, rings: stats, pins })
}

/// Groups blobs into rings around `centre` by splitting the sorted radii at gaps larger than
/// 40% of the first ring's radius. Returns at most `expected_rings + 1` groups (blob indices).
fn group_rings(blobs: &[Blob], centre: [f64; 2], expected_rings: u32) -> Vec<Vec<usize>> {
    let mut order: Vec<(f64, usize)> = blobs
        .iter()
        .enumerate()
        .map(|(i, b)| (((b.centroid[0] - centre[0]).powi(2) + (b.centroid[1] - centre[1]).powi(2)).sqrt(), i))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first_ring = order.get(1).map_or(1.0, |o| o.0);
    let gap = 0.4 * first_ring;
    let mut groups: Vec<Vec<usize>> = vec![vec![order[0].1]];
    for w in order.windows(2) {
        if w[1].0 - w[0].0 > gap {
            if groups.len() == expected_rings as usize + 1 {
                break;
            }
            groups.push(Vec::new());
        }
        if let Some(g) = groups.last_mut() {
            g.push(w[1].1);
        }
    }
    groups
}

/// Simulated-vs-real comparison of two undeformed images.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Root-mean-square difference of the ring radii over rings 1..=K (px).
    pub ring_radius_rms_px: f64,
    /// Largest single-ring radius difference (px).
    pub ring_radius_max_px: f64,
    /// Relative difference of the mean blob area, (sim - real) / real.
    pub area_rel_err: f64,
    /// Pins per ring, simulated.
    pub sim_counts: Vec<usize>,
    /// Pins per ring, real.
    pub real_counts: Vec<usize>,
    /// Distance between the pattern centres (px).
    pub centre_offset_px: f64,
}

/// Compares ring profiles (same image size).
pub fn compare(sim: &RingProfile, real: &RingProfile) -> Comparison {
    let pairs: Vec<(f64, f64)> =
        sim.rings.iter().zip(&real.rings).skip(1).map(|(s, r)| (s.mean_radius_px, r.mean_radius_px)).collect();
    let rms = (pairs.iter().map(|(s, r)| (s - r).powi(2)).sum::<f64>() / pairs.len().max(1) as f64).sqrt();
    let max = pairs.iter().map(|(s, r)| (s - r).abs()).fold(0.0, f64::max);
    Comparison {
        ring_radius_rms_px: rms,
        ring_radius_max_px: max,
        area_rel_err: (sim.mean_area_px() - real.mean_area_px()) / real.mean_area_px(),
        sim_counts: sim.rings.iter().map(|r| r.count).collect(),
        real_counts: real.rings.iter().map(|r| r.count).collect(),
        centre_offset_px: ((sim.centre[0] - real.centre[0]).powi(2) + (sim.centre[1] - real.centre[1]).powi(2)).sqrt(),
    }
}

/// A per-ring table (radius, pin count, blob area) of a simulated and a real profile.
pub fn ring_table(sim: &RingProfile, real: &RingProfile) -> String {
    let mut out = String::from("ring  real_r_px  sim_r_px  real_n  sim_n  real_area  sim_area\n");
    for (s, r) in sim.rings.iter().zip(&real.rings) {
        out.push_str(&format!(
            "{:>4} {:>10.2} {:>9.2} {:>7} {:>6} {:>10.1} {:>9.1}\n",
            r.ring, r.mean_radius_px, s.mean_radius_px, r.count, s.count, r.mean_area_px, s.mean_area_px
        ));
    }
    out
}

/// Renders `sensor` undeformed at the real image's size and compares the two profiles.
pub fn compare_sensor(
    sensor: &SensorParams,
    real: &GrayImage,
    real_name: &str,
) -> Result<(Comparison, RingProfile, RingProfile)> {
    let renderer = PinRenderer::new(sensor, real.width())?;
    let sim_img = renderer.render_undeformed();
    let sim = ring_profile(&sim_img, sensor.pins.rings, "simulated reference")?;
    let real_p = ring_profile(real, sensor.pins.rings, real_name)?;
    Ok((compare(&sim, &real_p), sim, real_p))
}

/// Fits the camera (field of view, distance, radial distortion k1, principal point), the
/// ring pitch, the pin phase and the tip radius of `start` to a real undeformed image, by
/// least squares on each ring's mean radius and blob size (square root of the area). Dome,
/// skin and pin length are kept: they are mechanical and fitted against deformed images.
pub fn fit_camera(start: &SensorParams, real: &GrayImage, real_name: &str) -> Result<SensorParams> {
    fit_camera_at(start, real, real_name, None)
}

/// [`fit_camera`] with the camera distance (mm) held at `distance_mm` when given. The
/// undeformed image barely tells the distance from the field of view and distortion (the
/// blob sizes alone do); deformed images do, through the perspective of pins pressed towards
/// the camera, so the deformation fit chooses it and this refits the rest.
pub fn fit_camera_at(
    start: &SensorParams,
    real: &GrayImage,
    real_name: &str,
    distance_mm: Option<f64>,
) -> Result<SensorParams> {
    let real_p = ring_profile(real, start.pins.rings, real_name)?;
    let size = real.width();
    let mut base = start.clone();
    base.pins.ring_polar_deg = None;
    base.camera.principal_offset = [real_p.centre[0] / size as f64 - 0.5, real_p.centre[1] / size as f64 - 0.5];
    base.pins.phase_deg = real_p.phase_deg();
    if let Some(d) = distance_mm {
        base.camera.distance_mm = d;
    }
    let with = |p: &[f64]| {
        let mut s = base.clone();
        s.camera.fov_deg = p[0];
        s.pins.ring_pitch_deg = p[1];
        s.camera.k1 = p[2];
        s.pins.tip_radius_mm = p[3];
        if let Some(&d) = p.get(4) {
            s.camera.distance_mm = d;
        }
        s
    };
    // Model: ring k's first pin, projected; its distance from the principal point and its
    // disc radius.
    let residuals = |p: &[f64]| -> Option<Vec<f64>> {
        let s = with(p);
        s.validate("fit").ok()?;
        let cam = crate::camera::Camera::new(&s.camera, size);
        let layout = crate::pins::PinLayout::new(&s);
        let mut out = Vec::new();
        for ring in real_p.rings.iter() {
            let pin = layout.pins.iter().find(|q| q.ring == ring.ring)?;
            let disc = cam.project_disc(&pin.tip, &pin.normal, layout.tip_radius_mm)?;
            let w = (ring.count as f64).sqrt();
            if ring.ring > 0 {
                out.push(w * ((disc.u - cam.principal[0]).hypot(disc.v - cam.principal[1]) - ring.mean_radius_px));
            }
            out.push(w * (std::f64::consts::PI.sqrt() * disc.r - ring.mean_area_px.sqrt()));
        }
        Some(out)
    };
    let mut p0 = vec![base.camera.fov_deg, base.pins.ring_pitch_deg, base.camera.k1, base.pins.tip_radius_mm];
    let mut steps = vec![10.0, 1.0, 0.1, 0.1];
    if distance_mm.is_none() {
        p0.push(base.camera.distance_mm);
        steps.push(10.0);
    }
    let fit = levenberg_marquardt(&p0, &steps, 300, residuals).ok_or_else(|| SimError::Analysis {
        source_name: real_name.to_owned(),
        reason: "camera fit undefined at the start values".to_owned(),
    })?;
    let mut sensor = with(&fit.params);
    // The rendered (binarised) blob area differs slightly from pi r^2: one correction pass.
    sensor.validate("camera fit")?;
    let (cmp, _, _) = compare_sensor(&sensor, real, real_name)?;
    sensor.pins.tip_radius_mm /= (1.0 + cmp.area_rel_err).sqrt();
    sensor.validate("camera fit")?;
    Ok(sensor)
}

/// Fits [`Realism::pin_radius_scale`] (bisection) so that the lab-processed realistic render
/// of `sensor` has the real image's mean blob area. Returns the realism settings and the
/// remaining relative area error.
pub fn fit_realism(
    sensor: &SensorParams,
    start: &Realism,
    real: &GrayImage,
    real_name: &str,
) -> Result<(Realism, f64)> {
    let renderer = PinRenderer::new(sensor, real.width())?;
    let pins = renderer.layout().poses();
    let target = ring_profile(real, sensor.pins.rings, real_name)?.mean_area_px();
    let area_err = |scale: f64| -> Result<f64> {
        let r = Realism { pin_radius_scale: scale, ..start.clone() };
        let img = r.render(&renderer, &pins)?;
        Ok(ring_profile(&img, sensor.pins.rings, "realistic render")?.mean_area_px() / target - 1.0)
    };
    let (mut lo, mut hi) = (0.3, 1.5);
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        if area_err(mid)? > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let scale = 0.5 * (lo + hi);
    Ok((Realism { pin_radius_scale: scale, ..start.clone() }, area_err(scale)?))
}

/// Angular bins of [`fit_framing`]'s rim search (5 deg each).
const RIM_BINS: usize = 72;

/// Fits the rim ring and mask of a lab's framing ([`FramingParams`](crate::FramingParams)) to a real undeformed
/// image, about the principal point `centre` (px), given the pin field's radius `field_px`
/// (px, to the outermost pin centres). The white pixels beyond `1.08 field_px` are the rim's
/// candidates; a rim is found when they fill a band at least 0.8 px thick in 60% of the
/// `RIM_BINS` 5-degree sectors (specks and clutter near a masked edge do not). Its radius is the median candidate distance, its width the median over
/// sectors of the candidates' radial thickness (count over arc length), and the mask closes
/// half a pixel past its outer edge. No rim (the surface recordings: the lab masked it off):
/// the default framing, nothing drawn.
pub fn fit_framing(real: &GrayImage, centre: [f64; 2], field_px: f64) -> crate::sensor::FramingParams {
    let size = real.width() as f64;
    let mut dist = Vec::new();
    let mut per_bin = vec![Vec::new(); RIM_BINS];
    for (x, y, p) in real.enumerate_pixels() {
        let (du, dv) = (x as f64 + 0.5 - centre[0], y as f64 + 0.5 - centre[1]);
        let d = du.hypot(dv);
        if p.0[0] >= 128 && d > 1.08 * field_px {
            let bin = ((dv.atan2(du) + std::f64::consts::PI) / std::f64::consts::TAU * RIM_BINS as f64) as usize;
            per_bin[bin.min(RIM_BINS - 1)].push(d);
            dist.push(d);
        }
    }
    if dist.is_empty() {
        return crate::sensor::FramingParams::default();
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let radius = median(&mut dist);
    // A sector holds the rim when its candidates would fill a band 0.8 px thick along its arc.
    let arc = radius * std::f64::consts::TAU / RIM_BINS as f64;
    let holds = |b: &&Vec<f64>| b.len() as f64 >= 0.8 * arc;
    if (per_bin.iter().filter(holds).count() as f64) < 0.6 * RIM_BINS as f64 {
        return crate::sensor::FramingParams::default();
    }
    let mut widths: Vec<f64> = per_bin.iter().filter(holds).map(|b| b.len() as f64 / arc).collect();
    let width = median(&mut widths).clamp(1.0, crate::sensor::RIM_WIDTH_MAX * size);
    crate::sensor::FramingParams {
        rim_radius: Some(radius / size),
        rim_width: Some(width / size),
        mask_radius: Some(((radius + 0.5 * width + 0.5) / size).min(crate::sensor::FRAMING_RADIUS_MAX)),
    }
}

/// Refines a camera fit ring by ring: each ring's polar angle (`pins.ring_polar_deg`) set so
/// that its projected radius equals the real ring's mean radius in `real` (secant steps from
/// the ring pitch's angles). A uniform pitch cannot follow a dome whose rings are spaced
/// unevenly (the edge recordings' TacTip: 5.5 px to ring 1, 4.3 px between the outer rings at
/// 128 px); the camera (field of view, distortion) stays as fitted. Rings the real profile
/// lacks keep their pitch's angle; the result keeps the angles increasing within (0, 90) deg.
pub fn fit_ring_angles(sensor: &SensorParams, real: &RingProfile) -> Result<SensorParams> {
    let size = real.size;
    let mut angles: Vec<f64> = sensor.ring_polar_rad().iter().map(|a| a.to_degrees()).collect();
    let radius_of = |angles: &[f64]| -> Option<Vec<f64>> {
        let mut s = sensor.clone();
        s.pins.ring_polar_deg = Some(angles.to_vec());
        let cam = crate::camera::Camera::new(&s.camera, size);
        let layout = crate::pins::PinLayout::new(&s);
        (1..=s.pins.rings)
            .map(|k| {
                let pin = layout.pins.iter().find(|q| q.ring == k)?;
                let d = cam.project_disc(&pin.tip, &pin.normal, layout.tip_radius_mm)?;
                Some((d.u - cam.principal[0]).hypot(d.v - cam.principal[1]))
            })
            .collect()
    };
    let target: Vec<Option<f64>> =
        (1..=sensor.pins.rings).map(|k| real.rings.iter().find(|r| r.ring == k).map(|r| r.mean_radius_px)).collect();
    let fail = |reason: &str| SimError::Analysis { source_name: real_name(real), reason: reason.to_owned() };
    for _ in 0..30 {
        let r0 = radius_of(&angles).ok_or_else(|| fail("a ring leaves the camera's view"))?;
        let h = 1e-3;
        let bumped: Vec<f64> = angles.iter().map(|a| a + h).collect();
        let r1 = radius_of(&bumped).ok_or_else(|| fail("a ring leaves the camera's view"))?;
        let mut worst: f64 = 0.0;
        for (k, t) in target.iter().enumerate() {
            let Some(t) = t else { continue };
            let slope = (r1[k] - r0[k]) / h;
            if slope > 0.0 {
                let step = ((t - r0[k]) / slope).clamp(-1.0, 1.0);
                angles[k] += step;
                worst = worst.max((t - r0[k]).abs());
            }
        }
        if worst < 1e-4 {
            break;
        }
    }
    let mut out = sensor.clone();
    out.pins.ring_polar_deg = Some(angles);
    out.validate("ring angle fit")?;
    Ok(out)
}

/// A name for errors about a profile.
fn real_name(real: &RingProfile) -> String {
    format!("the real reference ({} px, {} pins)", real.size, real.pins)
}
