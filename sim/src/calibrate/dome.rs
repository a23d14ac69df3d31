//! Fitting the finite-element dome's own parameters to a lab's recordings (`tacsim calibrate
//! --dome`): the gel's modulus, the skin's thickness and the rigid base's depth.
//!
//! - The gel's modulus is searched as its ratio to the skin's: the recordings are pressed to
//!   a depth, and linear elasticity with Coulomb friction (`|q| <= mu p`, both scaling with
//!   the moduli) moves no pin when both moduli scale together.
//! - The skin's thickness `t` changes the pins' length with it (`length = tip depth - t`), so
//!   that the pin tips, and with them the undeformed image, stay where the camera fit put them.
//! - The base's depth below the apex is bounded to the dome's `[R, 2R]`
//!   ([`crate::SensorParams::validate`]).
//!
//! Each candidate dome is a finite-element build of its own (about 20 s and 75 MB of cache at
//! the default 8 cells, `docs/guide/fem.md`), so the search is a coordinate search on a lattice
//! of points, each scored once ([`search_dome`]), rather than a simplex that would build a dome
//! for every evaluation: from the sensor's own dome, each coordinate stepped while the score
//! falls (the gel ratio by factors of 2, the skin by 0.4 mm, the base by 4 mm), then the steps
//! halved once, within a budget of domes. The score is the caller's: the surface fit's rig
//! fitted anew on each dome ([`super::fitting::calibrate`]), the edge fit's label map
//! ([`super::edge::fit_edge`]).

use std::f64::consts::LN_2;

use serde::{Deserialize, Serialize};

use super::model::Deformation;
use crate::error::{Result, SimError};
use crate::sensor::{SensorParams, SkinModel};

/// The search's first steps: `ln` of the gel ratio, the skin's thickness (mm), the base's depth
/// (mm).
pub const DOME_STEPS: [f64; 3] = [LN_2, 0.4, 4.0];

/// Gel ratios searched: from a gel a thousand times softer than the skin to one as stiff.
pub const GEL_RATIO_RANGE: [f64; 2] = [1e-3, 1.0];

/// Skin thicknesses searched (mm): at least this, and at most [`MAX_SKIN_OF_RADIUS`] of the
/// dome's radius.
pub const MIN_SKIN_MM: f64 = 0.3;

/// The thickest skin searched, as a share of the dome's radius.
pub const MAX_SKIN_OF_RADIUS: f64 = 0.2;

/// The shortest pins a thicker skin may leave (mm): the surface fit's bound.
pub const MIN_PIN_MM: f64 = 0.5;

/// One candidate dome.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DomePoint {
    /// Gel modulus over skin modulus.
    pub gel_ratio: f64,
    /// Skin thickness (mm).
    pub skin_thickness_mm: f64,
    /// Depth of the rigid base below the apex (mm).
    pub base_depth_mm: f64,
}

impl DomePoint {
    /// The dome of `sensor` (whatever its body).
    pub fn of(sensor: &SensorParams) -> Self {
        Self {
            gel_ratio: sensor.skin.gel_youngs_modulus_mpa / sensor.skin.youngs_modulus_mpa,
            skin_thickness_mm: sensor.dome.skin_thickness_mm,
            base_depth_mm: sensor.skin.base_depth_mm,
        }
    }

    /// `base` with the finite-element dome of this point, the pin tips kept (validated):
    /// [`Deformation::sensor`] of [`DomePoint::on`] `base`'s own parameters.
    pub fn sensor(&self, base: &SensorParams) -> Result<SensorParams> {
        self.on(base, &Deformation::of(base, 0.0)).sensor(base)
    }

    /// `d` (its rig) on this dome of `base`: the dome's gel ratio, base and pins' length
    /// (the tips kept, [`Deformation::sensor`] making the skin's thickness of it).
    pub fn on(&self, base: &SensorParams, d: &Deformation) -> Deformation {
        Deformation {
            model: SkinModel::Dome,
            gel_ratio: self.gel_ratio,
            base_depth_mm: self.base_depth_mm,
            pin_length_mm: self.pin_length_mm(base),
            ..d.clone()
        }
    }

    /// The pins' length (mm) this point leaves on `base`'s tips.
    pub fn pin_length_mm(&self, base: &SensorParams) -> f64 {
        tip_depth_mm(base) - self.skin_thickness_mm
    }

    /// The search's coordinates: `ln` gel ratio, skin (mm), base (mm).
    fn coordinates(&self) -> [f64; 3] {
        [self.gel_ratio.ln(), self.skin_thickness_mm, self.base_depth_mm]
    }

    fn from_coordinates(c: [f64; 3]) -> Self {
        Self { gel_ratio: c[0].exp(), skin_thickness_mm: c[1], base_depth_mm: c[2] }
    }

    /// Whether the search may take this point on `base`: the ranges of the module's
    /// constants, the base in `[R, 2R]`, and a sensor that validates.
    fn searchable(&self, base: &SensorParams) -> bool {
        let r = base.dome.outer_radius_mm;
        let within = |v: f64, lo: f64, hi: f64| v.is_finite() && v >= lo - 1e-9 && v <= hi + 1e-9;
        within(self.gel_ratio, GEL_RATIO_RANGE[0], GEL_RATIO_RANGE[1])
            && within(self.skin_thickness_mm, MIN_SKIN_MM, MAX_SKIN_OF_RADIUS * r)
            && within(self.base_depth_mm, r, 2.0 * r)
            && self.pin_length_mm(base) >= MIN_PIN_MM
            && self.sensor(base).is_ok()
    }
}

/// How deep the pin tips sit below the dome's outer surface (mm): skin plus pins.
fn tip_depth_mm(sensor: &SensorParams) -> f64 {
    sensor.dome.skin_thickness_mm + sensor.pins.length_mm
}

/// One dome the search scored.
#[derive(Clone, Debug, Serialize)]
pub struct DomeTrial<T> {
    /// The dome.
    pub point: DomePoint,
    /// Its score (lower is better).
    pub score: f64,
    /// What the caller fitted on it (the rig, the label map).
    pub fitted: T,
}

/// The outcome of [`search_dome`].
#[derive(Clone, Debug, Serialize)]
pub struct DomeSearch<T> {
    /// Every dome scored, in the order scored.
    pub trials: Vec<DomeTrial<T>>,
    /// Index of the lowest score.
    pub best: usize,
}

impl<T> DomeSearch<T> {
    /// The best trial.
    pub fn winner(&self) -> &DomeTrial<T> {
        &self.trials[self.best]
    }
}

/// What [`search_dome`] scores a dome with: `score(point, best)` fits the caller's model on
/// the dome `point` from the best trial's fit so far (`None` for the first) and returns its
/// score (lower is better) and fit.
pub type DomeScore<'a, T> = dyn FnMut(&DomePoint, Option<&T>) -> Result<(f64, T)> + 'a;

/// The coordinate search of the module's docs from `base`'s own dome (clamped into the
/// searched ranges), scoring at most `budget` domes with `score` ([`DomeScore`]).
/// Deterministic: the same scores give the same trials.
pub fn search_dome<T>(
    base: &SensorParams,
    budget: usize,
    score: &mut DomeScore<'_, T>,
    progress: &dyn Fn(&str),
) -> Result<DomeSearch<T>> {
    if budget == 0 {
        return Err(SimError::invalid("the dome fit", "budget", "score at least one dome"));
    }
    let start = dome_start(base)?;
    let mut trials: Vec<DomeTrial<T>> = Vec::new();
    // Scores a new dome from the fit of trial `best`, appended to `trials`.
    let mut run = |point: DomePoint, best: Option<usize>, trials: &mut Vec<DomeTrial<T>>| -> Result<usize> {
        let (s, fitted) = score(&point, best.map(|b| &trials[b].fitted))?;
        progress(&format!(
            "dome: gel / skin {:.4}, skin {:.2} mm, base {:.1} mm: {s:.4}",
            point.gel_ratio, point.skin_thickness_mm, point.base_depth_mm
        ));
        trials.push(DomeTrial { point, score: s, fitted });
        Ok(trials.len() - 1)
    };
    let mut best = run(start, None, &mut trials)?;
    let mut steps = DOME_STEPS;
    'passes: for _ in 0..2 {
        for axis in 0..3 {
            for dir in [-1.0, 1.0] {
                loop {
                    let mut c = trials[best].point.coordinates();
                    c[axis] += dir * steps[axis];
                    let point = DomePoint::from_coordinates(c);
                    if !point.searchable(base) {
                        break;
                    }
                    // A dome scored before is not scored again.
                    let i = match trials.iter().position(|t| same(t.point.coordinates(), c)) {
                        Some(i) => i,
                        None if trials.len() >= budget => break 'passes,
                        None => run(point, Some(best), &mut trials)?,
                    };
                    if trials[i].score < trials[best].score {
                        best = i;
                    } else {
                        break;
                    }
                }
            }
        }
        steps = steps.map(|s| 0.5 * s);
    }
    Ok(DomeSearch { trials, best })
}

/// Where [`search_dome`] starts on `base`: its own dome clamped into the searched ranges; an
/// error naming the ranges where even that cannot be searched (so that a command can refuse
/// the sensor before any work).
pub fn dome_start(base: &SensorParams) -> Result<DomePoint> {
    let r = base.dome.outer_radius_mm;
    let own = DomePoint::of(base);
    let start = DomePoint {
        gel_ratio: own.gel_ratio.clamp(GEL_RATIO_RANGE[0], GEL_RATIO_RANGE[1]),
        skin_thickness_mm: own.skin_thickness_mm.clamp(MIN_SKIN_MM, MAX_SKIN_OF_RADIUS * r),
        base_depth_mm: own.base_depth_mm.clamp(r, 2.0 * r),
    };
    if !start.searchable(base) {
        return Err(SimError::invalid(
            "the dome fit",
            "sensor",
            format!(
                "its dome (gel ratio {:.4}, skin {:.2} mm, base {:.1} mm, pins {:.2} mm) cannot start the search: \
                 the gel ratio in [{}, {}], the skin in [{MIN_SKIN_MM}, {:.1}] mm, the base in [R, 2R] = [{r}, {}] mm \
                 and pins of at least {MIN_PIN_MM} mm",
                start.gel_ratio,
                start.skin_thickness_mm,
                start.base_depth_mm,
                start.pin_length_mm(base),
                GEL_RATIO_RANGE[0],
                GEL_RATIO_RANGE[1],
                MAX_SKIN_OF_RADIUS * r,
                2.0 * r
            ),
        ));
    }
    Ok(start)
}

/// Whether two points' coordinates are the same lattice point (steps are halved at most once,
/// so far above the rounding of their sums).
fn same(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dome_sensor() -> SensorParams {
        let mut s = SensorParams::half_space();
        s.skin.model = SkinModel::Dome;
        s.skin.gel_youngs_modulus_mpa = 0.1;
        s.dome.skin_thickness_mm = 1.0;
        s.pins.length_mm = 2.0;
        s.skin.base_depth_mm = 20.0;
        s
    }

    /// A bowl on the search's coordinates with its floor at `at`.
    fn bowl(p: &DomePoint, at: DomePoint) -> f64 {
        let (a, b) = (p.coordinates(), at.coordinates());
        (a[0] - b[0]).powi(2) + 4.0 * (a[1] - b[1]).powi(2) + 0.01 * (a[2] - b[2]).powi(2)
    }

    #[test]
    fn the_dome_search_walks_the_lattice_to_the_floor_and_scores_each_dome_once() {
        let base = dome_sensor();
        // The floor on the lattice: gel ratio 0.1 / 4 * sqrt(2), skin 1.0 + 0.6 mm, base 20 + 6 mm.
        let floor = DomePoint { gel_ratio: 0.1 * 2f64.powf(-1.5), skin_thickness_mm: 1.6, base_depth_mm: 26.0 };
        let mut scored = Vec::new();
        let search = search_dome(
            &base,
            100,
            &mut |p, best: Option<&usize>| {
                scored.push(*p);
                Ok((bowl(p, floor), best.map_or(0, |b| b + 1)))
            },
            &|_| {},
        )
        .expect("searched");
        let w = search.winner().point;
        assert!(same(w.coordinates(), floor.coordinates()), "{w:?}");
        assert!(
            scored.iter().enumerate().all(|(i, p)| scored[..i].iter().all(|q| !same(p.coordinates(), q.coordinates())))
        );
        assert_eq!(search.trials.len(), scored.len());
        // The fit is carried from the best so far: the first trial starts fresh.
        assert_eq!(search.trials[0].fitted, 0);
        // The tips stay: pins shorten as the skin thickens.
        let s = w.sensor(&base).expect("a valid dome");
        assert!((s.pins.length_mm + s.dome.skin_thickness_mm - 3.0).abs() < 1e-12);
        assert_eq!(s.skin.model, SkinModel::Dome);
        assert!((s.skin.gel_youngs_modulus_mpa / s.skin.youngs_modulus_mpa - w.gel_ratio).abs() < 1e-15);
    }

    #[test]
    fn the_dome_search_keeps_to_its_ranges_and_its_budget() {
        let base = dome_sensor();
        // A floor far outside every range: the search stops at the bounds.
        let far = DomePoint { gel_ratio: 10.0, skin_thickness_mm: 9.0, base_depth_mm: 90.0 };
        let search =
            search_dome(&base, 200, &mut |p, _: Option<&()>| Ok((bowl(p, far), ())), &|_| {}).expect("searched");
        for t in &search.trials {
            let p = t.point;
            assert!(p.gel_ratio <= 1.0 + 1e-9 && p.base_depth_mm <= 40.0 + 1e-9, "{p:?}");
            assert!(p.pin_length_mm(&base) >= MIN_PIN_MM - 1e-9, "{p:?}");
        }
        let w = search.winner().point;
        assert!(w.gel_ratio > 0.7 && w.base_depth_mm > 37.0, "{w:?}");
        // A budget of three domes scores three.
        let mut n = 0;
        let short = search_dome(
            &base,
            3,
            &mut |p, _: Option<&()>| {
                n += 1;
                Ok((bowl(p, far), ()))
            },
            &|_| {},
        )
        .expect("searched");
        assert_eq!((n, short.trials.len()), (3, 3));
        assert!(search_dome(&base, 0, &mut |_, _: Option<&()>| Ok((0.0, ())), &|_| {}).is_err());
    }

    #[test]
    fn a_dome_the_search_cannot_start_from_is_refused_with_its_ranges() {
        let mut base = dome_sensor();
        // Pins of 0.2 mm: no skin thickness in range leaves them 0.5 mm.
        base.pins.length_mm = 0.2;
        base.dome.skin_thickness_mm = 3.0;
        let err =
            search_dome(&base, 5, &mut |_, _: Option<&()>| Ok((0.0, ())), &|_| {}).expect_err("refused").to_string();
        assert!(err.contains("pins of at least 0.5 mm") && err.contains("[20, 40] mm"), "{err}");
    }
}
