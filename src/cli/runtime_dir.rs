//! Keeps libwayland's `error: XDG_RUNTIME_DIR is invalid or not set in the
//! environment.` out of the output on headless machines.
//!
//! Where the line comes from: every Vulkan instance loads Mesa's implicit
//! device-select layer (`VK_LAYER_MESA_device_select`). When the instance
//! enables `VK_KHR_wayland_surface` (wgpu enables every surface extension
//! the loader offers, for a headless instance too), the layer calls
//! `wl_display_connect(NULL)` inside `vkEnumeratePhysicalDevices` to find
//! the compositor's GPU; libwayland-client prints the line on stderr when
//! `XDG_RUNTIME_DIR` is unset or not an absolute path, and gives up. wgpu
//! enumerates twice per instance, and linkgi opens one instance per GPU
//! probe, hence two to four lines per command.
//!
//! What is done: [`ensure`], first thing in `main` (before any thread or
//! wgpu instance exists, so changing the environment races nothing), points
//! an unset or relative `XDG_RUNTIME_DIR` at a private directory,
//! `<temp dir>/linkgi-runtime-<uid>`, created with mode 0700 and checked to
//! be a real directory owned by this user with no access for others (what
//! the XDG base directory specification asks of a runtime directory).
//! libwayland then looks for its socket there, finds none and returns
//! quietly. A session that has a runtime directory keeps it, and every
//! other message of the loader and the drivers still reaches stderr. Where
//! the directory cannot be made ours the variable is left alone (the line
//! comes back, harmless).
//!
//! Not chosen: switching the layer off (`NODEVICE_SELECT=1`) would also
//! switch off `MESA_VK_DEVICE_SELECT` for people who pick their GPU with
//! it; wgpu has no setting that leaves the Wayland surface extension out of
//! a headless instance; silencing stderr around instance creation would
//! hide real errors.

use std::path::{Path, PathBuf};

/// Name of the variable libwayland reads.
const VAR: &str = "XDG_RUNTIME_DIR";

/// Points `XDG_RUNTIME_DIR` at a private directory when it is unset or not
/// an absolute path (see the module doc). Call before any thread starts.
pub fn ensure() {
    let current = std::env::var_os(VAR);
    if current.as_deref().is_some_and(|d| Path::new(d).is_absolute()) {
        return;
    }
    if let Some(dir) = private_dir() {
        // No other thread exists yet (the first statement of `main`).
        std::env::set_var(VAR, dir);
    }
}

/// `<temp>/linkgi-runtime-<uid>`, made if missing; `None` unless it is a
/// directory (not a link) owned by this user with mode 0700.
#[cfg(unix)]
fn private_dir() -> Option<PathBuf> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    // The owner of /proc/self is the process's effective user.
    let uid = std::fs::metadata("/proc/self").ok()?.uid();
    let dir = std::env::temp_dir().join(format!("linkgi-runtime-{uid}"));
    if let Err(e) = std::fs::DirBuilder::new().mode(0o700).create(&dir) {
        if e.kind() != std::io::ErrorKind::AlreadyExists {
            return None;
        }
    }
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    let private = meta.is_dir() && meta.uid() == uid && meta.permissions().mode() & 0o777 == 0o700;
    (private && dir.is_absolute()).then_some(dir)
}

#[cfg(not(unix))]
fn private_dir() -> Option<PathBuf> {
    None
}
