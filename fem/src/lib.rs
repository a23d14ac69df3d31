//! tacsim-fem: the TacTip as it is built, a thin rubber skin shell over a nearly incompressible
//! gel on a rigid base, as a finite-element model.
//!
//! Data flows one way: [`DomeSpec`] (geometry, materials, resolution) -> [`Mesh`]
//! ([`CubedBall`]: ten-node tetrahedra, the skin's faces exact spheres) -> [`Stiffness`]
//! (assembled with [`Material`]s, the base held) -> [`Factor`] (faer's sparse Cholesky) ->
//! displacements under nodal forces, and the pins' tips through [`PinProbe`]s.
//!
//! # Frame and units
//! The sensor frame of tacsim-sim: the dome's centre at the origin, its apex at
//! `(0, 0, R)`, the base plane at `z = 0` (or `z = -skirt` below a cylindrical skirt).
//! Lengths in mm, forces in N, moduli in MPa (N/mm^2).
//!
//! # Validation
//! The tests in `fem/tests/` check the element and the mesh against analytic answers: Lame's
//! thick sphere under internal pressure (at Poisson's ratio 0.3 and 0.4999: no locking), and
//! the gel's volume under a press, the Hertz limit of a solid dome; the neo-Hookean solve of
//! [`FlatPress`] measures what the linear model leaves out at depth.

mod cache;
mod condense;
mod dome;
mod element;
mod error;
mod hyperelastic;
mod material;
mod mesh;
mod response;
mod system;

pub use condense::{Compliance, Header, key as condensation_key};
pub use dome::{Dome, DomeSpec, MAX_SKIN_REFINEMENT, MOTION, PinProbe, PinSite, ProbeTerm, THROUGH_SKIN};
pub use element::{ElementMatrices, face_forces, face_shape, matrices};
pub use error::{FemError, Result};
pub use hyperelastic::{FlatPress, Kinematics, NonlinearElement, PressState, large_displacement, neo_hookean};
pub use material::{MAX_POISSON, Material};
pub use mesh::{Block, CubedBall, Mesh, Region, Tie};
pub use response::{PinResponse, ResponseHeader, patch_weight, response_key};
pub use system::{Factor, SOLVE_BLOCK, Stiffness, Terms};
