//! Links the extension so it finds MuJoCo inside the installed `mujoco==3.17.0` wheel: the
//! extension is `site-packages/simserpent/_core.abi3.so`, the wheel's library is
//! `site-packages/mujoco/libmujoco.so.3.17.0`, hence the rpath `$ORIGIN/../mujoco`. `import
//! mujoco` and `import simserpent` then share one library, and no `LD_LIBRARY_PATH` is needed.
//!
//! At build time mujoco-rs finds a copy of the same library through the root package's
//! pkg-config file (`build/pkgconfig`, via `.cargo/config.toml`) or `MUJOCO_DYNAMIC_LINK_DIR`;
//! only the SONAME `libmujoco.so.3.17.0` is recorded, so which copy it links against does not
//! matter at run time.
//!
//! Windows has no rpath: `simserpent/__init__.py` adds the `mujoco` package's folder (which holds
//! `mujoco.dll`) to the DLL search path before it imports the extension. The target is
//! `CARGO_CFG_TARGET_OS`, since this script runs on the host.
fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo::rustc-link-arg-cdylib=-Wl,-rpath,$ORIGIN/../mujoco");
    }
}
