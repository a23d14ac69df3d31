//! One closed-loop run: touch down on the edge, then perceive, servo and move until the
//! trajectory closes on its start or the step limit, with the contact engine carrying history
//! along every sub-step; and the metrics of the run.

use std::time::Instant;

use serde::Serialize;
use tacsim_sim::SensorParams;
use tacsim_sim::contact::engine::{ContactModel, Simulation, contact_disk_grid};
use tacsim_sim::contact::pose::SensorPose;
use tacsim_sim::scene::{ObjectPose, Scene};
use tacsim_sim::stimulus::Catalogue;

use crate::control::Servo;
use crate::error::{ExploreError, Result};
use crate::learned::LearnedPerception;
use crate::perception::{Corruption, EdgeEstimate, Geometric, oracle, wrap_deg};
use crate::reconstruct::{Fusion, iou};
use crate::robot::Robot;
use crate::scenario::{PerceptionKind, Scenario};

/// What a run achieved, with the pass/fail verdict per criterion.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// Scenario name.
    pub name: String,
    /// Stimulus.
    pub shape: String,
    /// Perception used.
    pub perception: PerceptionKind,
    /// Servo steps taken.
    pub steps: usize,
    /// Whether the trajectory closed on its start.
    pub closed: bool,
    /// Fraction of the contour covered.
    pub completion: f64,
    /// Mean distance of the sensor centre from its reference line off the contour (mm).
    pub mean_deviation_mm: f64,
    /// Largest such distance (mm).
    pub max_deviation_mm: f64,
    /// Mean absolute angle between the sensor's `x` axis and the edge (deg).
    pub mean_yaw_error_deg: f64,
    /// IoU of the footprint fused from the contact engine's patches with the true one: the
    /// best the pins can do, and the criterion for `oracle` perception, which renders no image.
    pub iou: f64,
    /// Image-based perception: IoU of the footprint fused from the patches read off the
    /// image's pins (Voronoi cells, [`crate::contact_geometry`]): the criterion.
    pub iou_pins: Option<f64>,
    /// Image-based perception: its error against the oracle at the poses where it read a
    /// contact.
    pub perception_error: Option<PerceptionError>,
    /// Distance travelled (mm) and simulated time at the scenario's speed (s).
    pub travelled_mm: f64,
    /// Simulated time (s).
    pub sim_time_s: f64,
    /// Contact-engine sub-steps solved.
    pub substeps: usize,
    /// Wall time (s) and servo steps per second.
    pub wall_s: f64,
    /// Servo steps per wall second.
    pub steps_per_s: f64,
    /// The plot's file name in the report directory (`NAME.svg`; a scenario whose name another
    /// one shares takes its folder's name too).
    pub plot: String,
    /// Whether every criterion holds.
    pub pass: bool,
    /// The criteria that failed.
    pub failures: Vec<String>,
    /// Sensor poses after each step: `[x, y, yaw]` (mm, deg); the first is the start.
    pub trajectory: Vec<[f64; 3]>,
    /// The true contour (world mm), for plots.
    #[serde(skip)]
    pub contour: Vec<[f64; 2]>,
    /// The reconstructed footprint raster and its bounds `[x0, y0, x1, y1]`.
    #[serde(skip)]
    pub footprint: (Vec<bool>, usize, usize, [f64; 4]),
    /// Image-based perception: the footprint fused from the pins' patches, on the same raster.
    #[serde(skip)]
    pub footprint_pins: Option<Vec<bool>>,
}

/// Error of an image-based estimate against the true pose relative to the edge ([`oracle`]),
/// over the steps where the image showed contact (estimate minus truth).
#[derive(Clone, Debug, Default, Serialize)]
pub struct PerceptionError {
    /// Steps with an estimate.
    pub steps: usize,
    /// Mean signed lateral offset error (mm): negative reads the sensor as further onto the
    /// material than it is.
    pub offset_bias_mm: f64,
    /// Mean absolute lateral offset error (mm).
    pub offset_mae_mm: f64,
    /// Mean signed edge angle error (deg).
    pub angle_bias_deg: f64,
    /// Mean absolute edge angle error (deg).
    pub angle_mae_deg: f64,
}

impl PerceptionError {
    /// Adds one step's estimate against the truth.
    fn add(&mut self, estimate: &EdgeEstimate, truth: &EdgeEstimate) {
        let (dx, da) = (estimate.offset_mm - truth.offset_mm, wrap_deg(estimate.angle_deg - truth.angle_deg));
        self.steps += 1;
        self.offset_bias_mm += dx;
        self.offset_mae_mm += dx.abs();
        self.angle_bias_deg += da;
        self.angle_mae_deg += da.abs();
    }

    /// The sums turned into means.
    fn finish(mut self) -> Self {
        let n = self.steps.max(1) as f64;
        for v in [&mut self.offset_bias_mm, &mut self.offset_mae_mm, &mut self.angle_bias_deg, &mut self.angle_mae_deg]
        {
            *v /= n;
        }
        self
    }
}

/// Arc length along a closed polyline of the point nearest `p`.
fn arc_position(outline: &[[f64; 2]], cumulative: &[f64], p: [f64; 2]) -> f64 {
    let mut best = (f64::INFINITY, 0.0);
    for (k, a) in outline.iter().enumerate() {
        let b = outline[(k + 1) % outline.len()];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let q = [a[0] + t * dx, a[1] + t * dy];
        let d2 = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
        if d2 < best.0 {
            best = (d2, cumulative[k] + t * len2.sqrt());
        }
    }
    best.1
}

/// The pins of the sensor of `model` pressed `depth_mm` straight onto a flat face (the top of
/// the built-in `disk`, at its centre, with friction `friction`): image-based perception's
/// template ([`Geometric`]).
pub fn reference_press(model: &ContactModel, depth_mm: f64, friction: f64) -> Result<Vec<tacsim_sim::pins::PinPose>> {
    let disk =
        tacsim_sim::embedded::catalogue().map_err(ExploreError::sim("loading the built-in shapes"))?.get("disk")?;
    let scene = tacsim_sim::scene::flat_scene(&disk, friction)?;
    let mut sim = Simulation::with_grid(model, &scene, Some(contact_disk_grid(model, depth_mm)));
    sim.step(SensorPose::new(0.0, 0.0, depth_mm, 0.0))?;
    Ok(sim.pins())
}

/// Runs `scenario` with `sensor` on the stimuli of `catalogue`; `learned` builds the reader of
/// `learned` and `learned-raw` perception (an error names the scenario where it is needed and
/// missing).
pub fn run(
    scenario: &Scenario,
    sensor: &SensorParams,
    catalogue: &Catalogue,
    learned: Option<&dyn LearnedPerception>,
) -> Result<RunReport> {
    let wall = Instant::now();
    let in_scenario = format!("scenario {}", scenario.name);
    let stim = catalogue
        .get(&scenario.shape)
        .map_err(ExploreError::sim(format!("scenario {}: field `shape`", scenario.name)))?;
    let stim = stim.with_friction(scenario.friction);
    let (contact_mm, friction) = (stim.entry.contact_mm, stim.entry.friction);
    let mut scene = Scene::new();
    let object = scene.add(stim, ObjectPose::default())?;
    let outline = scene.contour_world(object).into_iter().max_by_key(|l| l.len()).unwrap_or_default();
    let mut cumulative = vec![0.0; outline.len() + 1];
    for k in 0..outline.len() {
        let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
        cumulative[k + 1] = cumulative[k] + (b[0] - a[0]).hypot(b[1] - a[1]);
    }
    let perimeter = cumulative[outline.len()];

    // Start on the edge nearest the start point, aligned with it, at the offset reference.
    let start = scenario.start_mm.or(contact_mm).unwrap_or([1e3, 0.0]);
    let e = scene.edge(object, start[0], start[1]);
    let n = [e.tangent[1], -e.tangent[0]];
    let r = scenario.control.offset_ref_mm;
    let pose0 = SensorPose {
        x_mm: e.point[0] + r * n[0],
        y_mm: e.point[1] + r * n[1],
        depth_mm: scenario.depth_mm,
        yaw_deg: e.tangent[1].atan2(e.tangent[0]).to_degrees(),
        rx_deg: 0.0,
        ry_deg: 0.0,
    };
    pose0.validate(&scenario.name, sensor.dome.outer_radius_mm)?;

    let model = ContactModel::new(sensor);
    let grid = contact_disk_grid(&model, scenario.depth_mm);
    let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
    // A flat face pressed `d` into the dome touches within about sqrt(R d) (Hertz); inside
    // that radius, no contact means no material.
    let reach = 0.9 * (sensor.dome.outer_radius_mm * scenario.depth_mm).sqrt();
    let mut fusion = Fusion::default();
    let mut robot = Robot::new(pose0, scenario.substep_mm);
    let mut servo = Servo::new(&scenario.control, scenario.step_mm);
    let mut corruption = Corruption::new(&scenario.noise, scenario.seed);
    // Image-based perception reads the contact patch off the pins (Voronoi cells) whatever
    // estimates the pose: `pins` tracks them frame to frame, and with `geometric` perception
    // it also gives the estimate.
    let mut pins = match scenario.perception {
        PerceptionKind::Oracle => None,
        _ => {
            let press = reference_press(&model, scenario.depth_mm, friction)?;
            Some(Geometric::new(sensor, scenario.image_size, &press).map_err(|e| e.within(&in_scenario))?)
        }
    };
    let learned = match scenario.perception {
        PerceptionKind::Learned | PerceptionKind::LearnedRaw => match learned {
            Some(l) => Some(l.reader(scenario, sensor)?),
            None => {
                return Err(ExploreError::Perception {
                    what: format!("{in_scenario}: field `perception`"),
                    reason: "learned perception needs trained networks, which this caller does not supply: \
                             run the scenario with `tacsim run`"
                        .into(),
                });
            }
        },
        PerceptionKind::Oracle | PerceptionKind::Geometric => None,
    };
    // Without contact the image-based estimates say "the edge is a contact radius inward".
    let searching =
        EdgeEstimate { offset_mm: (sensor.dome.outer_radius_mm * scenario.depth_mm).sqrt(), angle_deg: 0.0 };
    // Touch down one step back along the edge and slide onto the start, so that the start's
    // image (the tare of image-based perception) carries the drag of sliding like every
    // later one.
    let yaw = pose0.yaw_deg.to_radians();
    let back = SensorPose {
        x_mm: pose0.x_mm - scenario.step_mm * yaw.cos(),
        y_mm: pose0.y_mm - scenario.step_mm * yaw.sin(),
        ..pose0
    };
    sim.step(back)?;
    let onto_start = Robot::new(back, scenario.substep_mm).move_to(pose0);
    for p in &onto_start {
        sim.step(*p)?;
    }
    let centres = grid.centres();
    // Each visited pose adds its contact patch: the contact engine's to `fusion`, and, with
    // image-based perception, the one read off the image's pins to `fusion_pins`.
    let mut fusion_pins = Fusion::default();
    let fuse = |fusion: &mut Fusion,
                fusion_pins: &mut Fusion,
                pins: &Option<Geometric>,
                sim: &Simulation,
                pose: &SensorPose| {
        fusion.add_patch(&grid, sim.pressure(), pose, reach);
        if let Some(g) = pins {
            fusion_pins.add_points(&centres, &g.touching(&centres), pose, reach);
        }
    };
    // The robot starts on the edge, aligned with it: image-based perception takes its first
    // estimate there as its zero (a tare), as a robot would at a known start.
    if let Some(g) = &mut pins {
        g.tare(&sim.pins(), EdgeEstimate { offset_mm: r, angle_deg: 0.0 });
    }
    let mut substeps = 1 + onto_start.len();
    let mut trajectory = vec![[pose0.x_mm, pose0.y_mm, pose0.yaw_deg]];
    let (mut deviations, mut yaw_errors) = (Vec::new(), Vec::new());
    let s0 = arc_position(&outline, &cumulative, [pose0.x_mm, pose0.y_mm]);
    let (mut last_s, mut progress) = (s0, 0.0f64);
    let mut closed = false;
    let mut steps = 0;
    let mut perception_error = PerceptionError::default();
    while steps < scenario.max_steps {
        // One image per step, for the pins' patch and whichever perception reads it.
        let img = pins.as_ref().map(|g| g.render(&sim.pins()));
        let from_pins = pins.as_mut().zip(img.as_ref()).and_then(|(g, img)| g.estimate_image(img));
        let read = match (&learned, &img) {
            (Some(l), Some(img)) => l.estimate(img)?,
            _ => from_pins,
        };
        let fresh = match read {
            Some(e) => {
                perception_error.add(&e, &oracle(&scene, object, &robot.pose));
                e
            }
            None if scenario.perception == PerceptionKind::Oracle => oracle(&scene, object, &robot.pose),
            None => searching,
        };
        fuse(&mut fusion, &mut fusion_pins, &pins, &sim, &robot.pose);
        let estimate = corruption.apply(fresh);
        let target = servo.next(&robot.pose, &estimate);
        for p in robot.move_to(target) {
            sim.step(p)?;
            substeps += 1;
        }
        steps += 1;
        let pose = robot.pose;
        trajectory.push([pose.x_mm, pose.y_mm, pose.yaw_deg]);
        let now = oracle(&scene, object, &pose);
        deviations.push((now.offset_mm - r).abs());
        yaw_errors.push(wrap_deg(now.angle_deg).abs());
        let s = arc_position(&outline, &cumulative, [pose.x_mm, pose.y_mm]);
        let mut ds = s - last_s;
        if ds > 0.5 * perimeter {
            ds -= perimeter;
        } else if ds < -0.5 * perimeter {
            ds += perimeter;
        }
        progress += ds;
        last_s = s;
        if progress >= perimeter - 0.5 * scenario.step_mm {
            closed = true;
            break;
        }
    }
    if let Some(g) = &mut pins {
        g.estimate(&sim.pins());
    }
    fuse(&mut fusion, &mut fusion_pins, &pins, &sim, &robot.pose);
    let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 };
    let (lo, hi) = outline.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    let bounds = [lo[0] - 5.0, lo[1] - 5.0, hi[0] + 5.0, hi[1] + 5.0];
    let (fp, nx, ny) = fusion.footprint(bounds);
    let stimulus = &scene.objects()[object].stimulus;
    let inside = |x: f64, y: f64| stimulus.contour.contains([x, y]);
    let footprint_pins = pins.is_some().then(|| fusion_pins.footprint(bounds).0);
    let iou_pins = footprint_pins.as_ref().map(|fp| iou(fp, nx, bounds, inside));
    let iou = iou(&fp, nx, bounds, inside);
    let c = &scenario.criteria;
    let mut report = RunReport {
        name: scenario.name.clone(),
        shape: scenario.shape.clone(),
        perception: scenario.perception,
        steps,
        closed,
        completion: (progress / perimeter).clamp(0.0, 1.0),
        mean_deviation_mm: mean(&deviations),
        max_deviation_mm: deviations.iter().fold(0.0, |m, v| m.max(*v)),
        mean_yaw_error_deg: mean(&yaw_errors),
        iou,
        iou_pins,
        perception_error: (scenario.perception != PerceptionKind::Oracle).then(|| perception_error.finish()),
        travelled_mm: robot.travelled_mm,
        sim_time_s: robot.travelled_mm / scenario.speed_mm_s,
        substeps,
        wall_s: 0.0,
        steps_per_s: 0.0,
        plot: String::new(),
        pass: false,
        failures: Vec::new(),
        trajectory,
        contour: outline,
        footprint: (fp, nx, ny, bounds),
        footprint_pins,
    };
    let checks = [
        (
            report.closed && report.completion >= c.completion,
            format!("completion {:.3} (closed: {}) < {}", report.completion, report.closed, c.completion),
        ),
        (
            report.mean_deviation_mm <= c.mean_deviation_mm,
            format!("mean deviation {:.3} mm > {}", report.mean_deviation_mm, c.mean_deviation_mm),
        ),
        (
            report.max_deviation_mm <= c.max_deviation_mm,
            format!("max deviation {:.3} mm > {}", report.max_deviation_mm, c.max_deviation_mm),
        ),
        (
            report.mean_yaw_error_deg <= c.yaw_error_deg,
            format!("mean yaw error {:.2} deg > {}", report.mean_yaw_error_deg, c.yaw_error_deg),
        ),
        match report.iou_pins {
            Some(v) => (v >= c.iou, format!("IoU from the pins {v:.3} < {}", c.iou)),
            None => (report.iou >= c.iou, format!("IoU {:.3} < {}", report.iou, c.iou)),
        },
    ];
    report.failures = checks.into_iter().filter(|(ok, _)| !ok).map(|(_, why)| why).collect();
    report.pass = report.failures.is_empty();
    report.wall_s = wall.elapsed().as_secs_f64();
    report.steps_per_s = steps as f64 / report.wall_s.max(1e-9);
    Ok(report)
}
