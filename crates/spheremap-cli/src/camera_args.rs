//! The rasterizer's camera flags, shared by `render` and `analyze`: `gluLookAt` and
//! `gluPerspective` arguments, each defaulting to a framing of the mesh.

use crate::job::vec3;
use spheremap::jobs::render::GlCamera;

#[derive(clap::Args, Debug)]
pub struct CameraArgs {
    /// Camera position, as gluLookAt (default: on +Z of the mesh's bounding sphere, framing it).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    eye: Option<Vec<f64>>,
    /// The point looked at (default: the bounding box's centre).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    target: Option<Vec<f64>>,
    /// Up direction (default 0 1 0).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    up: Option<Vec<f64>>,
    /// The three at once, as the texgen command's view spec: lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ.
    #[arg(long, conflicts_with_all = ["eye", "target", "up"])]
    camera: Option<String>,
    /// Vertical field of view in degrees, as gluPerspective.
    #[arg(long, default_value_t = 40.0)]
    fovy: f64,
    /// Near plane distance (default: from the bounding sphere).
    #[arg(long)]
    near: Option<f64>,
    /// Far plane distance (default: from the bounding sphere).
    #[arg(long)]
    far: Option<f64>,
}

impl CameraArgs {
    /// The camera for `positions` and an image of `size`.
    pub fn camera(
        &self,
        positions: &[[f32; 3]],
        size: (usize, usize),
    ) -> spheremap::Result<GlCamera> {
        let (eye, target, up) = match &self.camera {
            Some(spec) => {
                let v = spec
                    .strip_prefix("lookat:")
                    .map(|r| spheremap::base::parse::parse_numbers(r, "camera"))
                    .transpose()?
                    .filter(|v| v.len() == 9)
                    .ok_or_else(|| {
                        spheremap::Error::param(
                            "camera",
                            format!("{spec:?}: expected lookat:EX,EY,EZ,TX,TY,TZ,UX,UY,UZ"),
                        )
                    })?;
                (
                    Some([v[0], v[1], v[2]]),
                    Some([v[3], v[4], v[5]]),
                    Some([v[6], v[7], v[8]]),
                )
            }
            None => (vec3(&self.eye), vec3(&self.target), vec3(&self.up)),
        };
        GlCamera::framing(
            positions, eye, target, up, self.fovy, self.near, self.far, size,
        )
    }
}
