//! Sparse linear algebra of the static path: the block pattern of the stiffness (built
//! once), the system of the free degrees of freedom, and its solvers: faer's sparse
//! Cholesky (symmetric stiffness) or LU (unsymmetric) with the symbolic factorisation kept
//! across Newton iterations, and conjugate gradients with a Jacobi preconditioner.

use faer::Side;
use faer::sparse::linalg::solvers::{Llt, Lu, SymbolicLlt, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;
use thiserror::Error;

/// The coupling of the stiffness at the level of particles: row a lists the particles b
/// whose displacement the force on a depends on. Rows sorted; the pattern is symmetric (b
/// in row a exactly when a in row b), which the LU solve relies on.
pub struct BlockPattern {
    pub offsets: Vec<usize>,
    pub cols: Vec<u32>,
}

impl BlockPattern {
    /// The pattern of sorted, deduplicated rows.
    pub fn from_rows(rows: Vec<Vec<u32>>) -> Self {
        let mut offsets = vec![0];
        for r in &rows {
            offsets.push(offsets.last().copied().unwrap_or(0) + r.len());
        }
        Self {
            offsets,
            cols: rows.concat(),
        }
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.cols.len()
    }

    /// Number of particles (rows).
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The columns of row a.
    pub fn row(&self, a: usize) -> &[u32] {
        &self.cols[self.offsets[a]..self.offsets[a + 1]]
    }

    /// Groups of particles no two of which share a row (a distance-2 colouring of the
    /// coupling graph, greedy in particle order): displacing all the particles of a group
    /// at once changes the force on every particle through at most one of them, so that
    /// one force evaluation per group and component gives all their columns of the
    /// stiffness (Curtis, Powell and Reid).
    pub fn column_groups(&self) -> Vec<Vec<u32>> {
        let n = self.len();
        let mut colour = vec![u32::MAX; n];
        // The last particle that marked each colour as taken.
        let mut taken: Vec<usize> = Vec::new();
        let mut groups: Vec<Vec<u32>> = Vec::new();
        for b in 0..n {
            for &a in self.row(b) {
                for &c in self.row(a as usize) {
                    let k = colour[c as usize];
                    if k != u32::MAX {
                        taken[k as usize] = b;
                    }
                }
            }
            let k = (0..groups.len())
                .find(|&k| taken[k] != b)
                .unwrap_or_else(|| {
                    groups.push(Vec::new());
                    taken.push(usize::MAX);
                    groups.len() - 1
                });
            colour[b] = k as u32;
            groups[k].push(b as u32);
        }
        groups
    }

    /// Every row as (row, its columns, its values), the values split from `values` with
    /// `block` entries per column.
    pub fn rows_mut<'a>(
        &'a self,
        values: &'a mut [f64],
        block: usize,
    ) -> Vec<(usize, &'a [u32], &'a mut [f64])> {
        let mut out = Vec::with_capacity(self.offsets.len() - 1);
        let mut rest = values;
        for a in 0..self.offsets.len() - 1 {
            let (lo, hi) = (self.offsets[a], self.offsets[a + 1]);
            let (row, tail) = rest.split_at_mut((hi - lo) * block);
            out.push((a, &self.cols[lo..hi], row));
            rest = tail;
        }
        out
    }
}

/// How the dual-support Newton step's linear system is solved (`method.solver`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// faer's sparse Cholesky (supernodal or simplicial, with a fill-reducing ordering);
    /// the symbolic factorisation is computed once, the numeric one every iteration.
    #[default]
    Direct,
    /// Conjugate gradients with a Jacobi preconditioner, matrix in CSR.
    Cg,
}

/// Bytes per entry of an assembled tangent: column and source index (usize each), the
/// value in the pattern's blocks and in the free system (f64 each); and, for a
/// factorisation, the copy of the structure its symbolic analysis takes (usize) with that
/// analysis's work space (about as much again). The seed-004 cantilever at 6.2e5 unknowns
/// peaked at 38 bytes an entry with CG and 46 with the Cholesky analysis, its model
/// included.
const ASSEMBLED_BYTES: f64 = 32.0;
const FACTORISED_BYTES: f64 = 48.0;

/// A linear solve that failed.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SolveError {
    #[error(
        "the tangent is not positive definite, which conjugate gradients need: the \
         boundary conditions may leave a rigid-body motion free (pin enough components; \
         note §4.3), or the state is past a stability limit, where method.solver = \
         \"direct\" still solves (by LU once Cholesky refuses the tangent)"
    )]
    NotPositiveDefinite,
    #[error(
        "the stiffness is singular (the LU solve left a relative residual of {residual:e}): \
         the boundary conditions leave a rigid-body motion free; prescribe enough \
         displacement or velocity components (`fixed`, `displacement`, \
         `solution-displacement`) to hold the body"
    )]
    Singular { residual: f64 },
    #[error(
        "conjugate gradients did not reach the relative residual {tolerance:e} in \
         {iterations} iterations (reached {reached:e}); raise method.linear_max_iterations \
         or use method.solver = \"direct\""
    )]
    NoConvergence {
        tolerance: f64,
        iterations: usize,
        reached: f64,
    },
    #[error(
        "the assembled tangent of {dofs} unknowns needs {needed_mb:.0} MB ({entries} \
         entries) and {available_mb:.0} MB are available: coarsen the case (spacing), or, \
         for `dual-support-sph`, run on the GPU (--backend gpu), whose matrix-free solve \
         assembles no tangent"
    )]
    TangentTooLarge {
        dofs: usize,
        entries: usize,
        needed_mb: f64,
        available_mb: f64,
    },
    #[error(
        "the Cholesky factor of {dofs} unknowns needs {needed_mb:.0} MB ({fill} non-zeros, \
         {ratio:.1} times the tangent's lower triangle) and {available_mb:.0} MB are \
         available; use method.solver = \"cg\""
    )]
    OutOfMemory {
        dofs: usize,
        fill: usize,
        ratio: f64,
        needed_mb: f64,
        available_mb: f64,
    },
}

/// The linear solver of a free system.
#[derive(Clone, Copy, Debug)]
pub enum Linear {
    /// Sparse Cholesky of a symmetric positive definite stiffness.
    Cholesky,
    /// Sparse LU with partial pivoting of an unsymmetric stiffness. The free system's rows
    /// are then read as the columns of the matrix: the block values are those of Kᵀ.
    Lu,
    /// Jacobi-preconditioned conjugate gradients (symmetric positive definite).
    Cg(CgSettings),
}

impl From<(SolverKind, CgSettings)> for Linear {
    fn from((kind, cg): (SolverKind, CgSettings)) -> Self {
        match kind {
            SolverKind::Direct => Self::Cholesky,
            SolverKind::Cg => Self::Cg(cg),
        }
    }
}

/// What a linear solve did.
#[derive(Clone, Copy, Debug, Default)]
pub struct SolveStats {
    /// CG iterations (0 for the direct solve).
    pub iterations: usize,
    pub seconds: f64,
    /// The Cholesky factorisation refused the tangent (indefinite) and LU solved it.
    pub indefinite: bool,
}

/// The stiffness restricted to the free degrees of freedom, as a full CSR matrix on the
/// symmetric structure of the pattern (which is also its CSC structure), with for every
/// entry the index of its value in the block values of the pattern.
pub struct FreeSystem {
    pub n: usize,
    kind: Linear,
    row_ptr: Vec<usize>,
    col: Vec<usize>,
    src: Vec<usize>,
    solver: Solver,
}

enum Solver {
    Cholesky {
        matrix: SymbolicSparseColMat<usize>,
        symbolic: SymbolicLlt<usize>,
        /// The symbolic LU of the same structure, made at the first tangent the Cholesky
        /// factorisation refuses.
        lu: OnceLock<SymbolicLu<usize>>,
    },
    Lu {
        matrix: SymbolicSparseColMat<usize>,
        symbolic: SymbolicLu<usize>,
    },
    Cg {
        tolerance: f64,
        max_iterations: usize,
    },
}

/// Settings of the iterative solver.
#[derive(Clone, Copy, Debug)]
pub struct CgSettings {
    pub tolerance: f64,
    pub max_iterations: usize,
}

/// Non-zeros of the Cholesky factor and of the lower triangle of the matrix (the factor
/// 0 for LU and CG).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fill {
    pub factor: usize,
    pub lower: usize,
}

impl FreeSystem {
    /// The free system of a pattern of d×d blocks; `free[a·d + k]` is the free index of
    /// component k of particle a, or None where it is prescribed.
    pub fn new(
        pattern: &BlockPattern,
        d: usize,
        free: &[Option<u32>],
        linear: Linear,
    ) -> Result<(Self, Fill), SolveError> {
        let n = free.iter().flatten().count();
        // The assembled tangent's memory before any of it is allocated.
        let entries = pattern.blocks() * d * d;
        let per_entry = match linear {
            Linear::Cg(_) => ASSEMBLED_BYTES,
            Linear::Cholesky | Linear::Lu => FACTORISED_BYTES,
        };
        let needed = entries as f64 * per_entry;
        if let Some(available) = available_memory()
            && needed > available
        {
            return Err(SolveError::TangentTooLarge {
                dofs: n,
                entries,
                needed_mb: needed / 1e6,
                available_mb: available / 1e6,
            });
        }
        let mut row_ptr = vec![0usize; n + 1];
        let (mut col, mut src) = (Vec::with_capacity(entries), Vec::with_capacity(entries));
        for a in 0..pattern.offsets.len() - 1 {
            for k in 0..d {
                let Some(r) = free[a * d + k] else { continue };
                for q in pattern.offsets[a]..pattern.offsets[a + 1] {
                    let b = pattern.cols[q] as usize;
                    for l in 0..d {
                        if let Some(c) = free[b * d + l] {
                            col.push(c as usize);
                            src.push(q * d * d + k * d + l);
                        }
                    }
                }
                row_ptr[r as usize + 1] = col.len();
            }
        }
        let lower = (0..n)
            .map(|r| {
                col[row_ptr[r]..row_ptr[r + 1]]
                    .iter()
                    .filter(|&&c| c >= r)
                    .count()
            })
            .sum();
        let (solver, fill) = match linear {
            Linear::Cholesky => {
                let matrix =
                    SymbolicSparseColMat::new_checked(n, n, row_ptr.clone(), None, col.clone());
                let factor = faer::sparse::linalg::cholesky::factorize_symbolic_cholesky(
                    matrix.as_ref(),
                    Side::Lower,
                    Default::default(),
                    Default::default(),
                )
                .map_err(|_| out_of_memory(n, 0, lower))?
                .len_val();
                if let Some(available) = available_memory()
                    && (factor + col.len()) as f64 * 8.0 > available
                {
                    return Err(SolveError::OutOfMemory {
                        dofs: n,
                        fill: factor,
                        ratio: factor as f64 / lower.max(1) as f64,
                        needed_mb: (factor + col.len()) as f64 * 8.0 / 1e6,
                        available_mb: available / 1e6,
                    });
                }
                let symbolic = SymbolicLlt::try_new(matrix.as_ref(), Side::Lower)
                    .map_err(|_| out_of_memory(n, factor, lower))?;
                (
                    Solver::Cholesky {
                        matrix,
                        symbolic,
                        lu: OnceLock::new(),
                    },
                    Fill { factor, lower },
                )
            }
            Linear::Lu => {
                let matrix =
                    SymbolicSparseColMat::new_checked(n, n, row_ptr.clone(), None, col.clone());
                let symbolic =
                    SymbolicLu::try_new(matrix.as_ref()).map_err(|_| out_of_memory(n, 0, lower))?;
                (Solver::Lu { matrix, symbolic }, Fill { factor: 0, lower })
            }
            Linear::Cg(cg) => (
                Solver::Cg {
                    tolerance: cg.tolerance,
                    max_iterations: cg.max_iterations,
                },
                Fill { factor: 0, lower },
            ),
        };
        Ok((
            Self {
                n,
                kind: linear,
                row_ptr,
                col,
                src,
                solver,
            },
            fill,
        ))
    }

    /// The linear solver.
    pub fn kind(&self) -> Linear {
        self.kind
    }

    /// The free system's values from the pattern's block values.
    pub fn gather(&self, block_values: &[f64]) -> Vec<f64> {
        self.src.par_iter().map(|&q| block_values[q]).collect()
    }

    /// y = K x.
    pub fn matvec(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.par_iter_mut().enumerate().for_each(|(r, y)| {
            *y = (self.row_ptr[r]..self.row_ptr[r + 1])
                .map(|q| values[q] * x[self.col[q]])
                .sum();
        });
    }

    /// Solves K x = b.
    pub fn solve(&self, values: &[f64], b: &[f64]) -> Result<(Vec<f64>, SolveStats), SolveError> {
        let started = std::time::Instant::now();
        let (x, iterations, indefinite) = match &self.solver {
            Solver::Cholesky {
                matrix,
                symbolic,
                lu,
            } => {
                let k = SparseColMatRef::new(matrix.as_ref(), values);
                match Llt::try_new_with_symbolic(symbolic.clone(), k, Side::Lower) {
                    Ok(llt) => {
                        let mut x = faer::Col::<f64>::from_fn(self.n, |r| b[r]);
                        faer::linalg::solvers::Solve::solve_in_place(&llt, &mut x);
                        ((0..self.n).map(|r| x[r]).collect(), 0, false)
                    }
                    // Past a stability limit the symmetric tangent is indefinite: LU with
                    // partial pivoting solves it all the same (a singular one it refuses).
                    Err(_) => {
                        let symbolic = match lu.get() {
                            Some(symbolic) => symbolic,
                            None => {
                                let symbolic = SymbolicLu::try_new(matrix.as_ref())
                                    .map_err(|_| SolveError::NotPositiveDefinite)?;
                                lu.get_or_init(|| symbolic)
                            }
                        };
                        (self.lu_solve(matrix, symbolic, values, b)?, 0, true)
                    }
                }
            }
            Solver::Lu { matrix, symbolic } => {
                (self.lu_solve(matrix, symbolic, values, b)?, 0, false)
            }
            Solver::Cg {
                tolerance,
                max_iterations,
            } => {
                let (x, iterations) = self.cg(values, b, *tolerance, *max_iterations)?;
                (x, iterations, false)
            }
        };
        Ok((
            x,
            SolveStats {
                iterations,
                seconds: started.elapsed().as_secs_f64(),
                indefinite,
            },
        ))
    }

    /// Solves K x = b by sparse LU with partial pivoting, the values read as Kᵀ by rows
    /// (K itself for a symmetric K).
    fn lu_solve(
        &self,
        matrix: &SymbolicSparseColMat<usize>,
        symbolic: &SymbolicLu<usize>,
        values: &[f64],
        b: &[f64],
    ) -> Result<Vec<f64>, SolveError> {
        let k = SparseColMatRef::new(matrix.as_ref(), values);
        let singular = |residual| SolveError::Singular { residual };
        let lu =
            Lu::try_new_with_symbolic(symbolic.clone(), k).map_err(|_| singular(f64::INFINITY))?;
        let mut x = faer::Col::<f64>::from_fn(self.n, |r| b[r]);
        faer::linalg::solvers::Solve::solve_in_place(&lu, &mut x);
        let x: Vec<f64> = (0..self.n).map(|r| x[r]).collect();
        // A singular K gives no error from the factorisation but a non-finite x or one
        // that does not solve the system: |K x − b| ≤ 1e-8 |b| is asked.
        let residual = self.lu_residual(values, &x, b);
        if residual.is_nan() || residual > 1e-8 {
            return Err(singular(residual));
        }
        Ok(x)
    }

    /// |K x − b|/|b| with the values of Kᵀ by rows (the LU layout); 0 for b = 0 and x = 0.
    fn lu_residual(&self, values: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let mut r = b.to_vec();
        for (c, &xc) in x.iter().enumerate().take(self.n) {
            for q in self.row_ptr[c]..self.row_ptr[c + 1] {
                r[self.col[q]] -= values[q] * xc;
            }
        }
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        let (nr, nb) = (norm(&r), norm(b));
        if nb > 0.0 { nr / nb } else { nr }
    }

    /// Preconditioned conjugate gradients from x = 0, Jacobi preconditioner, stopped at
    /// |r| ≤ tolerance |b|.
    fn cg(
        &self,
        values: &[f64],
        b: &[f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<(Vec<f64>, usize), SolveError> {
        let n = self.n;
        let diag: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|r| {
                (self.row_ptr[r]..self.row_ptr[r + 1])
                    .find(|&q| self.col[q] == r)
                    .map_or(1.0, |q| values[q])
            })
            .collect();
        if diag.iter().any(|&d| d <= 0.0 || d.is_nan()) {
            return Err(SolveError::NotPositiveDefinite);
        }
        let dot = |a: &[f64], b: &[f64]| -> f64 { a.par_iter().zip(b).map(|(a, b)| a * b).sum() };
        let norm_b = dot(b, b).sqrt();
        let mut x = vec![0.0; n];
        if norm_b == 0.0 {
            return Ok((x, 0));
        }
        let mut r = b.to_vec();
        let mut z: Vec<f64> = r.iter().zip(&diag).map(|(r, d)| r / d).collect();
        let mut p = z.clone();
        let mut q = vec![0.0; n];
        let mut rz = dot(&r, &z);
        for it in 1..=max_iterations {
            self.matvec(values, &p, &mut q);
            let pq = dot(&p, &q);
            if pq <= 0.0 || pq.is_nan() {
                return Err(SolveError::NotPositiveDefinite);
            }
            let alpha = rz / pq;
            x.par_iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
            r.par_iter_mut().zip(&q).for_each(|(r, q)| *r -= alpha * q);
            if dot(&r, &r).sqrt() <= tolerance * norm_b {
                return Ok((x, it));
            }
            z.par_iter_mut()
                .zip(&r)
                .zip(&diag)
                .for_each(|((z, r), d)| *z = r / d);
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            p.par_iter_mut()
                .zip(&z)
                .for_each(|(p, z)| *p = z + beta * *p);
        }
        Err(SolveError::NoConvergence {
            tolerance,
            iterations: max_iterations,
            reached: dot(&r, &r).sqrt() / norm_b,
        })
    }
}

fn out_of_memory(dofs: usize, fill: usize, lower: usize) -> SolveError {
    SolveError::OutOfMemory {
        dofs,
        fill,
        ratio: fill as f64 / lower.max(1) as f64,
        needed_mb: f64::INFINITY,
        available_mb: available_memory().unwrap_or(f64::NAN) / 1e6,
    }
}

/// Memory available to the process [bytes], from /proc/meminfo where there is one.
fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}
