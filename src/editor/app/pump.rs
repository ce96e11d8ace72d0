//! The link to the evaluation worker: a request when what is shown changed, the results taken
//! in (thumbnails, reports, the viewer's pictures), and a new worker when the device is lost.

use super::*;

impl EditorApp {
    /// Send the worker a request when the document, the time or the viewed node changed, and
    /// take in what it finished.
    pub(super) fn pump(&mut self, ctx: &egui::Context) {
        let view = self.viewed();
        // A knob dragged, the timeline scrubbed or playing: evaluate at the proxy factor.
        let interacting = ctx.dragged_id().is_some() || self.playing;
        let Some(worker) = self.worker.as_mut() else {
            return;
        };
        // The whole document: an undo while inside a group may change what lies outside it.
        let key = format!(
            "{:?}|{:?}@{}:{}",
            view,
            self.wipe,
            self.time,
            tyndall_engine::graph::save_string(self.state.root())
        );
        let changed = key != self.requested;
        // A change while interacting is shown at the proxy size; the interaction's end asks
        // for the full picture of the same document.
        let ended = !interacting && self.proxy.requested > 1;
        if changed || ended {
            self.requested = key;
            self.proxy.requested = if changed && interacting {
                self.proxy.factor
            } else {
                1
            };
            worker.request(Request {
                generation: 0,
                graph: crate::worker::graph_for_evaluation(&self.registry, &self.state),
                time: self.time,
                size: VIEW_SIZE,
                view,
                compare: self.wipe.clone(),
                proxy: self.proxy.requested,
                textures: self.window.is_some(),
            });
        }
        if let Some(p) = worker.poll_progress() {
            self.progress = Some(p);
        }
        let mut lost = None;
        for out in worker.poll() {
            lost = lost.or(out.device_lost);
            // Nodes no longer in the (flattened) document lose their pictures and reports.
            self.thumbs.retain(|id, _| out.nodes.contains_key(id));
            self.reports.retain(|id, _| out.nodes.contains_key(id));
            self.aliases = out.aliases;
            for (id, rep) in out.nodes {
                if let Some(t) = &rep.thumb {
                    let window = self.window.as_ref();
                    if let Some(tex) = shown::thumbnail_texture(ctx, window, &id, t) {
                        self.thumbs.insert(id.clone(), tex);
                    }
                }
                self.reports.insert(id, NodeReport { thumb: None, ..rep });
            }
            if out.view.is_some() {
                self.pictures = out.view;
                self.view_tex = None;
                // The probe reads the new pictures at the pixel under the pointer.
                self.probe_reads = shown::Probe::default();
            }
            if out.compare.is_some() || self.wipe.is_none() {
                self.compare = out.compare;
                self.wipe_tex = None;
            }
            self.proxy.took(out.proxy, out.size, out.elapsed);
            let ran = self.reports.values().filter(|r| r.status.ran()).count();
            let errors = self.reports.values().filter(|r| r.error.is_some()).count();
            self.status = match errors {
                0 => format!(
                    "{}: {ran} ran in {:.0} ms",
                    self.proxy.shown_text(),
                    out.elapsed.as_secs_f64() * 1e3
                ),
                n => format!("{n} node(s) failed; see the canvas"),
            };
            if self.device_restarts > 0 {
                // Kept in view: the restart message itself is replaced by the first summary.
                self.status +=
                    &format!(" (GPU device lost and replaced {}×)", self.device_restarts);
            }
        }
        if let Some(reason) = lost {
            self.restart_after_loss(&reason);
            ctx.request_repaint();
        } else if !worker.idle() {
            ctx.request_repaint_after(Duration::from_millis(30));
        }
    }

    /// Send the jobs the tools asked for this frame and file the answers; draw again soon while
    /// one is open (its tool takes the answer when it next draws).
    pub(super) fn exchange_jobs(&mut self, ctx: &egui::Context) {
        let answered = self.jobs.exchange(self.worker.as_mut());
        if answered {
            // Taken by its tool on the next frame.
            ctx.request_repaint();
        } else if self.jobs.waiting() {
            ctx.request_repaint_after(Duration::from_millis(30));
        }
    }

    /// The worker's device was lost: drop the worker (and its cache, which lived on that
    /// device), start a new one on a new device and ask for the whole evaluation again.
    fn restart_after_loss(&mut self, reason: &str) {
        if let Some(old) = self.worker.take() {
            old.abandon();
        }
        // The window's device went with it (when shared): pictures are read back from now on.
        if self.window.take().is_some() {
            self.thumbs.clear();
            self.view_tex = None;
            self.wipe_tex = None;
            self.pictures = None;
            self.compare = None;
        }
        self.requested.clear();
        self.progress = None;
        self.jobs.reset();
        match Gpu::shared() {
            Ok(gpu) => {
                self.worker = Some(Worker::start(self.registry.clone(), gpu));
                self.device_restarts += 1;
                self.status = format!("{reason}: restarted on a new device");
            }
            Err(e) => {
                self.status = format!("{reason}; no new device ({e}): pictures are off");
            }
        }
    }
}

/// Proxy evaluation in the window: the factor used while a knob is dragged, kept so that a
/// proxy update lands within [`ProxyState::BUDGET`] (halving or doubling the resolution
/// after each proxy result), and what the viewer shows now.
#[derive(Debug, Clone)]
pub struct ProxyState {
    /// The factor of the next proxy request: 2 (½), 4 (¼) or 8 (⅛).
    pub factor: u32,
    /// The factor of the last request sent (1: full resolution).
    pub requested: u32,
    /// The factor and size of the pictures shown.
    pub shown: (u32, (u32, u32)),
}

impl Default for ProxyState {
    fn default() -> Self {
        Self {
            factor: 2,
            requested: 1,
            shown: (1, VIEW_SIZE),
        }
    }
}

impl ProxyState {
    /// The time a proxy update should take at most (a few frames at 60 Hz).
    pub const BUDGET: Duration = Duration::from_millis(100);

    /// A result came in: note what is shown, and adapt the proxy factor to the budget.
    pub fn took(&mut self, proxy: u32, size: (u32, u32), elapsed: Duration) {
        self.shown = (proxy, size);
        if proxy > 1 {
            if elapsed > Self::BUDGET && self.factor < 8 {
                self.factor *= 2;
            } else if elapsed < Self::BUDGET / 4 && self.factor > 2 {
                self.factor /= 2;
            }
        }
    }

    /// Which resolution the viewer shows, for the status bar: `full 480×270` or
    /// `proxy ½ 240×135`.
    pub fn shown_text(&self) -> String {
        let (f, (w, h)) = self.shown;
        match f {
            1 => format!("full {w}×{h}"),
            2 => format!("proxy ½ {w}×{h}"),
            4 => format!("proxy ¼ {w}×{h}"),
            f => format!("proxy 1/{f} {w}×{h}"),
        }
    }

    /// The shown pictures' scale on screen: a proxy picture is drawn at the full size.
    pub fn display_scale(&self) -> f32 {
        self.shown.0 as f32
    }
}
