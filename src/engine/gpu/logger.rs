//! wgpu's error log records captured per thread, so validation-layer messages become errors
//! of the GPU call that caused them.

/// Collects error-level log records from wgpu (the Vulkan validation layer reports through
/// them) so that [`Gpu::take_errors`](super::Gpu::take_errors) turns them into failures; installed when validation is on.
pub(super) struct ValidationLogger;

thread_local! {
    /// Error records logged on this thread (the validation layer reports synchronously on the
    /// thread that made the offending call, so per-thread lists attribute errors correctly).
    pub(super) static LOGGED_ERRORS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
    /// Depth of `Gpu::scoped` calls on this thread: only messages logged inside our own GPU
    /// calls are ours (an egui renderer on the same thread logs through the same logger).
    pub(super) static CAPTURING: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

impl log::Log for ValidationLogger {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::Level::Warn && m.target().starts_with("wgpu")
    }

    fn log(&self, r: &log::Record) {
        if !self.enabled(r.metadata()) {
            return;
        }
        let line = format!("{}: {}", r.target(), r.args());
        if r.level() == log::Level::Warn {
            eprintln!("warning: {line}");
        } else {
            if CAPTURING.with(|c| c.get()) > 0 {
                LOGGED_ERRORS.with(|v| v.borrow_mut().push(line));
            }
        }
    }

    fn flush(&self) {}
}

pub(super) static LOGGER: ValidationLogger = ValidationLogger;
