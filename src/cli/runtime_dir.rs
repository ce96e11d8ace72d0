//! A private `XDG_RUNTIME_DIR` for processes started without one (CI runners, cron, farms).

use std::path::PathBuf;

/// Point `XDG_RUNTIME_DIR` at a private directory (`$TMPDIR/tyndall-runtime-$USER`, mode 0700
/// as the XDG base-directory spec asks) when it is unset or not a directory: without it the
/// Vulkan loader's window-system probing prints "error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment." twice per device (CI runners, cron jobs, farm nodes), before a render that
/// then succeeds. Call it before any thread starts (it sets an environment variable).
pub fn ensure_runtime_dir() {
    let valid = std::env::var_os("XDG_RUNTIME_DIR")
        .map(PathBuf::from)
        .is_some_and(|p| p.is_absolute() && p.is_dir());
    if valid {
        return;
    }
    let user = std::env::var("USER").unwrap_or_else(|_| "user".into());
    let dir = std::env::temp_dir().join(format!("tyndall-runtime-{user}"));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
    }
    std::env::set_var("XDG_RUNTIME_DIR", &dir);
}
