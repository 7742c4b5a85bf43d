//! Mass contributions of one tet that need no dual: barycentric (Eq. 3) and consistent FEM.

use super::volume;
use crate::geometry::LocalTet;

/// Barycentric (lumped) mass of one tet: `Vol / 4` at each corner (paper Eq. 3).
///
/// ```
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// assert_eq!(tetlap::local::barycentric_mass(&t), [1.0 / 24.0; 4]);
/// ```
pub fn barycentric_mass(t: &LocalTet) -> [f64; 4] {
    [volume(t) / 4.0; 4]
}

/// Consistent P1 mass of one tet, `M_ab = Vol (1 + delta_ab) / 20`, as
/// `(off_diagonal, diagonal) = (Vol / 20, Vol / 10)`.
pub fn fem_mass(t: &LocalTet) -> (f64, f64) {
    let v = volume(t);
    (v / 20.0, v / 10.0)
}
