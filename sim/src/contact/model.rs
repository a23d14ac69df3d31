//! Everything fixed about a sensor's contact: its material, elastic body, pins and solver
//! settings, shared by every path the sensor takes.

use std::sync::Arc;

use super::body::dome::DomeBody;
use super::body::kept::KeptOperators;
use super::body::kernel::Elastic;
use super::body::layered::{Layer, LayeredBody, LayeredKernels};
use super::body::operator::{HalfSpace, Operator, Pairing};
use super::body::{DomeContact, ElasticBody};
use super::geometry::cut::EdgeProfile;
use super::geometry::grid::Grid;
use super::geometry::refine::FineGrids;
use super::pins::motion::PIN_SUBSQUARES;
use super::solve::normal::NormalSettings;
use super::solve::tangential::TangentialSettings;
use crate::error::Result;
use crate::pins::PinLayout;
use crate::sensor::{SensorParams, SkinModel};

/// Everything fixed about a sensor's contact: material, pins, solver settings.
#[derive(Clone, Debug)]
pub struct ContactModel {
    /// The sensor.
    pub sensor: Arc<SensorParams>,
    /// Skin material.
    pub material: Elastic,
    /// The elastic body behind the skin surface ([`crate::sensor::SkinModel`]).
    pub body: Arc<dyn ElasticBody>,
    /// Pins of the undeformed sensor.
    pub layout: Arc<PinLayout>,
    /// Normal solver settings.
    pub normal: NormalSettings,
    /// Tangential solver settings.
    pub tangential: TangentialSettings,
    /// Alternations of normal and tangential solves on coupled materials (1 = Goodman's
    /// approximation: no coupling).
    pub coupling_iterations: usize,
    /// Sub-squares per side of the cells near a pin in the pin product (`pins/motion.rs`;
    /// 1: one point force per cell).
    pub pin_subsquares: usize,
    /// Sub-cells per side of the cells along a sharp edge, solved again for the pins
    /// (`refine.rs`; 0 or 1: none): the sensor's `skin.edge_subcells`.
    pub edge_subcells: usize,
    /// The pressure's profile across a stimulus's sharp edge: the singular one on a
    /// half-space and a layer, decaying over a fraction of the skin's thickness on a skin over
    /// a gel and the dome ([`EdgeProfile::of_skin`]).
    pub(in crate::contact) edge_profile: EdgeProfile,
    /// The sub-cells' fine grids, shared by the model's simulations.
    pub(in crate::contact) fine_grids: FineGrids,
    /// The operators built on the paths' grids, kept for the next path on a grid of the same
    /// shape and cell side (a body with a length of its own: [`ContactModel::operator`]).
    pub(in crate::contact) operators: KeptOperators,
}

impl ContactModel {
    /// The contact model of a (validated) sensor. A dome body (`skin.model = "dome"`) is read
    /// from the cache folder or built there first ([`DomeBody::get`]): the one step that can
    /// fail.
    pub fn new(sensor: &SensorParams) -> Result<Self> {
        let material = Elastic::from_young(sensor.skin.youngs_modulus_mpa, sensor.skin.poisson);
        let skin = &sensor.skin;
        let gel = Elastic::from_young(skin.gel_youngs_modulus_mpa, skin.gel_poisson);
        let t = sensor.dome.skin_thickness_mm;
        let skin_on_gel =
            || vec![Layer { thickness_mm: t, material }, Layer { thickness_mm: skin.base_depth_mm - t, material: gel }];
        let layers = match skin.model {
            SkinModel::HalfSpace => None,
            SkinModel::Layer => Some(vec![Layer { thickness_mm: skin.base_depth_mm, material }]),
            SkinModel::SkinOnGel | SkinModel::Dome => Some(skin_on_gel()),
        };
        // Tables reach every grid offset (at most 2 sqrt(2) 0.95 R) and every pin offset.
        let r_max = 3.0 * sensor.dome.outer_radius_mm;
        let tables = |body: &LayeredBody| LayeredKernels::get(body, t, r_max);
        let body: Arc<dyn ElasticBody> = match (skin.model, layers) {
            (_, None) => Arc::new(HalfSpace { material, pairing: Pairing::RigidIndenter }),
            (SkinModel::Dome, Some(layers)) => {
                let dome = DomeBody::get(sensor)?;
                let layered = LayeredBody { layers };
                let near = LayeredKernels::near_field(&layered, t, r_max, dome.spread_mm());
                Arc::new(DomeContact { contact: tables(&layered), near, dome })
            }
            (_, Some(layers)) => tables(&LayeredBody { layers }),
        };
        Ok(Self {
            sensor: Arc::new(sensor.clone()),
            material,
            body,
            layout: Arc::new(PinLayout::new(sensor)),
            // Looser than the validation's: the grid's discretisation error (about 1e-3) is far
            // above them (the force of a tap changes by 5e-7 between 1e-7 and 1e-5), and pin
            // positions change by well under 1e-4 mm: at most 3.8e-5 mm from a tight solve on
            // the paths of test `default_tolerances_keep_the_pins_within_a_tenth_of_a_micron...`
            // (1.5e-5 at 1e-5 / 1e-4, which took 14% more instructions on the bench's slide and
            // 8% more on its tap; issue 31, `docs/experiments/contact.md`, "Tolerances three times
            // looser").
            normal: NormalSettings { tolerance: 3e-5, ..NormalSettings::default() },
            tangential: TangentialSettings { tolerance: 3e-4, ..TangentialSettings::default() },
            coupling_iterations: 4,
            pin_subsquares: PIN_SUBSQUARES,
            edge_subcells: sensor.skin.edge_subcells,
            edge_profile: match skin.model {
                SkinModel::HalfSpace | SkinModel::Layer => EdgeProfile::SINGULAR,
                SkinModel::SkinOnGel | SkinModel::Dome => EdgeProfile::of_skin(t),
            },
            fine_grids: FineGrids::default(),
            operators: KeptOperators::default(),
        })
    }

    /// The body's operator on `grid`. A body with a length of its own (not
    /// [`ElasticBody::scale_free`]) has an operator per cell side, costly to build: one kept
    /// from a path on a grid of the same shape and cell side where there is one (the same
    /// bits, [`KeptOperators`]); a half-space's is its unit tables scaled.
    pub(in crate::contact) fn operator(&self, grid: Grid) -> Operator {
        if self.body.scale_free() {
            return self.body.operator(grid);
        }
        self.operators.get(grid, |g| self.body.operator(g))
    }

    pub(in crate::contact) fn dome_radius(&self) -> f64 {
        self.sensor.dome.outer_radius_mm
    }

    /// The radius (mm) of the outer profile the contact's gap is measured on
    /// ([`crate::sensor::SkinParams::gap_radius_mm`]); `None` where it is the dome's own.
    pub(in crate::contact) fn gap_radius(&self) -> Option<f64> {
        Some(self.sensor.skin.gap_radius_mm).filter(|&r| r > 0.0)
    }
}
