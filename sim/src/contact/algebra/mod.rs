//! The linear algebra under the solvers: cell matrices and their cache, SIMD lanes, storage
//! precision and the inverse-stencil preconditioner.
pub(super) mod lanes;
pub(super) mod matrix;
pub(super) mod precision;
pub(super) mod stencil;
