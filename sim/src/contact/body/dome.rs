//! The dome body (`skin.model = "dome"`): the TacTip as it is built, a skin shell over the gel
//! that fills it on the rigid base, as a finite-element model (tacsim-fem), behind the same
//! contact solver.
//!
//! The contact plane and the pins both see the dome through one split of a force's response:
//! ```text
//! u(F) = dome(F spread over a Gaussian patch of s) + layers(F) - layers(F spread over the patch)
//! ```
//! The far field is the finite-element dome's response ([`PinResponse::spread`]) to the force
//! spread as a Gaussian patch `exp(-d^2 / s^2)` about its point, `s` = [`SPREAD_FACES`] outer
//! faces of the default mesh wide, whatever the mesh: a load the mesh resolves, so a press
//! bulges the skin elsewhere (the gel keeps its volume), the shell carries the motion far and
//! the dome curves away. The near field, what the patch leaves out within a few `s` of the
//! force, comes from the skin-on-gel layers' kernels of the same skin and gel
//! (`LayeredKernels::near_field`), exact for a flat skin where the dome's curvature matters
//! least. On the contact plane the dome's part is its surface response to the apex's patch
//! ([`DomeBody::apex_radial`], `DomeContact` in `mod.rs`); for the pins each loaded cell's
//! force (N; cut cells at their load point, refined cells at their sub-cells' centroid) acts
//! at the point of the undeformed dome above the cell, along its own direction in the contact
//! frame (`(Qx, Qy, -P)`), the near field summed by the layers' own pin rule
//! (`pins/motion.rs`). A point force on elements 2-3 mm wide, 0.66 mm above the pins, was not
//! converged (`docs/experiments/fem-dome.md`).
//!
//! The response is built once per sensor (mesh, factorisation, one solve per pin read-out
//! row: about 20 s at the default 8 cells on 2 cores) and kept on disk under a key of
//! everything that shapes it ([`cache_dir`]), then in memory for the process.

use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::Vector3;
use tacsim_fem::{DomeSpec, MAX_POISSON, Material, PinResponse, PinSite, response_key};

use crate::contact::algebra::lanes::Real;
use crate::contact::geometry::frame::ContactFrame;
use crate::error::{Result, SimError};
use crate::pins::PinLayout;
use crate::sensor::SensorParams;

/// Environment variable naming the folder of the dome's cached responses.
const CACHE_ENV: &str = "TACSIM_CACHE_DIR";

/// The folder the dome's responses are cached in: `$TACSIM_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/tacsim`, else `$HOME/.cache/tacsim`, else `tacsim-cache` in the
/// system's temporary folder.
pub fn cache_dir() -> PathBuf {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    var(CACHE_ENV)
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("tacsim")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("tacsim")))
        .unwrap_or_else(|| std::env::temp_dir().join("tacsim-cache"))
}

/// The finite-element model of a sensor's dome: its spec and pins, and their response.
#[derive(Debug)]
pub struct DomeBody {
    /// What the dome was built from.
    pub spec: DomeSpec,
    /// The pins' response to forces on the outer hemisphere, each spread as a Gaussian patch
    /// ([`DomeBody::spread_mm`]), and the surface's own under the apex's patch.
    pub response: PinResponse,
    /// [`DomeBody::apex_radial`]'s table, made on first use.
    apex_radial: OnceLock<Vec<[f64; 4]>>,
}

/// How many domes a process keeps in memory, the last read (each 60-150 MB at the default 8
/// cells): `tacsim calibrate --dome` reads one after another, and kept them all (2.06 GB at the
/// surface fit's 14 domes; `/usr/bin/time -f %M`). A dome dropped is read from the cache folder
/// again when asked for (about a second).
const KEPT_DOMES: usize = 4;

/// Radial step (mm) of [`DomeBody::apex_radial`]'s table.
const APEX_STEP_MM: f64 = 0.1;
/// Azimuths the apex's field is averaged over at each radius.
const APEX_AZIMUTHS: usize = 32;
/// How far out (in dome radii, projected on the contact plane) the apex's field is read: as
/// far as the contact's cells ([`crate::contact::geometry::gap`]'s `DOME_FRACTION`); held
/// beyond.
const APEX_REACH: f64 = 0.95;

impl DomeBody {
    /// The dome of a (validated) sensor: from this process's memory, else the cache folder,
    /// else built and saved there. Poisson's ratios of 0.5 are taken as 0.4999 (the element's
    /// limit, `tacsim_fem::MAX_POISSON`).
    pub fn get(sensor: &SensorParams) -> Result<Arc<DomeBody>> {
        Self::get_in(sensor, &cache_dir())
    }

    /// The file in the cache folder `dir` that holds a sensor's dome.
    pub fn cache_path(sensor: &SensorParams, dir: &std::path::Path) -> Result<PathBuf> {
        let (_, _, key) = inputs_of(sensor)?;
        Ok(PinResponse::path_in(dir, key))
    }

    /// [`DomeBody::get`] with the cache folder `dir`.
    pub fn get_in(sensor: &SensorParams, dir: &std::path::Path) -> Result<Arc<DomeBody>> {
        // The domes read last, oldest first ([`KEPT_DOMES`] at most).
        type Cache = Mutex<Vec<(u64, Arc<DomeBody>)>>;
        static CACHE: OnceLock<Cache> = OnceLock::new();
        let (spec, sites, key) = inputs_of(sensor)?;
        static BUILDING: Mutex<()> = Mutex::new(());
        let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
        let kept = || {
            let kept = cache.lock().unwrap_or_else(|p| p.into_inner());
            kept.iter().find(|(k, _)| *k == key).map(|(_, body)| body.clone())
        };
        if let Some(body) = kept() {
            return Ok(body);
        }
        // One dome is read or built at a time (each takes most of the memory and every core):
        // the threads that wait for it then find it kept.
        let _building = BUILDING.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(body) = kept() {
            return Ok(body);
        }
        let response = PinResponse::cached(dir, &spec, &sites, spread_of(&spec), |_, _| {})?;
        let body = Arc::new(DomeBody { spec, response, apex_radial: OnceLock::new() });
        let mut kept = cache.lock().unwrap_or_else(|p| p.into_inner());
        if kept.len() >= KEPT_DOMES {
            kept.remove(0);
        }
        kept.push((key, body.clone()));
        Ok(body)
    }

    /// The Gaussian patch's `s` (mm) the far field spreads each force over:
    /// `SPREAD_FACES` of the outer faces' size `pi R / (4 N)` at the default `N`
    /// (`crate::sensor::DEFAULT_DOME_CELLS`) whatever the sensor's mesh: 2.95 mm on the
    /// 20 mm dome.
    pub fn spread_mm(&self) -> f64 {
        self.response.spread_mm
    }

    /// The surface's response to a force at the apex spread as the far field's Gaussian patch,
    /// as the layered kernels' radial functions `[F_zz, F_pr, F_s, F_d]` (mm/N) at `r` (mm)
    /// from the apex on the contact plane, in the contact's conventions (force `(Qx, Qy, P)`,
    /// `P` pressing; displacement `z` into the body; `layered.rs`'s `combine`): the
    /// finite-element field at the dome's point above `(x, y)` averaged over the azimuth,
    /// its reciprocal pair `F_pr`, `-F_zq` averaged too. Tabulated every `APEX_STEP_MM` up
    /// to `APEX_REACH` of the radius, linear between, held beyond.
    pub fn apex_radial(&self, r: f64) -> [f64; 4] {
        self.apex_radial_lanes([r], &|v: [f64; 1]| v[0])
    }

    /// [`Self::apex_radial`] at `N` radii at once: the rows gathered per lane, the line on `T`
    /// ([`Real`]), each lane the bits of one radius alone. `lanes` makes values into `T`.
    #[inline(always)]
    pub(crate) fn apex_radial_lanes<T: Real, const N: usize>(
        &self,
        r: [f64; N],
        lanes: &impl Fn([f64; N]) -> T,
    ) -> [T; 4] {
        let table = self.apex_radial.get_or_init(|| self.apex_table());
        let mut at = [0usize; N];
        let mut frac = [0.0; N];
        for l in 0..N {
            let t = (r[l].max(0.0) / APEX_STEP_MM).min((table.len() - 1) as f64);
            at[l] = (t as usize).min(table.len().saturating_sub(2));
            frac[l] = t - at[l] as f64;
        }
        let f = lanes(frac);
        let mut out = [f; 4];
        for (j, out) in out.iter_mut().enumerate() {
            let (a, b) =
                (lanes(std::array::from_fn(|l| table[at[l]][j])), lanes(std::array::from_fn(|l| table[at[l] + 1][j])));
            *out = a + f * (b - a);
        }
        out
    }

    fn apex_table(&self) -> Vec<[f64; 4]> {
        let radius = self.spec.outer_radius_mm;
        let n = (APEX_REACH * radius / APEX_STEP_MM).floor() as usize + 1;
        (0..n.max(2))
            .map(|i| {
                let r = i as f64 * APEX_STEP_MM;
                let z = (radius * radius - r * r).max(0.0).sqrt();
                let mut sums = [0.0; 4];
                for a in 0..APEX_AZIMUTHS {
                    let theta = 2.0 * std::f64::consts::PI * (a as f64 + 0.5) / APEX_AZIMUTHS as f64;
                    let (sn, c) = theta.sin_cos();
                    let (c2, s2) = (c * c - sn * sn, 2.0 * sn * c);
                    let Some(u) = self.response.apex_field([r * c, r * sn, z]) else { continue };
                    // The contact's force (Qx, Qy, P) is the sensor's (Qx, Qy, -P); its
                    // displacement (ux, uy, z into the body) the sensor's (ux, uy, -uz).
                    let p = [-u[2][0], -u[2][1], u[2][2]];
                    let qx = [u[0][0], u[0][1], -u[0][2]];
                    let qy = [u[1][0], u[1][1], -u[1][2]];
                    sums[0] += p[2];
                    // F_pr from the pressure's radial motion, -F_zq from the shear's normal.
                    sums[1] += 0.5 * (p[0] * c + p[1] * sn) - 0.5 * (qx[2] * c + qy[2] * sn);
                    sums[2] += 0.5 * (qx[0] + qy[1]);
                    sums[3] += 0.5 * (-qx[0] * c2 - qx[1] * s2 - qy[0] * s2 + qy[1] * c2);
                }
                sums.map(|v| v / APEX_AZIMUTHS as f64)
            })
            .collect()
    }

    /// The far field of every pin's motion under the point forces of a contact state in
    /// `frame` (whose contact plane touches the dome at its apex), each `([x, y], f)`: its
    /// point on the contact plane (mm) and its force `(Qx, Qy, P)` (N, `P` pressing): the dome's
    /// response to each force spread as a Gaussian patch, as the skin motion `(u, omega)` (mm,
    /// rad) at the pin's base in the contact frame. `layout` holds the pins in the sensor frame.
    pub(crate) fn far_motions(
        &self,
        layout: &PinLayout,
        frame: &ContactFrame,
        forces: impl Iterator<Item = ([f64; 2], [f64; 3])>,
    ) -> Vec<(Vector3<f64>, Vector3<f64>)> {
        let r = self.spec.outer_radius_mm;
        let loads = forces.map(|([x, y], f)| {
            let z = (r * r - x * x - y * y).max(0.0).sqrt();
            let at = frame.to_sensor(Vector3::new(x, y, z));
            let force = frame.to_sensor(Vector3::new(f[0], f[1], -f[2]));
            ([at.x, at.y, at.z], [force.x, force.y, force.z])
        });
        // Loads off the hemisphere cannot occur: the gap keeps cells above the sensor's
        // equator (`DomeCells`); test `dome_pins_take_every_load_on_random_tilted_paths`.
        let (motions, missed) = self.response.motions(loads);
        debug_assert!(missed == [0.0; 3], "forces off the dome's hemisphere: {missed:?} N");
        layout
            .pins
            .iter()
            .zip(motions)
            .map(|(pin, m)| {
                let (tip, omega) = (Vector3::new(m[0], m[1], m[2]), Vector3::new(m[3], m[4], m[5]));
                // The response's rows are the tip's displacement: the base's is what the
                // post's turn does not carry.
                let u = tip - omega.cross(&(pin.tip - pin.base));
                (frame.to_contact(u), frame.to_contact(omega))
            })
            .collect()
    }
}

/// The far field's Gaussian patch, in outer faces' sizes of the default mesh (see
/// [`DomeBody::spread_mm`]). The patch is part of the model, so it stays put as the mesh is
/// refined: shrinking with the faces (1.5 of each mesh's own), the split's part changed with
/// the mesh and the pins of 10 and 12 cells differed by up to 0.020-0.022 mm, against
/// 0.015-0.016 mm with the patch fixed (8 and 10 cells: 0.022-0.027 and 0.024-0.026 mm). With
/// the pins read at the skin's inner face (commit 4a47b14), 1.5 faces kept them within
/// 0.041-0.048 mm between 8 and 10 cells, 1.0 within 0.055-0.069 and 2.0 within 0.032-0.040
/// (`docs/experiments/fem-dome.md`). A wider patch leaves more to the flat layers.
pub const SPREAD_FACES: f64 = 1.5;

fn spread_of(spec: &DomeSpec) -> f64 {
    SPREAD_FACES * std::f64::consts::PI * spec.outer_radius_mm / (4.0 * crate::sensor::DEFAULT_DOME_CELLS as f64)
}

/// What shapes a sensor's dome: its spec, its pins and their key.
fn inputs_of(sensor: &SensorParams) -> Result<(DomeSpec, Vec<PinSite>, u64)> {
    let spec = spec_of(sensor)?;
    let sites = sites_of(&PinLayout::new(sensor));
    let key = response_key(&spec, &sites, spread_of(&spec));
    Ok((spec, sites, key))
}

/// The finite-element spec of a sensor: its dome's radius and skin, the skin's and gel's
/// materials, the base `skin.base_depth_mm` below the apex (a skirt below the equator where
/// deeper than the radius), and the resolution `skin.dome_cells`, `skin.dome_skin_layers`,
/// `skin.dome_skin_refinement`, `skin.dome_refined_gel_shells` (`SkinParams::dome_gel_shells`).
fn spec_of(sensor: &SensorParams) -> Result<DomeSpec> {
    let (d, k) = (&sensor.dome, &sensor.skin);
    let material = |e: f64, nu: f64| Material::new(e, nu.min(MAX_POISSON));
    let spec = DomeSpec {
        outer_radius_mm: d.outer_radius_mm,
        skin_thickness_mm: d.skin_thickness_mm,
        skirt_mm: k.base_depth_mm - d.outer_radius_mm,
        skin: material(k.youngs_modulus_mpa, k.poisson)?,
        gel: material(k.gel_youngs_modulus_mpa, k.gel_poisson)?,
        cells: k.dome_cells,
        skin_layers: k.dome_skin_layers,
        skin_refinement: k.dome_skin_refinement,
        refined_gel_shells: k.dome_gel_shells(),
    };
    spec.validate()?;
    Ok(spec)
}

/// The pins as the finite-element model reads them: base, tip and skin patch.
fn sites_of(layout: &PinLayout) -> Vec<PinSite> {
    layout
        .pins
        .iter()
        .map(|p| PinSite {
            base: [p.base.x, p.base.y, p.base.z],
            tip: [p.tip.x, p.tip.y, p.tip.z],
            patch_radius_mm: layout.patch_radius_mm,
        })
        .collect()
}

impl From<tacsim_fem::FemError> for SimError {
    fn from(e: tacsim_fem::FemError) -> Self {
        SimError::Dome(e.to_string())
    }
}
