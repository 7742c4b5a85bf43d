//! How the faces of a mesh are shared: boundary faces, pairs of elements across interior
//! faces, non-manifold faces and repeated elements. Topology only (no coordinates).
//!
//! Faces (a tet's triangles, a triangle's edges) are matched by a counting sort on their
//! smallest vertex followed by a sort of each small bucket, `O(m)` work in parallel: the
//! same order as a global lexicographic sort of the sorted vertex tuples, without one.

use crate::error::Result;
use crate::options::Options;
use crate::element::Simplex;
use super::group::{group_by, groups_mut};
use rayon::prelude::*;

/// The shared faces of a mesh of `S` elements.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Faces {
    /// Faces of exactly one element, as `[element, opposite corner]`, ascending.
    pub boundary: Vec<[u32; 2]>,
    /// Faces of two (or more) elements: every pair of consecutive elements around a face,
    /// as `[element, opposite corner, element, opposite corner]`, in lexicographic order of
    /// the face's sorted vertex indices (ties by element, then corner).
    pub interior: Vec<[u32; 4]>,
    /// Faces of more than two elements (non-manifold), sorted vertex indices (unused slots
    /// `u32::MAX`), ascending.
    pub nonmanifold: Vec<[u32; 3]>,
}

/// The sorted vertices of the face of `cell` opposite `corner`, padded with `u32::MAX`.
fn face_key(cell: &[u32], corner: usize) -> [u32; 3] {
    let mut face = [u32::MAX; 3];
    for (slot, (_, &v)) in cell.iter().enumerate().filter(|&(c, _)| c != corner).enumerate() {
        face[slot] = v;
    }
    face.sort_unstable();
    face
}

/// Records `(first, rest)` grouped by `first` (`n` groups), every group sorted.
fn sorted_groups<K: Ord + Copy + Default + Send + Sync>(
    n: usize,
    count: usize,
    record: impl Fn(usize) -> (u32, K) + Sync,
    opts: &Options,
) -> Result<(Vec<usize>, Vec<K>)> {
    let (offsets, mut values) = group_by(n, count, record, opts)?;
    groups_mut(&mut values, &offsets).into_par_iter().for_each(|group| group.sort_unstable());
    opts.cancelled()?;
    Ok((offsets, values))
}

/// The boundary, interior and non-manifold faces of `cells` over `n` vertices.
///
/// ```
/// use tetlap::{faces, Options, Tet};
/// // two tets sharing the face (1, 2, 3)
/// let f = faces::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]], 5, &Options::default())?;
/// assert_eq!(f.interior, vec![[0, 0, 1, 0]]);
/// assert_eq!(f.boundary.len(), 6);
/// assert!(f.nonmanifold.is_empty());
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn faces<S: Simplex>(cells: &[S::Cell], n: usize, opts: &Options) -> Result<Faces> {
    let k = S::CORNERS;
    let record = |r: usize| {
        let (t, c) = (r / k, r % k);
        let key = face_key(cells[t].as_ref(), c);
        (key[0], (key[1], key[2], r as u32))
    };
    let (offsets, sorted) = opts.install(|| sorted_groups(n, k * cells.len(), record, opts))?;
    // scan every bucket for runs of equal faces
    type Found = (Vec<[u32; 2]>, Vec<[u32; 4]>, Vec<[u32; 3]>);
    let per_bucket: Vec<Found> = (0..n)
        .into_par_iter()
        .map(|v| {
            let group = &sorted[offsets[v]..offsets[v + 1]];
            let (mut boundary, mut interior, mut nonmanifold) = (vec![], vec![], vec![]);
            let mut start = 0;
            while start < group.len() {
                let (a, b, _) = group[start];
                let end = start + group[start..].iter().take_while(|g| (g.0, g.1) == (a, b)).count();
                let item = |q: usize| [group[q].2 / k as u32, group[q].2 % k as u32];
                match end - start {
                    1 => boundary.push(item(start)),
                    count => {
                        for q in start..end - 1 {
                            let (x, y) = (item(q), item(q + 1));
                            interior.push([x[0], x[1], y[0], y[1]]);
                        }
                        if count > 2 {
                            nonmanifold.push([v as u32, a, b]);
                        }
                    }
                }
                start = end;
            }
            (boundary, interior, nonmanifold)
        })
        .collect();
    let mut faces = Faces::default();
    for (b, i, m) in per_bucket {
        faces.boundary.extend(b);
        faces.interior.extend(i);
        faces.nonmanifold.extend(m);
    }
    faces.boundary.par_sort_unstable();
    Ok(faces)
}

/// Whether each element has a face (a tet's triangle, a triangle's edge) that no other
/// element shares: a boundary face (the [`Faces::boundary`] of [`faces`], per element).
///
/// ```
/// use tetlap::{boundary_elements, Options, Tet};
/// // two tets sharing the face (1, 2, 3): both have boundary faces
/// let b = boundary_elements::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]], 5, &Options::default())?;
/// assert_eq!(b, vec![true, true]);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn boundary_elements<S: Simplex>(cells: &[S::Cell], n: usize, opts: &Options) -> Result<Vec<bool>> {
    let mut boundary = vec![false; cells.len()];
    for &[t, _] in &faces::<S>(cells, n, opts)?.boundary {
        boundary[t as usize] = true;
    }
    Ok(boundary)
}

/// Whether each element repeats the vertex set of an element with a lower index.
///
/// ```
/// let dup = tetlap::duplicate_elements::<tetlap::Tet>(&[[0, 1, 2, 3], [1, 0, 3, 2], [0, 1, 2, 4]], 5,
///                                                     &tetlap::Options::default())?;
/// assert_eq!(dup, vec![false, true, false]);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn duplicate_elements<S: Simplex>(cells: &[S::Cell], n: usize, opts: &Options) -> Result<Vec<bool>> {
    let record = |t: usize| {
        let mut key = [u32::MAX; 4];
        for (slot, &v) in key.iter_mut().zip(cells[t].as_ref()) {
            *slot = v;
        }
        key.sort_unstable();
        (key[0], (key[1], key[2], key[3], t as u32))
    };
    let (offsets, sorted) = opts.install(|| sorted_groups(n, cells.len(), record, opts))?;
    let mut duplicate = vec![false; cells.len()];
    for v in 0..n {
        let group = &sorted[offsets[v]..offsets[v + 1]];
        for pair in group.windows(2) {
            if (pair[0].0, pair[0].1, pair[0].2) == (pair[1].0, pair[1].1, pair[1].2) {
                duplicate[pair[1].3 as usize] = true;
            }
        }
    }
    Ok(duplicate)
}

/// The unique edges `(i, j)`, `i < j`, of `cells` over `n` vertices, sorted.
///
/// ```
/// let edges = tetlap::edges::<tetlap::Tri>(&[[0, 1, 2], [2, 1, 3]], 4, &tetlap::Options::default())?;
/// assert_eq!(edges, vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn edges<S: Simplex>(cells: &[S::Cell], n: usize, opts: &Options) -> Result<Vec<[u32; 2]>> {
    let pairs = S::EDGES.len();
    let record = |r: usize| {
        let (a, b) = S::EDGES[r % pairs];
        let cell = cells[r / pairs].as_ref();
        let (i, j) = (cell[a].min(cell[b]), cell[a].max(cell[b]));
        (i, j)
    };
    let (offsets, sorted) = opts.install(|| sorted_groups(n, pairs * cells.len(), record, opts))?;
    let per_vertex: Vec<Vec<[u32; 2]>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut group: Vec<[u32; 2]> = sorted[offsets[i]..offsets[i + 1]].iter().map(|&j| [i as u32, j]).collect();
            group.dedup();
            group
        })
        .collect();
    Ok(per_vertex.concat())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::{Tet, Tri};

    #[test]
    fn a_closed_surface_has_no_boundary_and_a_fin_is_nonmanifold() {
        let opts = Options::default();
        let closed = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        let f = faces::<Tri>(&closed, 4, &opts).unwrap();
        assert!(f.boundary.is_empty());
        assert_eq!(f.interior.len(), 6);
        assert!(f.nonmanifold.is_empty());
        // three triangles on the edge (0, 1)
        let fin = [[0, 1, 2], [0, 1, 3], [1, 0, 4]];
        let f = faces::<Tri>(&fin, 5, &opts).unwrap();
        assert_eq!(f.nonmanifold, vec![[0, 1, u32::MAX]]);
        assert_eq!(f.interior, vec![[0, 2, 1, 2], [1, 2, 2, 2]]);
        assert_eq!(f.boundary.len(), 6);
    }

    #[test]
    fn interior_faces_come_in_lexicographic_order() {
        // a 2 x 1 x 1 box of 12 Kuhn tets, numbered so that faces interleave
        let cells = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
        let f = faces::<Tet>(&cells, 8, &Options::default()).unwrap();
        let key = |p: &[u32; 4]| face_key(&cells[p[0] as usize], p[1] as usize);
        let keys: Vec<_> = f.interior.iter().map(key).collect();
        assert!(keys.windows(2).all(|w| w[0] <= w[1]), "{keys:?}");
        assert_eq!(f.interior.len(), 6);
        assert_eq!(f.boundary.len(), 12);
        for p in &f.interior {
            assert_eq!(key(p), face_key(&cells[p[2] as usize], p[3] as usize));
        }
    }

    #[test]
    fn boundary_elements_of_tets_and_triangles() {
        let opts = Options::default();
        // two tets sharing the face (1, 2, 3): every tet has boundary faces
        assert_eq!(boundary_elements::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]], 5, &opts).unwrap(), [true, true]);
        // a fan of 4 triangles around vertex 0: each has an edge on the rim
        let fan = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        assert_eq!(boundary_elements::<Tri>(&fan, 5, &opts).unwrap(), [true; 4]);
        // a closed tetrahedron surface: no boundary
        let closed = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        assert_eq!(boundary_elements::<Tri>(&closed, 4, &opts).unwrap(), [false; 4]);
    }
}
