//! Parsers for the small textual inputs users type: 4×4 matrices and look-at specs.  They live
//! in the core (not the CLI) so that every front end and the fuzzers share them.

use crate::base::error::{Error, Result};

/// A 4×4 matrix, row-major, math convention (`eye = M · p`).
pub type Mat4 = [[f64; 4]; 4];

/// The modelview that does nothing.
pub use super::vec::IDENTITY4 as IDENTITY;

/// Parses a modelview spec (`param` names the argument in errors):
///
/// * `identity`
/// * 16 numbers separated by commas and/or whitespace, **row-major** (the matrix as printed in
///   a maths text, `eye = M p`); with `column_major` they are read in OpenGL's memory order
///   (what `glGetFloatv(GL_MODELVIEW_MATRIX)` returns) instead;
/// * `lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ` — exactly `gluLookAt(eye, target, up)`.
pub fn parse_matrix4(spec: &str, column_major: bool, param: &str) -> Result<Mat4> {
    let spec = spec.trim();
    if spec.eq_ignore_ascii_case("identity") {
        return Ok(IDENTITY);
    }
    if let Some(rest) = spec.strip_prefix("lookat:") {
        let v = parse_numbers(rest, param)?;
        if v.len() != 9 {
            return Err(Error::param(
                param,
                format!("lookat: needs 9 numbers (eye, target, up), got {}", v.len()),
            ));
        }
        return look_at(
            [v[0], v[1], v[2]],
            [v[3], v[4], v[5]],
            [v[6], v[7], v[8]],
            param,
        );
    }
    let v = parse_numbers(spec, param)?;
    if v.len() != 16 {
        return Err(Error::param(
            param,
            format!(
                "expected 16 numbers (a 4x4 matrix), 'identity' or 'lookat:...', got {} numbers",
                v.len()
            ),
        ));
    }
    let mut m = [[0.0; 4]; 4];
    for (k, x) in v.into_iter().enumerate() {
        let (r, c) = if column_major {
            (k % 4, k / 4)
        } else {
            (k / 4, k % 4)
        };
        m[r][c] = x;
    }
    Ok(m)
}

/// Numbers separated by commas, semicolons, brackets and/or whitespace; each must be finite.
pub fn parse_numbers(text: &str, param: &str) -> Result<Vec<f64>> {
    text.split(|c: char| c == ',' || c == ';' || c == '[' || c == ']' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(Error::param(param, format!("{t:?} is not a finite number"))),
            Err(_) => Err(Error::param(param, format!("{t:?} is not a number"))),
        })
        .collect()
}

/// `gluLookAt(eye, target, up)` as a row-major matrix.
pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3], param: &str) -> Result<Mat4> {
    use glam::DVec3;
    let (e, t, u) = (DVec3::from(eye), DVec3::from(target), DVec3::from(up));
    let f = (t - e)
        .try_normalize()
        .ok_or_else(|| Error::param(param, "eye and target coincide"))?;
    let s = f
        .cross(u)
        .try_normalize()
        .ok_or_else(|| Error::param(param, "up is zero or parallel to the view direction"))?;
    let u = s.cross(f);
    Ok([
        [s.x, s.y, s.z, -s.dot(e)],
        [u.x, u.y, u.z, -u.dot(e)],
        [-f.x, -f.y, -f.z, f.dot(e)],
        [0.0, 0.0, 0.0, 1.0],
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn row_and_column_major() {
        let s = "1 2 3 4, 5 6 7 8, 9 10 11 12, 13 14 15 16";
        let r = parse_matrix4(s, false, "m").unwrap();
        assert_eq!(r[0], [1.0, 2.0, 3.0, 4.0]);
        let c = parse_matrix4(s, true, "m").unwrap();
        assert_eq!(c[0], [1.0, 5.0, 9.0, 13.0]);
        assert!(parse_matrix4("1 2 3", false, "m")
            .unwrap_err()
            .to_string()
            .starts_with("m: expected 16"));
        assert!(parse_matrix4("lookat:0,0,0,0,0,0,0,1,0", false, "m").is_err());
        assert!(parse_matrix4(&"nan ".repeat(16), false, "m").is_err());
    }
    #[test]
    fn look_at_is_glu() {
        let m = look_at([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], "m").unwrap();
        assert_eq!(
            m,
            [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, -5.0],
                [0.0, 0.0, 0.0, 1.0]
            ]
        );
    }
}
