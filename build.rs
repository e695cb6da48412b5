//! Provisions MuJoCo 3.17.0 so that `cargo run` and `cargo test` work on a fresh clone.
//!
//! The library comes from the official `mujoco==3.17.0` wheel for the target platform:
//! `libmujoco.so.3.17.0` (Linux), `mujoco.dll` (Windows), `libmujoco.3.17.0.dylib` (macOS).
//! The target is `CARGO_CFG_TARGET_OS` (this script runs on the host, so `cfg!` would name
//! the host), so a cross build for Windows on Linux provisions the Windows library.
//!
//! Order of preference:
//! 1. `MUJOCO_DYNAMIC_LINK_DIR` (an absolute directory holding the library): used as it is. On
//!    Windows it holds `mujoco.lib` (mujoco-rs checks it) and `mujoco.dll` (or `../bin/mujoco.dll`,
//!    the layout of MuJoCo's release zip).
//! 2. `.mujoco/lib` (Linux, macOS) or `.mujoco/win64` (Windows) in this repository, made by an
//!    earlier build.
//! 3. The wheel, downloaded with `python3 -m pip download` into the user cache
//!    (`$SIMSERPENT_CACHE_DIR`, else `$XDG_CACHE_HOME/simserpent`, else `~/.cache/simserpent`)
//!    and unpacked into `.mujoco/`. The Windows wheel has no import library: this script lists
//!    the DLL's exports in `mujoco.def` and makes `mujoco.lib` from it with MinGW's `dlltool`
//!    (GNU targets) or the MSVC `lib` tool (MSVC targets).
//!
//! Linux and macOS: mujoco-rs finds the library through `build/pkgconfig/mujoco.pc` (see
//! `.cargo/config.toml`); pkg-config does not need the file to exist yet, and this script runs
//! before our final link. Every binary, test and bench of this package gets an rpath (the
//! executable's folder, its parent and the absolute library directory), so no
//! `LD_LIBRARY_PATH` is needed at run time. The macOS path is written from the macOS wheels'
//! contents but has not been built on a Mac.
//!
//! Windows: mujoco-rs links through `MUJOCO_DYNAMIC_LINK_DIR` only and checks it before this
//! script runs, so the directory must exist first: `scripts/build-windows` runs this file as a
//! program of its own (`SIMSERPENT_PROVISION_ONLY=1`, which provisions and prints the
//! directory), then cargo with the variable set. `mujoco.dll` is copied next to every
//! executable (the profile folder, `deps/` for tests, `examples/`): Windows looks for a DLL in
//! the executable's folder.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const MUJOCO_VERSION: &str = "3.17.0";

/// The operating system the build is for, with what differs between them.
#[derive(Clone, Copy, PartialEq)]
enum Platform {
    Linux,
    Windows,
    MacOs,
}

impl Platform {
    fn from_target(name: &str) -> Result<Platform, String> {
        match name {
            "linux" => Ok(Platform::Linux),
            "windows" => Ok(Platform::Windows),
            "macos" => Ok(Platform::MacOs),
            other => Err(format!("target OS `{other}` is not supported (Linux, Windows and macOS are)")),
        }
    }

    /// The library file the executables load at run time.
    fn runtime_lib(self) -> String {
        match self {
            Platform::Linux => format!("libmujoco.so.{MUJOCO_VERSION}"),
            Platform::Windows => "mujoco.dll".into(),
            Platform::MacOs => format!("libmujoco.{MUJOCO_VERSION}.dylib"),
        }
    }

    /// Where the executables look for the runtime library, relative to a folder on their search
    /// path. macOS: the wheel's dylib names itself `@rpath/mujoco.framework/Versions/A/...`
    /// (its install name), and executables linked against it look for exactly that path.
    fn runtime_rel(self) -> PathBuf {
        match self {
            Platform::Linux | Platform::Windows => PathBuf::from(self.runtime_lib()),
            Platform::MacOs => Path::new("mujoco.framework").join("Versions").join("A").join(self.runtime_lib()),
        }
    }

    /// The name the linker looks for (a symlink to the runtime library on Linux and macOS).
    fn link_name(self) -> &'static str {
        match self {
            Platform::Linux => "libmujoco.so",
            Platform::Windows => "mujoco.lib",
            Platform::MacOs => "libmujoco.dylib",
        }
    }

    /// The folder under `.mujoco/` the library is unpacked into.
    fn unpack_dir(self) -> &'static str {
        match self {
            Platform::Linux | Platform::MacOs => "lib",
            Platform::Windows => "win64",
        }
    }

    /// Whether a wheel's file name is for this OS and CPU (`arch` as in `CARGO_CFG_TARGET_ARCH`).
    fn wheel_matches(self, file_name: &str, arch: &str) -> bool {
        let Some(tag) = file_name.strip_suffix(".whl").and_then(|n| n.rsplit('-').next()) else {
            return false;
        };
        match self {
            Platform::Linux => tag.contains("linux") && tag.contains(arch),
            Platform::Windows => tag == if arch == "aarch64" { "win_arm64" } else { "win_amd64" },
            Platform::MacOs => {
                tag.starts_with("macosx") && (tag.ends_with("universal2") || tag.ends_with(mac_arch(arch)))
            }
        }
    }

    /// `pip download` arguments that select this OS's wheel (none for the host's own platform).
    fn pip_platform(self, arch: &str) -> Vec<String> {
        let host_is_target = match self {
            Platform::Linux => cfg!(target_os = "linux"),
            Platform::Windows => cfg!(target_os = "windows"),
            Platform::MacOs => cfg!(target_os = "macos"),
        } && env::consts::ARCH == arch;
        if host_is_target {
            return Vec::new();
        }
        let platform = match self {
            Platform::Linux => format!("manylinux_2_28_{arch}"),
            Platform::Windows => if arch == "aarch64" { "win_arm64" } else { "win_amd64" }.to_string(),
            Platform::MacOs => format!("macosx_11_0_{}", mac_arch(arch)),
        };
        ["--platform", &platform, "--python-version", "3.11"].iter().map(|s| s.to_string()).collect()
    }
}

fn mac_arch(arch: &str) -> &str {
    if arch == "aarch64" { "arm64" } else { arch }
}

fn main() {
    let manifest_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets this"));
    let os =
        Platform::from_target(&env::var("CARGO_CFG_TARGET_OS").unwrap_or_default()).unwrap_or_else(|why| fail(&why));
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_else(|_| env::consts::ARCH.to_string());
    let target_env = env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    if env::var_os("SIMSERPENT_PROVISION_ONLY").is_some() {
        // Run as a program of its own (scripts/build-windows): provision, print the directory.
        match provision(&manifest_dir, os, &arch, &target_env) {
            Ok(dir) => println!("{}", dir.display()),
            Err(why) => fail(&why),
        }
        return;
    }
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    println!("cargo::rerun-if-env-changed=SIMSERPENT_CACHE_DIR");
    // Offscreen rendering (the `render` feature) exists on Linux only: mujoco-rs' renderer is
    // an optional Linux-only dependency (Cargo.toml), so elsewhere the feature enables nothing
    // and the code behind `cfg(offscreen_render)` is left out.
    println!("cargo::rustc-check-cfg=cfg(offscreen_render)");
    if env::var_os("CARGO_FEATURE_RENDER").is_some() && os == Platform::Linux {
        println!("cargo::rustc-cfg=offscreen_render");
    }
    if env::var_os("DOCS_RS").is_some() {
        return;
    }
    if os != Platform::Linux && env::var_os("CARGO_FEATURE_VIEWER").is_some() {
        fail(
            "the `viewer` feature is Linux-only (mujoco-rs' viewer elsewhere needs its winit renderer); \
             build without it (the default features work on every platform)",
        );
    }

    let lib_dir = match env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        Ok(dir) => PathBuf::from(dir),
        Err(_) => match provision(&manifest_dir, os, &arch, &target_env) {
            Ok(dir) if os == Platform::Windows => fail(&format!(
                "MuJoCo for Windows is ready in {0}, but mujoco-rs links on Windows only through \
                 MUJOCO_DYNAMIC_LINK_DIR: build with MUJOCO_DYNAMIC_LINK_DIR={0} (scripts/build-windows does)",
                dir.display()
            )),
            Ok(dir) => dir,
            Err(why) => fail(&why),
        },
    };
    let lib_file = runtime_lib_in(os, &lib_dir).unwrap_or_else(|| {
        fail(&format!(
            "no {} in {} (from MUJOCO_DYNAMIC_LINK_DIR or .mujoco/{})",
            os.runtime_lib(),
            lib_dir.display(),
            os.unpack_dir()
        ))
    });
    println!("cargo::rerun-if-changed={}", lib_file.display());

    // Copy the library next to the executables: on Windows the only way they find it without a
    // PATH change, on Linux and macOS so they keep working if the repository moves.
    if let Some(profile_dir) = profile_dir() {
        let dirs = match os {
            Platform::Windows => vec![profile_dir.join("deps"), profile_dir.join("examples"), profile_dir],
            Platform::Linux | Platform::MacOs => vec![profile_dir],
        };
        for dir in dirs {
            let dest = dir.join(os.runtime_rel());
            let dir = dest.parent().expect("a file in a folder").to_path_buf();
            let stale = match (fs::metadata(&lib_file), fs::metadata(&dest)) {
                (Ok(a), Ok(b)) => a.len() != b.len(),
                _ => true,
            };
            if stale {
                let copied = fs::create_dir_all(&dir).and_then(|()| fs::copy(&lib_file, &dest));
                // On Linux and macOS the absolute rpath below still works if this fails.
                if let (Err(e), Platform::Windows) = (copied, os) {
                    fail(&format!("cannot copy {} to {}: {e}", lib_file.display(), dest.display()));
                }
            }
        }
    }
    match os {
        Platform::Linux => println!("cargo::rustc-link-arg=-Wl,-rpath,$ORIGIN:$ORIGIN/..:{}", lib_dir.display()),
        Platform::MacOs => {
            println!("cargo::rustc-link-arg=-Wl,-rpath,@loader_path");
            println!("cargo::rustc-link-arg=-Wl,-rpath,@loader_path/..");
            println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
        }
        Platform::Windows => {}
    }
    println!("cargo::rustc-env=SIMSERPENT_MUJOCO_LIB={}", lib_file.display());
}

/// The runtime library in a link directory (on Windows also `../bin`, as in MuJoCo's release zip).
fn runtime_lib_in(os: Platform, lib_dir: &Path) -> Option<PathBuf> {
    let mut candidates = vec![lib_dir.join(os.runtime_lib())];
    match os {
        Platform::Linux | Platform::MacOs => candidates.push(lib_dir.join(os.link_name())),
        Platform::Windows => candidates.push(lib_dir.join("..").join("bin").join(os.runtime_lib())),
    }
    candidates.into_iter().find(|p| p.exists())
}

/// The `target/<profile>` directory, derived from `OUT_DIR` (`target/<profile>/build/<pkg>/out`).
fn profile_dir() -> Option<PathBuf> {
    let out = PathBuf::from(env::var_os("OUT_DIR")?);
    Some(out.parent()?.parent()?.parent()?.to_path_buf())
}

fn provision(manifest_dir: &Path, os: Platform, arch: &str, target_env: &str) -> Result<PathBuf, String> {
    let root = manifest_dir.join(".mujoco");
    let lib_dir = root.join(os.unpack_dir());
    let lib = lib_dir.join(os.runtime_lib());
    if !lib.exists() {
        let wheel = cached_wheel(os, arch)?;
        unpack(&wheel, &root, os)?;
    }
    if !lib.exists() {
        return Err(format!("the wheel did not contain mujoco/{}", os.runtime_lib()));
    }
    let runtime = lib_dir.join(os.runtime_rel());
    if !runtime.exists() {
        // macOS: the install name's path beside the library itself (see `Platform::runtime_rel`).
        let copied =
            fs::create_dir_all(runtime.parent().expect("a file in a folder")).and_then(|()| fs::copy(&lib, &runtime));
        copied.map_err(|e| format!("cannot copy {} to {}: {e}", lib.display(), runtime.display()))?;
    }
    let link = lib_dir.join(os.link_name());
    if fs::symlink_metadata(&link).is_err() {
        match os {
            Platform::Linux | Platform::MacOs => symlink(&os.runtime_lib(), &link)?,
            Platform::Windows => import_library(&lib, &link, target_env)?,
        }
    }
    Ok(lib_dir)
}

#[cfg(unix)]
fn symlink(target: &str, link: &Path) -> Result<(), String> {
    std::os::unix::fs::symlink(target, link).map_err(|e| format!("cannot create {}: {e}", link.display()))
}

/// Hosts without symlinks (a Windows host building for Linux or macOS) get a copy.
#[cfg(not(unix))]
fn symlink(target: &str, link: &Path) -> Result<(), String> {
    let source = link.with_file_name(target);
    fs::copy(&source, link)
        .map(drop)
        .map_err(|e| format!("cannot copy {} to {}: {e}", source.display(), link.display()))
}

/// Makes the import library `lib` for `dll`: its exports go into `mujoco.def`, then MinGW's
/// `dlltool` (GNU targets) or MSVC's `lib` (MSVC targets) turns that into the library.
fn import_library(dll: &Path, lib: &Path, target_env: &str) -> Result<(), String> {
    let bytes = fs::read(dll).map_err(|e| format!("cannot read {}: {e}", dll.display()))?;
    let exports = pe_exports(&bytes).map_err(|why| format!("cannot list the exports of {}: {why}", dll.display()))?;
    let def = dll.with_extension("def");
    let mut text = String::from("LIBRARY mujoco.dll\nEXPORTS\n");
    for (name, is_data) in &exports {
        text.push_str(name);
        text.push_str(if *is_data { " DATA\n" } else { "\n" });
    }
    fs::write(&def, text).map_err(|e| format!("cannot write {}: {e}", def.display()))?;
    let partial = lib.with_extension("lib.part");
    let tools: Vec<(&str, Vec<std::ffi::OsString>)> = if target_env == "msvc" {
        let (def_arg, out_arg) = (format!("/def:{}", def.display()), format!("/out:{}", partial.display()));
        vec![("lib", vec!["/nologo".into(), "/machine:x64".into(), def_arg.into(), out_arg.into()])]
    } else {
        let args = vec![
            "-d".into(),
            def.clone().into(),
            "-D".into(),
            "mujoco.dll".into(),
            "-l".into(),
            partial.clone().into(),
        ];
        vec![("x86_64-w64-mingw32-dlltool", args.clone()), ("dlltool", args)]
    };
    let mut tried = Vec::new();
    for (tool, args) in &tools {
        match Command::new(tool).args(args).output() {
            Ok(out) if out.status.success() => {
                return fs::rename(&partial, lib).map_err(|e| format!("cannot create {}: {e}", lib.display()));
            }
            Ok(out) => {
                return Err(format!(
                    "`{tool}` could not make {} from {}:\n{}",
                    lib.display(),
                    def.display(),
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
            Err(e) => tried.push(format!("`{tool}` ({e})")),
        }
    }
    Err(format!(
        "the Windows wheel has no import library, and no tool to make one was found: tried {}.\n\
         On Debian/Ubuntu: `apt-get install binutils-mingw-w64-x86-64` (it comes with gcc-mingw-w64-x86-64-posix, \
         the linker a Windows cross build needs); with MSVC: run the build from a Developer Command Prompt \
         (it has `lib`). Or take `lib/mujoco.lib` and `bin/mujoco.dll` from MuJoCo's release zip \
         (mujoco-{MUJOCO_VERSION}-windows-x86_64.zip) and set MUJOCO_DYNAMIC_LINK_DIR to its `lib` folder.",
        tried.join(", ")
    ))
}

/// The exported names of a 64-bit PE file (a DLL), each with whether it is data (its address
/// lies in a section that is not executable).
fn pe_exports(pe: &[u8]) -> Result<Vec<(String, bool)>, String> {
    let u16_at = |at: usize| pe.get(at..at + 2).map(|b| u16::from_le_bytes([b[0], b[1]])).ok_or("truncated file");
    let u32_at =
        |at: usize| pe.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).ok_or("truncated file");
    if pe.get(0..2) != Some(b"MZ") {
        return Err("not a PE file (no MZ header)".into());
    }
    let nt = u32_at(0x3c)? as usize;
    if pe.get(nt..nt + 4) != Some(b"PE\0\0") {
        return Err("not a PE file (no PE signature)".into());
    }
    let coff = nt + 4;
    let n_sections = u16_at(coff + 2)? as usize;
    let optional = coff + 20;
    let optional_size = u16_at(coff + 16)? as usize;
    if u16_at(optional)? != 0x20b {
        return Err("not a 64-bit (PE32+) file".into());
    }
    // Data directory 0 (exports) of a PE32+ optional header.
    let export_rva = u32_at(optional + 112)?;
    if export_rva == 0 {
        return Err("no export table".into());
    }
    // Section table: virtual address, virtual size, raw data offset, characteristics.
    let sections: Vec<(u32, u32, u32, u32)> = (0..n_sections)
        .map(|i| {
            let s = optional + optional_size + 40 * i;
            Ok((u32_at(s + 12)?, u32_at(s + 8)?, u32_at(s + 20)?, u32_at(s + 36)?))
        })
        .collect::<Result<_, &str>>()?;
    let section_of = |rva: u32| sections.iter().find(|(va, size, _, _)| rva >= *va && rva < va + size);
    let offset = |rva: u32| {
        section_of(rva).map(|(va, _, raw, _)| (rva - va + raw) as usize).ok_or("an address outside every section")
    };
    const EXECUTABLE: u32 = 0x2000_0000;
    let dir = offset(export_rva)?;
    let n_names = u32_at(dir + 24)? as usize;
    let functions = offset(u32_at(dir + 28)?)?;
    let names = offset(u32_at(dir + 32)?)?;
    let ordinals = offset(u32_at(dir + 36)?)?;
    let mut exports = Vec::with_capacity(n_names);
    for i in 0..n_names {
        let name_at = offset(u32_at(names + 4 * i)?)?;
        let len = pe.get(name_at..).and_then(|s| s.iter().position(|&b| b == 0)).ok_or("unterminated name")?;
        let name = std::str::from_utf8(&pe[name_at..name_at + len]).map_err(|_| "a name that is not UTF-8")?;
        let ordinal = u16_at(ordinals + 2 * i)? as usize;
        let rva = u32_at(functions + 4 * ordinal)?;
        let is_data = section_of(rva).is_some_and(|(_, _, _, flags)| flags & EXECUTABLE == 0);
        exports.push((name.to_string(), is_data));
    }
    Ok(exports)
}

fn cache_dir() -> PathBuf {
    if let Some(dir) = env::var_os("SIMSERPENT_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("simserpent");
    }
    match env::var_os("HOME").or_else(|| env::var_os("LOCALAPPDATA")) {
        Some(home) => PathBuf::from(home).join(".cache").join("simserpent"),
        None => env::temp_dir().join("simserpent-cache"),
    }
}

fn find_wheel(dir: &Path, os: Platform, arch: &str) -> Option<PathBuf> {
    let prefix = format!("mujoco-{MUJOCO_VERSION}-");
    fs::read_dir(dir).ok()?.flatten().map(|e| e.path()).find(|p| {
        p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with(&prefix) && os.wheel_matches(n, arch))
    })
}

fn cached_wheel(os: Platform, arch: &str) -> Result<PathBuf, String> {
    let dir = cache_dir();
    if let Some(wheel) = find_wheel(&dir, os, arch) {
        return Ok(wheel);
    }
    fs::create_dir_all(&dir).map_err(|e| format!("cannot create cache {}: {e}", dir.display()))?;
    let platform = os.pip_platform(arch);
    // Cargo shows a build script's warnings; run on its own, it says so on stderr.
    let note =
        format!("downloading mujoco=={MUJOCO_VERSION} {} from PyPI (once, into {})", platform.join(" "), dir.display());
    if env::var_os("SIMSERPENT_PROVISION_ONLY").is_some() {
        eprintln!("{note}");
    } else {
        println!("cargo::warning={note}");
    }
    let python = if cfg!(windows) { "python" } else { "python3" };
    let output = Command::new(python)
        .args(["-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--disable-pip-version-check"])
        .args(&platform)
        .arg(format!("mujoco=={MUJOCO_VERSION}"))
        .arg("-d")
        .arg(&dir)
        .output()
        .map_err(|e| format!("cannot run `{python} -m pip` ({e})"))?;
    if !output.status.success() {
        return Err(format!(
            "`{python} -m pip download mujoco=={MUJOCO_VERSION} {}` failed:\n{}",
            platform.join(" "),
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    find_wheel(&dir, os, arch)
        .ok_or_else(|| format!("pip reported success but no matching wheel is in {}", dir.display()))
}

/// Unpacks the library and headers from the wheel (a zip file) with Python's zipfile module.
fn unpack(wheel: &Path, root: &Path, os: Platform) -> Result<(), String> {
    const SCRIPT: &str = r#"
import sys, zipfile, os, shutil
wheel, root, lib, lib_dir = sys.argv[1:5]
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        if name == 'mujoco/' + lib:
            dest = os.path.join(root, lib_dir, lib)
        elif name.startswith('mujoco/include/mujoco/') and name.endswith('.h'):
            dest = os.path.join(root, 'include', 'mujoco', os.path.basename(name))
        else:
            continue
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        with z.open(name) as src, open(dest + '.part', 'wb') as out:
            shutil.copyfileobj(src, out)
        os.replace(dest + '.part', dest)
"#;
    let python = if cfg!(windows) { "python" } else { "python3" };
    let status = Command::new(python)
        .args(["-c", SCRIPT])
        .arg(wheel)
        .arg(root)
        .arg(os.runtime_lib())
        .arg(os.unpack_dir())
        .status()
        .map_err(|e| format!("cannot run {python} to unpack {} ({e})", wheel.display()))?;
    if status.success() { Ok(()) } else { Err(format!("unpacking {} failed", wheel.display())) }
}

fn fail(why: &str) -> ! {
    let os = Platform::from_target(&env::var("CARGO_CFG_TARGET_OS").unwrap_or_default()).unwrap_or(Platform::Linux);
    eprintln!(
        "\n==================== SimSerpent: MuJoCo {MUJOCO_VERSION} is not available ====================\n\
         {why}\n\n\
         SimSerpent needs {lib} (MuJoCo {MUJOCO_VERSION}). Either\n\
         * install Python 3 with pip and network access to PyPI, and build again\n\
           (the build downloads the official `mujoco=={MUJOCO_VERSION}` wheel once), or\n\
         * put that wheel `mujoco-{MUJOCO_VERSION}-*.whl` for the target platform into {cache}, or\n\
         * set MUJOCO_DYNAMIC_LINK_DIR to an absolute directory that holds {link} ({MUJOCO_VERSION}).\n\
         ==========================================================================================\n",
        lib = os.runtime_lib(),
        link = os.link_name(),
        cache = cache_dir().display()
    );
    std::process::exit(1);
}
