//! What a shader's entry points need of an adapter, read from its WGSL by naga: bindings of
//! each class per stage, storage formats, 3D storage, workgroup size. Checked against an
//! adapter by [`super::adapter::Capabilities::lacks_for`].

use wgpu::TextureFormat as F;

/// What one entry point of a shader binds and needs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EntryNeeds {
    /// The entry point's name.
    pub entry: String,
    /// Storage textures it uses.
    pub storage_textures: u32,
    /// Of those, 3D ones.
    pub storage_3d: u32,
    /// Sampled (`textureLoad`) textures it uses.
    pub sampled_textures: u32,
    /// Storage buffers it uses.
    pub storage_buffers: u32,
    /// Uniform buffers it uses.
    pub uniform_buffers: u32,
    /// `@workgroup_size` (1, 1, 1 for vertex and fragment stages).
    pub workgroup: [u32; 3],
    /// Formats of the storage textures it uses.
    pub storage_formats: Vec<wgpu::TextureFormat>,
    /// Every `@group(0)` binding it uses: (number, variable name, kind).
    pub bindings: Vec<(u32, String, BindingKind)>,
}

/// What kind of resource a binding takes (what [`super::Bind`] must match).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BindingKind {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage>`.
    StorageBuffer,
    /// `texture_2d<f32>` (read with `textureLoad`).
    Texture2d,
    /// `texture_3d<f32>`.
    Texture3d,
    /// `texture_storage_2d<…, write>`.
    StorageTexture2d,
    /// `texture_storage_3d<…, write>`.
    StorageTexture3d,
    /// Anything else (samplers, arrays of textures).
    Other,
}

impl BindingKind {
    /// Its name in messages.
    pub fn name(self) -> &'static str {
        match self {
            BindingKind::Uniform => "a uniform buffer",
            BindingKind::StorageBuffer => "a storage buffer",
            BindingKind::Texture2d => "a 2D texture",
            BindingKind::Texture3d => "a 3D texture",
            BindingKind::StorageTexture2d => "a 2D storage texture",
            BindingKind::StorageTexture3d => "a 3D storage texture",
            BindingKind::Other => "another kind of binding",
        }
    }
}

impl EntryNeeds {
    /// The groups of a dispatch covering `size` invocations (x, y, z) with this entry point's
    /// workgroup size.
    pub fn groups(&self, size: [u32; 3]) -> [u32; 3] {
        [0, 1, 2].map(|k| size[k].div_ceil(self.workgroup[k].max(1)))
    }
}

/// What a shader's entry points need, read from the WGSL by naga.
#[derive(Debug, Clone, Default)]
pub struct ShaderNeeds {
    /// One row per entry point.
    pub entries: Vec<EntryNeeds>,
    /// Every `@group(0)` binding the module declares: (variable name, number). Dispatches
    /// name their resources by variable name; this is where the number comes from.
    pub names: Vec<(String, u32)>,
}

impl ShaderNeeds {
    /// The binding number of the `@group(0)` variable `name`, if the module declares one.
    pub fn binding(&self, name: &str) -> Option<u32> {
        self.names.iter().find(|(n, _)| n == name).map(|(_, b)| *b)
    }
}

impl ShaderNeeds {
    /// Parse and validate `source` and count, per entry point, the resources it uses.
    pub fn of(source: &str) -> Result<ShaderNeeds, String> {
        let module = naga::front::wgsl::parse_str(source).map_err(|e| e.message().to_string())?;
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .map_err(|e| e.as_inner().to_string())?;
        let names = module
            .global_variables
            .iter()
            .filter_map(|(_, gv)| {
                let b = gv.binding.as_ref().filter(|b| b.group == 0)?;
                Some((gv.name.clone()?, b.binding))
            })
            .collect();
        let mut entries = Vec::new();
        for (i, ep) in module.entry_points.iter().enumerate() {
            let uses = info.get_entry_point(i);
            let mut e = EntryNeeds {
                entry: ep.name.clone(),
                storage_textures: 0,
                storage_3d: 0,
                sampled_textures: 0,
                storage_buffers: 0,
                uniform_buffers: 0,
                workgroup: if ep.stage == naga::ShaderStage::Compute {
                    ep.workgroup_size
                } else {
                    [1, 1, 1]
                },
                storage_formats: Vec::new(),
                bindings: Vec::new(),
            };
            for (h, gv) in module.global_variables.iter() {
                let Some(binding) = &gv.binding else { continue };
                if uses[h].is_empty() {
                    continue;
                }
                e.bindings.push((
                    binding.binding,
                    gv.name.clone().unwrap_or_default(),
                    binding_kind(&module, gv),
                ));
                match gv.space {
                    naga::AddressSpace::Uniform => e.uniform_buffers += 1,
                    naga::AddressSpace::Storage { .. } => e.storage_buffers += 1,
                    naga::AddressSpace::Handle => {
                        if let naga::TypeInner::Image { class, dim, .. } =
                            &module.types[gv.ty].inner
                        {
                            match class {
                                naga::ImageClass::Storage { format, .. } => {
                                    e.storage_textures += 1;
                                    if *dim == naga::ImageDimension::D3 {
                                        e.storage_3d += 1;
                                    }
                                    if let Some(f) = storage_format(*format) {
                                        if !e.storage_formats.contains(&f) {
                                            e.storage_formats.push(f);
                                        }
                                    }
                                }
                                _ => e.sampled_textures += 1,
                            }
                        }
                    }
                    _ => {}
                }
            }
            entries.push(e);
        }
        Ok(ShaderNeeds { entries, names })
    }
}

fn storage_format(f: naga::StorageFormat) -> Option<wgpu::TextureFormat> {
    use naga::StorageFormat as S;
    Some(match f {
        S::R32Float => F::R32Float,
        S::Rg32Float => F::Rg32Float,
        S::Rgba32Float => F::Rgba32Float,
        S::R32Uint => F::R32Uint,
        S::R32Sint => F::R32Sint,
        S::Rgba8Unorm => F::Rgba8Unorm,
        S::Rgba16Float => F::Rgba16Float,
        _ => return None,
    })
}

fn binding_kind(module: &naga::Module, gv: &naga::GlobalVariable) -> BindingKind {
    match gv.space {
        naga::AddressSpace::Uniform => BindingKind::Uniform,
        naga::AddressSpace::Storage { .. } => BindingKind::StorageBuffer,
        naga::AddressSpace::Handle => match &module.types[gv.ty].inner {
            naga::TypeInner::Image { class, dim, .. } => {
                let d3 = *dim == naga::ImageDimension::D3;
                match (class, d3) {
                    (naga::ImageClass::Storage { .. }, false) => BindingKind::StorageTexture2d,
                    (naga::ImageClass::Storage { .. }, true) => BindingKind::StorageTexture3d,
                    (_, false) => BindingKind::Texture2d,
                    (_, true) => BindingKind::Texture3d,
                }
            }
            _ => BindingKind::Other,
        },
        _ => BindingKind::Other,
    }
}
