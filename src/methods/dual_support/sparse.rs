//! Sparse linear algebra of the static path: the block pattern of the tangent (built once),
//! the system of the free degrees of freedom, and its two solvers: faer's sparse Cholesky
//! with the symbolic factorisation kept across Newton iterations, and conjugate gradients
//! with a Jacobi preconditioner.

use super::support::Support;
use crate::tensor::Dim;
use faer::Side;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The coupling of the tangent at the level of particles: a and b are coupled when some
/// element {i} ∪ S_i holds both (two hops through the supports). Rows sorted.
pub struct BlockPattern {
    pub offsets: Vec<usize>,
    pub cols: Vec<u32>,
}

impl BlockPattern {
    /// The pattern of the dual-support tangent: row a holds every node of every element
    /// holding a (a itself and S'_a).
    pub fn new<D: Dim>(s: &Support<D>) -> Self {
        let rows: Vec<Vec<u32>> = (0..s.len())
            .into_par_iter()
            .map(|a| {
                let mut row: Vec<u32> = s
                    .elements_of(a)
                    .flat_map(|(i, _)| s.nodes(i))
                    .map(|n| n as u32)
                    .collect();
                row.sort_unstable();
                row.dedup();
                row
            })
            .collect();
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

/// How the Newton step's linear system is solved (`method.solver`).
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

/// A linear solve that failed.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SolveError {
    #[error(
        "the tangent is not positive definite (Cholesky failed): the boundary conditions \
         may leave a rigid-body motion free (pin enough components; note §4.3), or the \
         state is past a stability limit"
    )]
    NotPositiveDefinite,
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

/// What a linear solve did.
#[derive(Clone, Copy, Debug, Default)]
pub struct SolveStats {
    /// CG iterations (0 for the direct solve).
    pub iterations: usize,
    pub seconds: f64,
}

/// The tangent restricted to the free degrees of freedom, as a full symmetric CSR matrix
/// (which is also its CSC form), with for every entry the index of its value in the block
/// values of the pattern.
pub struct FreeSystem {
    pub n: usize,
    row_ptr: Vec<usize>,
    col: Vec<usize>,
    src: Vec<usize>,
    solver: Solver,
}

enum Solver {
    Direct {
        matrix: SymbolicSparseColMat<usize>,
        symbolic: SymbolicLlt<usize>,
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

/// Non-zeros of the Cholesky factor and the ratio to the lower triangle of the matrix.
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
        kind: SolverKind,
        cg: CgSettings,
    ) -> Result<(Self, Fill), SolveError> {
        let n = free.iter().flatten().count();
        let mut row_ptr = vec![0usize; n + 1];
        let (mut col, mut src) = (Vec::new(), Vec::new());
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
        let (solver, fill) = match kind {
            SolverKind::Direct => {
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
                (Solver::Direct { matrix, symbolic }, Fill { factor, lower })
            }
            SolverKind::Cg => (
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
                row_ptr,
                col,
                src,
                solver,
            },
            fill,
        ))
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
        let (x, iterations) = match &self.solver {
            Solver::Direct { matrix, symbolic } => {
                let k = SparseColMatRef::new(matrix.as_ref(), values);
                let llt = Llt::try_new_with_symbolic(symbolic.clone(), k, Side::Lower)
                    .map_err(|_| SolveError::NotPositiveDefinite)?;
                let mut x = faer::Col::<f64>::from_fn(self.n, |r| b[r]);
                faer::linalg::solvers::Solve::solve_in_place(&llt, &mut x);
                ((0..self.n).map(|r| x[r]).collect(), 0)
            }
            Solver::Cg {
                tolerance,
                max_iterations,
            } => self.cg(values, b, *tolerance, *max_iterations)?,
        };
        Ok((
            x,
            SolveStats {
                iterations,
                seconds: started.elapsed().as_secs_f64(),
            },
        ))
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
