//! An OpenColorIO processor applied to an image (issue #45): on the GPU through the WGSL the
//! `ocio` crate writes for it (with the LUT textures it asks for), on the CPU — the reference —
//! through the crate's CPU processor. `ColourSpace` and `DisplayView` build the processor; this
//! runs it.
//!
//! The pass is OpenColorIO's module (its function `ocio_main`, its uniform buffer at binding 0
//! when the transform has dynamic properties, its LUT textures from binding 3) with an entry
//! point that reads `src` (binding 1) and writes `out_image` (binding 2), one invocation per
//! pixel; alpha goes through OpenColorIO as it does on the CPU. 1D LUTs are asked for as 2D
//! textures (wgpu's 1D textures are of no help here), 3D LUTs are RGBA 3D textures
//! (`Gpu::lut_volume`; OpenColorIO's shader interpolates them itself). The text is a runtime shader
//! ([`Shader::runtime`]): one per distinct transform, its pipeline cached.

use tyndall_engine::colour::{ColourCtx, ColourError};
use tyndall_engine::eval::NodeError;
use tyndall_engine::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::io::Raster;

use ocio::gpu::{GpuShaderCreator, GpuShaderDesc};

/// The entry point appended to OpenColorIO's module.
const ENTRY: &str = "
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn apply(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(src);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, id.xy, ocio_main(textureLoad(src, id.xy, 0)));
}
";

/// A colour error as a node's: the parameter it came from.
pub fn param_error(param: &str) -> impl Fn(ColourError) -> NodeError + '_ {
    move |e| NodeError::Param {
        param: param.to_string(),
        message: e.to_string(),
    }
}

/// The processor from colour space `from` to `to` of `config` (empty: the evaluation's
/// config; an empty space: the working space), errors naming the parameters `config`, `from`,
/// `to`.
pub fn colour_space_processor(
    colour: &ColourCtx,
    config: &str,
    from: &str,
    to: &str,
) -> Result<ocio::Processor, NodeError> {
    let config = colour.config(config).map_err(param_error("config"))?;
    let working = colour.working_space();
    let from = config
        .colour_space(from, working)
        .map_err(param_error("from"))?;
    let to = config
        .colour_space(to, working)
        .map_err(param_error("to"))?;
    config.processor(&from, &to).map_err(param_error("to"))
}

/// The processor from colour space `source` through `display` / `view` with `look` of
/// `config` (empties: the evaluation's config, the working space, the config's default
/// display, the display's default view, no look), errors naming the parameters of those names.
pub fn display_view_processor(
    colour: &ColourCtx,
    config: &str,
    source: &str,
    display: &str,
    view: &str,
    look: &str,
) -> Result<ocio::Processor, NodeError> {
    let config = colour.config(config).map_err(param_error("config"))?;
    let source = config
        .colour_space(source, colour.working_space())
        .map_err(param_error("source"))?;
    let display = config.display(display).map_err(param_error("display"))?;
    let view = config.view(&display, view).map_err(param_error("view"))?;
    let look = if look.is_empty() {
        String::new()
    } else {
        config.look(look).map_err(param_error("look"))?
    };
    config
        .display_view_processor(&source, &display, &view, &look)
        .map_err(param_error("view"))
}

/// A processor made ready for the GPU: its shader, uniform buffer and LUT textures.
pub struct OcioPass {
    shader: Shader,
    /// The uniform buffer's variable name and bytes, when the transform has any.
    uniform: Option<(String, Vec<u8>)>,
    /// Each LUT texture: variable name, width, height, channels (1 or 4), values.
    textures: Vec<(String, u32, u32, u32, Vec<f32>)>,
    /// Each 3D LUT: variable name, edge length, RGBA values (x fastest).
    volumes: Vec<(String, u32, Vec<f32>)>,
}

/// The GPU form of `processor`; why OpenColorIO could not write one is an error on the node's
/// parameter `param` (the one that chose the transform).
pub fn prepare(processor: &ocio::Processor, param: &str) -> Result<OcioPass, NodeError> {
    gpu_form(processor).map_err(|message| NodeError::Param {
        param: param.to_string(),
        message,
    })
}

fn gpu_form(processor: &ocio::Processor) -> Result<OcioPass, String> {
    let gpu = processor
        .default_gpu_processor()
        .map_err(|e| e.to_string())?;
    let mut desc = GpuShaderDesc::new();
    desc.set_language(ocio::GpuLanguage::Wgsl);
    desc.set_allow_texture_1d(false);
    desc.set_function_name("ocio_main");
    desc.set_resource_prefix("ocio_");
    desc.set_descriptor_set_index(0, 3)
        .map_err(|e| e.to_string())?;
    gpu.extract_gpu_shader_info(&mut desc)
        .map_err(|e| e.to_string())?;
    let bindings = desc
        .wgsl_bindings()
        .ok_or("OpenColorIO wrote no WGSL bindings")?;
    let text = format!("{}\n{ENTRY}", desc.shader_text());
    let uniform = match bindings.uniform_binding {
        Some(b) => {
            let name = binding_name(&text, b)
                .ok_or_else(|| format!("OpenColorIO's shader has no variable at binding {b}"))?;
            Some((
                name,
                bindings.uniform_buffer(&desc).map_err(|e| e.to_string())?,
            ))
        }
        None => None,
    };
    let mut textures = Vec::new();
    for i in 0..desc.num_textures() {
        let t = desc.texture(i).map_err(|e| e.to_string())?;
        let values = desc.texture_values(i).map_err(|e| e.to_string())?;
        let b = bindings
            .texture(&t.texture_name)
            .ok_or_else(|| format!("no binding for LUT `{}`", t.texture_name))?;
        let texels = (b.width * b.height) as usize;
        let per_texel = match b.format {
            ocio::gpu::wgsl::WgslTextureFormat::R32Float => 1,
            ocio::gpu::wgsl::WgslTextureFormat::Rgba32Float => 3,
        };
        if values.len() < texels * per_texel {
            return Err(format!("LUT `{}`: too few values", t.texture_name));
        }
        let (channels, data) = match b.format {
            ocio::gpu::wgsl::WgslTextureFormat::R32Float => (1, values[..texels].to_vec()),
            ocio::gpu::wgsl::WgslTextureFormat::Rgba32Float => (
                4,
                values[..texels * 3]
                    .chunks(3)
                    .flat_map(|c| [c[0], c[1], c[2], 1.0])
                    .collect(),
            ),
        };
        textures.push((t.texture_name.clone(), b.width, b.height, channels, data));
    }
    let mut volumes = Vec::new();
    for i in 0..desc.num_3d_textures() {
        let t = desc.texture_3d(i).map_err(|e| e.to_string())?;
        let values = desc.texture_3d_values(i).map_err(|e| e.to_string())?;
        let n = t.width;
        let texels = (n * n * n) as usize;
        if values.len() < texels * 3 {
            return Err(format!("3D LUT `{}`: too few values", t.texture_name));
        }
        let rgba = values[..texels * 3]
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 1.0])
            .collect();
        volumes.push((t.texture_name.clone(), n, rgba));
    }
    Ok(OcioPass {
        shader: Shader::runtime("ocio", &text),
        uniform,
        textures,
        volumes,
    })
}

/// The variable declared at `@group(0) @binding(b)` in `text`.
fn binding_name(text: &str, b: u32) -> Option<String> {
    let tag = format!("@binding({b})");
    let line = text
        .lines()
        .find(|l| l.contains(&tag) && l.contains("var"))?;
    let after = line.split("var").nth(1)?;
    let after = after.split('>').next_back()?.trim_start();
    Some(after.split(':').next()?.trim().to_string())
}

/// The pass over `src`: a new Rgba32F texture of its size.
pub fn apply(gpu: &Gpu, pass: &OcioPass, src: &GpuTexture) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(src.width, src.height, TexFormat::Rgba32F)?;
    let mut luts = Vec::with_capacity(pass.textures.len());
    for (name, w, h, channels, data) in &pass.textures {
        luts.push((name.as_str(), gpu.upload(*w, *h, *channels, data)?));
    }
    let mut cubes = Vec::with_capacity(pass.volumes.len());
    for (name, n, rgba) in &pass.volumes {
        cubes.push((name.as_str(), gpu.lut_volume([*n; 3], rgba)?));
    }
    let mut binds = vec![
        ("src", Bind::Texture(src)),
        ("out_image", Bind::Storage(&out)),
    ];
    if let Some((name, bytes)) = &pass.uniform {
        binds.push((name.as_str(), Bind::Uniform(bytes)));
    }
    for (name, t) in &luts {
        binds.push((name, Bind::Texture(t)));
    }
    for (name, v) in &cubes {
        binds.push((name, Bind::Volume(v)));
    }
    gpu.dispatch(pass.shader, "apply", &binds, src.width, src.height)?;
    Ok(out)
}

/// CPU reference: `processor` on every pixel of a four-channel raster.
pub fn reference(processor: &ocio::Processor, image: &Raster) -> Raster {
    let mut out = image.clone();
    processor
        .default_cpu_processor()
        .apply_rgba_slice(&mut out.data);
    out
}
