//! Views: which way the eye of a map looks, as a rotation from the eye frame to the world.
//!
//! A sphere map (and any map made "for a view") is defined in the eye frame of a viewer looking
//! down its own −Z with +Y up.  A view places that frame in the right-handed Y-up world:
//!
//! * **look / up** — world vectors for the eye's −Z and (approximately) +Y, like `gluLookAt`'s
//!   `center − eye` and `up`: `Z = −look/‖look‖`, `X = up × Z` normalized, `Y = Z × X`.
//! * **yaw / pitch / roll** (degrees) — `R = Ry(yaw)·Rx(pitch)·Rz(roll)`, right-hand rule about
//!   world +Y, then the eye's +X, then its +Z: yaw 90 looks along −X (turned left), pitch 90
//!   looks up (+Y), roll 90 tips the eye's up towards −X (counter-clockwise as seen).
//!
//! The returned matrix is row-major with the eye axes as columns: `world = R · eye`.

use crate::base::error::{Error, Result};
use crate::base::vec::{cross, norm};

pub type Mat3 = [[f64; 3]; 3];

/// The identity view: looking down world −Z with +Y up.
pub use crate::base::vec::IDENTITY3 as IDENTITY;

fn columns(x: [f64; 3], y: [f64; 3], z: [f64; 3]) -> Mat3 {
    [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
}

/// The view whose eye looks along `look` with `up` as its up direction.
pub fn look_up(look: [f64; 3], up: [f64; 3]) -> Result<Mat3> {
    let ll = norm(look);
    if !(ll > 0.0 && ll.is_finite()) {
        return Err(Error::param("look", "must be a finite, non-zero vector"));
    }
    if !(norm(up) > 0.0 && norm(up).is_finite()) {
        return Err(Error::param("up", "must be a finite, non-zero vector"));
    }
    let z = [-look[0] / ll, -look[1] / ll, -look[2] / ll];
    let x = cross(up, z);
    let lx = norm(x);
    if !(lx > 1e-9 * norm(up)) {
        return Err(Error::param(
            "up",
            "is parallel to look; choose another up vector",
        ));
    }
    let x = [x[0] / lx, x[1] / lx, x[2] / lx];
    let y = cross(z, x);
    Ok(columns(x, y, z))
}

/// The view turned by yaw, pitch and roll (degrees) from the identity view.
pub fn yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64) -> Result<Mat3> {
    for (v, n) in [(yaw, "yaw"), (pitch, "pitch"), (roll, "roll")] {
        if !v.is_finite() {
            return Err(Error::param(n, "must be a finite number of degrees"));
        }
    }
    let (sy, cy) = yaw.to_radians().sin_cos();
    let (sp, cp) = pitch.to_radians().sin_cos();
    let (sr, cr) = roll.to_radians().sin_cos();
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rx = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
    let rz = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
    Ok(mul(&mul(&ry, &rx), &rz))
}

/// Matrix product.
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Transpose (the inverse of a rotation).
pub fn transpose(a: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = a[j][i];
        }
    }
    r
}

/// The rotation that takes directions in the destination's eye frame to the source's frame,
/// when the destination is made for view `dst` and the source for view `src`.
pub fn between(src: &Mat3, dst: &Mat3) -> Mat3 {
    mul(&transpose(src), dst)
}

/// The rotation a conversion applies (destination eye frame → source frame) from the options
/// users give: the output's view as `look`/`up` or yaw/pitch/roll (not both; neither = the
/// identity view), and the input's view as `src_look`/`src_up`.  `up` defaults to +Y.
pub fn conversion_rotation(
    look: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    yaw_pitch_roll_deg: Option<[f64; 3]>,
    src_look: Option<[f64; 3]>,
    src_up: Option<[f64; 3]>,
) -> Result<Mat3> {
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    let dst = output_view(look, up, yaw_pitch_roll_deg)?;
    let src = match src_look {
        Some(l) => look_up(l, src_up.unwrap_or(Y))?,
        None => IDENTITY,
    };
    Ok(between(&src, &dst))
}

/// The view of a map made for `look`/`up` or yaw/pitch/roll (neither: the identity), as the
/// options of [`conversion_rotation`] give it.
pub fn output_view(
    look: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    yaw_pitch_roll_deg: Option<[f64; 3]>,
) -> Result<Mat3> {
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    Ok(match (look, yaw_pitch_roll_deg) {
        (Some(_), Some(_)) => {
            return Err(Error::param(
                "look",
                "give look/up or yaw/pitch/roll, not both",
            ))
        }
        (Some(l), None) => look_up(l, up.unwrap_or(Y))?,
        (None, Some([a, b, c])) => yaw_pitch_roll(a, b, c)?,
        (None, None) if up.is_some() => {
            return Err(Error::param("up", "needs look (the direction of the view)"))
        }
        (None, None) => IDENTITY,
    })
}

/// A view as the `look` and `up` world vectors that [`look_up`] turns back into it (the eye's
/// −Z and +Y columns); `None` for the identity view (to rounding).
pub fn as_look_up(view: &Mat3) -> Option<([f64; 3], [f64; 3])> {
    let identity = (0..3).all(|i| (0..3).all(|j| (view[i][j] - IDENTITY[i][j]).abs() < 1e-12));
    (!identity).then(|| {
        (
            [0, 1, 2].map(|i| -view[i][2]),
            [0, 1, 2].map(|i| view[i][1]),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: &Mat3, d: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|i| m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2])
    }
    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    #[test]
    fn pinned_views() {
        let fwd = [0.0, 0.0, -1.0];
        let m = look_up([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]).unwrap();
        assert!(close(apply(&m, [1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        let m = look_up([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap();
        assert!(close(apply(&m, fwd), [1.0, 0.0, 0.0]));
        assert!(close(apply(&m, [1.0, 0.0, 0.0]), [0.0, 0.0, 1.0])); // right is +Z
        let m = yaw_pitch_roll(90.0, 0.0, 0.0).unwrap();
        assert!(close(apply(&m, fwd), [-1.0, 0.0, 0.0]));
        let m = yaw_pitch_roll(0.0, 90.0, 0.0).unwrap();
        assert!(close(apply(&m, fwd), [0.0, 1.0, 0.0]));
        let m = yaw_pitch_roll(0.0, 0.0, 90.0).unwrap();
        assert!(close(apply(&m, [0.0, 1.0, 0.0]), [-1.0, 0.0, 0.0]));
        // yaw/pitch and look/up agree.
        let a = yaw_pitch_roll(30.0, 20.0, 0.0).unwrap();
        let look = apply(&a, fwd);
        let b = look_up(look, [0.0, 1.0, 0.0]).unwrap();
        for i in 0..3 {
            assert!(close(a[i], b[i]), "{a:?} {b:?}");
        }
        assert!(look_up([0.0, 1.0, 0.0], [0.0, 2.0, 0.0]).is_err());
        assert!(look_up([0.0; 3], [0.0, 1.0, 0.0]).is_err());
    }
}
