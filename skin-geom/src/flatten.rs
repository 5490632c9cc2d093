//! Least-squares conformal maps (LSCM): the flattening Psi: S* -> M* of thesis Ch. 3.2.
//!
//! Psi is piecewise linear; on each triangle it should be a similarity (angles kept). Writing the
//! triangle's corners in its own plane as complex numbers z_j and their images as U_j = u_j + i v_j,
//! the map is conformal on the triangle iff dU/dz̄ = 0, and for a linear map
//!
//!   dU/dz̄ = (i / 4A) * sum_j e_j U_j,   e_j = z_{j+2} - z_{j+1}   (edge opposite corner j)
//!
//! so LSCM minimises E(U) = sum_T |sum_j e_j U_j|^2 / A_T (Lévy et al. 2002; Desbrun et al. 2002,
//! the parameterization the thesis cites). E is a quadratic form H (2n x 2n, symmetric positive
//! semi-definite, zero on similarities); two pinned vertices remove the similarity and leave a
//! sparse positive definite system H_ff x_f = -H_fp x_p, solved by a sparse Cholesky factorisation
//! with a fill-reducing ordering (faer).
//!
//! [`Lscm::new`] does everything that depends only on the triangles: a fill-reducing order of the
//! vertices (approximate minimum degree on the vertex graph, each vertex's u and v kept together),
//! the sparsity pattern in that order (built directly in compressed-column form, no triplets),
//! each triangle's slots in it, and the symbolic factorisation. [`Lscm::solve`] fills the values for given vertex positions and solves, so a mesh
//! flattened again (after re-calibration, or with taxels switched off) skips the symbolic work.

use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::{SupernodalThreshold, amd};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{Point2, Point3};
use std::sync::Arc;

const PINNED: u32 = u32::MAX;

/// A prepared LSCM problem for one edge-connected mesh with two pinned vertices.
#[derive(Debug, Clone)]
pub struct Lscm {
    faces: Vec<[usize; 3]>,
    pins: [usize; 2],
    /// Index among free vertices, or `PINNED`.
    free: Vec<u32>,
    /// Compressed-column pattern of H_ff, both triangles stored (faer reads the upper one).
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Start of each free vertex's neighbour list in `row_idx` for its u column, and its length.
    col_start: Vec<usize>,
    degree: Vec<u32>,
    /// For each face and corner pair (j, k), the rank of j in k's neighbour list.
    ranks: Vec<[u32; 9]>,
    symbolic: Arc<SymbolicCholesky<usize>>,
}

impl Lscm {
    /// Prepares the problem for `n` vertices, triangles `faces` (one edge-connected piece using
    /// every vertex) and the two vertices to pin.
    pub fn new(n: usize, faces: &[[usize; 3]], pins: [usize; 2]) -> Result<Lscm> {
        if pins[0] == pins[1] || pins.iter().any(|&p| p >= n) {
            return Err(Error::Solve(format!(
                "invalid pinned vertices {pins:?} for {n} vertices"
            )));
        }
        let mut free = vec![0u32; n];
        let mut next = 0u32;
        for (v, slot) in free.iter_mut().enumerate() {
            if pins.contains(&v) {
                *slot = PINNED;
            } else {
                *slot = next;
                next += 1;
            }
        }
        let nf = next as usize;
        // Neighbour lists (free vertices only, self included), sorted by free index. The free
        // vertices are then renumbered in approximate-minimum-degree order and the lists rebuilt,
        // so the matrix is assembled already in factorisation order: no permutation of the
        // matrix on every solve.
        let (start, rows) = vertex_graph(faces, &free, nf);
        let order = amd_order(&start, &rows, nf)?;
        for f in free.iter_mut().filter(|f| **f != PINNED) {
            *f = order[*f as usize] as u32;
        }
        let (start, rows) = vertex_graph(faces, &free, nf);
        let degree: Vec<u32> = (0..nf).map(|i| (start[i + 1] - start[i]) as u32).collect();
        // Each vertex k owns two columns (u_k, v_k), each with two rows per neighbour.
        let mut col_ptr = Vec::with_capacity(2 * nf + 1);
        let mut row_idx = Vec::with_capacity(4 * rows.len());
        let mut col_start = Vec::with_capacity(nf);
        col_ptr.push(0);
        for k in 0..nf {
            let neighbours = &rows[start[k]..start[k + 1]];
            col_start.push(row_idx.len());
            for _ in 0..2 {
                for &j in neighbours {
                    row_idx.push(2 * j as usize);
                    row_idx.push(2 * j as usize + 1);
                }
                col_ptr.push(row_idx.len());
            }
        }
        let rank = |k: u32, j: u32| -> u32 {
            let list = &rows[start[k as usize]..start[k as usize + 1]];
            list.binary_search(&j).unwrap_or(0) as u32
        };
        let ranks = faces
            .iter()
            .map(|f| {
                let mut r = [0u32; 9];
                for j in 0..3 {
                    for k in 0..3 {
                        let (fj, fk) = (free[f[j]], free[f[k]]);
                        if fj != PINNED && fk != PINNED {
                            r[3 * j + k] = rank(fk, fj);
                        }
                    }
                }
                r
            })
            .collect();
        let pattern = SymbolicSparseColMatRef::new_checked(2 * nf, 2 * nf, &col_ptr, None, &row_idx);
        // Simplicial factorisation: with the vertices already in minimum-degree order, it beat
        // faer's supernodal variant at every mesh size measured (702 to 100,172 vertices; 7x at
        // 100k, where supernodes stay small). The matrix is stored in full, and `Side::Upper` lets
        // faer's symbolic analysis read it without transposing.
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Upper, SymmetricOrdering::Identity, params)
            .map_err(|e| Error::Solve(format!("symbolic factorisation: {e:?}")))?;
        let symbolic = Arc::new(symbolic);
        Ok(Lscm {
            faces: faces.to_vec(),
            pins,
            free,
            col_ptr,
            row_idx,
            col_start,
            degree,
            ranks,
            symbolic,
        })
    }

    /// The pinned vertices.
    pub fn pins(&self) -> [usize; 2] {
        self.pins
    }

    /// Flattens: returns one 2D point per vertex, with the pinned vertices at `pin_uv`.
    pub fn solve(&self, vertices: &[Point3<f64>], pin_uv: [Point2<f64>; 2]) -> Result<Vec<Point2<f64>>> {
        let nf = self.col_start.len();
        let mut values = vec![0.0f64; self.row_idx.len()];
        let mut rhs = vec![0.0f64; 2 * nf];
        for (f, face) in self.faces.iter().enumerate() {
            let (e, area) = local_edges(vertices[face[0]], vertices[face[1]], vertices[face[2]]);
            if !(area > 0.0) {
                return Err(Error::Solve(format!("triangle {f} has zero area")));
            }
            let inv_area = 1.0 / area;
            for k in 0..3 {
                let fk = self.free[face[k]];
                for j in 0..3 {
                    let fj = self.free[face[j]];
                    if fj == PINNED {
                        continue;
                    }
                    let c = (e[j].0 * e[k].0 + e[j].1 * e[k].1) * inv_area;
                    let s = (e[k].0 * e[j].1 - e[j].0 * e[k].1) * inv_area;
                    if fk == PINNED {
                        let p = if face[k] == self.pins[0] {
                            pin_uv[0]
                        } else {
                            pin_uv[1]
                        };
                        rhs[2 * fj as usize] -= c * p.x + s * p.y;
                        rhs[2 * fj as usize + 1] -= -s * p.x + c * p.y;
                        continue;
                    }
                    let fk = fk as usize;
                    let r = self.ranks[f][3 * j + k] as usize;
                    let u_col = self.col_start[fk] + 2 * r;
                    let v_col = u_col + 2 * self.degree[fk] as usize;
                    values[u_col] += c; // (u_j, u_k)
                    values[u_col + 1] -= s; // (v_j, u_k)
                    values[v_col] += s; // (u_j, v_k)
                    values[v_col + 1] += c; // (v_j, v_k)
                }
            }
        }
        let pattern =
            SymbolicSparseColMatRef::new_checked(2 * nf, 2 * nf, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &values);
        let symbolic = &*self.symbolic;
        let mut l_values = vec![0.0f64; symbolic.len_val()];
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let mut mem = MemBuffer::new(scratch);
        symbolic
            .factorize_numeric_llt(
                &mut l_values,
                matrix,
                Side::Upper,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| {
                Error::Solve(format!(
                    "the LSCM system is not positive definite ({e:?}); is the mesh connected?"
                ))
            })?;
        LltRef::new(symbolic, &l_values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut rhs, 2 * nf, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        let mut out = Vec::with_capacity(self.free.len());
        for (v, &fv) in self.free.iter().enumerate() {
            out.push(if fv == PINNED {
                if v == self.pins[0] { pin_uv[0] } else { pin_uv[1] }
            } else {
                Point2::new(rhs[2 * fv as usize], rhs[2 * fv as usize + 1])
            });
        }
        if out.iter().any(|p| !(p.x.is_finite() && p.y.is_finite())) {
            return Err(Error::Solve("the solve produced non-finite coordinates".into()));
        }
        Ok(out)
    }
}

/// The free-vertex adjacency (self included) in compressed-column form: column starts and the
/// sorted row indices of each column. Built by counting, then sorting each short column, which is
/// much cheaper than sorting all the edge pairs at once.
fn vertex_graph(faces: &[[usize; 3]], free: &[u32], nf: usize) -> (Vec<usize>, Vec<u32>) {
    let mut count = vec![1usize; nf + 1]; // the diagonal
    count[nf] = 0;
    for f in faces {
        for a in 0..3 {
            let fa = free[f[a]];
            if fa != PINNED {
                count[fa as usize] += (0..3).filter(|&b| b != a && free[f[b]] != PINNED).count();
            }
        }
    }
    let mut slot = vec![0usize; nf + 1];
    for i in 0..nf {
        slot[i + 1] = slot[i] + count[i];
    }
    let mut rows = vec![0u32; slot[nf]];
    let mut fill = slot.clone();
    for i in 0..nf {
        rows[fill[i]] = i as u32;
        fill[i] += 1;
    }
    for f in faces {
        for a in 0..3 {
            let fa = free[f[a]];
            if fa == PINNED {
                continue;
            }
            for b in 0..3 {
                let fb = free[f[b]];
                if b != a && fb != PINNED {
                    rows[fill[fa as usize]] = fb;
                    fill[fa as usize] += 1;
                }
            }
        }
    }
    // Sort and deduplicate each column in place, compacting as we go.
    let mut start = vec![0usize; nf + 1];
    let mut out = 0;
    for i in 0..nf {
        let (lo, hi) = (slot[i], slot[i + 1]);
        rows[lo..hi].sort_unstable();
        let mut last = u32::MAX;
        for k in lo..hi {
            if rows[k] != last {
                last = rows[k];
                rows[out] = last;
                out += 1;
            }
        }
        start[i + 1] = out;
    }
    rows.truncate(out);
    (start, rows)
}

/// Fill-reducing order of the vertices: approximate minimum degree on the n x n vertex graph (a
/// quarter of the entries of the 2n x 2n system, whose (u, v) pairs stay together). Returns each
/// vertex's new index.
fn amd_order(start: &[usize], rows: &[u32], nf: usize) -> Result<Vec<usize>> {
    let rows: Vec<usize> = rows.iter().map(|&r| r as usize).collect();
    let graph = SymbolicSparseColMatRef::new_checked(nf, nf, start, None, &rows);
    let (mut perm, mut perm_inv) = (vec![0usize; nf], vec![0usize; nf]);
    let mut mem = MemBuffer::new(amd::order_scratch::<usize>(nf, rows.len()));
    amd::order(
        &mut perm,
        &mut perm_inv,
        graph,
        amd::Control::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| Error::Solve(format!("ordering: {e:?}")))?;
    Ok(perm_inv)
}

/// The edges e_j = z_{j+2} - z_{j+1} of a triangle in its own plane (counter-clockwise about the
/// normal given by its winding), and its area.
fn local_edges(p0: Point3<f64>, p1: Point3<f64>, p2: Point3<f64>) -> ([(f64, f64); 3], f64) {
    let d1 = p1 - p0;
    let d2 = p2 - p0;
    let l1 = d1.norm();
    let n = d1.cross(&d2);
    let twice_area = n.norm();
    if l1 == 0.0 || twice_area == 0.0 {
        return ([(0.0, 0.0); 3], 0.0);
    }
    let x2 = d2.dot(&d1) / l1;
    let y2 = twice_area / l1;
    let z = [(0.0, 0.0), (l1, 0.0), (x2, y2)];
    let e = [0, 1, 2].map(|j| {
        let (a, b) = (z[(j + 2) % 3], z[(j + 1) % 3]);
        (a.0 - b.0, a.1 - b.1)
    });
    (e, 0.5 * twice_area)
}
