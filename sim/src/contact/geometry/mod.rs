//! Where the contact is: the grid on the contact plane and its frame, the footprint a path
//! covers, the initial gap from the scene's rays, the cells a sharp edge cuts and their
//! sub-cells.
pub(super) mod cut;
pub(super) mod edge;
pub(super) mod footprint;
pub(super) mod frame;
pub(super) mod gap;
pub(super) mod grid;
pub(super) mod refine;
