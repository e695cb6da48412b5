//! Compiling MJCF with MuJoCo's whole error message: `mujoco-rs` keeps only the first 99
//! bytes of it (its error buffer has 100), which cuts the line and file MuJoCo names.

use super::SimError;
use mujoco_rs::mujoco_c::{mj_deleteModel, mj_loadXML};
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_auxiliary::MjVfs;
use std::ffi::{CStr, CString, c_char, c_int};
use std::path::Path;

/// Bytes of the buffer for MuJoCo's error message (its own messages are at most 1000).
const ERROR_BUFFER_BYTES: usize = 8192;

/// MJCF to compile: a text (compiled from memory) or a file (compiled from its folder).
#[derive(Clone, Copy)]
pub(super) enum Mjcf<'a> {
    Text(&'a str),
    File(&'a Path),
}

/// Compiles `mjcf`; on failure, [`SimError::ModelRejected`] with `what` (e.g. "the generated
/// model") and MuJoCo's whole message, in which `renames` (scratch path, the user's path)
/// are replaced so that it names the user's own files.
pub(super) fn compile(mjcf: Mjcf<'_>, what: &str, renames: &[(String, String)]) -> Result<MjModel, SimError> {
    let loaded = match mjcf {
        Mjcf::Text(xml) => MjModel::from_xml_string(xml),
        Mjcf::File(path) => MjModel::from_xml(path),
    };
    loaded.map_err(|short| {
        let mut message = full_load_error(mjcf).unwrap_or_else(|| short.to_string());
        for (from, to) in renames {
            message = message.replace(from.as_str(), to);
        }
        SimError::ModelRejected { what: what.to_string(), message: message.trim_end().to_string() }
    })
}

/// MuJoCo's whole message of why `mjcf` does not load, by loading it again with a large error
/// buffer (only on failure, so the cost does not matter); `None` if it loads after all.
pub(super) fn full_load_error(mjcf: Mjcf<'_>) -> Option<String> {
    let mut vfs = MjVfs::new();
    let (name, in_vfs) = match mjcf {
        Mjcf::Text(xml) => {
            vfs.add_from_buffer("model.xml", xml.as_bytes()).ok()?;
            ("model.xml".to_string(), true)
        }
        Mjcf::File(path) => (path.to_str()?.to_string(), false),
    };
    let name = CString::new(name).ok()?;
    let mut buffer: Vec<c_char> = vec![0; ERROR_BUFFER_BYTES];
    let vfs_ptr = if in_vfs { std::ptr::from_ref(vfs.ffi()) } else { std::ptr::null() };
    // SAFETY: `name` is a NUL-terminated string and `vfs_ptr` null or a live VFS, both outliving
    // the call; MuJoCo writes at most `buffer.len()` bytes, NUL-terminated, into `buffer`. A
    // model it returns is ours and is freed at once.
    #[allow(unsafe_code)]
    let message = unsafe {
        let model = mj_loadXML(name.as_ptr(), vfs_ptr, buffer.as_mut_ptr(), buffer.len() as c_int);
        if !model.is_null() {
            mj_deleteModel(model);
            return None;
        }
        CStr::from_ptr(buffer.as_ptr()).to_string_lossy().into_owned()
    };
    let message = message.trim_end().to_string();
    (!message.is_empty()).then_some(message)
}
