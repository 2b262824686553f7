//! Small vector maths on the plain arrays that requests, reports and the mappings carry
//! (`[f64; 3]`, row-major 3×3 and 4×4), computed by glam: one definition of each, written so
//! that results are bit-for-bit those of the component formulas (a normalisation divides by
//! the length, as the mappings' references do, rather than multiplying by its reciprocal).

use glam::DVec3;

/// The 3×3 identity (a rotation that does nothing, the identity view).
pub const IDENTITY3: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The 4×4 identity (a modelview that does nothing).
pub const IDENTITY4: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    DVec3::from_array(a).dot(DVec3::from_array(b))
}

#[inline]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    DVec3::from_array(a).cross(DVec3::from_array(b)).to_array()
}

#[inline]
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    (DVec3::from_array(a) - DVec3::from_array(b)).to_array()
}

/// The Euclidean length.
#[inline]
pub fn norm(a: [f64; 3]) -> f64 {
    DVec3::from_array(a).length()
}

/// `a` divided by its length (NaN for a zero vector, as the division gives).
#[inline]
pub fn normalize(a: [f64; 3]) -> [f64; 3] {
    let v = DVec3::from_array(a);
    (v / v.length()).to_array()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bit_for_bit_the_component_formulas() {
        let a = [0.3, -1.7, 2.9e-3];
        let b = [-4.1, 0.25, 7.0];
        assert_eq!(dot(a, b), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        assert_eq!(
            cross(a, b),
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        );
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        assert_eq!(norm(a), l);
        assert_eq!(normalize(a), a.map(|v| v / l));
        assert_eq!(sub(a, b), [a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
    }
}
