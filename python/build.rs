//! How the extension finds MuJoCo at run time.
//!
//! Linux: the wheel carries its own copy of the library it was built against. `maturin build
//! --auditwheel repair` (see `scripts/build-wheel`) copies `libmujoco.so.3.17.0` into
//! `simserpent.libs/` under a name of its own (`libmujoco-<hash>.so.3.17.0`, the same SONAME
//! rewritten), points the extension's `DT_NEEDED` at it and sets its RPATH to
//! `$ORIGIN/../simserpent.libs`. So the extension never loads another package's libmujoco, and any
//! `mujoco` release (or none) can be installed beside it; each library keeps its own symbols
//! (Python loads extensions with `RTLD_LOCAL`).
//!
//! At build time mujoco-rs finds the library through the root package's pkg-config file
//! (`build/pkgconfig`, via `.cargo/config.toml`) or `MUJOCO_DYNAMIC_LINK_DIR`; the repair step
//! finds the same file through `LD_LIBRARY_PATH` (set by the script).
//!
//! Windows has no rpath: the wheel carries `mujoco.dll` beside the extension, and
//! `simserpent/__init__.py` adds the package's folder to the DLL search path before it imports
//! the extension.
fn main() {
    println!("cargo::rerun-if-changed=build.rs");
}
