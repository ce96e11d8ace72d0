//! Which adapter Tyndall runs on. This file is the one place that states what Tyndall needs of
//! a GPU adapter ([`NEEDED_FORMATS`], [`NEEDED_LIMITS`], compute shaders), checks every adapter
//! of every backend against it ([`survey`]) and chooses the best one that qualifies
//! ([`Survey::choose`]: discrete, then integrated, then virtual, then CPU; Vulkan / Metal / DX12
//! before GL). A user picks one by hand with `--adapter NAME-or-INDEX` or `TYNDALL_ADAPTER`.
//!
//! What a single shader needs beyond that (storage textures per stage, storage formats,
//! workgroup size) is read from the shader itself ([`ShaderNeeds::of`]); an adapter that
//! qualifies but cannot give one node's shader what it needs runs every other node, and that
//! node fails with one line naming what is missing ([`Capabilities::lacks_for`]).
//!
//! Where the adapter offers less than the usual path assumes, [`Capabilities`] also decides the
//! substitutes the rest of `src/engine/gpu/` uses (one mechanism for every node): a two-channel float
//! texture that cannot be a storage texture (GL) is stored as four channels, and a float format
//! that cannot be rendered to is rasterised into one that can.

use wgpu::{TextureFormat as F, TextureUsages as U};

pub use super::shader_needs::{EntryNeeds, ShaderNeeds};
pub use super::survey::{
    backend_name, describe, device_type_name, survey, AdapterReport, Chosen, NoAdapter, Survey,
    INSTALL_HINT,
};

/// One texture format Tyndall uses, the usages it needs of it and why.
#[derive(Debug, Clone, Copy)]
pub struct FormatNeed {
    /// The format.
    pub format: wgpu::TextureFormat,
    /// Usages every qualifying adapter must allow.
    pub usages: wgpu::TextureUsages,
    /// What Tyndall keeps in it.
    pub role: &'static str,
}

/// Formats and usages an adapter must offer to qualify. (`Rg32Float` storage and float render
/// targets are not here: [`Capabilities`] substitutes for them.)
pub const NEEDED_FORMATS: &[FormatNeed] = &[
    FormatNeed {
        format: F::R32Float,
        usages: U::TEXTURE_BINDING
            .union(U::STORAGE_BINDING)
            .union(U::COPY_SRC)
            .union(U::COPY_DST),
        role: "Scalar, Depth and ShadowMap values and volumes",
    },
    FormatNeed {
        format: F::Rgba32Float,
        usages: U::TEXTURE_BINDING
            .union(U::STORAGE_BINDING)
            .union(U::COPY_SRC)
            .union(U::COPY_DST),
        role: "Image values",
    },
    FormatNeed {
        format: F::Depth32Float,
        usages: U::RENDER_ATTACHMENT,
        role: "the depth test of shadow-map and G-buffer rasterisation",
    },
];

/// One device limit Tyndall needs at least `need` of.
#[derive(Debug, Clone, Copy)]
pub struct LimitNeed {
    /// wgpu's name of the limit.
    pub name: &'static str,
    /// The least value that qualifies.
    pub need: u64,
    /// Why.
    pub why: &'static str,
    /// Reads the limit.
    pub get: fn(&wgpu::Limits) -> u64,
}

/// Limits an adapter must meet to qualify (a shader's own binding counts are checked per node).
pub const NEEDED_LIMITS: &[LimitNeed] = &[
    LimitNeed {
        name: "max_texture_dimension_2d",
        need: 2048,
        why: "a 1920×1080 render",
        get: |l| l.max_texture_dimension_2d as u64,
    },
    LimitNeed {
        name: "max_texture_dimension_3d",
        need: 256,
        why: "density volumes",
        get: |l| l.max_texture_dimension_3d as u64,
    },
    LimitNeed {
        name: "max_compute_invocations_per_workgroup",
        need: 64,
        why: "8×8 and 4×4×4 workgroups",
        get: |l| l.max_compute_invocations_per_workgroup as u64,
    },
    LimitNeed {
        name: "max_storage_textures_per_shader_stage",
        need: 1,
        why: "every compute pass writes a storage texture",
        get: |l| l.max_storage_textures_per_shader_stage as u64,
    },
];

/// Formats whose features [`Capabilities`] records.
const RECORDED: [wgpu::TextureFormat; 6] = [
    F::R32Float,
    F::Rg32Float,
    F::Rgba32Float,
    F::Depth32Float,
    F::R32Uint,
    F::Rgba32Uint,
];

/// What one adapter offers, as far as Tyndall cares.
#[derive(Debug, Clone)]
pub struct Capabilities {
    /// The adapter's limits.
    pub limits: wgpu::Limits,
    /// Its downlevel flags (compute shaders among them).
    pub downlevel: wgpu::DownlevelFlags,
    /// Its features.
    pub features: wgpu::Features,
    formats: Vec<(wgpu::TextureFormat, wgpu::TextureFormatFeatures)>,
    /// Take GL's substitutes on any adapter ([`Capabilities::emulating_gl`], which
    /// `GpuOptions::emulate_gl` — `TYNDALL_GPU_EMULATE=gl` — asks for): Rg32Float stored as
    /// Rgba32Float, rasterisation into integer bit patterns — so their results can be compared
    /// with the usual path on one adapter. Off as read from an adapter.
    pub emulate_gl: bool,
    /// Whether a compute pass can write every slice of a 3D storage texture. Not on wgpu's GL
    /// backend: it binds a 3D image non-layered (`glBindImageTexture(…, layered = false, layer
    /// 0, …)`), so only slice 0 would be written; volumes are then written through storage
    /// buffers ([`Capabilities::volume_rows`]).
    pub layered_3d_storage: bool,
    /// On wgpu's GL backend, the context's version as `GL_VERSION` gives it (wgpu reports it
    /// as the adapter's `driver_info`); `None` on other backends. wgpu calls a context
    /// compute-capable when the driver lists `GL_ARB_compute_shader`, but naga writes compute
    /// shaders only for GLSL 4.30 / ES 3.10, so the check reads the version itself
    /// ([`gl_context_lacks`]).
    pub gl_version: Option<String>,
    /// Passes of fewer invocations than this get their parameter block (`var<uniform>`) as a
    /// read-only storage buffer instead; 0: never, `u64::MAX`: always. Mesa's CPU drivers
    /// compile a shader per dispatch of a uniform block that steers a branch: see
    /// `src/engine/gpu/params.rs` for why and for the default ([`super::PARAMS_IN_STORAGE_BELOW`]
    /// there, 0 elsewhere); `TYNDALL_GPU_PARAMS=uniform|storage` chooses by hand.
    pub params_in_storage_below: u64,
}

impl Capabilities {
    /// Read them off an adapter.
    pub fn of(adapter: &wgpu::Adapter) -> Self {
        Self {
            limits: adapter.limits(),
            downlevel: adapter.get_downlevel_capabilities().flags,
            features: adapter.features(),
            formats: RECORDED
                .iter()
                .map(|f| (*f, adapter.get_texture_format_features(*f)))
                .collect(),
            emulate_gl: false,
            layered_3d_storage: adapter.get_info().backend != wgpu::Backend::Gl,
            gl_version: (adapter.get_info().backend == wgpu::Backend::Gl)
                .then(|| adapter.get_info().driver_info),
            params_in_storage_below: super::params::default_params_in_storage_below(adapter),
        }
    }

    /// The same capabilities taking GL's substitutes (see [`Capabilities::emulate_gl`]).
    pub fn emulating_gl(mut self) -> Self {
        self.emulate_gl = true;
        self
    }

    /// Whether passes write volume levels through a storage buffer copied into the texture
    /// before the volume is next read (see `src/engine/gpu/volume.rs`), rather than as a 3D storage
    /// texture: where the
    /// adapter cannot write every slice of one ([`Capabilities::layered_3d_storage`]), and when
    /// emulating GL.
    pub fn volume_rows(&self) -> bool {
        self.emulate_gl || !self.layered_3d_storage
    }

    /// The usages the adapter allows for `format` (empty for a format not recorded).
    pub fn usages(&self, format: wgpu::TextureFormat) -> wgpu::TextureUsages {
        self.formats
            .iter()
            .find(|(f, _)| *f == format)
            .map_or(U::empty(), |(_, feat)| feat.allowed_usages)
    }

    fn allows(&self, format: wgpu::TextureFormat, usages: wgpu::TextureUsages) -> bool {
        self.usages(format).contains(usages)
    }

    /// The format a texture of logical format `format` is stored in: itself where the adapter
    /// lets it be a storage texture, else the four-channel float format (GL has no `rg32float`
    /// images). Shaders are rewritten to match ([`Capabilities::adapt_source`]).
    pub fn stored(&self, format: wgpu::TextureFormat) -> wgpu::TextureFormat {
        if format == F::Rg32Float
            && (self.emulate_gl || !self.allows(F::Rg32Float, U::STORAGE_BINDING))
        {
            F::Rgba32Float
        } else {
            format
        }
    }

    /// The format a raster pass writes for a target stored as `format`: itself where it is
    /// renderable, else the 32-bit unsigned-integer format of as many channels (the floats'
    /// bit patterns, turned back into floats after the pass: see `raster.rs`), or `None` when
    /// neither can be rendered to.
    pub fn render_format(&self, format: wgpu::TextureFormat) -> Option<wgpu::TextureFormat> {
        if !self.emulate_gl && self.allows(format, U::RENDER_ATTACHMENT) {
            return Some(format);
        }
        let bits = if format.components() == 1 {
            F::R32Uint
        } else {
            F::Rgba32Uint
        };
        self.allows(bits, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING)
            .then_some(bits)
    }

    /// The usages a pooled texture stored as `format` is created with: binding, storage and
    /// copies always, render attachment where the adapter allows it.
    pub fn texture_usages(&self, format: wgpu::TextureFormat) -> wgpu::TextureUsages {
        let base = U::TEXTURE_BINDING | U::STORAGE_BINDING | U::COPY_SRC | U::COPY_DST;
        base | (self.usages(format) & U::RENDER_ATTACHMENT)
    }

    /// A shader's WGSL as this adapter runs it: storage formats replaced by what they are
    /// stored as (`rg32float` → `rgba32float` where [`Capabilities::stored`] says so), with
    /// `params_in_storage` the parameter blocks declared as read-only storage buffers (see
    /// [`Capabilities::params_in_storage_below`]), and 3D storage levels written through row
    /// buffers where [`Capabilities::volume_rows`] says so.
    pub fn adapt_source<'a>(
        &self,
        source: &'a str,
        params_in_storage: bool,
    ) -> std::borrow::Cow<'a, str> {
        let mut out = std::borrow::Cow::Borrowed(source);
        if self.stored(F::Rg32Float) != F::Rg32Float && source.contains("rg32float") {
            out = std::borrow::Cow::Owned(out.replace("<rg32float", "<rgba32float"));
        }
        if params_in_storage && source.contains("var<uniform>") {
            out = std::borrow::Cow::Owned(out.replace("var<uniform>", "var<storage, read>"));
        }
        if self.volume_rows() && source.contains("texture_storage_3d") {
            out = std::borrow::Cow::Owned(super::volume::rows_source(&out));
        }
        out
    }

    /// Why this adapter does not qualify (empty: it does).
    pub fn lacks(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self
            .downlevel
            .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        {
            out.push("compute shaders".to_string());
        } else if let Some(why) = self.gl_version.as_deref().and_then(gl_context_lacks) {
            out.push(why);
        }
        for need in NEEDED_FORMATS {
            let missing = need.usages - self.usages(need.format);
            if !missing.is_empty() {
                out.push(format!(
                    "{:?} as {} (for {})",
                    need.format,
                    usage_names(missing),
                    need.role
                ));
            }
        }
        for f in [F::R32Float, F::Rgba32Float] {
            if self.render_format(f).is_none() {
                out.push(format!(
                    "a render target for {f:?} values (for shadow maps and G-buffers)"
                ));
            }
        }
        for l in NEEDED_LIMITS {
            let have = (l.get)(&self.limits);
            if have < l.need {
                out.push(format!(
                    "{} ≥ {} (has {have}; for {})",
                    l.name, l.need, l.why
                ));
            }
        }
        out
    }

    /// What this adapter lacks for a shader's entry points (empty: it can run all of them).
    pub fn lacks_for(&self, needs: &ShaderNeeds) -> Vec<String> {
        let l = &self.limits;
        let mut out = Vec::new();
        let mut note = |what: String| {
            if !out.contains(&what) {
                out.push(what);
            }
        };
        for e in &needs.entries {
            // Parameter blocks count as storage buffers where they may be bound as such, and as
            // uniforms where they may stay uniforms (as both when the pass size decides).
            let below = self.params_in_storage_below;
            // Volume levels written through row buffers are storage buffers, not textures.
            let rows = u32::from(self.volume_rows()) * e.storage_3d;
            let as_storage = u32::from(below > 0) * e.uniform_buffers + rows;
            let as_uniform = u32::from(below < u64::MAX) * e.uniform_buffers;
            let counts = [
                (
                    "storage textures",
                    e.storage_textures - rows,
                    l.max_storage_textures_per_shader_stage,
                ),
                (
                    "sampled textures",
                    e.sampled_textures,
                    l.max_sampled_textures_per_shader_stage,
                ),
                (
                    "storage buffers",
                    e.storage_buffers + as_storage,
                    l.max_storage_buffers_per_shader_stage,
                ),
                (
                    "uniform buffers",
                    as_uniform,
                    l.max_uniform_buffers_per_shader_stage,
                ),
            ];
            for (what, need, have) in counts {
                if need > have {
                    note(format!(
                        "{need} {what} per shader stage (entry `{}`; the adapter allows {have})",
                        e.entry
                    ));
                }
            }
            let [x, y, z] = e.workgroup;
            if x > l.max_compute_workgroup_size_x
                || y > l.max_compute_workgroup_size_y
                || z > l.max_compute_workgroup_size_z
                || x * y * z > l.max_compute_invocations_per_workgroup
            {
                note(format!("workgroups of {x}×{y}×{z} (entry `{}`)", e.entry));
            }
            for f in &e.storage_formats {
                if !self.allows(self.stored(*f), U::STORAGE_BINDING) {
                    note(format!("{f:?} storage textures (entry `{}`)", e.entry));
                }
            }
        }
        out
    }
}

/// What a GL context of version `version` (`GL_VERSION`: `4.5 (Core Profile) Mesa 22.3.6`,
/// `3.3.0 NVIDIA 580.95.05`, `OpenGL ES 3.2 Mesa …`) lacks for Tyndall's compute passes: `None`
/// from OpenGL 4.3 and OpenGL ES 3.1 on (and for a version it cannot read, which wgpu would not
/// have opened), else one line naming the context and what to do.
pub fn gl_context_lacks(version: &str) -> Option<String> {
    let v = version.trim();
    let (es, rest) = match v.strip_prefix("OpenGL ES") {
        Some(r) => (true, r.trim_start()),
        None => (false, v),
    };
    let number = rest.split_whitespace().next()?;
    let mut parts = number.split('.');
    let major: u32 = parts.next()?.parse().ok()?;
    let minor: u32 = parts
        .next()?
        .trim_end_matches(|c: char| !c.is_ascii_digit())
        .parse()
        .ok()?;
    let need = if es { (3, 1) } else { (4, 3) };
    if (major, minor) >= need {
        return None;
    }
    let api = if es { "OpenGL ES" } else { "OpenGL" };
    Some(format!(
        "compute shaders: the driver gave an {api} {major}.{minor} context ({v}) and compute passes need {api} ≥ {}.{} (Tyndall asked for 4.6 down to 4.3 first: update the driver, or use the Vulkan backend, WGPU_BACKEND=vulkan)",
        need.0, need.1
    ))
}

fn usage_names(u: wgpu::TextureUsages) -> String {
    let names = [
        (U::TEXTURE_BINDING, "texture binding"),
        (U::STORAGE_BINDING, "storage texture"),
        (U::RENDER_ATTACHMENT, "render target"),
        (U::COPY_SRC, "copy source"),
        (U::COPY_DST, "copy destination"),
    ];
    names
        .iter()
        .filter(|(f, _)| u.contains(*f))
        .map(|(_, n)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}
