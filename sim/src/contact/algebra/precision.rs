//! The precision of the contact engine's dense products: [`Precision`] says which a solver
//! may use, [`Coefficient`] is the type its tables and sums are kept in (`f64` or `f32`),
//! shared by [`CellMatrix`](crate::contact::CellMatrix)'s panels and
//! [`Operator::apply`](crate::contact::Operator::apply)'s dense products.

/// How a [`CellMatrix`](crate::contact::CellMatrix) stores its coefficients, and so what its products add in.
///
/// Single precision halves the bytes a product streams and doubles the lanes of each vector
/// instruction; each row's sum is then accumulated in `f32` (a relative rounding of about
/// `1e-7` per term, a few `1e-6` over a row of hundreds), the inputs rounded to `f32` and the
/// sums widened back (6.6e-7 of the largest row at most on the test's 47-cell shear product).
/// It serves solvers whose tolerance is well above that ([`Precision::for_tolerance`]): the
/// tangential iterations at the model's `1e-4` and the normal conjugate gradient at its
/// `1e-5`, not the validation's and the tests' tight solves. At the model's tolerances the
/// pins stay within a tenth of a micron of a tight solve's in double precision (test
/// `default_tolerances_keep_the_pins_within_a_tenth_of_a_micron_of_a_tight_solve`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// `f64` coefficients and sums.
    #[default]
    Double,
    /// `f32` coefficients and sums.
    Single,
}

impl Precision {
    /// The tolerance from which a solver's products may be single (relative to the solver's
    /// own measure): about 15 times the largest rounding of a single-precision row sum the
    /// tests measure (the model's normal tolerance was this until issue 31 took it to 3e-5).
    pub const SINGLE_FROM_TOLERANCE: f64 = 1e-5;

    /// Single for a solver that stops at `tolerance` of at least
    /// [`Precision::SINGLE_FROM_TOLERANCE`], double below.
    pub fn for_tolerance(tolerance: f64) -> Self {
        if tolerance >= Self::SINGLE_FROM_TOLERANCE { Self::Single } else { Self::Double }
    }

    /// Bytes per coefficient.
    pub(in crate::contact) fn bytes(self) -> usize {
        match self {
            Self::Double => std::mem::size_of::<f64>(),
            Self::Single => std::mem::size_of::<f32>(),
        }
    }
}

/// A coefficient type of the dense products: `f64`, or `f32` in [`Precision::Single`].
pub(in crate::contact) trait Coefficient:
    Copy + Default + std::ops::Add<Output = Self> + std::ops::Mul<Output = Self> + std::ops::AddAssign + std::iter::Sum
{
    /// `v` rounded to this type.
    fn of(v: f64) -> Self;
    /// Widened to `f64`.
    fn wide(self) -> f64;
}

impl Coefficient for f64 {
    fn of(v: f64) -> Self {
        v
    }
    fn wide(self) -> f64 {
        self
    }
}

impl Coefficient for f32 {
    fn of(v: f64) -> Self {
        v as f32
    }
    fn wide(self) -> f64 {
        self as f64
    }
}
