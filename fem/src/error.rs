//! The crate's error type.

/// What can go wrong building or solving a finite-element model.
#[derive(Debug, thiserror::Error)]
pub enum FemError {
    /// A parameter outside its accepted range (names the field, the value and the range).
    #[error("{field} = {value}: {expected}")]
    Parameter {
        /// The parameter's name as the sensor file or the caller spells it.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The accepted range, in words.
        expected: &'static str,
    },
    /// An element turned inside out or flat by the mesh's map (a bug or absurd geometry).
    #[error("element {element} has a non-positive Jacobian ({jacobian:e}): the mesh is degenerate")]
    Degenerate {
        /// The element's index.
        element: usize,
        /// Its smallest Jacobian determinant at a quadrature point (mm^3 per unit volume).
        jacobian: f64,
    },
    /// The stiffness matrix could not be factorised (not positive definite: the body is not
    /// held, or a material is out of range).
    #[error("the stiffness matrix could not be factorised: {0}")]
    Factorisation(String),
    /// A pin's base lies in no skin element.
    #[error("pin {pin} at ({x:.3}, {y:.3}, {z:.3}) mm lies in no skin element")]
    PinOutside {
        /// The pin's index.
        pin: usize,
        /// Its base (mm, sensor frame).
        x: f64,
        /// y (mm).
        y: f64,
        /// z (mm).
        z: f64,
    },
    /// A surface degree of freedom asked for is held by the base.
    #[error("degree of freedom {dof} of the condensed surface is held by the base: take a smaller cap")]
    HeldSurface {
        /// The degree of freedom (`3 node + direction`).
        dof: usize,
    },
    /// Newton's method did not converge at a depth of a press, even on halved steps.
    #[error(
        "Newton's method did not converge in {iterations} iterations at depth {depth_mm} mm: take a smaller step_mm"
    )]
    NoConvergence {
        /// The press's depth (mm).
        depth_mm: f64,
        /// Iterations tried.
        iterations: usize,
    },
    /// Reading or writing the cached condensed response.
    #[error("{path}: {message}")]
    Cache {
        /// The cache file.
        path: String,
        /// What went wrong and what to do.
        message: String,
    },
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, FemError>;
