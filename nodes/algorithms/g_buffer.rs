//! A scene's G-buffer seen by a camera: linear depth (the distance to the first surface; sky:
//! the camera's far distance), world normals facing the camera and albedo, rasterised. The
//! `GBuffer` node is this pass (or its ray-cast twin, [`super::ray_cast`]); `LightMapSolve`
//! renders the depth of each painted view with it.

use tyndall_engine::eval::Matrices;
use tyndall_engine::gpu::Recorder;
use tyndall_engine::gpu::{GpuError, GpuTexture, MeshDraw, RasterTarget, Shader, TexFormat};
use tyndall_engine::scene::GpuScene;

use super::ray_cast::{self, Method};

/// The raster pass (`shaders/algorithms/g_buffer.wgsl`); a kind that calls [`render`] lists it
/// in its `NodeDecl::shaders`, and [`GBufferParams::LAYOUT`] in its uniforms.
pub const SHADER: Shader = crate::shader(
    "algorithms/g_buffer",
    include_str!("../../shaders/algorithms/g_buffer.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/algorithms/g_buffer.wgsl` (struct `GBufferParams`).
    pub struct GBufferParams as "GBufferParams" {
        /// World → camera clip.
        pub view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Far distance.
        pub far: f32,
    }
}

/// Render the G-buffer of `scene` seen by `cam` at `w × h` with `method`: linear depth (sky:
/// the far distance), normals, albedo, and the camera's matrices (for other nodes that need a
/// view of the scene, e.g. `LightMapSolve`). A kind calling it with [`Method::RayCast`] lists
/// [`ray_cast::G_BUFFER_SHADER`] and its uniforms too.
pub fn render(
    gpu: &Recorder,
    scene: &GpuScene,
    cam: &tyndall_engine::scene::Camera,
    (w, h): (u32, u32),
    method: Method,
) -> Result<(GpuTexture, GpuTexture, GpuTexture, Matrices), GpuError> {
    let (view, proj) = (cam.view(), cam.proj(w as f32 / h as f32));
    let u = GBufferParams {
        view_proj: (proj * view).to_cols_array_2d(),
        eye: cam.position.to_array(),
        far: cam.far,
    };
    let depth = gpu.texture(w, h, TexFormat::R32F)?;
    let normal = gpu.texture(w, h, TexFormat::Rgba32F)?;
    let albedo = gpu.texture(w, h, TexFormat::Rgba32F)?;
    let draws = scene.draws();
    if method == Method::RayCast {
        let bvh = ray_cast::scene_bvh(gpu, scene, &draws)?;
        let p = ray_cast::RayCastParams {
            eye: u.eye,
            far: u.far,
            ..ray_cast::params(proj * view, w, h)
        };
        ray_cast::g_buffer(gpu, &bvh, &p, (&depth, &normal, &albedo))?;
        return Ok((depth, normal, albedo, Matrices::of_camera(cam, w, h)));
    }
    gpu.raster(
        SHADER,
        bytemuck::bytes_of(&u),
        &[
            RasterTarget {
                texture: &depth,
                clear: [cam.far as f64, 0.0, 0.0, 0.0],
            },
            RasterTarget {
                texture: &normal,
                clear: [0.0; 4],
            },
            RasterTarget {
                texture: &albedo,
                clear: [0.0; 4],
            },
        ],
        &MeshDraw {
            vertices: &scene.vertices,
            indices: &scene.indices,
            placements: &scene.placements,
            ranges: &draws,
        },
    )?;
    Ok((depth, normal, albedo, Matrices::of_camera(cam, w, h)))
}
