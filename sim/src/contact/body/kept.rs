//! The operators a contact model has built, kept for the next path on a grid of the same shape
//! and cell side.
//!
//! A body with a length of its own (layers, the finite-element dome) has an operator per cell
//! side: its cell integrals, inverse stencil, `f32` tables and spectra were about a sixth of a
//! dome tap's work. A footprint's side comes from the probe's cells
//! ([`crate::contact::geometry::footprint`]), so a run's paths share a few dozen sides: the
//! lab's edge recipe with the dome (5,000 taps, `scenarios/datasets/edge-2d.toml`) builds 61
//! operators, the bench's 200 dome taps 9. The model keeps the operators it builds within a
//! memory budget ([`KEPT_OPERATORS_MIB`]); an operator taken from here is the one the body
//! builds on the same grid, bit for bit, so what is kept changes no output.

use std::collections::HashMap;
use std::sync::{Mutex, PoisonError};

use super::operator::Operator;
use crate::contact::geometry::grid::Grid;

/// The memory (MiB) a model's kept operators may take at most, counted as
/// [`Operator::bytes_at_most`] each: 141 of them at the default 25 cells, 308 at the edge
/// recipe's 17.
pub const KEPT_OPERATORS_MIB: usize = 128;

/// The kept operators, and how often each grid was asked for lately. A clone of the model
/// starts with none.
#[derive(Debug, Default)]
pub(crate) struct KeptOperators(Mutex<Kept>);

#[derive(Debug, Default)]
struct Kept {
    operators: Vec<(Key, Operator)>,
    /// Requests per grid, kept or not, halved every [`Kept::window`] requests.
    requests: HashMap<Key, u32>,
    /// Requests since the counts were last halved.
    since_halved: usize,
}

/// A grid's shape and cell side (its bits).
type Key = (usize, usize, u64);

impl Kept {
    /// Requests between halvings of the counts: eight per operator kept, at least 64.
    fn window(&self) -> usize {
        8 * self.operators.len().max(8)
    }

    fn bytes(&self) -> usize {
        self.operators.iter().map(|((nx, ny, _), _)| Operator::bytes_at_most(*nx, *ny)).sum()
    }
}

impl Clone for KeptOperators {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl KeptOperators {
    /// The operator on `grid`: a kept one moved onto it, or `build`'s. A built one is kept
    /// where the memory budget allows; where it does not, it takes the place of the least
    /// requested ones if its grid was requested more often than each of them (frequency-based
    /// admission: paths cycling over more grids than fit, as a benchmark's repeated passes,
    /// keep hitting the ones kept, and a run that moves to other grids replaces them as the
    /// counts halve).
    pub(crate) fn get(&self, grid: Grid, build: impl FnOnce(Grid) -> Operator) -> Operator {
        let key = (grid.nx, grid.ny, grid.cell_mm.to_bits());
        {
            let mut kept = self.0.lock().unwrap_or_else(PoisonError::into_inner);
            *kept.requests.entry(key).or_default() += 1;
            kept.since_halved += 1;
            if kept.since_halved >= kept.window() {
                kept.since_halved = 0;
                kept.requests.retain(|_, n| {
                    *n /= 2;
                    *n > 0
                });
            }
            if let Some((_, hit)) = kept.operators.iter().find(|(k, _)| *k == key) {
                return hit.on(grid);
            }
        }
        // Built outside the lock: another thread may build the same one meanwhile (the same
        // bits), and only one is kept.
        let operator = build(grid);
        let mut kept = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        let budget = KEPT_OPERATORS_MIB << 20;
        let own = Operator::bytes_at_most(grid.nx, grid.ny);
        if own > budget || kept.operators.iter().any(|(k, _)| *k == key) {
            return operator;
        }
        // The least requested first, until the new one fits; none requested as often as it.
        let count = |k: &Key| kept.requests.get(k).copied().unwrap_or(0);
        let asked = count(&key);
        let mut order: Vec<(u32, usize)> = kept.operators.iter().enumerate().map(|(i, (k, _))| (count(k), i)).collect();
        order.sort_unstable();
        let (mut bytes, mut out) = (kept.bytes(), Vec::new());
        for (n, i) in order {
            if bytes + own <= budget {
                break;
            }
            if n >= asked {
                return operator;
            }
            let (nx, ny, _) = kept.operators[i].0;
            bytes -= Operator::bytes_at_most(nx, ny);
            out.push(i);
        }
        out.sort_unstable();
        for i in out.into_iter().rev() {
            kept.operators.remove(i);
        }
        kept.operators.push((key, operator.clone()));
        operator
    }

    /// How many operators are kept.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).operators.len()
    }
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;
    use crate::contact::body::operator::{Component, HalfSpace, Pairing, Product};
    use crate::contact::{ContactModel, Elastic};
    use crate::sensor::{SensorParams, SkinModel};

    /// Every table and product of `a` has the bits of `b`'s.
    fn assert_same_bits(a: &Operator, b: &Operator) {
        assert_eq!(a.grid(), b.grid());
        let n = a.grid().len();
        let field: Vec<f64> = (0..n).map(|k| ((k * 37 % 11) as f64 - 4.0) * 0.013).collect();
        let cells: Vec<usize> = (0..n).step_by(3).collect();
        for c in Component::ALL {
            assert!(a.table(c).iter().zip(b.table(c)).all(|(x, y)| x.to_bits() == y.to_bits()), "{c:?}");
            for product in [
                Product::Fft,
                Product::Dense { src: &cells, dst: &cells },
                Product::DenseSingle { src: &cells, dst: &cells },
            ] {
                let (mut u, mut v) = (vec![0.0; n], vec![0.0; n]);
                a.apply(&[(c, &field)], &mut u, product);
                b.apply(&[(c, &field)], &mut v, product);
                assert!(u.iter().zip(&v).all(|(x, y)| x.to_bits() == y.to_bits()), "{c:?} {product:?}");
            }
        }
        assert_eq!(a.normal_stencil(), b.normal_stencil());
        assert_eq!(a.checkerboard().to_bits(), b.checkerboard().to_bits());
    }

    #[test]
    fn an_operator_kept_for_another_path_is_the_one_built_on_the_grid() {
        let mut sensor = SensorParams::half_space();
        sensor.skin.model = SkinModel::Layer;
        sensor.skin.cells_across = 9;
        let model = ContactModel::new(&sensor).expect("contact model");
        let first = Grid { nx: 9, ny: 9, cell_mm: 0.81, centre_mm: [1.0, -2.0] };
        let second = Grid { centre_mm: [-3.5, 0.25], ..first };
        // The first path's operator, its tables made, then the second's from the kept one.
        assert_same_bits(&model.operator(first), &model.body.operator(first));
        assert_eq!(model.operators.len(), 1);
        let kept = model.operator(second);
        assert_eq!(model.operators.len(), 1, "taken, not built again");
        assert_same_bits(&kept, &model.body.operator(second));
    }

    #[test]
    fn a_half_space_keeps_nothing() {
        let mut sensor = SensorParams::half_space();
        sensor.skin.model = SkinModel::HalfSpace;
        let model = ContactModel::new(&sensor).expect("contact model");
        model.operator(Grid::square(9, 0.81));
        assert_eq!(model.operators.len(), 0);
    }

    fn half_space(grid: Grid) -> Operator {
        Operator::new(&HalfSpace { material: Elastic::from_young(1.0, 0.49), pairing: Pairing::RigidIndenter }, grid)
    }

    #[test]
    fn kept_operators_stay_within_their_memory_budget_and_paths_cycling_over_more_keep_hitting() {
        // 15.6 MB an operator at 101 cells: 8 fit in the budget.
        let n = 101;
        let fit = (KEPT_OPERATORS_MIB << 20) / Operator::bytes_at_most(n, n);
        assert_eq!(fit, 8);
        let kept = KeptOperators::default();
        let built = Cell::new(0);
        let build = |g: Grid| {
            built.set(built.get() + 1);
            half_space(g)
        };
        let sides: Vec<f64> = (0..fit + 8).map(|k| 0.1 + 0.001 * k as f64).collect();
        for pass in 0..4 {
            let before = built.get();
            for side in &sides {
                kept.get(Grid::square(n, *side), build);
                assert!(kept.len() <= fit);
            }
            let misses = built.get() - before;
            if pass == 0 {
                assert_eq!(misses, sides.len());
            } else {
                assert!(misses <= sides.len() - fit + 1, "pass {pass}: {misses} built of {}", sides.len());
            }
        }
        // A run that moves to other grids replaces the ones it left.
        let others: Vec<f64> = (0..fit).map(|k| 0.2 + 0.001 * k as f64).collect();
        for _ in 0..6 {
            for side in &others {
                kept.get(Grid::square(n, *side), build);
            }
        }
        let before = built.get();
        for side in &others {
            kept.get(Grid::square(n, *side), build);
        }
        assert_eq!(built.get(), before, "every one of the new grids kept");
    }
}
