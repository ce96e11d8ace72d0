//! Values travelling between nodes: GPU textures plus the metadata their port type carries.

use std::any::Any;
use std::sync::Arc;

use crate::gpu::GpuTexture;
use crate::graph::PortType;

/// A 4×4 matrix, column-major (as WGSL's `mat4x4<f32>`).
pub type Mat4 = [[f32; 4]; 4];

/// The identity matrix.
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// View and projection of the camera (for `Depth`) or the light (for `ShadowMap`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrices {
    /// World → view.
    pub view: Mat4,
    /// View → clip.
    pub proj: Mat4,
}

impl Default for Matrices {
    fn default() -> Self {
        Self {
            view: IDENTITY,
            proj: IDENTITY,
        }
    }
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
    /// Any other port type; the producing and consuming nodes agree on the payload.
    Other(PortType, Arc<dyn Any + Send + Sync>),
}

impl PortValue {
    /// The port type of this value.
    pub fn port_type(&self) -> PortType {
        match self {
            PortValue::ShadowMap(..) => PortType::ShadowMap,
            PortValue::Depth(..) => PortType::Depth,
            PortValue::Scalar(_) => PortType::Scalar,
            PortValue::Image(_) => PortType::Image,
            PortValue::Other(t, _) => *t,
        }
    }

    /// The 2D texture, for the image-like types.
    pub fn texture(&self) -> Option<&Arc<GpuTexture>> {
        match self {
            PortValue::ShadowMap(t, _)
            | PortValue::Depth(t, _)
            | PortValue::Scalar(t)
            | PortValue::Image(t) => Some(t),
            PortValue::Other(..) => None,
        }
    }

    /// GPU memory held, in bytes (0 for payloads of unknown size).
    pub fn bytes(&self) -> usize {
        self.texture().map_or(0, |t| t.bytes())
    }
}
