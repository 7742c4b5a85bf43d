//! Geometry of a tet mesh as a quality report: the per-tet quality of every tet and the
//! local Delaunay test of every interior face (the kernels are in [`crate::element::tet`]).

use crate::element::tet::{inside_circumsphere, quality_from_frame, tet_quality, tet_quality_exact, TetQuality};
use crate::error::Result;
use crate::mesh::TetView;
use crate::options::Options;
use crate::assembly::CHUNK;
use rayon::prelude::*;

/// The quality of every tet of `mesh`, in its order.
pub fn quality(mesh: &TetView, opts: &Options) -> Result<Vec<TetQuality>> {
    let signed = mesh.dim() == 3;
    let mut out = vec![TetQuality::default(); mesh.n_elements()];
    opts.install(|| {
        out.par_chunks_mut(CHUNK).enumerate().try_for_each_init(
            || vec![0.0; 3 * mesh.dim()],
            |scratch, (c, chunk)| {
                opts.cancelled()?;
                for (k, slot) in chunk.iter_mut().enumerate() {
                    let t = c * CHUNK + k;
                    let local = mesh.local(t, scratch);
                    *slot = if !signed || quality_from_frame(&local) {
                        tet_quality(&local, signed)
                    } else {
                        let corner = |v: u32| &mesh.points()[v as usize * 3..][..3];
                        tet_quality_exact(mesh.cells()[t].map(corner), signed)
                    };
                }
                Ok(())
            },
        )
    })?;
    Ok(out)
}

/// For every interior face `[t1, c1, t2, c2]` (see [`crate::Faces`]): whether the vertex of
/// `t2` opposite the face lies strictly inside the circumsphere of `t1` (R^3 only; in exact
/// arithmetic the test is symmetric in the two tets).
pub fn non_delaunay_faces(mesh: &TetView, interior: &[[u32; 4]], rtol: f64, opts: &Options) -> Result<Vec<bool>> {
    let point = |v: u32| -> [f64; 3] {
        let p = &mesh.points()[v as usize * mesh.dim()..];
        [p[0], p[1], p[2]]
    };
    let cells = mesh.cells();
    let m = cells.len() as u32;
    let bad = |f: &[u32; 4]| f[0] >= m || f[2] >= m || f[1] >= 4 || f[3] >= 4;
    if let Some(k) = crate::threads::position_first(interior, |_, f| bad(f))? {
        return Err(crate::Error::Shape {
            what: format!("interior face {k} must hold [element, corner, element, corner] of this mesh, got {:?}", interior[k]),
        });
    }
    let mut out = vec![false; interior.len()];
    opts.install(|| {
        out.par_chunks_mut(CHUNK).zip(interior.par_chunks(CHUNK)).try_for_each(|(flags, faces)| {
            opts.cancelled()?;
            for (flag, &[t1, _, t2, c2]) in flags.iter_mut().zip(faces) {
                let x = cells[t1 as usize].map(point);
                *flag = inside_circumsphere(x, point(cells[t2 as usize][c2 as usize]), rtol);
            }
            Ok(())
        })
    })?;
    Ok(out)
}

