//! The dual vertices of every tet as points in the ambient space, with the dual edges
//! through the tets' faces: the geometry of the orthogonal dual that finite-volume codes
//! use (cell centres, face centres, transmissibility lengths).

use crate::element::tet::{is_degenerate, power_centres, power_centres_precise, well_shaped};
use crate::element::Tet;
use crate::error::{Error, Result};
use crate::mesh::MeshView;
use crate::options::Options;
use rayon::prelude::*;

/// Elements per work item and per poll of the cancel flag.
const CHUNK: usize = super::CHUNK;

/// What one tet says about the dual (besides its points): see [`DualCentres`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TetDual {
    /// The barycentric coordinates of the tet's centre.
    pub barycentric: [f64; 4],
    /// The signed distance of the centre from the face opposite each corner, positive on
    /// the side of that corner (the tet's own side).
    pub heights: [f64; 4],
    /// The area of the face opposite each corner.
    pub areas: [f64; 4],
    /// The tet's signed volume: `det[x1 - x0, x2 - x0, x3 - x0] / 6` for a tet in R^3
    /// (its sign is the tet's orientation); for an immersed tet (`dim > 3`) its volume,
    /// positive (no orientation of R^d is at hand).
    pub volume: f64,
}

/// The centres of every tet of a mesh and of its faces, and the dual edges through them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DualCentres {
    /// `(m, 5, dim)` row-major: for every tet its centre, then the centres of its faces
    /// opposite corners 0, 1, 2, 3 (each in the face's plane, where the face's dual edge
    /// crosses it), in the ambient space.
    pub points: Vec<f64>,
    /// Per tet: its centre's barycentric coordinates, the dual edges' parts, the face
    /// areas and its volume.
    pub tets: Vec<TetDual>,
}

/// The centres of the dual of `mesh`: for every tet its power centre (the circumcentre
/// without vertex weights; with the mesh's vertex weights the weighted circumcentre, where
/// the power `|c - x_i|^2 - w_i` is equal at the four corners) and the centres of its four
/// faces, with the signed distances of the tet's centre from its faces and their areas
/// ([`crate::element::tet::power_centres`]), under the accuracy rule of
/// [`crate::element`] (the same closed forms and the same precise path as the dual
/// Laplacian).
///
/// The dual edge of an interior face is the segment between its two tets' centres; it
/// crosses the face's plane at right angles at the face's centre, and its signed length is
/// the sum of the two tets' heights at that face. A tet of zero volume is
/// [`Error::Degenerate`], one whose values leave the `f64` range
/// [`Error::NonFiniteResult`] (the lowest index first), whatever the
/// [`crate::Degenerate`] policy: a centre cannot be skipped. Bitwise identical for any
/// thread count.
///
/// ```
/// use tetlap::{dual_centres, Options, TetView};
/// let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.];
/// let d = dual_centres(&TetView::new(&points, 3, &[[0, 1, 2, 3]])?, &Options::default())?;
/// assert_eq!(&d.points[..3], &[0.5, 0.5, 0.5]); // the circumcentre of the corner tet
/// assert_eq!(d.tets[0].heights[3], 0.5); // its distance from the face z = 0
/// assert!((d.tets[0].volume - 1.0 / 6.0).abs() < 1e-16);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn dual_centres(mesh: &MeshView<Tet>, opts: &Options) -> Result<DualCentres> {
    mesh.plain("dual_centres")?;
    let (points, dim, cells) = (mesh.points(), mesh.dim(), mesh.cells());
    let width = 5 * dim;
    let mut out = DualCentres { points: vec![0.0; cells.len() * width], tets: vec![TetDual::default(); cells.len()] };
    let faults: Vec<Result<Option<Error>>> = opts.install(|| {
        Ok(out
            .points
            .par_chunks_mut(CHUNK * width)
            .zip(out.tets.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (p, tets))| {
                opts.cancelled()?;
                let mut scratch = vec![0.0; if dim > 3 { 3 * dim } else { 0 }];
                for (k, (p, tet)) in p.chunks_exact_mut(width).zip(tets.iter_mut()).enumerate() {
                    let element = c * CHUNK + k;
                    let cell = cells[element];
                    let x = cell.map(|v| &points[v as usize * dim..][..dim]);
                    let local = crate::element::local_tet(x, &mut scratch);
                    if is_degenerate(&local) {
                        return Ok(Some(Error::Degenerate { element }));
                    }
                    let weights = mesh.vertex_weights().map(|w| cell.map(|v| w[v as usize]));
                    let centres = match well_shaped(&local) {
                        true => power_centres(&local, weights.as_ref()),
                        false => power_centres_precise(x, &local, weights.as_ref()),
                    };
                    let s = local.scale;
                    let volume = local.det / 6.0 * s * s * s;
                    *tet = TetDual { barycentric: centres.barycentric, heights: centres.heights, areas: centres.areas, volume };
                    let offsets = [centres.centre, centres.faces[0], centres.faces[1], centres.faces[2], centres.faces[3]];
                    for (row, offset) in p.chunks_exact_mut(dim).zip(offsets) {
                        ambient(x[0], offset, &scratch, row);
                    }
                    let values = [&tet.barycentric[..], &tet.heights, &tet.areas, p];
                    if !volume.is_normal() || !values.iter().all(|v| v.iter().all(|x| x.is_finite())) {
                        return Ok(Some(Error::NonFiniteResult { element }));
                    }
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
    Ok(out)
}

/// `origin + offset` in R^d: `offset` along the axes of the tet's frame (the caller's axes
/// in R^3; for `d > 3` the orthonormal rows `q_0, q_1, q_2` that
/// [`crate::local_tet`] leaves in `basis`).
fn ambient(origin: &[f64], offset: [f64; 3], basis: &[f64], out: &mut [f64]) {
    let d = origin.len();
    for (c, o) in out.iter_mut().enumerate() {
        let along = if d == 3 { offset[c] } else { (0..3).map(|j| offset[j] * basis[j * d + c]).sum() };
        *o = origin[c] + along;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TetView;

    #[test]
    fn an_immersed_tet_has_the_centres_of_its_copy_in_r3() {
        // the tet in R^3 and rotated into R^5 (x0 -> (0.6 x0, 0.8 x0) in axes 0 and 3), shifted
        let x = [[0.1, 0.2, 0.3], [1.3, 0.1, -0.2], [0.2, 1.1, 0.4], [0.3, 0.1, 0.9]];
        let flat: Vec<f64> = x.iter().flatten().copied().collect();
        let y: Vec<f64> = x.iter().flat_map(|p| [0.6 * p[0], p[1], p[2], 0.8 * p[0], 7.0]).collect();
        let opts = Options::default();
        let a = dual_centres(&TetView::new(&flat, 3, &[[0, 1, 2, 3]]).unwrap(), &opts).unwrap();
        let b = dual_centres(&TetView::new(&y, 5, &[[0, 1, 2, 3]]).unwrap(), &opts).unwrap();
        for (p, q) in a.points.chunks(3).zip(b.points.chunks(5)) {
            let mapped = [0.6 * p[0], p[1], p[2], 0.8 * p[0], 7.0];
            assert!(mapped.iter().zip(q).all(|(u, v)| (u - v).abs() < 1e-13), "{p:?} {q:?}");
        }
        let (s, t) = (a.tets[0], b.tets[0]);
        assert!(s.heights.iter().zip(&t.heights).all(|(u, v)| (u - v).abs() < 1e-13));
        assert!(s.areas.iter().zip(&t.areas).all(|(u, v)| (u - v).abs() < 1e-13));
        assert!((s.volume.abs() - t.volume).abs() < 1e-15 && t.volume > 0.0);
    }

    #[test]
    fn a_flat_tet_is_named() {
        let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 0.];
        let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3], [0, 1, 2, 4]]).unwrap();
        assert_eq!(dual_centres(&mesh, &Options::default()), Err(Error::Degenerate { element: 1 }));
    }
}
