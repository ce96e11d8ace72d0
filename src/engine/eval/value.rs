//! Values travelling between nodes: GPU textures plus the metadata their port type carries.

use std::any::Any;
use std::sync::Arc;

use crate::gpu::GpuTexture;
use crate::graph::PortType;

/// A 4×4 matrix, column-major (as WGSL's `mat4x4<f32>`).
pub type Mat4 = [[f32; 4]; 4];

/// The depth a `ShadowMap` texel holds where no occluder covers it: "clear", not a depth.
///
/// An occluder at depth d shadows every point farther than d along its texel's ray, however
/// far (also past 1, the far end of the range the map's depth encodes); a clear texel shadows
/// nothing. The value is larger than any depth a map can hold, so the tests `z ≤ d + bias` and
/// the min/max trees (where it acts as +∞) need no special case, and it stays finite so that
/// filters never make a NaN of it. Every node that writes or edits a map keeps clear texels at
/// exactly this value (`shaders/lib/shadow.wgsl` has the same constant, `SHADOW_CLEAR`).
pub const SHADOW_CLEAR: f32 = 1.0e30;

/// Whether a shadow-map texel is clear (no occluder): at least [`SHADOW_CLEAR`].
pub fn is_clear(depth: f32) -> bool {
    depth >= SHADOW_CLEAR
}

/// The identity matrix.
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// What a `Depth` or `ShadowMap` carries besides its texels: the camera's or the light's
/// matrices, the far distance and the light's radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrices {
    /// World → view.
    pub view: Mat4,
    /// View → clip (wgpu conventions: y up, depth 0..1).
    pub proj: Mat4,
    /// For `Depth`: the linear depth given to sky pixels (the camera's far distance).
    pub far: f32,
    /// For `ShadowMap`: the light's colour × intensity (zero for cameras): W/m² for the sun,
    /// W/sr for a spot or point light.
    pub radiance: [f32; 3],
    /// For a `ShadowMap` of a spot or point light: the light (its position, cone, range and the
    /// map's depth range); `None` for the sun's orthographic map and for cameras.
    pub local: Option<crate::scene::LocalLight>,
}

impl Default for Matrices {
    /// Identity matrices (clip space = world space), far 1, white light.
    fn default() -> Self {
        Self {
            view: IDENTITY,
            proj: IDENTITY,
            far: 1.0,
            radiance: [1.0; 3],
            local: None,
        }
    }
}

impl Matrices {
    /// The matrices a `Depth` carries for a `w × h` image of `camera` (far distance as the
    /// sky's depth, no radiance).
    pub fn of_camera(camera: &crate::scene::Camera, w: u32, h: u32) -> Self {
        Self {
            view: camera.view().to_cols_array_2d(),
            proj: camera.proj(w as f32 / h.max(1) as f32).to_cols_array_2d(),
            far: camera.far,
            radiance: [0.0; 3],
            local: None,
        }
    }

    /// Projection × view (world → clip).
    pub fn view_proj(&self) -> glam::Mat4 {
        glam::Mat4::from_cols_array_2d(&self.proj) * glam::Mat4::from_cols_array_2d(&self.view)
    }

    /// The viewpoint in world space (the camera's position).
    pub fn eye(&self) -> glam::Vec3 {
        glam::Mat4::from_cols_array_2d(&self.view)
            .inverse()
            .transform_point3(glam::Vec3::ZERO)
    }

    /// The unit world direction of the view ray through the centre of pixel (x, y) of a `w × h`
    /// image (y down), as the scattering shaders compute it.
    pub fn pixel_ray(&self, x: u32, y: u32, w: u32, h: u32) -> glam::Vec3 {
        pixel_ray(self.view_proj().inverse(), self.eye(), x, y, w, h)
    }

    /// The unit world direction of view-space +Z, i.e. opposite to where the view looks: for a
    /// light, the direction towards the light.
    pub fn backward(&self) -> glam::Vec3 {
        glam::Mat4::from_cols_array_2d(&self.view)
            .inverse()
            .transform_vector3(glam::Vec3::Z)
            .normalize_or(glam::Vec3::Y)
    }
}

/// The unit world direction from `eye` through the centre of pixel (x, y) of a `w × h` image
/// (y down), given clip → world `inv_view_proj`: the CPU twin of the shaders' `view_ray`.
pub fn pixel_ray(
    inv_view_proj: glam::Mat4,
    eye: glam::Vec3,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
) -> glam::Vec3 {
    let q = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
    screen_ray(inv_view_proj, eye, q, w, h)
}

/// The unit world direction from `eye` through the screen point `q` (pixel units, continuous:
/// (0, 0) is the top-left corner of a `w × h` image, y down): the CPU twin of the shaders'
/// `screen_ray`.
pub fn screen_ray(
    inv_view_proj: glam::Mat4,
    eye: glam::Vec3,
    q: glam::Vec2,
    w: u32,
    h: u32,
) -> glam::Vec3 {
    let ndc = glam::Vec4::new(
        q.x / w as f32 * 2.0 - 1.0,
        1.0 - q.y / h as f32 * 2.0,
        1.0,
        1.0,
    );
    let far = inv_view_proj * ndc;
    (far.truncate() / far.w - eye).normalize_or(glam::Vec3::NEG_Z)
}

/// A value on a port.
#[derive(Clone, Debug)]
pub enum PortValue {
    /// Light-space depth in `R32F` and the light's matrices.
    ShadowMap(Arc<GpuTexture>, Matrices),
    /// Camera linear depth in `R32F` and the camera's matrices.
    Depth(Arc<GpuTexture>, Matrices),
    /// One channel, `R32F`.
    Scalar(Arc<GpuTexture>),
    /// RGBA, `RGBA32F`.
    Image(Arc<GpuTexture>),
    /// A baked transfer function, `RGBA32F`, N×N: texel (i, j) holds the colour at
    /// u = V̄ = (i + 0.5)/N, v = normalised depth = (j + 0.5)/N.
    Lut2D(Arc<GpuTexture>),
    /// A tabulated phase function, `RGBA32F`, W×1: texel i holds p(θ) per RGB channel (680 /
    /// 550 / 440 nm) at θ = π (i + 0.5)/W, in 1/sr, normalised so that
    /// 2π Σ p(θ_i) sin θ_i · π/W = 1 per channel; alpha 1.
    Phase(Arc<GpuTexture>),
    /// A soft visibility volume in light space (`SoftVisibility`): R32F, x/y over the light
    /// matrices' clip square (u = x/2 + 1/2, v = 1/2 − y/2), z over light depth 0…1 in equal
    /// slices; texel (i, j, k) holds the occlusion in [0, 1] at the far end of slice k.
    SoftShadow(Arc<crate::gpu::GpuVolume>, Matrices),
    /// A volume (noise, painted blend volume) and the world-space box `[min, max]` it covers.
    Volume(Arc<crate::gpu::GpuVolume>, [[f32; 3]; 2]),
    /// A light map, `RGBA32F`: the colour multiplying the sun at a point is the bilinear lookup
    /// at the point's (u, v) under these light matrices (orthographic along the light, u = x/2
    /// + 1/2, v = 1/2 − y/2 of light clip space, clamp to edge).
    LightMap(Arc<GpuTexture>, Matrices),
    /// Named layers of a multi-layer EXR with their header attributes (`Cryptomatte`).
    Layers(Arc<LayerSet>),
    /// Any other port type; the producing and consuming nodes agree on the payload.
    Other(PortType, Arc<dyn Any + Send + Sync>),
}

/// Named layers of a multi-layer EXR, on the GPU, with the header attributes that describe them
/// (the value of a `Layers` port): a node that makes several layers at once (`Cryptomatte`: three
/// ID/coverage layers per kind and a manifest) hands them to `AovOutput` as one value.
#[derive(Debug, Clone, Default)]
pub struct LayerSet {
    /// The layers, in the order they are written.
    pub layers: Vec<NamedLayer>,
    /// Header attributes written as strings (`cryptomatte/<key>/name`, `…/manifest`).
    pub attributes: Vec<(String, String)>,
}

/// One layer of a [`LayerSet`].
#[derive(Debug, Clone)]
pub struct NamedLayer {
    /// The layer's full name (`ViewLayer.CryptoObject00`): its channels are `<name>.<channel>`.
    pub name: String,
    /// Channel names of the texture's channels, in order (`R`, `G`, `B`, `A`; a one-channel
    /// texture names one).
    pub channels: Vec<String>,
    /// The samples (`R32F` or `RGBA32F`).
    pub texture: Arc<GpuTexture>,
    /// Always stored as 32-bit floats (IDs whose bits must survive), whatever the writer's
    /// precision.
    pub float: bool,
}

impl PortValue {
    /// The port type of this value.
    pub fn port_type(&self) -> PortType {
        match self {
            PortValue::ShadowMap(..) => PortType::ShadowMap,
            PortValue::Depth(..) => PortType::Depth,
            PortValue::Scalar(_) => PortType::Scalar,
            PortValue::Image(_) => PortType::Image,
            PortValue::Lut2D(_) => PortType::Lut2D,
            PortValue::LightMap(..) => PortType::LightMap,
            PortValue::Phase(_) => PortType::Phase,
            PortValue::Volume(..) => PortType::Volume,
            PortValue::SoftShadow(..) => PortType::SoftShadow,
            PortValue::Layers(_) => PortType::Layers,
            PortValue::Other(t, _) => *t,
        }
    }

    /// The 2D texture, for the image-like types.
    pub fn texture(&self) -> Option<&Arc<GpuTexture>> {
        match self {
            PortValue::ShadowMap(t, _)
            | PortValue::Depth(t, _)
            | PortValue::Scalar(t)
            | PortValue::Image(t)
            | PortValue::Lut2D(t)
            | PortValue::Phase(t)
            | PortValue::LightMap(t, _) => Some(t),
            PortValue::Other(..)
            | PortValue::Volume(..)
            | PortValue::SoftShadow(..)
            | PortValue::Layers(_) => None,
        }
    }

    /// The payload of an `Other` value, if it is a `T`.
    pub fn payload<T: Any + Send + Sync>(&self) -> Option<&T> {
        match self {
            PortValue::Other(_, p) => p.downcast_ref::<T>(),
            _ => None,
        }
    }

    /// GPU memory held, in bytes (0 for payloads of unknown size).
    pub fn bytes(&self) -> usize {
        match self {
            PortValue::Volume(v, _) | PortValue::SoftShadow(v, _) => v.bytes(),
            PortValue::Layers(set) => set.layers.iter().map(|l| l.texture.bytes()).sum(),
            _ => self.texture().map_or(0, |t| t.bytes()),
        }
    }
}
