//! One closed-loop run: touch down on the edge, then perceive, servo and move until the
//! trajectory closes on its start or the step limit, with the contact engine carrying history
//! along every sub-step; and the metrics of the run.

use std::time::Instant;

use serde::Serialize;
use tacsim_sim::contact::{ContactModel, Simulation, contact_disk_grid};
use tacsim_sim::stimulus::{Catalogue, project_on_segment};
use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose};

use crate::control::Servo;
use crate::error::{ExploreError, Result};
use crate::learned::LearnedPerception;
use crate::perception::{Corruption, EdgeEstimate, Geometric, oracle};
use crate::reconstruct::{Fusion, iou};
use crate::robot::Robot;
use crate::scenario::{PerceptionKind, Scenario};
use tacsim_data::wrap_deg;

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
    /// image's pins (Voronoi cells, `contact_geometry.rs`): the criterion.
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

/// The stimulus's outline as a closed course: where along it (mm of arc) a point lies, and
/// how far a move went along it.
struct Course {
    /// The outline (world mm), closed from its last point to its first.
    outline: Vec<[f64; 2]>,
    /// Arc length (mm) at each point, and the perimeter last.
    cumulative: Vec<f64>,
}

impl Course {
    fn new(outline: Vec<[f64; 2]>) -> Self {
        let mut cumulative = vec![0.0; outline.len() + 1];
        for k in 0..outline.len() {
            let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
            cumulative[k + 1] = cumulative[k] + (b[0] - a[0]).hypot(b[1] - a[1]);
        }
        Self { outline, cumulative }
    }

    /// The perimeter (mm).
    fn perimeter(&self) -> f64 {
        self.cumulative[self.outline.len()]
    }

    /// Arc length of the point of the outline nearest `p`.
    fn arc_position(&self, p: [f64; 2]) -> f64 {
        let mut best = (f64::INFINITY, 0.0);
        for (k, &a) in self.outline.iter().enumerate() {
            let b = self.outline[(k + 1) % self.outline.len()];
            if let Some(s) = project_on_segment(a, b, p)
                && s.distance2 < best.0
            {
                best = (s.distance2, self.cumulative[k] + s.t * s.length);
            }
        }
        best.1
    }

    /// The arc (mm) from arc position `from` to `to`, the short way round (signed).
    fn advance(&self, from: f64, to: f64) -> f64 {
        let perimeter = self.perimeter();
        let ds = to - from;
        if ds > 0.5 * perimeter {
            ds - perimeter
        } else if ds < -0.5 * perimeter {
            ds + perimeter
        } else {
            ds
        }
    }

    /// The outline's bounding box grown by `margin_mm`: `[x0, y0, x1, y1]` (mm).
    fn bounds(&self, margin_mm: f64) -> [f64; 4] {
        let (lo, hi) = self.outline.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), p| {
            ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
        });
        [lo[0] - margin_mm, lo[1] - margin_mm, hi[0] + margin_mm, hi[1] + margin_mm]
    }
}

/// The pins of the sensor of `model` pressed `depth_mm` straight onto a flat face (the top of
/// the built-in `disk`, at its centre, with friction `friction`): image-based perception's
/// template ([`Geometric`]).
pub fn reference_press(model: &ContactModel, depth_mm: f64, friction: f64) -> Result<Vec<tacsim_sim::PinPose>> {
    let disk =
        tacsim_sim::builtin_catalogue().map_err(ExploreError::sim("loading the built-in shapes"))?.get("disk")?;
    let scene = tacsim_sim::flat_scene(&disk, friction)?;
    let mut sim = Simulation::with_grid(model, &scene, Some(contact_disk_grid(model, depth_mm)));
    sim.step(SensorPose::new(0.0, 0.0, depth_mm, 0.0))?;
    Ok(sim.pins())
}

/// Runs `scenario` with `sensor` on the stimuli of `catalogue`; `learned` builds the reader of
/// `learned` and `learned-raw` perception (an error names the scenario where it is needed and
/// missing).
///
/// The stages, each a named step: the scene and its course (`setup`), the start pose
/// (`start_pose`), the perception (`Perceivers::new`), the touch-down (`touch_down`),
/// then per servo step perceive, fuse the contact patch, servo and move, until the course
/// closes or the step limit; last the footprints and the verdict (`RunReport::judge`).
pub fn run(
    scenario: &Scenario,
    sensor: &SensorParams,
    catalogue: &Catalogue,
    learned: Option<&dyn LearnedPerception>,
) -> Result<RunReport> {
    let wall = Instant::now();
    let (scene, object, friction, course) = setup(scenario, catalogue)?;
    let pose0 = start_pose(scenario, sensor, &scene, object)?;
    let r = scenario.control.offset_ref_mm;
    let model = ContactModel::new(sensor)?;
    let grid = contact_disk_grid(&model, scenario.depth_mm);
    let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
    // A flat face pressed `d` into the dome touches within about sqrt(R d) (Hertz); inside
    // that radius, no contact means no material.
    let reach = 0.9 * (sensor.dome.outer_radius_mm * scenario.depth_mm).sqrt();
    let mut fusion = Fusion::default();
    let mut robot = Robot::new(pose0, scenario.substep_mm);
    let mut servo = Servo::new(&scenario.control, scenario.step_mm);
    let mut corruption = Corruption::new(&scenario.noise, scenario.seed);
    let mut perceivers = Perceivers::new(scenario, sensor, &model, friction, learned)?;
    // Without contact the image-based estimates say "the edge is a contact radius inward".
    let searching =
        EdgeEstimate { offset_mm: (sensor.dome.outer_radius_mm * scenario.depth_mm).sqrt(), angle_deg: 0.0 };
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
    // The robot starts on the edge, aligned with it: image-based perception takes its zero
    // from taps across the edge there (a tare), as a robot would at a known start; either
    // way the sensor then touches down onto the start.
    let mut substeps = 0;
    if let Some(g) = &mut perceivers.pins {
        let taps = tare_taps(&mut sim, scenario, pose0, &mut substeps)?;
        g.tare(&taps);
    }
    sim.lift();
    substeps += touch_down(&mut sim, scenario, pose0)?;
    let mut tally = Tally::new(&course, &pose0);
    let perimeter = course.perimeter();
    let mut closed = false;
    let mut steps = 0;
    let mut perception_error = PerceptionError::default();
    while steps < scenario.max_steps {
        let fresh = match perceivers.read(&sim)? {
            Some(e) => {
                perception_error.add(&e, &oracle(&scene, object, &robot.pose));
                e
            }
            None if scenario.perception == PerceptionKind::Oracle => oracle(&scene, object, &robot.pose),
            None => searching,
        };
        fuse(&mut fusion, &mut fusion_pins, &perceivers.pins, &sim, &robot.pose);
        let estimate = corruption.apply(fresh);
        let target = servo.next(&robot.pose, &estimate);
        for p in robot.move_to(target) {
            sim.step(p)?;
            substeps += 1;
        }
        steps += 1;
        let now = oracle(&scene, object, &robot.pose);
        tally.record(&course, &robot.pose, &now, r);
        if tally.progress >= perimeter - 0.5 * scenario.step_mm {
            closed = true;
            break;
        }
    }
    if let Some(g) = &mut perceivers.pins {
        g.estimate(&sim.pins());
    }
    fuse(&mut fusion, &mut fusion_pins, &perceivers.pins, &sim, &robot.pose);
    let Tally { trajectory, deviations, yaw_errors, progress, .. } = tally;
    let pins = perceivers.pins;
    let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 };
    let bounds = course.bounds(5.0);
    let (fp, nx, ny) = fusion.footprint(bounds);
    let stimulus = &scene.objects()[object].stimulus;
    let inside = |x: f64, y: f64| stimulus.contour.contains([x, y]);
    let footprint_pins = pins.is_some().then(|| fusion_pins.footprint(bounds).0);
    let iou_pins = footprint_pins.as_ref().map(|fp| iou(fp, nx, bounds, inside));
    let iou = iou(&fp, nx, bounds, inside);
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
        contour: course.outline,
        footprint: (fp, nx, ny, bounds),
        footprint_pins,
    };
    report.judge(&scenario.criteria);
    report.wall_s = wall.elapsed().as_secs_f64();
    report.steps_per_s = steps as f64 / report.wall_s.max(1e-9);
    Ok(report)
}

/// The scene of `scenario`: its stimulus (with the scenario's friction) at the origin, the
/// object's index, the friction, and the course along its longest outline.
fn setup(scenario: &Scenario, catalogue: &Catalogue) -> Result<(Scene, usize, f64, Course)> {
    let stim = catalogue
        .get(&scenario.shape)
        .map_err(ExploreError::sim(format!("scenario {}: field `shape`", scenario.name)))?;
    let stim = stim.with_friction(scenario.friction);
    let friction = stim.entry.friction;
    let mut scene = Scene::new();
    let object = scene.add(stim, ObjectPose::default())?;
    let outline = scene.contour_world(object).into_iter().max_by_key(|l| l.len()).unwrap_or_default();
    Ok((scene, object, friction, Course::new(outline)))
}

/// The start: on the edge nearest the scenario's start point (else the stimulus's contact
/// location), aligned with it, at the servo's offset reference; checked against the dome.
fn start_pose(scenario: &Scenario, sensor: &SensorParams, scene: &Scene, object: usize) -> Result<SensorPose> {
    let contact_mm = scene.objects()[object].stimulus.entry.contact_mm;
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
    Ok(pose0)
}

/// The perception a scenario asks for besides the oracle.
/// The run's record, step by step: the trajectory, the true offset's deviation from the
/// reference and the true yaw error, and the arc (mm) travelled along the course.
struct Tally {
    trajectory: Vec<[f64; 3]>,
    deviations: Vec<f64>,
    yaw_errors: Vec<f64>,
    /// Arc position of the last pose.
    last_s: f64,
    /// Arc travelled (signed, the short way round each step).
    progress: f64,
}

impl Tally {
    fn new(course: &Course, start: &SensorPose) -> Self {
        Self {
            trajectory: vec![[start.x_mm, start.y_mm, start.yaw_deg]],
            deviations: Vec::new(),
            yaw_errors: Vec::new(),
            last_s: course.arc_position([start.x_mm, start.y_mm]),
            progress: 0.0,
        }
    }

    /// Records `pose`, whose true edge is `now`, against the offset reference `offset_ref_mm`.
    fn record(&mut self, course: &Course, pose: &SensorPose, now: &EdgeEstimate, offset_ref_mm: f64) {
        self.trajectory.push([pose.x_mm, pose.y_mm, pose.yaw_deg]);
        self.deviations.push((now.offset_mm - offset_ref_mm).abs());
        self.yaw_errors.push(wrap_deg(now.angle_deg).abs());
        let s = course.arc_position([pose.x_mm, pose.y_mm]);
        self.progress += course.advance(self.last_s, s);
        self.last_s = s;
    }
}

struct Perceivers {
    /// Image-based perception reads the contact patch off the pins (Voronoi cells) whatever
    /// estimates the pose: it tracks them frame to frame, and with `geometric` perception it
    /// also gives the estimate. `None` with the oracle.
    pins: Option<Geometric>,
    /// The learned reader of `learned` and `learned-raw` perception.
    learned: Option<Box<dyn crate::learned::EdgeReader>>,
}

impl Perceivers {
    /// One image of the pins per step, for their patch and whichever perception reads it:
    /// the learned reader's estimate where there is one, else the pins' (none with the
    /// oracle, or when the pins find no edge).
    fn read(&mut self, sim: &Simulation) -> Result<Option<EdgeEstimate>> {
        let img = self.pins.as_ref().map(|g| g.render(&sim.pins()));
        let from_pins = self.pins.as_mut().zip(img.as_ref()).and_then(|(g, img)| g.estimate_image(img));
        Ok(match (&self.learned, &img) {
            (Some(l), Some(img)) => l.estimate(img)?,
            _ => from_pins,
        })
    }

    fn new(
        scenario: &Scenario,
        sensor: &SensorParams,
        model: &ContactModel,
        friction: f64,
        learned: Option<&dyn LearnedPerception>,
    ) -> Result<Self> {
        let in_scenario = format!("scenario {}", scenario.name);
        let pins = match scenario.perception {
            PerceptionKind::Oracle => None,
            _ => {
                let press = reference_press(model, scenario.depth_mm, friction)?;
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
        Ok(Self { pins, learned })
    }
}

/// Lateral offsets (mm, off the material positive) of the tare's taps about the start: two
/// millimetres across the edge every quarter, past three periods of the estimate's sawtooth
/// ([`Geometric::tare`]).
const TARE_OFFSETS_MM: [f64; 9] = [-1.0, -0.75, -0.5, -0.25, 0.0, 0.25, 0.5, 0.75, 1.0];

/// The tare's taps: the pins and the true pose relative to the edge of a touch-down
/// ([`touch_down`]) at each of [`TARE_OFFSETS_MM`] across the edge from `pose0`, the sensor
/// lifted between them. Adds the sub-steps taken to `substeps`.
fn tare_taps(
    sim: &mut Simulation,
    scenario: &Scenario,
    pose0: SensorPose,
    substeps: &mut usize,
) -> Result<Vec<(Vec<tacsim_sim::PinPose>, EdgeEstimate)>> {
    // The outward normal: the tangent turned clockwise (the material on its left).
    let yaw = pose0.yaw_deg.to_radians();
    let out = [yaw.sin(), -yaw.cos()];
    let mut taps = Vec::with_capacity(TARE_OFFSETS_MM.len());
    for d in TARE_OFFSETS_MM {
        sim.lift();
        let at = SensorPose { x_mm: pose0.x_mm + d * out[0], y_mm: pose0.y_mm + d * out[1], ..pose0 };
        *substeps += touch_down(sim, scenario, at)?;
        taps.push((sim.pins(), EdgeEstimate { offset_mm: scenario.control.offset_ref_mm + d, angle_deg: 0.0 }));
    }
    Ok(taps)
}

/// Touches down one step back along the edge from `pose0` and slides onto it, so that the
/// start's image (the tare of image-based perception) carries the drag of sliding like every
/// later one. Returns the sub-steps taken.
fn touch_down(sim: &mut Simulation, scenario: &Scenario, pose0: SensorPose) -> Result<usize> {
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
    Ok(1 + onto_start.len())
}

impl RunReport {
    /// Sets the verdict: each criterion of `c` checked, the failures said in words.
    fn judge(&mut self, c: &crate::scenario::Criteria) {
        let checks = [
            (
                self.closed && self.completion >= c.completion,
                format!("completion {:.3} (closed: {}) < {}", self.completion, self.closed, c.completion),
            ),
            (
                self.mean_deviation_mm <= c.mean_deviation_mm,
                format!("mean deviation {:.3} mm > {}", self.mean_deviation_mm, c.mean_deviation_mm),
            ),
            (
                self.max_deviation_mm <= c.max_deviation_mm,
                format!("max deviation {:.3} mm > {}", self.max_deviation_mm, c.max_deviation_mm),
            ),
            (
                self.mean_yaw_error_deg <= c.yaw_error_deg,
                format!("mean yaw error {:.2} deg > {}", self.mean_yaw_error_deg, c.yaw_error_deg),
            ),
            match self.iou_pins {
                Some(v) => (v >= c.iou, format!("IoU from the pins {v:.3} < {}", c.iou)),
                None => (self.iou >= c.iou, format!("IoU {:.3} < {}", self.iou, c.iou)),
            },
        ];
        self.failures = checks.into_iter().filter(|(ok, _)| !ok).map(|(_, why)| why).collect();
        self.pass = self.failures.is_empty();
    }
}
