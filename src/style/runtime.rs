//! Locating and loading the ONNX Runtime shared library (ort `load-dynamic`), the single
//! process-wide ort `Environment`, and the CUDA execution provider.
//!
//! ort allows one dylib and one `Environment` per process, and panics when its lazy fallback
//! loader fails. So everything goes through [`environment`]: it checks the file exists, calls
//! `ort::init_from` (which returns an error for a non-library or a too-old one instead of
//! panicking) and builds the environment once; later calls reuse it.

#[cfg(feature = "ort")]
use std::ffi::{CStr, CString};
use std::path::{Path, PathBuf};
#[cfg(feature = "ort")]
use std::sync::Mutex;

#[cfg(feature = "ort")]
use ort::environment::Environment;

/// The ONNX Runtime version `scripts/install_ort.sh` installs (the PyPI wheel `onnxruntime`).
pub const ORT_VERSION: &str = "1.31.1";

/// How to get the library; appended to every library error.
pub const HOW_TO_GET: &str = "get it with `scripts/install_ort.sh` (installs libonnxruntime.so.1.31.1 from the PyPI \
     wheel onnxruntime==1.31.1 into <repo>/.ort/), then pass --ort-lib <path> or set ORT_DYLIB_PATH=<path>, or put \
     libonnxruntime.so* next to the panoconv executable";

/// Where the library came from (for messages).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LibSource {
    /// The path given with `--ort-lib`.
    Explicit,
    /// The `ORT_DYLIB_PATH` environment variable.
    EnvVar,
    /// A `libonnxruntime.so*` in the running executable's folder.
    BesideExe,
}

impl std::fmt::Display for LibSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LibSource::Explicit => "given path (--ort-lib)",
            LibSource::EnvVar => "ORT_DYLIB_PATH",
            LibSource::BesideExe => "file beside the executable",
        })
    }
}

/// Why no usable library could be found or loaded (`model` is added by the caller).
#[derive(Debug)]
pub enum LibError {
    /// No library file: the message says which path is missing or where it was looked for.
    Missing(String),
    /// The library file `lib` cannot be loaded, initialised, or used beside another one.
    Load {
        /// The library file.
        lib: PathBuf,
        /// What failed.
        detail: String,
    },
}

/// Resolves the library path: `explicit`, then `ORT_DYLIB_PATH`, then `libonnxruntime.so*`
/// beside the running executable. A path that is named but absent is an error (not a fall-through),
/// so a typo is reported rather than silently replaced.
pub fn find_library(explicit: Option<&Path>) -> Result<(PathBuf, LibSource), LibError> {
    if let Some(p) = explicit {
        return if p.is_file() {
            Ok((p.to_path_buf(), LibSource::Explicit))
        } else {
            Err(LibError::Missing(format!(
                "the ONNX Runtime library given by --ort-lib, {}, does not exist",
                p.display()
            )))
        };
    }
    if let Some(v) = std::env::var_os("ORT_DYLIB_PATH").filter(|v| !v.is_empty()) {
        let p = PathBuf::from(v);
        return if p.is_file() {
            Ok((p, LibSource::EnvVar))
        } else {
            Err(LibError::Missing(format!(
                "ORT_DYLIB_PATH={} does not name an existing file",
                p.display()
            )))
        };
    }
    let exe_dir = std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(Path::to_path_buf));
    if let Some(dir) = &exe_dir {
        if let Some(p) = beside(dir) {
            return Ok((p, LibSource::BesideExe));
        }
    }
    Err(LibError::Missing(format!(
        "no ONNX Runtime library: no --ort-lib, ORT_DYLIB_PATH unset, and no libonnxruntime.so* in {}",
        exe_dir
            .as_deref()
            .map_or_else(|| "<unknown executable folder>".into(), |d| d.display().to_string())
    )))
}

/// `libonnxruntime.so*` in `dir` (not `libonnxruntime_providers_*`): prefers the plain
/// `libonnxruntime.so`, else the lexically greatest versioned name.
fn beside(dir: &Path) -> Option<PathBuf> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| n == "libonnxruntime.so" || n.starts_with("libonnxruntime.so."))
        .filter(|n| dir.join(n).is_file())
        .collect();
    names.sort();
    if names.iter().any(|n| n == "libonnxruntime.so") {
        return Some(dir.join("libonnxruntime.so"));
    }
    names.pop().map(|n| dir.join(n))
}

#[cfg(feature = "ort")]
struct Loaded {
    lib: PathBuf,
    env: Environment,
}

#[cfg(feature = "ort")]
static RUNTIME: Mutex<Option<Loaded>> = Mutex::new(None);

/// The process-wide ort environment, loading the library found by [`find_library`] on first
/// use. Returns the canonical path of the library in use.
///
/// A second call naming a *different* library is an error: ONNX Runtime cannot be loaded twice
/// into one process (ort would silently keep the first).
#[cfg(feature = "ort")]
pub fn environment(explicit: Option<&Path>) -> Result<(Environment, PathBuf), LibError> {
    let mut guard = RUNTIME.lock().unwrap_or_else(|p| p.into_inner());
    let (path, source) = find_library(explicit)?;
    let canon = path.canonicalize().map_err(|e| LibError::Load {
        lib: path.clone(),
        detail: format!("cannot resolve the path ({e})"),
    })?;
    if let Some(l) = guard.as_ref() {
        if l.lib == canon {
            return Ok((l.env.clone(), canon));
        }
        return Err(LibError::Load {
            lib: canon,
            detail: format!(
                "ONNX Runtime is already loaded in this process from {}; one process can use only one library",
                l.lib.display()
            ),
        });
    }
    let builder = ort::init_from(&canon).map_err(|e| LibError::Load {
        lib: canon.clone(),
        detail: format!("{e} (library from the {source})"),
    })?;
    let env = builder
        .with_name("panoconv-style")
        .with_telemetry(false)
        .build()
        .map_err(|e| LibError::Load {
            lib: canon.clone(),
            detail: format!("creating the ONNX Runtime environment failed: {e}"),
        })?;
    *guard = Some(Loaded {
        lib: canon.clone(),
        env: env.clone(),
    });
    Ok((env, canon))
}

/// The execution providers compiled into the loaded library (`CPUExecutionProvider`, ...).
/// Only call after [`environment`] succeeded.
#[cfg(feature = "ort")]
pub fn available_providers() -> Result<Vec<String>, String> {
    let api = ort::api();
    let mut list: *mut *mut std::ffi::c_char = std::ptr::null_mut();
    let mut n: std::ffi::c_int = 0;
    // SAFETY: plain C API call with valid out-pointers; the list is released below.
    let st = unsafe { (api.GetAvailableProviders)(&mut list, &mut n) };
    status_to_result(st)?;
    let mut out = Vec::new();
    if !list.is_null() {
        for i in 0..n.max(0) as usize {
            // SAFETY: `list` holds `n` NUL-terminated strings owned by ONNX Runtime.
            let s = unsafe { CStr::from_ptr(*list.add(i)) };
            out.push(s.to_string_lossy().into_owned());
        }
        // SAFETY: releasing what GetAvailableProviders returned.
        let st = unsafe { (api.ReleaseAvailableProviders)(list, n) };
        status_to_result(st)?;
    }
    Ok(out)
}

/// The folder beside the library where `scripts/install_ort.sh --gpu` puts the CUDA and cuDNN
/// libraries of NVIDIA's PyPI wheels.
pub const CUDA_LIBS_DIR: &str = "cuda";

/// Appends the CUDA execution provider (device 0) to `builder`, failing (not falling back to the
/// CPU) when the machine has no NVIDIA driver, the library has no CUDA support, or CUDA cannot
/// start. `library`: the ONNX Runtime library in use; the CUDA libraries in its
/// [`CUDA_LIBS_DIR`] folder, if any, are loaded first so the provider finds them.
///
/// ort 2.0.0-rc.15 exposes `ort::ep::CUDA` only with its `cuda` cargo feature; with
/// `load-dynamic` that feature only compiles the wrapper, so this calls the same C API
/// (`CreateCUDAProviderOptions` + `SessionOptionsAppendExecutionProvider_CUDA_V2`) directly.
#[cfg(feature = "ort")]
pub fn append_cuda(
    builder: &mut ort::session::builder::SessionBuilder,
    library: &Path,
) -> Result<(), String> {
    // The driver first: on a machine without a GPU no library fixes anything.
    dlopen(Path::new("libcuda.so.1")).map_err(|e| {
        format!(
            "no NVIDIA GPU driver on this machine (libcuda.so.1 cannot be loaded: {e}); --device cuda \
             needs an NVIDIA GPU and its driver: use --device cpu"
        )
    })?;
    let providers = available_providers()?;
    if !providers.iter().any(|p| p == "CUDAExecutionProvider") {
        return Err(format!(
            "this ONNX Runtime library ({}) has no CUDA execution provider (it has: {}); the PyPI \
             `onnxruntime` wheel is CPU-only: run `scripts/install_ort.sh --gpu` (onnxruntime-gpu \
             {ORT_VERSION} and NVIDIA's CUDA 13 and cuDNN 9 wheels into <repo>/.ort-gpu/) and pass \
             the library it prints with --ort-lib or ORT_DYLIB_PATH",
            library.display(),
            providers.join(", ")
        ));
    }
    let unloaded = library
        .parent()
        .map(|d| preload(&d.join(CUDA_LIBS_DIR)))
        .unwrap_or_default();
    append_cuda_provider(builder).map_err(|e| {
        if unloaded.is_empty() {
            e
        } else {
            format!(
                "{e} (libraries beside it that did not load: {})",
                unloaded.join("; ")
            )
        }
    })
}

/// Loads every `*.so*` in `dir` (globally, so the CUDA provider's own dependencies resolve to
/// them), in passes until no more load: a library whose dependency comes later in the listing
/// loads in a later pass. Returns `name: error` of those that never loaded; nothing when
/// `dir` does not exist (CUDA installed system-wide).
#[cfg(feature = "ort")]
fn preload(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut pending: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.contains(".so"))
        })
        .collect();
    pending.sort();
    loop {
        let before = pending.len();
        let mut failed = Vec::new();
        pending.retain(|p| match dlopen(p) {
            Ok(()) => false,
            Err(e) => {
                failed.push(format!("{}: {e}", p.display()));
                true
            }
        });
        if pending.is_empty() || pending.len() == before {
            return failed;
        }
    }
}

/// `dlopen(path, RTLD_NOW | RTLD_GLOBAL)`, never closed (the provider uses it for the life of the
/// process); the loader's message on failure.
#[cfg(feature = "ort")]
fn dlopen(path: &Path) -> Result<(), String> {
    use std::os::unix::ffi::OsStrExt;
    let c = CString::new(path.as_os_str().as_bytes()).map_err(|e| e.to_string())?;
    // SAFETY: a NUL-terminated path; the handle is deliberately leaked.
    let handle = unsafe { libc::dlopen(c.as_ptr(), libc::RTLD_NOW | libc::RTLD_GLOBAL) };
    if !handle.is_null() {
        return Ok(());
    }
    // SAFETY: dlerror returns the calling thread's last loader message, or null.
    let msg = unsafe { libc::dlerror() };
    Err(if msg.is_null() {
        "cannot be loaded".into()
    } else {
        // SAFETY: non-null, NUL-terminated, valid until the next loader call on this thread.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    })
}

/// The C API calls that append the CUDA provider with `device_id` 0.
#[cfg(feature = "ort")]
fn append_cuda_provider(builder: &mut ort::session::builder::SessionBuilder) -> Result<(), String> {
    use ort::AsPointer;
    let api = ort::api();
    let mut opts: *mut ort::sys::OrtCUDAProviderOptionsV2 = std::ptr::null_mut();
    // SAFETY: C API with a valid out-pointer; released below on every path.
    status_to_result(unsafe { (api.CreateCUDAProviderOptions)(&mut opts) })?;
    if opts.is_null() {
        return Err("CreateCUDAProviderOptions returned null".into());
    }
    // TF32 (ONNX Runtime's default on Ampere and later) rounds convolution inputs to a 10-bit
    // mantissa: full FP32 keeps the GPU's output within a level of the CPU's. The exhaustive
    // cuDNN search (the default) picks each convolution's algorithm by timing, so two runs can
    // take algorithms that round differently: the heuristic choice depends on the shapes alone.
    let keys = ["device_id", "use_tf32", "cudnn_conv_algo_search"]
        .map(|k| CString::new(k).expect("no NUL"));
    let vals = ["0", "0", "DEFAULT"].map(|v| CString::new(v).expect("no NUL"));
    let kp: Vec<*const std::ffi::c_char> = keys.iter().map(|k| k.as_ptr()).collect();
    let vp: Vec<*const std::ffi::c_char> = vals.iter().map(|v| v.as_ptr()).collect();
    // SAFETY: `opts` is valid; key/value arrays outlive the call.
    let r = status_to_result(unsafe {
        (api.UpdateCUDAProviderOptions)(opts, kp.as_ptr(), vp.as_ptr(), kp.len())
    })
    .and_then(|()| {
        // SAFETY: the builder's session options pointer is valid for its lifetime.
        status_to_result(unsafe {
            (api.SessionOptionsAppendExecutionProvider_CUDA_V2)(builder.ptr_mut(), opts)
        })
    });
    // SAFETY: created above, not used afterwards (ONNX Runtime copies the options).
    unsafe { (api.ReleaseCUDAProviderOptions)(opts) };
    r
}

#[cfg(feature = "ort")]
fn status_to_result(st: ort::sys::OrtStatusPtr) -> Result<(), String> {
    if st.0.is_null() {
        return Ok(());
    }
    let api = ort::api();
    // SAFETY: non-null status from the C API: read its message, then release it once.
    let msg = unsafe { CStr::from_ptr((api.GetErrorMessage)(st.0)) }
        .to_string_lossy()
        .into_owned();
    unsafe { (api.ReleaseStatus)(st.0) };
    Err(msg)
}
