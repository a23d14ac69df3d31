//! The dome's linear response condensed onto the outer nodes that can touch and the pins'
//! tips, computed once per sensor and cached on disk.
//!
//! Column `j` of the tables is the response to a unit force (1 N) on surface degree of freedom
//! `j = 3 s + direction` (the surface node `s`'s, sensor axes): the surface table gives every
//! condensed node's displacement (mm, `3 S` rows), the pin table every pin tip's (`3 P` rows).
//! One solve per column; the pins' rows come from the same solves (a probe reads the nodes of
//! its element), so the pins cost nothing extra. By reciprocity the surface table is symmetric
//! (test `condensed_tables_reproduce_a_direct_solve_and_are_reciprocal`).
//!
//! # The cache file
//! `tacsim-dome-<key>.bin`: the magic line `TACSIMFEM1`, a little-endian `u64` header length,
//! the JSON header ([`Header`]: the key, the format, the sizes, the spec in words), then the
//! surface nodes' positions, the surface table and the pin table as little-endian `f64`,
//! columns one after the other. The key is a 64-bit FNV-1a hash of everything that shapes the
//! tables (the spec, the cap's angle, the pins, the format's version): a file is only read
//! back for the same inputs, and written atomically (temporary file, then rename).

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cache;
use crate::dome::{Dome, DomeSpec, PinSite};
use crate::error::{FemError, Result};
use crate::system::SOLVE_BLOCK;

/// Bump when the tables' meaning or the file's layout change.
const FORMAT: u32 = 2;
const MAGIC: &[u8] = b"TACSIMFEM1\n";

/// The condensed response of a dome.
#[derive(Clone, Debug, PartialEq)]
pub struct Compliance {
    /// The inputs' key (see the module's documentation).
    pub key: u64,
    /// The condensed outer nodes' positions (mm), in the mesh's node order.
    pub nodes: Vec<[f64; 3]>,
    /// Pins.
    pub pins: usize,
    /// Surface displacement per unit surface force (mm/N), `3 S x 3 S`, column-major.
    pub surface: Vec<f64>,
    /// Pin tip displacement per unit surface force (mm/N), `3 P x 3 S`, column-major.
    pub pin_table: Vec<f64>,
}

/// The cache file's header.
#[derive(Debug, Serialize, Deserialize)]
pub struct Header {
    /// The inputs' key, in hex.
    pub key: String,
    /// The format's version.
    pub format: u32,
    /// Condensed surface nodes.
    pub surface_nodes: usize,
    /// Pins.
    pub pins: usize,
    /// The spec, for a reader.
    pub spec: String,
}

/// The key of a condensation's inputs.
pub fn key(spec: &DomeSpec, max_polar_deg: f64, pins: &[PinSite]) -> u64 {
    let words = format!("{FORMAT} {spec:?} {:?} {pins:?}", max_polar_deg.to_bits());
    cache::key_of(&words)
}

impl Compliance {
    /// Condenses a built dome onto its outer nodes within `max_polar_deg` of the apex and onto
    /// the pins. Columns are solved [`SOLVE_BLOCK`] at a time, each block on one thread, so the
    /// tables do not depend on the thread count; `progress` is called with the columns done.
    pub fn condense(
        dome: &Dome,
        max_polar_deg: f64,
        pins: &[PinSite],
        progress: impl Fn(usize, usize) + Sync,
    ) -> Result<Self> {
        if !(0.0..=90.0).contains(&max_polar_deg) {
            return Err(FemError::Parameter {
                field: "max_polar_deg",
                value: max_polar_deg,
                expected: "an angle from the apex in [0, 90] deg",
            });
        }
        let probes = dome.pin_probes(pins)?;
        let surface_nodes = dome.outer_nodes(max_polar_deg);
        let n = dome.stiffness.size();
        let columns: Vec<usize> = surface_nodes
            .iter()
            .flat_map(|&s| (0..3).map(move |c| 3 * s + c))
            .map(|dof| dome.stiffness.free_index(dof).ok_or(FemError::HeldSurface { dof }))
            .collect::<Result<_>>()?;
        let (rows_s, rows_p) = (columns.len(), 3 * probes.len());
        let mut surface = vec![0.0; rows_s * columns.len()];
        let done = std::sync::atomic::AtomicUsize::new(0);
        let pin_blocks: Vec<Vec<f64>> = surface
            .par_chunks_mut(rows_s * SOLVE_BLOCK)
            .zip(columns.par_chunks(SOLVE_BLOCK))
            .map(|(out_s, cols)| {
                let k = cols.len();
                let mut out_p = vec![0.0; rows_p * k];
                let mut block = vec![0.0; n * k];
                for (j, &c) in cols.iter().enumerate() {
                    block[j * n + c] = 1.0;
                }
                dome.factor.solve_block(&mut block);
                for j in 0..k {
                    let x = &block[j * n..(j + 1) * n];
                    for (i, &row) in columns.iter().enumerate() {
                        out_s[j * rows_s + i] = x[row];
                    }
                    let u = |node: usize, m: usize| dome.stiffness.value(x, 3 * node + m);
                    for (p, probe) in probes.iter().enumerate() {
                        let tip = probe.displacement_of(u);
                        out_p[j * rows_p + 3 * p..j * rows_p + 3 * p + 3].copy_from_slice(&tip);
                    }
                }
                let total = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
                progress(total, columns.len());
                out_p
            })
            .collect();
        let pin_table = pin_blocks.concat();
        Ok(Self {
            key: key(&dome.spec, max_polar_deg, pins),
            nodes: surface_nodes.iter().map(|&s| dome.mesh.nodes[s]).collect(),
            pins: probes.len(),
            surface,
            pin_table,
        })
    }

    /// Condensed surface degrees of freedom (`3 S`).
    pub fn surface_dofs(&self) -> usize {
        3 * self.nodes.len()
    }

    /// The response at every condensed node and pin tip (mm) to forces (N) on the condensed
    /// nodes (`3 S` values, node by node).
    pub fn respond(&self, forces: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let s = self.surface_dofs();
        let p = 3 * self.pins;
        let mut us = vec![0.0; s];
        let mut up = vec![0.0; p];
        for (j, &f) in forces.iter().enumerate().take(s) {
            if f == 0.0 {
                continue;
            }
            for (u, c) in us.iter_mut().zip(&self.surface[j * s..(j + 1) * s]) {
                *u += c * f;
            }
            for (u, c) in up.iter_mut().zip(&self.pin_table[j * p..(j + 1) * p]) {
                *u += c * f;
            }
        }
        (us, up)
    }

    /// The cache file's path in `dir` for these inputs.
    pub fn path_in(dir: &Path, key: u64) -> PathBuf {
        dir.join(format!("tacsim-dome-{key:016x}.bin"))
    }

    /// Writes the tables to `path` atomically (a temporary file beside it, then a rename).
    pub fn save(&self, path: &Path, spec: &DomeSpec) -> Result<()> {
        let header = Header {
            key: format!("{:016x}", self.key),
            format: FORMAT,
            surface_nodes: self.nodes.len(),
            pins: self.pins,
            spec: format!("{spec:?}"),
        };
        let values: Vec<f64> =
            self.nodes.iter().flatten().chain(&self.surface).chain(&self.pin_table).copied().collect();
        cache::write(path, MAGIC, &header, &cache::bytes_of(&values, f64::to_le_bytes))
    }

    /// Reads the tables back, checking the magic, the key and the sizes; an error names the
    /// file and says what to do (delete it: it is rebuilt on the next use).
    pub fn load(path: &Path, key: u64) -> Result<Self> {
        let (header, mut data): (Header, _) = cache::read(path, MAGIC)?;
        let err = |message: String| cache::unusable(path, message);
        cache::check(path, (header.format, FORMAT), (&header.key, key))?;
        // In u128 (saturating) so that no header's counts overflow; once they add up to the
        // file's bytes, each fits a usize.
        let (s, p) = (3 * header.surface_nodes as u128, 3 * header.pins as u128);
        let expected = s.saturating_add(s.saturating_mul(s)).saturating_add(p.saturating_mul(s)).saturating_mul(8);
        if u128::from(data.left()) != expected {
            return Err(err(format!("{} bytes of tables where {expected} were expected", data.left())));
        }
        let (s, p) = (s as usize, p as usize);
        let nodes = data.values::<f64>(s)?;
        Ok(Self {
            key,
            nodes: nodes.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            pins: header.pins,
            surface: data.values(s * s)?,
            pin_table: data.values(p * s)?,
        })
    }

    /// The tables for these inputs: read from `dir` where a file with their key is there, else
    /// built (the dome meshed, assembled, factorised and condensed) and saved there.
    pub fn cached(
        dir: &Path,
        spec: &DomeSpec,
        max_polar_deg: f64,
        pins: &[PinSite],
        progress: impl Fn(usize, usize) + Sync,
    ) -> Result<Self> {
        spec.validate()?;
        let key = key(spec, max_polar_deg, pins);
        let path = Self::path_in(dir, key);
        if path.exists() {
            return Self::load(&path, key);
        }
        cache::check_writable(dir)?;
        let dome = Dome::build(spec)?;
        let tables = Self::condense(&dome, max_polar_deg, pins, progress)?;
        tables.save(&path, spec)?;
        Ok(tables)
    }
}
