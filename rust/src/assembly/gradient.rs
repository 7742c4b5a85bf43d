//! The P1 gradients of every element: the values of the gradient operator `G` (the
//! sparse matrix itself is built by the Python layer from them).

use crate::element::gradient::{tet_gradients, tri_gradients};
use crate::element::Simplex;
use crate::error::{Error, Result};
use crate::mesh::MeshView;
use crate::options::{Degenerate, Options};
use rayon::prelude::*;

/// Elements per work item and per poll of the cancel flag.
const CHUNK: usize = super::CHUNK;

/// The gradients of the barycentric coordinates of every element, `(m, K, dim)` row-major
/// in the ambient space (`K` = [`Simplex::CORNERS`]), and the elements' unsigned measures
/// (volumes of tets, areas of triangles), `(m,)`.
///
/// `grad f` on element `t` is `sum_a f[cell[a]] g[t][a]`; `-sum_t vol_t g[t][a] . g[t][b]`
/// is the primal Laplacian's `L[i, j]`. A zero-measure element is
/// [`Error::Degenerate`], one whose values leave the `f64` range [`Error::NonFiniteResult`]
/// (the first by index); with [`Degenerate::Skip`] both get zero gradients and measure 0.
/// Bitwise identical for any thread count.
pub fn gradients<S: Simplex>(mesh: &MeshView<S>, opts: &Options) -> Result<(Vec<f64>, Vec<f64>)> {
    let (points, dim, cells) = (mesh.points(), mesh.dim(), mesh.cells());
    let width = S::CORNERS * dim;
    let mut g = vec![0.0; cells.len() * width];
    let mut vol = vec![0.0; cells.len()];
    let faults: Vec<Result<Option<Error>>> = super::install::<S, _>(opts, || {
        Ok(g.par_chunks_mut(CHUNK * width)
            .zip(vol.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (g, vol))| {
                opts.cancelled()?;
                let mut scratch = vec![0.0; 3 * dim];
                for (k, (g, vol)) in g.chunks_exact_mut(width).zip(vol.iter_mut()).enumerate() {
                    let x: Vec<&[f64]> = cells[c * CHUNK + k].as_ref().iter().map(|&v| &points[v as usize * dim..][..dim]).collect();
                    *vol = match x[..] {
                        [a, b, c, d] => tet_gradients([a, b, c, d], &mut scratch, g),
                        [a, b, c] => tri_gradients([a, b, c], g),
                        _ => unreachable!("elements have 3 or 4 corners"),
                    };
                    let element = c * CHUNK + k;
                    let fault = if *vol == 0.0 {
                        Error::Degenerate { element }
                    } else if !(vol.is_finite() && g.iter().all(|v| v.is_finite())) {
                        Error::NonFiniteResult { element }
                    } else {
                        continue;
                    };
                    if opts.degenerate == Degenerate::Raise {
                        return Ok(Some(fault));
                    }
                    g.fill(0.0);
                    *vol = 0.0;
                }
                Ok(None)
            })
            .collect())
    })?;
    // the first chunk's fault is the one of the lowest element
    for fault in faults {
        if let Some(e) = fault? {
            return Err(e);
        }
    }
    Ok((g, vol))
}
