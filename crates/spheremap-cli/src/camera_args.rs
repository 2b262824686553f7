//! The rasterizer's camera flags, shared by `render` and `analyze`: `gluLookAt` and
//! `gluPerspective` arguments, each defaulting to a framing of the mesh.

use crate::job::vec3;
use spheremap::jobs::render::CameraRequest;

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
    #[arg(long, default_value_t = CameraRequest::default().fovy)]
    fovy: f64,
    /// Near plane distance (default: from the bounding sphere).
    #[arg(long)]
    near: Option<f64>,
    /// Far plane distance (default: from the bounding sphere).
    #[arg(long)]
    far: Option<f64>,
}

impl CameraArgs {
    /// The core's camera request, for an image of `size`.
    pub fn request(&self, size: (usize, usize)) -> CameraRequest {
        CameraRequest {
            eye: vec3(&self.eye),
            target: vec3(&self.target),
            up: vec3(&self.up),
            camera: self.camera.clone(),
            fovy: self.fovy,
            near: self.near,
            far: self.far,
            width: size.0,
            height: size.1,
        }
    }
}
