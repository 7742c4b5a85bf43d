//! The internal order: vertices along a space-filling (Morton) curve, elements grouped by
//! their first vertex in that order. Every driver works in this order and writes its
//! output in the user's numbering.
//!
//! Meshes come in any order: TetGen, TetWild or `scipy.spatial.Delaunay` hand over vertices
//! and elements with little memory locality, and a row of the Laplacian then gathers its
//! elements from all over memory. In the internal order the elements around a vertex, and
//! the vertices of an element, are close in memory whatever the input order, so the cost
//! of an assembly no longer depends on it.
//!
//! The order only decides where things are in memory, never how they are summed: every sum
//! of the crate still runs over the elements around a vertex in ascending *user* element
//! index, so the output is bitwise the same as with no reordering, for any thread count,
//! and equal between a cached [`crate::CachedMesh`] (whose order is fixed when it is built)
//! and a fresh assembly of its moved geometry.
//!
//! Cost: a sort of the `n` vertex keys and a counting sort of the `m` elements (two
//! parallel passes): `O(n log n + m)`.

use crate::error::Result;
use crate::mesh::MeshView;
use crate::options::Options;
use crate::element::Simplex;
use crate::topology::group::{group_u32, Incidence};
use rayon::prelude::*;

/// Bits per axis of the Morton code.
const BITS: u32 = 21;

/// A mesh in the internal order, with the maps back to the user's numbering.
#[derive(Debug, Clone)]
pub(crate) struct Layout<S: Simplex> {
    /// Internal vertex -> user vertex.
    pub vertex_of: Vec<u32>,
    /// User vertex -> internal vertex.
    pub rank: Vec<u32>,
    /// Internal element -> user element.
    pub element_of: Vec<u32>,
    /// User element -> internal element.
    pub internal_of: Vec<u32>,
    /// The elements, in internal order and numbering, each with its user's corner order.
    pub cells: Vec<S::Cell>,
    /// The coordinates in internal order, row-major.
    pub points: Vec<f64>,
    /// The vertex weights in internal order.
    pub weights: Option<Vec<f64>>,
    pub dim: usize,
}

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    (x | x << 2) & 0x1249249249249249
}

/// The Morton code of every vertex over the bounding box of the first three coordinates.
fn morton_codes(points: &[f64], dim: usize) -> Vec<u64> {
    let axes = dim.min(3);
    let (lo, hi) = points
        .par_chunks_exact(dim)
        .fold(
            || ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
            |(mut lo, mut hi), p| {
                for a in 0..axes {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
                (lo, hi)
            },
        )
        .reduce(
            || ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
            |(l1, h1), (l2, h2)| (std::array::from_fn(|a| l1[a].min(l2[a])), std::array::from_fn(|a| h1[a].max(h2[a]))),
        );
    let cells = ((1u64 << BITS) - 1) as f64;
    // (p - lo) / (hi - lo) computed without overflow for huge boxes
    let scale: [f64; 3] = std::array::from_fn(|a| {
        let width = hi[a] / 2.0 - lo[a] / 2.0;
        if a < axes && width > 0.0 { cells / 2.0 / width } else { 0.0 }
    });
    points
        .par_chunks_exact(dim)
        .map(|p| {
            let mut code = 0;
            for a in 0..axes {
                let q = ((p[a] / 2.0 - lo[a] / 2.0) * scale[a]).clamp(0.0, cells) as u64;
                code |= spread(q) << (2 - a);
            }
            code
        })
        .collect()
}


impl<S: Simplex> Layout<S> {
    /// The internal order of a validated mesh. Polls the cancel flag.
    pub fn new(mesh: &MeshView<S>, opts: &Options) -> Result<Self> {
        Ok(Self::ordered(mesh, opts, false)?.0)
    }

    /// [`Layout::new`] with the element-corners `K t + c` (internal `t`) around every
    /// internal vertex, in ascending user element index (as
    /// [`crate::assembly::pattern::corner_incidence`] makes them): both from the mesh's
    /// cells renumbered once.
    pub fn with_corners(mesh: &MeshView<S>, opts: &Options) -> Result<(Self, Incidence)> {
        let (layout, corners) = Self::ordered(mesh, opts, true)?;
        Ok((layout, corners.expect("asked for")))
    }

    fn ordered(mesh: &MeshView<S>, opts: &Options, with_corners: bool) -> Result<(Self, Option<Incidence>)> {
        let (points, dim, n) = (mesh.points(), mesh.dim(), mesh.n_vertices());
        let mut keyed: Vec<(u64, u32)> = morton_codes(points, dim).into_iter().zip(0..n as u32).collect();
        keyed.par_sort_unstable();
        let vertex_of: Vec<u32> = keyed.into_iter().map(|(_, v)| v).collect();
        opts.cancelled()?;
        let mut rank = vec![0u32; n];
        for (r, &v) in vertex_of.iter().enumerate() {
            rank[v as usize] = r as u32;
        }
        // the cells in internal numbering, in the user's order (a temporary)
        let ranked: Vec<S::Cell> = mesh
            .cells()
            .par_iter()
            .map(|cell| {
                let mut cell = *cell;
                for v in cell.as_mut() {
                    *v = rank[*v as usize];
                }
                cell
            })
            .collect();
        opts.cancelled()?;
        // elements grouped by their smallest internal vertex (a stable counting sort)
        let first = |t: usize| (*ranked[t].as_ref().iter().min().expect("a cell has corners"), t as u32);
        let element_of = group_u32(n, ranked.len(), first, opts)?.1;
        let mut internal_of = vec![0u32; element_of.len()];
        for (t, &u) in element_of.iter().enumerate() {
            internal_of[u as usize] = t as u32;
        }
        let corners = with_corners
            .then(|| {
                let k = S::CORNERS;
                let corner = |r: usize| {
                    let (e, c) = (r / k, r % k);
                    (ranked[e].as_ref()[c], k as u32 * internal_of[e] + c as u32)
                };
                group_u32(n, k * ranked.len(), corner, opts).map(|(offsets, items)| Incidence { offsets, items })
            })
            .transpose()?;
        let cells = element_of.par_iter().map(|&t| ranked[t as usize]).collect();
        drop(ranked);
        let internal_points = vertex_of.par_iter().flat_map_iter(|&v| &points[v as usize * dim..][..dim]).copied().collect();
        let weights = mesh.vertex_weights().map(|w| vertex_of.par_iter().map(|&v| w[v as usize]).collect());
        opts.cancelled()?;
        Ok((Layout { vertex_of, rank, element_of, internal_of, cells, points: internal_points, weights, dim }, corners))
    }

    /// The internal mesh (trusted: it was validated in the user's order).
    pub fn mesh(&self) -> MeshView<'_, S> {
        MeshView::trusted(&self.points, self.dim, &self.cells, self.weights.as_deref())
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertex_of.len()
    }

    /// Values per internal vertex rearranged into the user's order.
    pub fn to_user_vertices(&self, internal: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; internal.len()];
        for (&v, &x) in self.vertex_of.iter().zip(internal) {
            out[v as usize] = x;
        }
        out
    }
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Tet;

    #[test]
    fn morton_bits_interleave() {
        assert_eq!(spread(0b1), 0b1);
        assert_eq!(spread(0b11), 0b1001);
        assert_eq!(spread((1 << 21) - 1).count_ones(), 21);
    }

    #[test]
    fn vertices_follow_the_curve_and_elements_their_first_vertex() {
        // a 3 x 3 x 3 grid of points, numbered backwards, and some tets
        let points: Vec<f64> = (0..27).rev().flat_map(|i| [(i % 3) as f64, (i / 3 % 3) as f64, (i / 9) as f64]).collect();
        let cells = vec![[26u32, 25, 23, 17], [13, 14, 16, 22], [25, 22, 23, 13], [0, 1, 3, 9]];
        let layout = Layout::<Tet>::new(&MeshView::new(&points, 3, &cells).unwrap(), &Options::default()).unwrap();
        // the origin (user vertex 26) comes first, the far corner (user 0) last
        assert_eq!(layout.vertex_of[0], 26);
        assert_eq!(layout.vertex_of[26], 0);
        for (v, &u) in layout.vertex_of.iter().enumerate() {
            assert_eq!(layout.rank[u as usize] as usize, v);
            assert_eq!(&layout.points[v * 3..][..3], &points[u as usize * 3..][..3]);
        }
        // elements are grouped by their smallest internal vertex, stable within a group
        let firsts: Vec<u32> = layout.cells.iter().map(|c| *c.iter().min().unwrap()).collect();
        assert!(firsts.windows(2).all(|w| w[0] <= w[1]), "{firsts:?}");
        for (t, &u) in layout.element_of.iter().enumerate() {
            assert_eq!(layout.internal_of[u as usize] as usize, t);
            assert_eq!(layout.cells[t].map(|v| layout.vertex_of[v as usize]), cells[u as usize]);
        }
    }
}
