//! The elastic bodies behind the skin surface, behind one trait ([`ElasticBody`]): the
//! point-load kernels (half-space, layers on a rigid base), the influence operator they make on
//! a grid (dense or by FFT), and the finite-element dome.
pub(super) mod dome;
pub(super) mod fft2;
pub(super) mod kept;
pub(super) mod kernel;
pub(super) mod layered;
pub(super) mod operator;

use std::sync::Arc;

use nalgebra::Vector3;

use crate::contact::geometry::grid::Grid;
use dome::DomeBody;
use kernel::DepthKernel;
use layered::LayeredKernels;
use operator::{HalfSpace, Operator, RadialCorrection};

use crate::contact::algebra::lanes::Real;

/// An elastic body behind the skin surface: what the contact solve and the pins ask of it.
///
/// The solve asks for the influence operator on the path's grid (tractions on the contact
/// plane to surface displacements, MPa to mm); the pins for the kernels that carry each
/// loaded cell's force to the pin bases and, for a body with a far field of its own (the
/// finite-element dome), that body.
pub trait ElasticBody: std::fmt::Debug + Send + Sync {
    /// The influence operator on `grid` (contact frame).
    fn operator(&self, grid: Grid) -> Operator;

    /// Whether the body has no length of its own (the half-space): its operator on a grid of
    /// another cell size is the same up to scale, so sub-cells of any size share one.
    fn scale_free(&self) -> bool {
        false
    }

    /// The kernels the pins read the cells' forces through: the whole response, or, with a
    /// far field ([`ElasticBody::far_field`]), what the far field leaves out near each force.
    fn pin_kernel(&self) -> PinKernel<'_>;

    /// Whether the body has a skin whose pressure stays up to the contact's edge and drops to
    /// zero within a cell there (the layers and the dome, not the half-space): the cells along
    /// the contact's own edge are then solved again at sub-cells for the pins
    /// (`crate::contact::geometry::refine`).
    fn refines_contact_edge(&self) -> bool {
        false
    }

    /// The finite-element dome whose response to the forces (spread over a patch) adds to the
    /// pins' motion; `None` where the kernels are the whole response.
    fn far_field(&self) -> Option<&DomeBody> {
        None
    }
}

impl ElasticBody for HalfSpace {
    fn operator(&self, grid: Grid) -> Operator {
        Operator::new(self, grid)
    }

    fn scale_free(&self) -> bool {
        true
    }

    fn pin_kernel(&self) -> PinKernel<'_> {
        PinKernel::HalfSpace(DepthKernel::new(&self.material))
    }
}

impl ElasticBody for LayeredKernels {
    fn operator(&self, grid: Grid) -> Operator {
        Operator::layered(self, grid)
    }

    fn pin_kernel(&self) -> PinKernel<'_> {
        PinKernel::Layered(self)
    }

    fn refines_contact_edge(&self) -> bool {
        true
    }
}

/// The finite-element dome as the contact sees it, split as the pins are: a force's near field
/// from the skin-on-gel layers of the same skin and gel (a point force's kernels minus the
/// same force spread as a Gaussian patch, `near`), its far field from the dome (the patch's
/// response, `dome`). On the contact plane the operator is the layers' (`contact`) plus the
/// dome's surface response to the apex's patch less the layers' own to it
/// ([`DomeContact::far_field_radial`]), as a function of the offset alone: every force is
/// taken to act near the apex of the contact frame, where the dome is symmetric about its
/// axis. The pins take the layers' near field plus the dome's response to each force's
/// patch where it acts.
#[derive(Debug)]
pub struct DomeContact {
    /// The skin-on-gel kernels of the same skin and gel.
    pub contact: Arc<LayeredKernels>,
    /// Their near field at the pins (`LayeredKernels::near_field`).
    pub near: Arc<LayeredKernels>,
    /// The dome.
    pub dome: Arc<DomeBody>,
}

impl DomeContact {
    /// The dome's far field on the contact plane less the layers': radial functions
    /// `[F_zz, F_pr, F_s, F_d]` (mm/N) at `r` (mm) of the dome's surface response to the
    /// apex's Gaussian patch ([`DomeBody::apex_radial`]) minus the layers' response to the same
    /// patch (`LayeredKernels::surface_patch_radial`).
    pub fn far_field_radial(&self, r: f64) -> [f64; 4] {
        self.radial([r], &|v: [f64; 1]| v[0])
    }
}

impl RadialCorrection for DomeContact {
    /// [`DomeContact::far_field_radial`] at `N` radii at once, each lane its bits.
    #[inline(always)]
    fn radial<T: Real, const N: usize>(&self, r: [f64; N], lanes: &impl Fn([f64; N]) -> T) -> [T; 4] {
        let dome = self.dome.apex_radial_lanes(r, lanes);
        let layers = self.near.surface_patch_radial(r, lanes).unwrap_or([lanes([0.0; N]); 4]);
        let mut out = dome;
        for (out, layers) in out.iter_mut().zip(layers) {
            *out = *out - layers;
        }
        out
    }
}

impl ElasticBody for DomeContact {
    fn operator(&self, grid: Grid) -> Operator {
        Operator::layered_with(&self.contact, grid, Some(self))
    }

    fn pin_kernel(&self) -> PinKernel<'_> {
        PinKernel::Layered(&self.near)
    }

    fn refines_contact_edge(&self) -> bool {
        true
    }

    fn far_field(&self) -> Option<&DomeBody> {
        Some(&self.dome)
    }
}

/// Surface point load to displacement inside the body.
#[derive(Clone, Copy, Debug)]
pub enum PinKernel<'a> {
    /// Boussinesq and Cerruti at depth; bases at their depth below the contact plane.
    HalfSpace(DepthKernel),
    /// Tabulated layered kernels; bases at the pin depth of the tables.
    Layered(&'a LayeredKernels),
}

impl PinKernel<'_> {
    /// Displacement (mm, `z` into the body) at `offset` (lateral, depth) from `force`.
    #[inline]
    pub(in crate::contact) fn displacement(&self, force: [f64; 3], offset: [f64; 3]) -> [f64; 3] {
        match self {
            PinKernel::HalfSpace(k) => k.displacement(force, offset),
            PinKernel::Layered(k) => k.displacement(force, offset),
        }
    }

    /// Depth (mm) of the point `p` (in the layout's frame) near the pin base `base` on a dome
    /// of outer radius `dome_radius_mm`.
    pub(crate) fn depth(&self, dome_radius_mm: f64, base: &Vector3<f64>, p: &Vector3<f64>) -> f64 {
        match self {
            PinKernel::HalfSpace(_) => dome_radius_mm - p.z,
            PinKernel::Layered(k) => k.pin_depth_mm() + base.z - p.z,
        }
    }
}
