//! The mass contribution of one tet that needs no dual: barycentric (Eq. 3).

use super::volume;
use crate::element::frame::LocalTet;

/// Barycentric (lumped) mass of one tet: `Vol / 4` at each corner (paper Eq. 3).
///
/// ```
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// assert_eq!(tetlap::element::tet::barycentric_mass(&t), [1.0 / 24.0; 4]);
/// ```
pub fn barycentric_mass(t: &LocalTet) -> [f64; 4] {
    [volume(t) / 4.0; 4]
}
