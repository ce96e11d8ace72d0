//! Pictures on screen. When the window draws with the evaluation's device ([`WindowGpu`]: not on
//! wgpu's GL backend, not after a lost device, and only when the window's adapter is the one the
//! evaluation chose), the worker sends the evaluated textures and each shown picture is one
//! display pass on the GPU ([`crate::display`]) registered with egui as a native texture —
//! nothing read back but the probed pixel. Otherwise pictures come read back and are converted
//! on the CPU into egui textures, as before.

use std::sync::Arc;

use eframe::egui;
use eframe::egui_wgpu::RenderState;
use tyndall_engine::colour_pass::ViewTransform;
use tyndall_engine::gpu::{device_request, Gpu, GpuTexture, TexelRead};

use crate::display::{Display, Look, Shown};
use crate::view::Channel;
use crate::worker::{Picture, Worker};

/// A picture as egui draws it.
pub enum ShownTexture {
    /// Made from read-back pixels (egui's own texture).
    Managed(egui::TextureHandle),
    /// Drawn by the display pass on the window's device.
    Native(Box<Native>),
}

/// A display-pass texture registered with egui's renderer (freed there when dropped).
pub struct Native {
    id: egui::TextureId,
    size: egui::Vec2,
    _drawn: Shown,
    window: RenderState,
}

impl Drop for Native {
    fn drop(&mut self) {
        self.window.renderer.write().free_texture(&self.id);
    }
}

impl ShownTexture {
    /// egui's id of the texture.
    pub fn id(&self) -> egui::TextureId {
        match self {
            ShownTexture::Managed(t) => t.id(),
            ShownTexture::Native(n) => n.id,
        }
    }

    /// Its size in texels.
    pub fn size_vec2(&self) -> egui::Vec2 {
        match self {
            ShownTexture::Managed(t) => t.size_vec2(),
            ShownTexture::Native(n) => n.size,
        }
    }
}

/// The window's device when the evaluation shares it: egui's renderer and the display pass.
pub struct WindowGpu {
    /// eframe's wgpu state (device, queue, renderer).
    pub render: RenderState,
    /// The evaluation's context on the same device.
    pub gpu: Arc<Gpu>,
    display: Display,
}

impl WindowGpu {
    /// The evaluation's context on the window's device, when they can be one: the window's
    /// adapter is the one `evaluation` runs on, not wgpu's GL backend (a long pass there holds
    /// the context lock the window's frames need), and its device was created with the
    /// features and limits Tyndall asks for ([`device_request`], which `run` passes to eframe).
    pub fn share(render: &RenderState, evaluation: &Gpu) -> Option<WindowGpu> {
        let info = render.adapter.get_info();
        let same = info.name == evaluation.info.name && info.backend == evaluation.info.backend;
        let (features, limits) = device_request(&render.adapter);
        if !same
            || !tyndall_engine::display::window_shares_device(evaluation)
            || !render.device.features().contains(features)
            || !limits.check_limits(&render.device.limits())
        {
            return None;
        }
        let gpu = Arc::new(Gpu::on_device(
            &render.adapter,
            render.device.clone(),
            render.queue.clone(),
            evaluation,
        ));
        let display = match Display::new(&gpu) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("warning: the viewer reads pictures back: its display pass failed: {e}");
                return None;
            }
        };
        Some(WindowGpu {
            render: render.clone(),
            gpu,
            display,
        })
    }

    /// `t` drawn as `look` says and registered with egui (`None` when the pass failed: the
    /// picture is left out, as a failed read-back was).
    pub fn draw(&self, t: &GpuTexture, look: Look) -> Option<ShownTexture> {
        let drawn = self.display.draw(&self.gpu, t, look).ok()?;
        let id = self.render.renderer.write().register_native_texture(
            &self.render.device,
            &drawn.view,
            wgpu::FilterMode::Nearest,
        );
        Some(ShownTexture::Native(Box::new(Native {
            id,
            size: egui::vec2(drawn.size.0 as f32, drawn.size.1 as f32),
            _drawn: drawn,
            window: self.render.clone(),
        })))
    }
}

/// How the viewer shows a picture: channel, exposure in stops, display transform (None: plain
/// sRGB).
pub type ViewerLook<'a> = (Channel, f32, Option<&'a ViewTransform>);

/// `picture` on screen as the viewer shows it (`how`): the display pass — after the transform's
/// GPU pass when there is one — for a texture (on `window`), the CPU conversion for read-back
/// pixels.
pub fn viewer_texture(
    ctx: &egui::Context,
    window: Option<&WindowGpu>,
    name: &str,
    picture: &Picture,
    how: ViewerLook<'_>,
) -> Option<ShownTexture> {
    let (channel, stops, transform) = how;
    match picture {
        Picture::Pixels(r) => {
            let image = super::colour_image(r, how);
            Some(ShownTexture::Managed(ctx.load_texture(
                name,
                image,
                egui::TextureOptions::NEAREST,
            )))
        }
        Picture::Texture(t) => match transform {
            None => window?.draw(t, Look::viewer(channel, stops)),
            Some(transform) => {
                let window = window?;
                let viewed = tyndall_engine::colour_pass::view(
                    &window.gpu.recorder(),
                    transform.pass(),
                    t,
                    channel,
                    stops,
                )
                .ok()?;
                window.draw(&viewed, Look::encoded())
            }
        },
    }
}

/// A node thumbnail on screen: shrunk on the GPU for a texture, converted on the CPU for pixels
/// the worker already shrank.
pub fn thumbnail_texture(
    ctx: &egui::Context,
    window: Option<&WindowGpu>,
    id: &str,
    picture: &Picture,
) -> Option<ShownTexture> {
    match picture {
        Picture::Pixels(r) => {
            let image = super::colour_image(r, (Channel::Rgb, 0.0, None));
            Some(ShownTexture::Managed(ctx.load_texture(
                format!("thumb-{id}"),
                image,
                egui::TextureOptions::LINEAR,
            )))
        }
        Picture::Texture(t) => {
            window?.draw(t, Look::thumbnail(t.width, t.height, crate::worker::THUMB))
        }
    }
}

/// Reads of one pixel in flight: the pixel and each port's read.
type PixelReads = ((u32, u32), Vec<(String, TexelRead)>);

/// The pixel probe's reads in flight: the values under the pointer of every texture shown,
/// read back without waiting (4–16 bytes each).
#[derive(Default)]
pub struct Probe {
    /// The pixel asked for and its reads by port.
    pending: Option<PixelReads>,
    /// The pixel whose reads were last started.
    asked: Option<(u32, u32)>,
}

impl Probe {
    /// Ask for pixel (`x`, `y`) of the textures among `pictures` (once per pixel), and give the
    /// probe's line once every read is back.
    pub fn update(
        &mut self,
        gpu: &Gpu,
        pictures: &[(String, Picture)],
        x: u32,
        y: u32,
    ) -> Option<String> {
        if self.asked != Some((x, y)) {
            self.asked = Some((x, y));
            let rec = gpu.recorder();
            let reads = pictures
                .iter()
                .filter_map(|(port, p)| match p {
                    Picture::Texture(t) if x < t.width && y < t.height => {
                        Some((port.clone(), rec.read_texel_async(t, x, y).ok()?))
                    }
                    _ => None,
                })
                .collect();
            self.pending = Some(((x, y), reads));
        }
        self.poll(gpu)
    }

    /// The probe's line once every read of the newest pixel is back.
    pub fn poll(&mut self, gpu: &Gpu) -> Option<String> {
        let ((x, y), reads) = self.pending.as_ref()?;
        let mut values = Vec::new();
        for (port, read) in reads {
            // A failed read leaves its port out of the line, as a failed download did.
            if let Ok(v) = read.try_take(gpu)? {
                values.push((port.clone(), v));
            }
        }
        let line = crate::view::probe_line(*x, *y, &values);
        self.pending = None;
        Some(line)
    }

    /// Whether reads are still in flight (the window draws again soon to take them).
    pub fn waiting(&self) -> bool {
        self.pending.is_some()
    }
}

impl super::EditorApp {
    /// On the first frame: when the window draws with the adapter the evaluation runs on (not
    /// GL), move the evaluation onto the window's device, so pictures are drawn from the
    /// textures they were evaluated into ([`WindowGpu::share`]). The process-wide
    /// [`Gpu::shared`] stays as it was: after a lost device the editor restarts on it.
    pub(super) fn share_window_device(&mut self, frame: &eframe::Frame) {
        if std::mem::replace(&mut self.window_checked, true) {
            return;
        }
        let (Some(render), Some(worker)) = (frame.wgpu_render_state(), self.worker.as_ref()) else {
            return;
        };
        let Some(window) = WindowGpu::share(render, worker.gpu()) else {
            return;
        };
        if let Some(old) = self.worker.take() {
            old.abandon();
        }
        self.worker = Some(Worker::start(self.registry.clone(), window.gpu.clone()));
        self.requested.clear();
        self.jobs.reset();
        self.window = Some(window);
    }

    /// Whether the viewer draws evaluated textures on the window's device (no read-back).
    pub fn shares_window_device(&self) -> bool {
        self.window.is_some()
    }

    /// The context the document is evaluated on (the window's device while shared), if any.
    pub fn evaluation_gpu(&self) -> Option<&Arc<Gpu>> {
        self.worker.as_ref().map(Worker::gpu)
    }
}
