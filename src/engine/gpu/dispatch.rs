//! Compute dispatches: pipelines cached by (shader, entry point, binding signature), the
//! bindings checked against what the entry point uses, the workgroup count from the entry
//! point's own `@workgroup_size`.

use super::prepare::{Recipe, Slot};
use super::shader_needs::BindingKind;
use super::*;

impl Gpu {
    /// What `shader` needs, read once per stem with naga and kept.
    pub(crate) fn needs(&self, shader: Shader) -> Result<Arc<adapter::ShaderNeeds>, GpuError> {
        let mut known = self.shader_needs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = known.get(shader.stem) {
            return Ok(n.clone());
        }
        let needs = shader
            .wgsl()
            .and_then(adapter::ShaderNeeds::of)
            .map_err(|e| GpuError::Validation(format!("shader {}.wgsl: {e}", shader.stem)))?;
        let needs = Arc::new(needs);
        known.insert(shader.stem, needs.clone());
        Ok(needs)
    }

    /// What entry point `entry` of `shader` uses (its workgroup size, its bindings).
    fn entry_needs(&self, shader: Shader, entry: &str) -> Result<EntryRef, GpuError> {
        let needs = self.needs(shader)?;
        let index = needs
            .entries
            .iter()
            .position(|e| e.entry == entry)
            .ok_or_else(|| {
                GpuError::Validation(format!(
                    "shader {}.wgsl has no entry point `{entry}`",
                    shader.stem
                ))
            })?;
        Ok(EntryRef { needs, index })
    }

    /// `binds` with each WGSL variable name replaced by its binding number in `shader`.
    fn numbered<'a>(
        &self,
        shader: Shader,
        binds: &[(&str, Bind<'a>)],
    ) -> Result<Vec<(u32, Bind<'a>)>, GpuError> {
        let needs = self.needs(shader)?;
        binds
            .iter()
            .map(|(name, b)| match needs.binding(name) {
                Some(n) => Ok((n, *b)),
                None => Err(GpuError::Validation(format!(
                    "shader {}.wgsl has no binding `{name}` (it has {})",
                    shader.stem,
                    needs
                        .names
                        .iter()
                        .map(|(n, _)| format!("`{n}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))),
            })
            .collect()
    }

    /// Whether the pipeline of `key` was made (or is being made).
    pub(crate) fn has_pipeline(&self, key: &str) -> bool {
        let cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache.contains_key(key)
    }

    /// The pipeline `recipe` describes, and whether this call created it: made by the first
    /// caller, waited for by others meanwhile (a worker of [`Gpu::prepare_pipelines`] and the
    /// node that needs it), kept for the context's life. A failure is not kept: the next call
    /// tries again.
    pub(crate) fn obtain_pipeline(
        &self,
        shader: Shader,
        recipe: &Recipe,
        key: &str,
    ) -> Result<(Arc<wgpu::ComputePipeline>, bool), GpuError> {
        let cell = {
            let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
            cache.entry(key.to_string()).or_default().clone()
        };
        let mut created = false;
        let made = cell.get_or_init(|| {
            created = true;
            self.create_pipeline(shader, recipe, key)
        });
        match made {
            Ok(p) => Ok((p.clone(), created)),
            Err(e) => {
                let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
                if cache.get(key).is_some_and(|c| Arc::ptr_eq(c, &cell)) {
                    cache.remove(key);
                }
                Err(e.clone())
            }
        }
    }

    fn create_pipeline(
        &self,
        shader: Shader,
        recipe: &Recipe,
        key: &str,
    ) -> Result<Arc<wgpu::ComputePipeline>, GpuError> {
        let entry = recipe.entry.as_str();
        check_binds(shader, &*self.entry_needs(shader, entry)?, &recipe.slots)?;
        let source = shader.wgsl().map_err(GpuError::Validation)?;
        let created = std::time::Instant::now();
        let params_in_storage = recipe.params_in_storage;
        let constants: Vec<(&str, f64)> = recipe
            .constants
            .iter()
            .map(|(n, v)| (n.as_str(), *v))
            .collect();
        let p = self
            .scoped_here(|| {
                let entries: Vec<wgpu::BindGroupLayoutEntry> = recipe
                    .slots
                    .iter()
                    .map(|(i, slot)| wgpu::BindGroupLayoutEntry {
                        binding: *i,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: self.binding_type(*slot, params_in_storage),
                        count: None,
                    })
                    .collect();
                let bgl = self
                    .device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some(key),
                        entries: &entries,
                    });
                let layout = self
                    .device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some(key),
                        bind_group_layouts: &[Some(&bgl)],
                        immediate_size: 0,
                    });
                let adapted = self.caps.adapt_source(source, params_in_storage);
                self.disk.note(key, &adapted);
                let module = self
                    .device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(shader.stem),
                        source: wgpu::ShaderSource::Wgsl(adapted),
                    });
                Arc::new(
                    self.device
                        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                            label: Some(key),
                            layout: Some(&layout),
                            module: &module,
                            entry_point: Some(entry),
                            compilation_options: wgpu::PipelineCompilationOptions {
                                constants: &constants,
                                ..Default::default()
                            },
                            cache: self.disk.cache.as_ref(),
                        }),
                )
            })
            .map_err(|e| match e {
                GpuError::Validation(m) => {
                    GpuError::Validation(format!("shader {}.wgsl, entry {entry}: {m}", shader.stem))
                }
                other => other,
            })?;
        crate::trace::pipeline_created(key, created);
        Ok(p)
    }

    /// The layout type of one binding: what `b` is, on this adapter.
    fn binding_type(&self, slot: Slot, params_in_storage: bool) -> wgpu::BindingType {
        let storage_buffer = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let texture = |view_dimension| wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension,
            multisampled: false,
        };
        match slot {
            Slot::Uniform => wgpu::BindingType::Buffer {
                ty: adapter::Capabilities::params_binding(params_in_storage),
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            Slot::Texture => texture(wgpu::TextureViewDimension::D2),
            Slot::Storage(format) => wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: format.wgpu(),
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            Slot::Buffer => storage_buffer,
            Slot::Volume => texture(wgpu::TextureViewDimension::D3),
            // Written through its row buffer where the adapter cannot write every slice of a
            // 3D storage texture (see volume.rs).
            Slot::VolumeLevel if self.caps.volume_rows() => storage_buffer,
            Slot::VolumeLevel => wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: wgpu::TextureFormat::R32Float,
                view_dimension: wgpu::TextureViewDimension::D3,
            },
        }
    }
}

impl Recorder<'_> {
    /// The pipeline of a dispatch: made once per [`Recipe`] (its key), remembered under the
    /// running node's kind for [`Gpu::prepare_pipelines`].
    fn pipeline(
        &self,
        shader: Shader,
        entry: &str,
        binds: &[(u32, Bind)],
        constants: &[(&str, f64)],
        params_in_storage: bool,
    ) -> Result<Arc<wgpu::ComputePipeline>, GpuError> {
        // What the adapter lacks for this shader, in one line, rather than a driver error (for
        // a node's shaders checked before it runs, a lookup of the answer kept then).
        self.supports(shader)?;
        let recipe = Recipe::of(shader, entry, binds, constants, params_in_storage);
        let key = recipe.key();
        let (pipeline, _) = self.obtain_pipeline(shader, &recipe, &key)?;
        // Remembered under the running node's kind, for the next evaluation to prepare.
        self.used_pipeline(&key);
        Ok(pipeline)
    }

    /// Run one compute entry point over (at least) `width × height` invocations, in workgroups
    /// of the entry point's own `@workgroup_size` (read from the WGSL). Bindings are
    /// `(WGSL variable name, resource)` in group 0: the number is the shader's own (reflected
    /// with naga), a name the shader does not declare is an error, and every binding the entry
    /// point uses must be given as a resource of its kind. Pipelines are cached by (shader stem,
    /// entry point, binding signature).
    pub fn dispatch(
        &self,
        shader: Shader,
        entry: &str,
        binds: &[(&str, Bind)],
        width: u32,
        height: u32,
    ) -> Result<(), GpuError> {
        self.dispatch_with(shader, entry, binds, (width, height), &[])
    }

    /// [`Recorder::dispatch`] with values for the shader's pipeline-overridable constants
    /// (`override NAME: T = default;` in WGSL): each set of values is its own cached pipeline, and
    /// the driver compiles branches on them away. For switches that stay fixed over a dispatch
    /// (a mode of the node): code behind a uniform-buffer flag is still compiled in and, on SIMD
    /// drivers such as lavapipe, may be stepped through masked in every loop iteration.
    pub fn dispatch_with(
        &self,
        shader: Shader,
        entry: &str,
        binds: &[(&str, Bind)],
        (width, height): (u32, u32),
        constants: &[(&str, f64)],
    ) -> Result<(), GpuError> {
        let binds = &self.numbered(shader, binds)?;
        let storage = self
            .caps
            .params_in_storage(u64::from(width) * u64::from(height));
        let pipeline = self.pipeline(shader, entry, binds, constants, storage)?;
        let groups = self.entry_needs(shader, entry)?.groups([width, height, 1]);
        let start = tracing().then(|| {
            let _ = self.wait();
            std::time::Instant::now()
        });
        let groups = Workgroups::Count(groups);
        self.scoped(|| self.record(&pipeline, shader, binds, groups, storage))??;
        if let Some(start) = start {
            self.wait()?;
            eprintln!(
                "pass {}:{entry} {width}x{height}: {:.2} ms",
                shader.stem,
                start.elapsed().as_secs_f64() * 1e3
            );
        }
        Ok(())
    }

    /// Run compute entry point `entry` over (at least) `size` invocations in x, y, z, in
    /// workgroups of its own `@workgroup_size` — for passes over volumes.
    pub fn dispatch_3d(
        &self,
        shader: Shader,
        entry: &str,
        binds: &[(&str, Bind)],
        size: [u32; 3],
    ) -> Result<(), GpuError> {
        let binds = &self.numbered(shader, binds)?;
        let storage = self
            .caps
            .params_in_storage(size.iter().map(|n| u64::from(*n)).product());
        let pipeline = self.pipeline(shader, entry, binds, &[], storage)?;
        let groups = Workgroups::Count(self.entry_needs(shader, entry)?.groups(size));
        self.scoped(|| self.record(&pipeline, shader, binds, groups, storage))?
    }

    /// Run compute entry point `entry` over the workgroup counts (x, y, z) held in the first
    /// three words of `args`, written there by an earlier pass — a pass sized by what the GPU
    /// found (a list's length) without reading the size back. With `constants` as in
    /// [`Recorder::dispatch_with`].
    pub fn dispatch_indirect(
        &self,
        shader: Shader,
        entry: &str,
        binds: &[(&str, Bind)],
        args: &GpuBuffer,
        constants: &[(&str, f64)],
    ) -> Result<(), GpuError> {
        if args.words < 3 {
            return Err(GpuError::Validation(format!(
                "{}:{entry}: an indirect dispatch needs 3 words of workgroup counts, not {}",
                shader.stem, args.words
            )));
        }
        let binds = &self.numbered(shader, binds)?;
        // The size is the GPU's: the parameter block is a uniform (the form for large passes).
        let storage = self.caps.params_in_storage(u64::MAX);
        let pipeline = self.pipeline(shader, entry, binds, constants, storage)?;
        let groups = Workgroups::Indirect(&args.raw);
        self.scoped(|| self.record(&pipeline, shader, binds, groups, storage))?
    }

    fn record(
        &self,
        pipeline: &wgpu::ComputePipeline,
        shader: Shader,
        binds: &[(u32, Bind)],
        groups: Workgroups,
        params_in_storage: bool,
    ) -> Result<(), GpuError> {
        let buffers: Vec<Option<wgpu::Buffer>> = binds
            .iter()
            .map(|(_, b)| match b {
                Bind::Uniform(bytes) => {
                    let size = (bytes.len() as u64).div_ceil(16) * 16;
                    let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("uniform"),
                        size: size.max(16),
                        usage: adapter::Capabilities::params_usage(params_in_storage),
                        mapped_at_creation: false,
                    });
                    let mut padded = bytes.to_vec();
                    padded.resize(size.max(16) as usize, 0);
                    self.queue.write_buffer(&buf, 0, &padded);
                    Some(buf)
                }
                _ => None,
            })
            .collect();
        let mut entries = Vec::with_capacity(binds.len());
        for ((i, b), buf) in binds.iter().zip(&buffers) {
            let resource = match (b, buf) {
                (Bind::Texture(t), _) | (Bind::Storage(t), _) => {
                    wgpu::BindingResource::TextureView(t.view())
                }
                (Bind::Uniform(_), Some(buf)) => buf.as_entire_binding(),
                (Bind::Buffer(b), _) => b.raw.as_entire_binding(),
                (Bind::Volume(v), _) => wgpu::BindingResource::TextureView(v.view()),
                (Bind::VolumeLevel(v, l), _) => match v.rows(*l) {
                    Some(rows) => rows.as_entire_binding(),
                    None => wgpu::BindingResource::TextureView(v.level_view(*l)),
                },
                (Bind::VolumeLevelRead(v, l), _) => {
                    wgpu::BindingResource::TextureView(v.level_view(*l))
                }
                (Bind::Uniform(_), None) => {
                    return Err(GpuError::Validation(format!(
                        "{}: uniform {i} has no buffer",
                        shader.stem
                    )))
                }
            };
            entries.push(wgpu::BindGroupEntry {
                binding: *i,
                resource,
            });
        }
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(shader.stem),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let pass = |enc: &mut wgpu::CommandEncoder, timer: Option<&super::PassTimer>| {
            // Volumes this pass reads: what was written through their row buffers, first.
            for (_, b) in binds {
                if let Bind::Volume(v) | Bind::VolumeLevelRead(v, _) = b {
                    v.flush_rows(enc);
                }
            }
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(shader.stem),
                timestamp_writes: timer.map(|t| wgpu::ComputePassTimestampWrites {
                    query_set: &t.query,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            match groups {
                Workgroups::Count([x, y, z]) => pass.dispatch_workgroups(x, y, z),
                Workgroups::Indirect(args) => pass.dispatch_workgroups_indirect(args, 0),
            }
            drop(pass);
            // Volume levels written through row buffers: copied into their textures when
            // something reads them (see volume.rs).
            for (_, b) in binds {
                if let Bind::VolumeLevel(v, l) = b {
                    v.mark_written(*l);
                }
            }
        };
        // Into the recorder's encoder; timed, with its timestamps resolved after it.
        for (_, b) in binds {
            if let Bind::Texture(t) | Bind::Storage(t) = b {
                self.uses(t);
            }
        }
        let Some(timer) = self.pass_timer(shader.stem) else {
            self.encode(|enc| pass(enc, None));
            return Ok(());
        };
        self.encode(|enc| {
            pass(enc, Some(&timer));
            self.resolve_timer(&timer, enc);
        });
        self.keep_timer(timer);
        Ok(())
    }
}

/// How many workgroups a pass runs.
#[derive(Clone, Copy)]
enum Workgroups<'a> {
    /// Counted on the CPU.
    Count([u32; 3]),
    /// Written by an earlier pass into a buffer's first three words.
    Indirect(&'a wgpu::Buffer),
}

/// One entry point's needs, kept with the shader's.
struct EntryRef {
    needs: Arc<adapter::ShaderNeeds>,
    index: usize,
}

impl std::ops::Deref for EntryRef {
    type Target = adapter::EntryNeeds;
    fn deref(&self) -> &adapter::EntryNeeds {
        &self.needs.entries[self.index]
    }
}

/// The checked binding table: every binding the entry point uses is given, as a resource of
/// its kind (a resource for a binding the entry point does not use is allowed: a node passes
/// one list to the several entry points of a method).
fn check_binds(
    shader: Shader,
    e: &adapter::EntryNeeds,
    slots: &[(u32, Slot)],
) -> Result<(), GpuError> {
    for (number, name, kind) in &e.bindings {
        let at = || {
            format!(
                "shader {}.wgsl, entry {}: binding {number} (`{name}`)",
                shader.stem, e.entry
            )
        };
        match slots.iter().find(|(n, _)| n == number) {
            None => {
                return Err(GpuError::Validation(format!(
                    "{} is used but not bound",
                    at()
                )))
            }
            Some((_, s)) if s.kind() != *kind && *kind != BindingKind::Other => {
                return Err(GpuError::Validation(format!(
                    "{} is {} but was given {}",
                    at(),
                    kind.name(),
                    s.kind().name()
                )))
            }
            Some(_) => {}
        }
    }
    Ok(())
}
