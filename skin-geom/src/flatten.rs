//! Least-squares conformal maps (LSCM): the flattening Psi: S* -> M* of thesis Ch. 3.2.
//!
//! Psi is piecewise linear; on each triangle it should be a similarity (angles kept). Writing the
//! triangle's corners in its own plane as complex numbers z_j and their images as U_j = u_j + i v_j,
//! the map is conformal on the triangle iff dU/dz̄ = 0, and for a linear map
//!
//!   dU/dz̄ = (i / 4A) * sum_j e_j U_j,   e_j = z_{j+2} - z_{j+1}   (edge opposite corner j)
//!
//! so LSCM minimises E(U) = sum_T |sum_j e_j U_j|^2 / A_T = U^H H U (Lévy et al. 2002; Desbrun et
//! al. 2002, the parameterization the thesis cites), with the n x n Hermitian matrix
//!
//!   H_jk = sum_T conj(e_j) e_k / A_T.
//!
//! H is zero on similarities; two pinned vertices remove them and leave the Hermitian positive
//! definite system H_ff U_f = -H_fp U_p, solved by a sparse Cholesky factorisation (faer, complex).
//! Working in complex numbers halves the size of the system compared with the usual real 2n x 2n
//! form, and quarters the entries the symbolic analysis walks through.
//!
//! [`Lscm::new`] does everything that depends only on the triangles: a fill-reducing order of the
//! vertices (approximate minimum degree), the sparsity pattern in that order (built directly in
//! compressed-column form, no triplets), each triangle's slots in it, and the symbolic
//! factorisation. [`Lscm::solve`] fills the values for given vertex positions and solves, so a mesh
//! flattened again (after re-calibration, or with taxels switched off) skips the symbolic work.

use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, c64};
use nalgebra::{Point2, Point3};
use std::sync::Arc;

const PINNED: u32 = u32::MAX;

/// A prepared LSCM problem for one edge-connected mesh with two pinned vertices.
#[derive(Debug, Clone)]
pub struct Lscm {
    faces: Vec<[usize; 3]>,
    pins: [usize; 2],
    /// Index among free vertices (in factorisation order), or `PINNED`.
    free: Vec<u32>,
    /// Compressed-column pattern of the upper triangle of H_ff: column k holds the neighbours
    /// j < k, then k itself.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For each face and corner pair (j, k) with free j <= k, the slot of H_jk in `row_idx`.
    slots: Vec<[u32; 9]>,
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
        if let Some(f) = faces.iter().position(|f| f.iter().any(|&v| v >= n)) {
            return Err(Error::Solve(format!(
                "triangle {f} uses a vertex beyond the {n} given"
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
        // Renumber the free vertices in approximate-minimum-degree order, then build the pattern
        // in that order: the matrix is assembled ready for factorisation, never permuted.
        let (start, rows) = vertex_graph(faces, &free, nf);
        let order = amd_order(&start, &rows, nf)?;
        for f in free.iter_mut().filter(|f| **f != PINNED) {
            *f = order[*f as usize] as u32;
        }
        let (start, rows) = vertex_graph(faces, &free, nf);
        // Upper triangle only: in each sorted neighbour list, the entries up to and including the
        // vertex itself.
        let mut col_ptr = Vec::with_capacity(nf + 1);
        let mut row_idx = Vec::with_capacity(rows.len() / 2 + nf);
        col_ptr.push(0);
        for k in 0..nf {
            let list = &rows[start[k]..start[k + 1]];
            let upto = list.partition_point(|&j| j as usize <= k);
            row_idx.extend(list[..upto].iter().map(|&j| j as usize));
            col_ptr.push(row_idx.len());
        }
        let slot = |j: u32, k: u32| -> u32 {
            let (lo, hi) = (col_ptr[k as usize], col_ptr[k as usize + 1]);
            (lo + row_idx[lo..hi].partition_point(|&r| r < j as usize)) as u32
        };
        let slots = faces
            .iter()
            .map(|f| {
                let mut s = [u32::MAX; 9];
                for j in 0..3 {
                    for k in 0..3 {
                        let (fj, fk) = (free[f[j]], free[f[k]]);
                        if fj != PINNED && fk != PINNED && fj <= fk {
                            s[3 * j + k] = slot(fj, fk);
                        }
                    }
                }
                s
            })
            .collect();
        let pattern = SymbolicSparseColMatRef::new_checked(nf, nf, &col_ptr, None, &row_idx);
        // faer picks simplicial or supernodal from the predicted flop count; forcing either was
        // slower at some of the mesh sizes benchmarked (702 to 100,172 vertices).
        let params = CholeskySymbolicParams::default();
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Upper, SymmetricOrdering::Identity, params)
            .map_err(|e| Error::Solve(format!("symbolic factorisation: {e:?}")))?;
        Ok(Lscm {
            faces: faces.to_vec(),
            pins,
            free,
            col_ptr,
            row_idx,
            slots,
            symbolic: Arc::new(symbolic),
        })
    }

    /// The pinned vertices.
    pub fn pins(&self) -> [usize; 2] {
        self.pins
    }

    /// Flattens: returns one 2D point per vertex, with the pinned vertices at `pin_uv`.
    pub fn solve(&self, vertices: &[Point3<f64>], pin_uv: [Point2<f64>; 2]) -> Result<Vec<Point2<f64>>> {
        if vertices.len() != self.free.len() {
            return Err(Error::Solve(format!(
                "{} vertices given for a mesh of {}",
                vertices.len(),
                self.free.len()
            )));
        }
        let nf = self.col_ptr.len() - 1;
        let pinned = |v: usize| {
            let p = if v == self.pins[0] { pin_uv[0] } else { pin_uv[1] };
            c64::new(p.x, p.y)
        };
        let mut values = vec![c64::new(0.0, 0.0); self.row_idx.len()];
        let mut rhs = vec![c64::new(0.0, 0.0); nf];
        for (f, face) in self.faces.iter().enumerate() {
            let (e, area) = local_edges(vertices[face[0]], vertices[face[1]], vertices[face[2]]);
            if !(area > 0.0) {
                return Err(Error::Solve(format!("triangle {f} has zero area")));
            }
            for j in 0..3 {
                let fj = self.free[face[j]];
                if fj == PINNED {
                    continue;
                }
                for k in 0..3 {
                    // H_jk = conj(e_j) e_k / A
                    let h = e[j].conj() * e[k] / area;
                    let fk = self.free[face[k]];
                    if fk == PINNED {
                        rhs[fj as usize] -= h * pinned(face[k]);
                    } else if fj <= fk {
                        values[self.slots[f][3 * j + k] as usize] += h;
                    }
                }
            }
        }
        let pattern = SymbolicSparseColMatRef::new_checked(nf, nf, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &values);
        let symbolic = &*self.symbolic;
        let mut l_values = vec![c64::new(0.0, 0.0); symbolic.len_val()];
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<c64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<c64>(1, Par::Seq));
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
            MatMut::from_column_major_slice_mut(&mut rhs, nf, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        let mut out = Vec::with_capacity(self.free.len());
        for (v, &fv) in self.free.iter().enumerate() {
            out.push(if fv == PINNED {
                let p = pinned(v);
                Point2::new(p.re, p.im)
            } else {
                let u = rhs[fv as usize];
                Point2::new(u.re, u.im)
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
/// normal given by its winding), as complex numbers, and its area.
fn local_edges(p0: Point3<f64>, p1: Point3<f64>, p2: Point3<f64>) -> ([c64; 3], f64) {
    let d1 = p1 - p0;
    let d2 = p2 - p0;
    let l1 = d1.norm();
    let twice_area = d1.cross(&d2).norm();
    if l1 == 0.0 || twice_area == 0.0 {
        return ([c64::new(0.0, 0.0); 3], 0.0);
    }
    let z = [
        c64::new(0.0, 0.0),
        c64::new(l1, 0.0),
        c64::new(d2.dot(&d1) / l1, twice_area / l1),
    ];
    (
        [0, 1, 2].map(|j| z[(j + 2) % 3] - z[(j + 1) % 3]),
        0.5 * twice_area,
    )
}
