//! Tyndall's techniques. Node kinds, one stem each (`<stem>.rs`, or a folder `<stem>/mod.rs` with one file per part:
//! ports and parameters, CPU reference, GPU dispatch), the algorithms several of them share
//! ([`algorithms`]), and the registry that hands them to the document and the evaluator.
//!
//! Adding a node: write `nodes/<stem>.rs` and `shaders/<stem>.wgsl` (or the folders), then add
//! one line to [`registry`]; CONTRIBUTING.md lists every other place.

#![deny(missing_docs)]

use std::sync::Arc;

use tyndall_engine::eval::Registry;
use tyndall_engine::gpu::Shader;

pub mod algorithms;
pub mod bilateral_filter;
pub mod blend_volume;
pub mod blur;
pub mod colour_space;
pub mod composite;
pub mod constant;
pub mod cryptomatte;
pub mod depth_upsample;
pub mod display_view;
pub mod downsample;
pub mod epipolar;
pub mod g_buffer;
pub mod heterogeneity;
pub mod hole_composite;
pub mod hole_map;
pub mod image_input;
pub mod image_output;
pub mod light_map;
pub mod light_map_solve;
pub mod math;
pub mod morphology2d;
pub mod noise_volume;
pub mod perlin_noise2d;
pub mod phase;
pub mod plate;
pub mod radial_blur;
pub mod remap;
pub mod scene;
pub mod shadow_map;
pub mod side_by_side;
pub mod single_scattering;
pub mod sky;
pub mod soft_visibility;
pub mod temporal_accumulate;
pub mod tonemap;
pub mod transfer_function;
pub mod util;
pub mod vdb_volume;

include!(concat!(env!("OUT_DIR"), "/shader_files.rs"));

/// A technique's shader: `shader("blur", include_str!("../shaders/blur.wgsl"))` — its path
/// under `shaders/` without `.wgsl`, its embedded text, and [`SHADER_FILES`] for its `#import`
/// lines.
pub const fn shader(stem: &'static str, source: &'static str) -> Shader {
    Shader::new(stem, source, SHADER_FILES)
}

/// The text of `shaders/<path>.wgsl`, as embedded at build time.
pub fn shader_file(path: &str) -> Option<&'static str> {
    SHADER_FILES
        .iter()
        .find(|(name, _)| *name == path)
        .map(|(_, text)| *text)
}

/// Every `shaders/**/*.wgsl` path (without `.wgsl`), as embedded at build time.
pub fn shader_files() -> impl Iterator<Item = &'static str> {
    SHADER_FILES.iter().map(|(name, _)| *name)
}

/// Every node kind Tyndall ships.
pub fn registry() -> Registry {
    let mut r = Registry::new();
    r.add(Arc::new(bilateral_filter::BilateralFilter));
    r.add(Arc::new(blend_volume::BlendVolume));
    r.add(Arc::new(blur::Blur));
    r.add(Arc::new(composite::Composite));
    r.add(Arc::new(cryptomatte::Cryptomatte));
    r.add(Arc::new(constant::Constant));
    r.add(Arc::new(depth_upsample::DepthUpsample));
    r.add(Arc::new(downsample::Downsample));
    r.add(Arc::new(epipolar::Epipolar(epipolar::EpiOp::Dilation)));
    r.add(Arc::new(epipolar::Epipolar(epipolar::EpiOp::Closure)));
    r.add(Arc::new(g_buffer::GBufferNode));
    r.add(Arc::new(heterogeneity::Heterogeneity));
    r.add(Arc::new(hole_composite::HoleComposite));
    r.add(Arc::new(hole_map::HoleMap));
    r.add(Arc::new(image_input::ImageInput));
    r.add(Arc::new(image_output::ImageOutput));
    r.add(Arc::new(image_output::AovOutput));
    r.add(Arc::new(light_map::LightMap));
    r.add(Arc::new(light_map_solve::LightMapSolve));
    r.add(Arc::new(math::Math));
    r.add(Arc::new(morphology2d::Morphology2D(
        morphology2d::Op::Dilate,
    )));
    r.add(Arc::new(morphology2d::Morphology2D(
        morphology2d::Op::Erode,
    )));
    r.add(Arc::new(morphology2d::Morphology2D(
        morphology2d::Op::Closure,
    )));
    r.add(Arc::new(noise_volume::NoiseVolume));
    r.add(Arc::new(perlin_noise2d::PerlinNoise2D));
    r.add(Arc::new(phase::PhaseNode(phase::Model::HenyeyGreenstein)));
    r.add(Arc::new(phase::PhaseNode(phase::Model::Rayleigh)));
    r.add(Arc::new(phase::PhaseNode(phase::Model::Mie)));
    r.add(Arc::new(phase::PhaseNode(phase::Model::IceCrystals)));
    r.add(Arc::new(phase::PhaseNode(phase::Model::MultipleScattering)));
    r.add(Arc::new(plate::PlateDepth));
    r.add(Arc::new(plate::PlateOver));
    r.add(Arc::new(radial_blur::RadialBlur));
    r.add(Arc::new(remap::Remap));
    r.add(Arc::new(scene::SceneNode));
    r.add(Arc::new(shadow_map::ShadowMapNode));
    r.add(Arc::new(side_by_side::SideBySide));
    r.add(Arc::new(single_scattering::SingleScattering));
    r.add(Arc::new(sky::Sky));
    r.add(Arc::new(soft_visibility::SoftVisibility));
    r.add(Arc::new(temporal_accumulate::TemporalAccumulate));
    r.add(Arc::new(tonemap::Tonemap));
    r.add(Arc::new(colour_space::ColourSpace));
    r.add(Arc::new(display_view::DisplayView));
    r.add(Arc::new(transfer_function::TransferFunction));
    r.add(Arc::new(vdb_volume::VdbVolume));
    r
}
