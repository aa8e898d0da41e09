//! The FMI 2.0 C functions of a co-simulation FMU (FMI 2.0.4 standard, `fmi2Functions.h`),
//! written by hand (docs/decisions/fmi-version.md). Every function catches panics
//! (`catch_unwind`): none crosses the C ABI; a failure returns `fmi2Error` with a message to the
//! importer's logger.

#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use crate::instance::{CallResult, Instance, Phase};
use crate::variables::Type;

const OK: c_int = 0;
const ERROR: c_int = 3;
/// `fmi2CoSimulation` of `fmi2Type`.
const CO_SIMULATION: c_int = 1;

type Logger = Option<
    unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...),
>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct CallbackFunctions {
    logger: Logger,
    allocate_memory: *const c_void,
    free_memory: *const c_void,
    step_finished: *const c_void,
    environment: *mut c_void,
}

/// What an `fmi2Component` points to.
struct Component {
    inst: Instance,
    name: CString,
    logger: Logger,
    environment: *mut c_void,
}

/// Sends `message` to the importer's logger, if it gave one.
fn log(logger: Logger, env: *mut c_void, name: &CStr, status: c_int, message: &str) {
    let Some(f) = logger else { return };
    let category = if status >= ERROR {
        c"logStatusError"
    } else {
        c"logAll"
    };
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the importer's logger takes a printf format; the message goes in as "%s".
    unsafe {
        f(
            env,
            name.as_ptr(),
            status,
            category.as_ptr(),
            c"%s".as_ptr(),
            text.as_ptr(),
        )
    };
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs `f` on the instance behind `c`: its error is logged and returned as `fmi2Error`, a
/// panic as `fmi2Error` too, after which the instance is failed.
fn call(c: *mut c_void, what: &str, f: impl FnOnce(&mut Instance) -> CallResult) -> c_int {
    if c.is_null() {
        return ERROR;
    }
    // SAFETY: a non-null component is one `fmi2Instantiate` returned and not yet freed.
    let comp = unsafe { &mut *(c as *mut Component) };
    let result = catch_unwind(AssertUnwindSafe(|| f(&mut comp.inst)));
    let (status, message) = match result {
        Ok(Ok(())) => return OK,
        Ok(Err(m)) => (ERROR, format!("{what}: {m}")),
        Err(p) => {
            comp.inst.phase = Phase::Failed;
            (
                ERROR,
                format!(
                    "{what}: internal error ({}); the instance is failed",
                    panic_text(&*p)
                ),
            )
        }
    };
    log(comp.logger, comp.environment, &comp.name, status, &message);
    status
}

/// A slice from a C array (empty when `n` is zero, whatever the pointer).
unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if n == 0 || p.is_null() {
        &[]
    } else {
        std::slice::from_raw_parts(p, n)
    }
}

unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if n == 0 || p.is_null() {
        &mut []
    } else {
        std::slice::from_raw_parts_mut(p, n)
    }
}

/// The folder of a `file:` URI (`file:///a/b`, `file:/a/b`), percent-decoded.
fn uri_path(uri: &str) -> Result<PathBuf, String> {
    let rest = uri
        .strip_prefix("file://localhost")
        .or_else(|| uri.strip_prefix("file://"))
        .or_else(|| uri.strip_prefix("file:"))
        .ok_or_else(|| format!("resource location {uri} is not a file: URI"))?;
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut k = 0;
    while k < bytes.len() {
        let hex = bytes
            .get(k + 1..k + 3)
            .and_then(|h| std::str::from_utf8(h).ok());
        match (bytes[k], hex.and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(b)) => {
                out.push(b);
                k += 3;
            }
            (b, _) => {
                out.push(b);
                k += 1;
            }
        }
    }
    use std::os::unix::ffi::OsStringExt;
    Ok(PathBuf::from(std::ffi::OsString::from_vec(out)))
}

unsafe fn text<'a>(p: *const c_char) -> &'a str {
    if p.is_null() {
        ""
    } else {
        CStr::from_ptr(p).to_str().unwrap_or("")
    }
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    _logging_on: c_int,
) -> *mut c_void {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let (logger, env) = match functions.as_ref() {
            Some(f) => (f.logger, f.environment),
            None => (None, std::ptr::null_mut()),
        };
        let name = CString::new(text(instance_name)).unwrap_or_default();
        let made = (|| {
            if fmu_type != CO_SIMULATION {
                return Err("this FMU is co-simulation only (fmi2CoSimulation)".to_string());
            }
            let resources = uri_path(text(resource_location))?;
            Instance::new(&resources, text(guid))
        })();
        match made {
            Ok(inst) => Box::into_raw(Box::new(Component {
                inst,
                name,
                logger,
                environment: env,
            })) as *mut c_void,
            Err(m) => {
                log(logger, env, &name, ERROR, &format!("fmi2Instantiate: {m}"));
                std::ptr::null_mut()
            }
        }
    }));
    result.unwrap_or(std::ptr::null_mut())
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: *mut c_void) {
    if !c.is_null() {
        let _ = catch_unwind(|| drop(Box::from_raw(c as *mut Component)));
    }
}

#[no_mangle]
pub extern "C" fn fmi2SetDebugLogging(
    c: *mut c_void,
    _on: c_int,
    _n: usize,
    _categories: *const *const c_char,
) -> c_int {
    call(c, "fmi2SetDebugLogging", |_| Ok(()))
}

#[no_mangle]
pub extern "C" fn fmi2SetupExperiment(
    c: *mut c_void,
    _tolerance_defined: c_int,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: c_int,
    _stop_time: f64,
) -> c_int {
    call(c, "fmi2SetupExperiment", |i| i.setup_experiment(start_time))
}

#[no_mangle]
pub extern "C" fn fmi2EnterInitializationMode(c: *mut c_void) -> c_int {
    call(c, "fmi2EnterInitializationMode", |i| {
        i.enter_initialization()
    })
}

#[no_mangle]
pub extern "C" fn fmi2ExitInitializationMode(c: *mut c_void) -> c_int {
    call(c, "fmi2ExitInitializationMode", |i| i.exit_initialization())
}

#[no_mangle]
pub extern "C" fn fmi2Terminate(c: *mut c_void) -> c_int {
    call(c, "fmi2Terminate", |i| i.terminate())
}

#[no_mangle]
pub extern "C" fn fmi2Reset(c: *mut c_void) -> c_int {
    call(c, "fmi2Reset", |i| {
        i.reset();
        Ok(())
    })
}

/// Gets values of type `ty` and converts them with `to`.
unsafe fn get<T>(
    c: *mut c_void,
    what: &str,
    vr: *const c_uint,
    n: usize,
    value: *mut T,
    ty: Type,
    to: fn(f64) -> T,
) -> c_int {
    call(c, what, |i| {
        let vrs = slice(vr, n);
        let mut buf = vec![0.0; n];
        i.get(vrs, ty, &mut buf)?;
        for (o, x) in slice_mut(value, n).iter_mut().zip(buf) {
            *o = to(x);
        }
        Ok(())
    })
}

/// Sets values of type `ty` converted with `from`.
unsafe fn set<T: Copy>(
    c: *mut c_void,
    what: &str,
    vr: *const c_uint,
    n: usize,
    value: *const T,
    ty: Type,
    from: fn(T) -> f64,
) -> c_int {
    call(c, what, |i| {
        let vals: Vec<f64> = slice(value, n).iter().map(|x| from(*x)).collect();
        i.set(slice(vr, n), ty, &vals)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *mut f64,
) -> c_int {
    get(c, "fmi2GetReal", vr, n, v, Type::Real, |x| x)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *mut c_int,
) -> c_int {
    get(c, "fmi2GetInteger", vr, n, v, Type::Integer, |x| x as c_int)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *mut c_int,
) -> c_int {
    get(c, "fmi2GetBoolean", vr, n, v, Type::Boolean, |x| {
        c_int::from(x != 0.0)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *const f64,
) -> c_int {
    set(c, "fmi2SetReal", vr, n, v, Type::Real, |x| x)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *const c_int,
) -> c_int {
    set(c, "fmi2SetInteger", vr, n, v, Type::Integer, f64::from)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: *mut c_void,
    vr: *const c_uint,
    n: usize,
    v: *const c_int,
) -> c_int {
    set(c, "fmi2SetBoolean", vr, n, v, Type::Boolean, |x| {
        f64::from(u8::from(x != 0))
    })
}

/// The refusal of a call these FMUs do not support (no String variables, no derivatives, no
/// serialised state, no asynchronous steps), unless it asks for nothing.
fn unsupported(c: *mut c_void, what: &str, n: usize) -> c_int {
    call(c, what, |_| {
        if n == 0 {
            Ok(())
        } else {
            Err("not supported by this FMU (see its model description's capabilities)".into())
        }
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetString(
    c: *mut c_void,
    _vr: *const c_uint,
    n: usize,
    _v: *mut *const c_char,
) -> c_int {
    unsupported(c, "fmi2GetString", n)
}

#[no_mangle]
pub extern "C" fn fmi2SetString(
    c: *mut c_void,
    _vr: *const c_uint,
    n: usize,
    _v: *const *const c_char,
) -> c_int {
    unsupported(c, "fmi2SetString", n)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: *mut c_void, state: *mut *mut c_void) -> c_int {
    call(c, "fmi2GetFMUstate", |i| {
        if state.is_null() {
            return Err("no place for the state (null pointer)".into());
        }
        let saved = i.clone();
        if (*state).is_null() {
            *state = Box::into_raw(Box::new(saved)) as *mut c_void;
        } else {
            *(*state as *mut Instance) = saved;
        }
        Ok(())
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: *mut c_void, state: *mut c_void) -> c_int {
    call(c, "fmi2SetFMUstate", |i| {
        let saved = (state as *const Instance)
            .as_ref()
            .ok_or("no state given (null pointer)")?;
        *i = saved.clone();
        Ok(())
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: *mut c_void, state: *mut *mut c_void) -> c_int {
    call(c, "fmi2FreeFMUstate", |_| {
        if !state.is_null() && !(*state).is_null() {
            drop(Box::from_raw(*state as *mut Instance));
            *state = std::ptr::null_mut();
        }
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2SerializedFMUstateSize(
    c: *mut c_void,
    _s: *mut c_void,
    _size: *mut usize,
) -> c_int {
    unsupported(c, "fmi2SerializedFMUstateSize", 1)
}

#[no_mangle]
pub extern "C" fn fmi2SerializeFMUstate(
    c: *mut c_void,
    _s: *mut c_void,
    _b: *mut u8,
    _n: usize,
) -> c_int {
    unsupported(c, "fmi2SerializeFMUstate", 1)
}

#[no_mangle]
pub extern "C" fn fmi2DeSerializeFMUstate(
    c: *mut c_void,
    _b: *const u8,
    _n: usize,
    _s: *mut *mut c_void,
) -> c_int {
    unsupported(c, "fmi2DeSerializeFMUstate", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetDirectionalDerivative(
    c: *mut c_void,
    _u: *const c_uint,
    nu: usize,
    _z: *const c_uint,
    _nz: usize,
    _dv: *const f64,
    _dz: *mut f64,
) -> c_int {
    unsupported(c, "fmi2GetDirectionalDerivative", nu)
}

#[no_mangle]
pub extern "C" fn fmi2SetRealInputDerivatives(
    c: *mut c_void,
    _vr: *const c_uint,
    n: usize,
    _order: *const c_int,
    _v: *const f64,
) -> c_int {
    unsupported(c, "fmi2SetRealInputDerivatives", n)
}

#[no_mangle]
pub extern "C" fn fmi2GetRealOutputDerivatives(
    c: *mut c_void,
    _vr: *const c_uint,
    n: usize,
    _order: *const c_int,
    _v: *mut f64,
) -> c_int {
    unsupported(c, "fmi2GetRealOutputDerivatives", n)
}

#[no_mangle]
pub extern "C" fn fmi2DoStep(c: *mut c_void, t: f64, h: f64, _no_set_prior: c_int) -> c_int {
    call(c, "fmi2DoStep", |i| i.do_step(t, h))
}

#[no_mangle]
pub extern "C" fn fmi2CancelStep(c: *mut c_void) -> c_int {
    unsupported(c, "fmi2CancelStep", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetStatus(c: *mut c_void, _kind: c_int, _v: *mut c_int) -> c_int {
    unsupported(c, "fmi2GetStatus", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetRealStatus(c: *mut c_void, _kind: c_int, _v: *mut f64) -> c_int {
    unsupported(c, "fmi2GetRealStatus", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetIntegerStatus(c: *mut c_void, _kind: c_int, _v: *mut c_int) -> c_int {
    unsupported(c, "fmi2GetIntegerStatus", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetBooleanStatus(c: *mut c_void, _kind: c_int, _v: *mut c_int) -> c_int {
    unsupported(c, "fmi2GetBooleanStatus", 1)
}

#[no_mangle]
pub extern "C" fn fmi2GetStringStatus(
    c: *mut c_void,
    _kind: c_int,
    _v: *mut *const c_char,
) -> c_int {
    unsupported(c, "fmi2GetStringStatus", 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_uris_become_paths() {
        assert_eq!(
            uri_path("file:///tmp/a%20b/resources").unwrap(),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(uri_path("file:/tmp/x").unwrap(), PathBuf::from("/tmp/x"));
        assert!(uri_path("http://x/y").is_err());
    }

    #[test]
    fn a_null_component_is_an_error_not_a_crash() {
        assert_eq!(fmi2DoStep(std::ptr::null_mut(), 0.0, 1.0, 0), ERROR);
        assert_eq!(
            unsafe {
                fmi2Instantiate(
                    std::ptr::null(),
                    1,
                    std::ptr::null(),
                    std::ptr::null(),
                    std::ptr::null(),
                    0,
                    0,
                )
            },
            std::ptr::null_mut()
        );
    }
}
