//! Typed input getters: `ctx.shadow_map("shadow")?` for a required input, `ctx.phase_opt("phase")?`
//! for an optional one (`None` when unconnected); the same on an [`Earlier`] frame's inputs
//! (`earlier.depth("depth")?`). Edges are type-checked when connected, so the
//! only failures are an unconnected required input and a value of another type (injected by a
//! caller), each an error naming the port.

use std::sync::Arc;

use super::{Earlier, Matrices, NodeError, PortValue, RunCtx};
use crate::gpu::{GpuTexture, GpuVolume};

fn wrong(port: &str, what: &str, v: &PortValue) -> NodeError {
    NodeError::Input {
        port: port.to_string(),
        message: format!("is a {} value, not {what}", v.port_type().name()),
    }
}

macro_rules! getters {
    ($( $(#[$doc:meta])* $name:ident, $opt:ident, $what:literal: $variant:ident($($f:ident),+) -> $ty:ty; )+) => {
        getters!(@for RunCtx<'_>; $( $(#[$doc])* $name, $opt, $what: $variant($($f),+) -> $ty; )+);
        getters!(@for Earlier; $( $(#[$doc])* $name, $opt, $what: $variant($($f),+) -> $ty; )+);
    };
    (@for $on:ty; $( $(#[$doc:meta])* $name:ident, $opt:ident, $what:literal: $variant:ident($($f:ident),+) -> $ty:ty; )+) => {
        impl $on {
            $(
                $(#[$doc])*
                pub fn $name(&self, port: &str) -> Result<$ty, NodeError> {
                    match self.require(port)? {
                        PortValue::$variant($($f),+) => Ok(($(Clone::clone($f)),+)),
                        v => Err(wrong(port, $what, v)),
                    }
                }

                #[doc = concat!("[`RunCtx::", stringify!($name), "`] of an optional input: `None` when unconnected.")]
                pub fn $opt(&self, port: &str) -> Result<Option<$ty>, NodeError> {
                    match self.input(port) {
                        None => Ok(None),
                        Some(PortValue::$variant($($f),+)) => Ok(Some(($(Clone::clone($f)),+))),
                        Some(v) => Err(wrong(port, $what, v)),
                    }
                }
            )+
        }
    };
}

getters! {
    /// A required ShadowMap input: the map and its light's matrices.
    shadow_map, shadow_map_opt, "a shadow map": ShadowMap(t, m) -> (Arc<GpuTexture>, Matrices);
    /// A required Depth input: linear depth and its camera's matrices.
    depth, depth_opt, "a depth image": Depth(t, m) -> (Arc<GpuTexture>, Matrices);
    /// A required Scalar input.
    scalar, scalar_opt, "a one-channel image": Scalar(t) -> Arc<GpuTexture>;
    /// A required Image input.
    image, image_opt, "an image": Image(t) -> Arc<GpuTexture>;
    /// A required Phase input: the tabulated phase function.
    phase, phase_opt, "a phase function": Phase(t) -> Arc<GpuTexture>;
    /// A required LightMap input: the map and its matrices.
    light_map, light_map_opt, "a light map": LightMap(t, m) -> (Arc<GpuTexture>, Matrices);
    /// A required SoftShadow input: the visibility volume and its light's matrices.
    soft_shadow, soft_shadow_opt, "a soft visibility volume": SoftShadow(v, m) -> (Arc<GpuVolume>, Matrices);
    /// A required Volume input: the volume and its world box.
    volume, volume_opt, "a volume": Volume(v, b) -> (Arc<GpuVolume>, [[f32; 3]; 2]);
    /// A required Lut2D input.
    lut2d, lut2d_opt, "a 2D table": Lut2D(t) -> Arc<GpuTexture>;
}

impl RunCtx<'_> {
    /// A required Scene input: the scene and its uploaded meshes.
    pub fn scene(&self, port: &str) -> Result<&crate::scene::GpuScene, NodeError> {
        let v = self.require(port)?;
        v.payload::<crate::scene::GpuScene>()
            .ok_or_else(|| wrong(port, "a scene", v))
    }

    /// The texture on an optional image-like input (Scalar, Image, Depth, ShadowMap — a port
    /// accepting several of them): `None` when unconnected; see [`RunCtx::require_texture`].
    pub fn texture_opt(&self, port: &str) -> Result<Option<Arc<GpuTexture>>, NodeError> {
        match self.input(port) {
            None => Ok(None),
            Some(_) => self.require_texture(port).map(Some),
        }
    }

    /// [`RunCtx::scene`] of an optional input: `None` when unconnected.
    pub fn scene_opt(&self, port: &str) -> Result<Option<&crate::scene::GpuScene>, NodeError> {
        match self.input(port) {
            None => Ok(None),
            Some(_) => self.scene(port).map(Some),
        }
    }
}

impl Earlier {
    /// The value on input `port` at this earlier frame, if connected.
    pub fn input(&self, port: &str) -> Option<&PortValue> {
        self.inputs.get(port)
    }

    /// The value on a required input `port` at this earlier frame.
    pub fn require(&self, port: &str) -> Result<&PortValue, NodeError> {
        self.input(port).ok_or_else(|| NodeError::Input {
            port: port.to_string(),
            message: format!("produced no value {} frames earlier", self.offset),
        })
    }
}
