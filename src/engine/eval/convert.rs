//! Moving values between files (CPU rasters) and ports (GPU textures).

use std::sync::Arc;

use super::node::NodeError;
use super::value::{Matrices, PortValue};
use crate::gpu::{Gpu, Recorder};
use crate::graph::PortType;
use crate::io::Raster;

/// Upload a raster as a value of `ty`: one channel feeds `Scalar`, `Depth` or `ShadowMap`
/// (matrices identity), four channels feed `Image`; a one-channel raster given for an `Image`
/// becomes grey with alpha 1, a square RGBA raster feeds `Lut2D`. Other combinations are refused
/// with a message.
pub fn upload_raster(gpu: &Gpu, r: &Raster, ty: PortType) -> Result<PortValue, NodeError> {
    let mismatch = || {
        NodeError::Other(format!(
            "a {}-channel image cannot feed a {ty} port (one channel feeds Scalar/Depth/ShadowMap, RGBA feeds Image)",
            r.channels
        ))
    };
    match (ty, r.channels) {
        (PortType::Image, 4) => Ok(PortValue::Image(Arc::new(
            gpu.upload(r.width, r.height, 4, &r.data)?,
        ))),
        (PortType::Lut2D, 4) if r.width == r.height => Ok(PortValue::Lut2D(Arc::new(
            gpu.upload(r.width, r.height, 4, &r.data)?,
        ))),
        (PortType::Image, 1) => {
            let data: Vec<f32> = r.data.iter().flat_map(|v| [*v, *v, *v, 1.0]).collect();
            Ok(PortValue::Image(Arc::new(
                gpu.upload(r.width, r.height, 4, &data)?,
            )))
        }
        (PortType::Scalar | PortType::Depth | PortType::ShadowMap, 1) => {
            let t = Arc::new(gpu.upload(r.width, r.height, 1, &r.data)?);
            Ok(match ty {
                PortType::Depth => PortValue::Depth(t, Matrices::default()),
                PortType::ShadowMap => PortValue::ShadowMap(t, Matrices::default()),
                _ => PortValue::Scalar(t),
            })
        }
        _ => Err(mismatch()),
    }
}

/// Start reading a 2D value back ([`Recorder::read_texture_later`]); the raster comes from
/// [`PendingRaster::wait`], on any thread.
pub fn download_later(gpu: &Recorder, v: &PortValue) -> Result<PendingRaster, NodeError> {
    let t = v
        .texture()
        .ok_or_else(|| NodeError::Other(format!("a {} value is not an image", v.port_type())))?;
    Ok(PendingRaster {
        read: gpu.read_texture_later(t)?,
        size: (t.width, t.height),
        channels: t.format.channels(),
    })
}

/// A [`download_later`] in flight.
pub struct PendingRaster {
    read: crate::gpu::PendingRead,
    size: (u32, u32),
    channels: u32,
}

impl PendingRaster {
    /// The raster, once the GPU has copied it.
    pub fn wait(self) -> Result<Raster, crate::gpu::GpuError> {
        Ok(Raster {
            width: self.size.0,
            height: self.size.1,
            channels: self.channels,
            data: self.read.wait()?,
        })
    }
}

/// Read a 2D value back to the CPU.
pub fn download(gpu: &Recorder, v: &PortValue) -> Result<Raster, NodeError> {
    let t = v
        .texture()
        .ok_or_else(|| NodeError::Other(format!("a {} value is not an image", v.port_type())))?;
    let data = gpu.read_texture(t)?;
    Ok(Raster {
        width: t.width,
        height: t.height,
        channels: t.format.channels(),
        data,
    })
}
