//! Several evaluations of one formula at once: [`Lanes`] holds one `f64` per evaluation and
//! does every operation lane by lane, so that a formula written once over [`Real`] gives, in
//! each lane, the bits of the same formula on `f64` (addition, multiplication, division and
//! the square root are correctly rounded on every vector unit, and nothing is fused or
//! reordered). The pin product evaluates the half-space's kernels for [`LANES`] point forces
//! at a time this way (`pins/motion.rs`).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Evaluations per [`Lanes`]: four `f64` fill an AVX2 register.
pub const LANES: usize = 4;

/// The arithmetic a kernel formula needs, on `f64` or on [`Lanes`].
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
{
    /// The value `v` in every lane (of `self`'s kind).
    fn splat_like(self, v: f64) -> Self;
    /// The square root.
    fn sqrt(self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat_like(self, v: f64) -> Self {
        v
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
}

/// [`LANES`] values, one per evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lanes(pub [f64; LANES]);

macro_rules! lane_op {
    ($trait:ident, $method:ident) => {
        impl $trait for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, other: Lanes) -> Lanes {
                Lanes(std::array::from_fn(|l| $trait::$method(self.0[l], other.0[l])))
            }
        }
    };
}

lane_op!(Add, add);
lane_op!(Sub, sub);
lane_op!(Mul, mul);
lane_op!(Div, div);

impl Mul<f64> for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn mul(self, other: f64) -> Lanes {
        Lanes(self.0.map(|v| v * other))
    }
}

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        Lanes(self.0.map(|v| -v))
    }
}

impl Lanes {
    /// The value `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        Lanes([v; LANES])
    }
}

impl Real for Lanes {
    #[inline(always)]
    fn splat_like(self, v: f64) -> Self {
        Lanes::splat(v)
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        Lanes(self.0.map(f64::sqrt))
    }
}

/// [`Lanes`] in one AVX2 register: the same operations, lane by lane, by the vector unit's
/// instructions (`vsqrtpd`, `vdivpd`, ...), so the same bits.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct Avx2Lanes {
    simd: pulp::x86::V3,
    v: pulp::f64x4,
}

#[cfg(target_arch = "x86_64")]
impl Avx2Lanes {
    /// The lanes `v` on the vector unit `simd`.
    #[inline(always)]
    pub fn new(simd: pulp::x86::V3, v: [f64; LANES]) -> Self {
        Self { simd, v: pulp::cast(v) }
    }

    /// The lanes' values.
    #[inline(always)]
    pub fn to_array(self) -> [f64; LANES] {
        pulp::cast(self.v)
    }
}

#[cfg(target_arch = "x86_64")]
macro_rules! avx2_op {
    ($trait:ident, $method:ident, $op:ident) => {
        impl $trait for Avx2Lanes {
            type Output = Avx2Lanes;
            #[inline(always)]
            fn $method(self, other: Avx2Lanes) -> Avx2Lanes {
                Avx2Lanes { simd: self.simd, v: self.simd.$op(self.v, other.v) }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
avx2_op!(Add, add, add_f64x4);
#[cfg(target_arch = "x86_64")]
avx2_op!(Sub, sub, sub_f64x4);
#[cfg(target_arch = "x86_64")]
avx2_op!(Mul, mul, mul_f64x4);
#[cfg(target_arch = "x86_64")]
avx2_op!(Div, div, div_f64x4);

#[cfg(target_arch = "x86_64")]
impl Mul<f64> for Avx2Lanes {
    type Output = Avx2Lanes;
    #[inline(always)]
    fn mul(self, other: f64) -> Avx2Lanes {
        self * self.splat_like(other)
    }
}

#[cfg(target_arch = "x86_64")]
impl Neg for Avx2Lanes {
    type Output = Avx2Lanes;
    #[inline(always)]
    fn neg(self) -> Avx2Lanes {
        // The sign bit flipped, as `-x` on `f64`.
        Avx2Lanes { simd: self.simd, v: self.simd.xor_f64x4(self.v, self.simd.splat_f64x4(-0.0)) }
    }
}

#[cfg(target_arch = "x86_64")]
impl Real for Avx2Lanes {
    #[inline(always)]
    fn splat_like(self, v: f64) -> Self {
        Avx2Lanes { simd: self.simd, v: self.simd.splat_f64x4(v) }
    }

    #[inline(always)]
    fn sqrt(self) -> Self {
        Avx2Lanes { simd: self.simd, v: self.simd.sqrt_f64x4(self.v) }
    }
}

/// The sum of `values` in [`LANES`] interleaved partial sums (value `i` into sum `i mod
/// LANES`), added pairwise at the end: the same bits on every machine, without one chain of
/// dependent additions (a solver's dot products and residuals over a few hundred cells, issue
/// 31: one such chain per sum and iteration took 4 cycles an element).
#[inline]
pub(crate) fn lane_sum(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut values = values.into_iter();
    let mut acc = [0.0; LANES];
    'all: loop {
        for a in &mut acc {
            match values.next() {
                Some(v) => *a += v,
                None => break 'all,
            }
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lane_sum_adds_each_lane_in_order_then_pairs_them() {
        let values = [1e16, 1.0, -1e16, 1.0, 3.0, 0.5, 0.25];
        // Lanes: 1e16 + 3, 1 + 0.5, -1e16 + 0.25, 1.
        let want = ((1e16 + 3.0) + (1.0 + 0.5)) + ((-1e16 + 0.25) + 1.0);
        assert_eq!(lane_sum(values), want);
        assert_eq!(lane_sum([]), 0.0);
        assert_eq!(lane_sum([2.5]), 2.5);
    }
}
