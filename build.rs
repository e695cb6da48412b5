//! Provisions MuJoCo 3.17.0 so that `cargo run` and `cargo test` work on a fresh clone.
//!
//! Order of preference:
//! 1. `MUJOCO_DYNAMIC_LINK_DIR` (an absolute directory holding `libmujoco.so`): used as it is.
//! 2. `.mujoco/lib/libmujoco.so.3.17.0` in this repository (made by an earlier build).
//! 3. The official `mujoco==3.17.0` wheel from PyPI, downloaded with `python3 -m pip download`
//!    into the user cache (`$SIMSERPENT_CACHE_DIR`, else `$XDG_CACHE_HOME/simserpent`, else
//!    `~/.cache/simserpent`) and unpacked into `.mujoco/`.
//!
//! mujoco-rs finds the library through `build/pkgconfig/mujoco.pc` (see `.cargo/config.toml`);
//! pkg-config does not need the file to exist yet, and this script runs before our final link.
//! Every binary, test and bench of this package gets an rpath (`$ORIGIN`, `$ORIGIN/..` and the
//! absolute library directory) so no `LD_LIBRARY_PATH` is needed at run time.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const MUJOCO_VERSION: &str = "3.17.0";
const SONAME: &str = "libmujoco.so.3.17.0";

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=MUJOCO_DYNAMIC_LINK_DIR");
    println!("cargo::rerun-if-env-changed=SIMSERPENT_CACHE_DIR");
    if env::var_os("DOCS_RS").is_some() {
        return;
    }
    let manifest_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets this"));
    let lib_dir = match env::var("MUJOCO_DYNAMIC_LINK_DIR") {
        Ok(dir) => PathBuf::from(dir),
        Err(_) => match provision(&manifest_dir) {
            Ok(dir) => dir,
            Err(why) => fail(&why),
        },
    };
    let lib_file =
        [SONAME, "libmujoco.so"].iter().map(|name| lib_dir.join(name)).find(|p| p.exists()).unwrap_or_else(|| {
            fail(&format!("no libmujoco.so in {} (from MUJOCO_DYNAMIC_LINK_DIR or .mujoco/lib)", lib_dir.display()))
        });
    println!("cargo::rerun-if-changed={}", lib_file.display());

    // Copy the library next to the binaries so they keep working if the repository moves.
    if let Some(profile_dir) = profile_dir() {
        let dest = profile_dir.join(SONAME);
        let stale = match (fs::metadata(&lib_file), fs::metadata(&dest)) {
            (Ok(a), Ok(b)) => a.len() != b.len(),
            _ => true,
        };
        if stale {
            // Best effort: the absolute rpath below still works if this fails.
            let _ = fs::copy(&lib_file, &dest);
        }
    }
    println!("cargo::rustc-link-arg=-Wl,-rpath,$ORIGIN:$ORIGIN/..:{}", lib_dir.display());
    println!("cargo::rustc-env=SIMSERPENT_MUJOCO_LIB={}", lib_file.display());
}

/// The `target/<profile>` directory, derived from `OUT_DIR` (`target/<profile>/build/<pkg>/out`).
fn profile_dir() -> Option<PathBuf> {
    let out = PathBuf::from(env::var_os("OUT_DIR")?);
    Some(out.parent()?.parent()?.parent()?.to_path_buf())
}

fn provision(manifest_dir: &Path) -> Result<PathBuf, String> {
    let root = manifest_dir.join(".mujoco");
    let lib_dir = root.join("lib");
    let lib = lib_dir.join(SONAME);
    if !lib.exists() {
        let wheel = cached_wheel()?;
        unpack(&wheel, &root)?;
    }
    if !lib.exists() {
        return Err(format!("the wheel did not contain mujoco/{SONAME}"));
    }
    let link = lib_dir.join("libmujoco.so");
    if fs::symlink_metadata(&link).is_err() {
        std::os::unix::fs::symlink(SONAME, &link).map_err(|e| format!("cannot create {}: {e}", link.display()))?;
    }
    Ok(lib_dir)
}

fn cache_dir() -> PathBuf {
    if let Some(dir) = env::var_os("SIMSERPENT_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("simserpent");
    }
    match env::var_os("HOME") {
        Some(home) => PathBuf::from(home).join(".cache").join("simserpent"),
        None => env::temp_dir().join("simserpent-cache"),
    }
}

fn find_wheel(dir: &Path) -> Option<PathBuf> {
    let prefix = format!("mujoco-{MUJOCO_VERSION}-");
    fs::read_dir(dir)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .find(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with(&prefix) && n.ends_with(".whl")))
}

fn cached_wheel() -> Result<PathBuf, String> {
    let dir = cache_dir();
    if let Some(wheel) = find_wheel(&dir) {
        return Ok(wheel);
    }
    fs::create_dir_all(&dir).map_err(|e| format!("cannot create cache {}: {e}", dir.display()))?;
    println!("cargo::warning=downloading mujoco=={MUJOCO_VERSION} from PyPI (once, into {})", dir.display());
    let output = Command::new("python3")
        .args(["-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--disable-pip-version-check"])
        .arg(format!("mujoco=={MUJOCO_VERSION}"))
        .arg("-d")
        .arg(&dir)
        .output()
        .map_err(|e| format!("cannot run `python3 -m pip` ({e})"))?;
    if !output.status.success() {
        return Err(format!(
            "`python3 -m pip download mujoco=={MUJOCO_VERSION}` failed:\n{}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    find_wheel(&dir).ok_or_else(|| format!("pip reported success but no wheel is in {}", dir.display()))
}

/// Unpacks the library and headers from the wheel (a zip file) with Python's zipfile module.
fn unpack(wheel: &Path, root: &Path) -> Result<(), String> {
    const SCRIPT: &str = r#"
import sys, zipfile, os, shutil
wheel, root = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        if name.startswith('mujoco/libmujoco.so'):
            dest = os.path.join(root, 'lib', os.path.basename(name))
        elif name.startswith('mujoco/include/mujoco/') and name.endswith('.h'):
            dest = os.path.join(root, 'include', 'mujoco', os.path.basename(name))
        else:
            continue
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        with z.open(name) as src, open(dest + '.part', 'wb') as out:
            shutil.copyfileobj(src, out)
        os.replace(dest + '.part', dest)
"#;
    let status = Command::new("python3")
        .args(["-c", SCRIPT])
        .arg(wheel)
        .arg(root)
        .status()
        .map_err(|e| format!("cannot run python3 to unpack {} ({e})", wheel.display()))?;
    if status.success() { Ok(()) } else { Err(format!("unpacking {} failed", wheel.display())) }
}

fn fail(why: &str) -> ! {
    eprintln!(
        "\n==================== SimSerpent: MuJoCo {MUJOCO_VERSION} is not available ====================\n\
         {why}\n\n\
         SimSerpent needs libmujoco.so.{MUJOCO_VERSION}. Either\n\
         * install Python 3 with pip and network access to PyPI, and build again\n\
           (the build downloads the official `mujoco=={MUJOCO_VERSION}` wheel once), or\n\
         * put a wheel `mujoco-{MUJOCO_VERSION}-*.whl` into {}, or\n\
         * set MUJOCO_DYNAMIC_LINK_DIR to an absolute directory that holds libmujoco.so ({MUJOCO_VERSION}).\n\
         ==========================================================================================\n",
        cache_dir().display()
    );
    std::process::exit(1);
}
