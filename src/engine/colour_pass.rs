//! An OpenColorIO processor run on the GPU (issue #45) through the WGSL the `ocio` crate
//! writes for it, with the LUT textures it asks for: what the colour nodes run
//! ([`apply`]: `ColourSpace`, `DisplayView`, files read and written in a colour space) and what
//! the editor's viewer runs after its exposure ([`view`]: display, view and look menus). The
//! CPU reference is the crate's CPU processor.
//!
//! The pass is OpenColorIO's module (its function `ocio_main`, its uniform buffer at binding 0
//! when the transform has dynamic properties, its LUT textures from binding 3) with an entry
//! point that reads `src` (binding 1) and writes `out_image` (binding 2), one invocation per
//! pixel; alpha goes through OpenColorIO as it does on the CPU. 1D LUTs are asked for as 2D
//! textures (wgpu's 1D textures are of no help here), 3D LUTs are RGBA 3D textures
//! (`Gpu::lut_volume`; OpenColorIO's shader interpolates them itself). The text is a runtime
//! shader ([`Shader::runtime`]): one per distinct transform, its pipeline cached.

use crate::gpu::{Bind, GpuError, GpuTexture, Recorder, Shader, TexFormat};

use ocio::gpu::{GpuShaderCreator, GpuShaderDesc};

/// The entry point of a node's pass, appended to OpenColorIO's module.
const APPLY: &str = "
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

/// The viewer's entry point: the channel(s) shown and the exposure first (as the display
/// pass's `show` picks them), then the transform; a non-finite value stays NaN so the display
/// pass shows it magenta, whatever the transform would make of it. Its parameters sit at a
/// binding past any LUT's.
const VIEW: &str = "
struct ViewerParams {
    // 2^stops of exposure.
    gain: f32,
    // 0 RGB, 1 R, 2 G, 3 B, 4 A, 5 Rec. 709 luminance.
    channel: u32,
    // 1: a one-channel picture (grey from .r); 4: RGBA.
    channels: u32,
    _pad: u32,
}

@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;
@group(0) @binding(63) var<uniform> viewer: ViewerParams;

fn viewer_finite(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

@compute @workgroup_size(8, 8)
fn view(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(src);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let t = textureLoad(src, id.xy, 0);
    var c: vec3<f32>;
    if viewer.channels == 1u {
        c = vec3<f32>(t.x);
    } else {
        switch viewer.channel {
            case 1u: { c = vec3<f32>(t.x); }
            case 2u: { c = vec3<f32>(t.y); }
            case 3u: { c = vec3<f32>(t.z); }
            case 4u: { c = vec3<f32>(t.w); }
            case 5u: { c = vec3<f32>(0.2126 * t.x + 0.7152 * t.y + 0.0722 * t.z); }
            default: { c = t.xyz; }
        }
    }
    c = c * viewer.gain;
    var o = vec4<f32>(bitcast<f32>(0x7fc00000u));
    if viewer_finite(c.x) && viewer_finite(c.y) && viewer_finite(c.z) {
        o = ocio_main(vec4<f32>(c, 1.0));
    }
    textureStore(out_image, id.xy, o);
}
";

/// The binding of the viewer's parameters: past OpenColorIO's uniform (0), the pass's own
/// (1, 2) and any transform's LUTs (from 3).
pub const VIEWER_BINDING: u32 = 63;

/// A processor made ready for the GPU: its shaders, uniform buffer and LUT textures.
pub struct OcioPass {
    shader: Shader,
    viewer: Shader,
    /// The uniform buffer's variable name and bytes, when the transform has any.
    uniform: Option<(String, Vec<u8>)>,
    /// Each LUT texture: variable name, width, height, channels (1 or 4), values.
    textures: Vec<(String, u32, u32, u32, Vec<f32>)>,
    /// Each 3D LUT: variable name, edge length, RGBA values (x fastest).
    volumes: Vec<(String, u32, Vec<f32>)>,
}

/// The GPU form of `processor`, or why OpenColorIO could not write one.
pub fn prepare(processor: &ocio::Processor) -> Result<OcioPass, String> {
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
    let module = desc.shader_text();
    let uniform = match bindings.uniform_binding {
        Some(b) => {
            let name = binding_name(module, b)
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
    if 3 + textures.len() + volumes.len() >= VIEWER_BINDING as usize {
        return Err(format!(
            "{} LUTs: more than the viewer's binding {VIEWER_BINDING} leaves room for",
            textures.len() + volumes.len()
        ));
    }
    Ok(OcioPass {
        shader: Shader::runtime("ocio", &format!("{module}\n{APPLY}")),
        viewer: Shader::runtime("ocio-viewer", &format!("{module}\n{VIEW}")),
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

/// The transform over `src` (four channels): a new Rgba32F texture of its size.
pub fn apply(gpu: &Recorder, pass: &OcioPass, src: &GpuTexture) -> Result<GpuTexture, GpuError> {
    run(gpu, pass, pass.shader, "apply", src, None)
}

/// The viewer's pass over `src` (one or four channels): `channel` of it (see
/// [`crate::display::Channel`]) times 2^`stops`, through the transform, into a new Rgba32F
/// texture of display values (non-finite inputs NaN), which the display pass then quantizes
/// without encoding ([`crate::display::Look::encoded`]).
pub fn view(
    gpu: &Recorder,
    pass: &OcioPass,
    src: &GpuTexture,
    channel: crate::display::Channel,
    stops: f32,
) -> Result<GpuTexture, GpuError> {
    let mut params = [0u8; 16];
    params[0..4].copy_from_slice(&2f32.powf(stops).to_le_bytes());
    params[4..8].copy_from_slice(&crate::display::channel_index(channel).to_le_bytes());
    params[8..12].copy_from_slice(&src.format.channels().to_le_bytes());
    run(gpu, pass, pass.viewer, "view", src, Some(&params))
}

fn run(
    gpu: &Recorder,
    pass: &OcioPass,
    shader: Shader,
    entry: &str,
    src: &GpuTexture,
    viewer: Option<&[u8]>,
) -> Result<GpuTexture, GpuError> {
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
    if let Some(bytes) = viewer {
        binds.push(("viewer", Bind::Uniform(bytes)));
    }
    if let Some((name, bytes)) = &pass.uniform {
        binds.push((name.as_str(), Bind::Uniform(bytes)));
    }
    for (name, t) in &luts {
        binds.push((name, Bind::Texture(t)));
    }
    for (name, v) in &cubes {
        binds.push((name, Bind::Volume(v)));
    }
    gpu.dispatch(shader, entry, &binds, src.width, src.height)?;
    Ok(out)
}

/// A viewer's display transform (the editor's display, view and look menus): OpenColorIO's
/// display / view with a look, from the graph's working space, on the GPU after the viewer's
/// exposure ([`view`]) and on the CPU for read-back pictures ([`ViewTransform::rgb`]).
pub struct ViewTransform {
    pass: OcioPass,
    cpu: ocio::CpuProcessor,
}

impl ViewTransform {
    /// From colour space `source` of `config` through `display` / `view` with `look` (empty:
    /// none); names as [`crate::colour::ColourConfig`] resolves them (empty display / view:
    /// the config's defaults).
    pub fn new(
        config: &crate::colour::ColourConfig,
        source: &str,
        display: &str,
        view: &str,
        look: &str,
    ) -> Result<ViewTransform, crate::colour::ColourError> {
        let source = config.colour_space(source, crate::colour::WORKING_SPACE)?;
        let display = config.display(display)?;
        let view = config.view(&display, view)?;
        let look = if look.is_empty() {
            String::new()
        } else {
            config.look(look)?
        };
        let processor = config.display_view_processor(&source, &display, &view, &look)?;
        let pass = prepare(&processor).map_err(|reason| crate::colour::ColourError::Processor {
            config: config.source().to_string(),
            what: format!("the GPU form of display `{display}`, view `{view}`"),
            reason,
        })?;
        Ok(ViewTransform {
            pass,
            cpu: processor.default_cpu_processor(),
        })
    }

    /// Its GPU pass (for [`view`]).
    pub fn pass(&self) -> &OcioPass {
        &self.pass
    }

    /// A linear RGB colour (exposed, opaque) through it on the CPU: display values.
    pub fn rgb(&self, rgb: [f32; 3]) -> [f32; 3] {
        crate::colour::convert_rgb(&self.cpu, rgb)
    }
}
