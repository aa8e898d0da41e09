//! The FMU's contents and its C functions in process (FMPy drives the packed FMUs:
//! python/tests/test_fmu.py).

use std::ffi::CString;

use beltwin_fmu::ffi::{fmi2DoStep, fmi2FreeInstance, fmi2Instantiate, fmi2SetReal};
use beltwin_fmu::instance::Instance;
use beltwin_fmu::package::{contents, FmuKind};
use beltwin_fmu::variables::Causality;

fn resources(kind: FmuKind) -> (tempfile::TempDir, String) {
    let cfg = fom::ValidConfig::default_hvac();
    let c = contents(kind, &cfg, None).expect("the default drive packs");
    let dir = tempfile::tempdir().expect("a temporary folder");
    for (name, bytes) in &c.resources {
        std::fs::write(dir.path().join(name), bytes).expect("written");
    }
    (dir, c.guid)
}

#[test]
fn the_same_export_gives_the_same_token_and_every_output_is_listed() {
    let cfg = fom::ValidConfig::default_hvac();
    let a = contents(FmuKind::Fom, &cfg, None).unwrap();
    let b = contents(FmuKind::Fom, &cfg, None).unwrap();
    assert_eq!(a.guid, b.guid);
    assert_eq!(a.model_description, b.model_description);
    let longer = cfg.clone().with_duration(5.0).unwrap();
    assert_ne!(contents(FmuKind::Fom, &longer, None).unwrap().guid, a.guid);
    let outputs = a
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .count();
    assert_eq!(outputs, 7);
    // Each output once under Outputs and once under InitialUnknowns.
    assert_eq!(
        a.model_description.matches("<Unknown index=").count(),
        2 * outputs
    );
    let inputs: Vec<&str> = a
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Input)
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(inputs, ["motor_on", "extra_load_torque_nm"]);
    assert!(contents(FmuKind::Surrogate, &cfg, None).is_err());
}

#[test]
fn a_foreign_token_is_refused_by_name() {
    let (dir, guid) = resources(FmuKind::Fom);
    let err = Instance::new(dir.path(), "{not-this-one}").unwrap_err();
    assert!(err.contains("instantiation token {not-this-one}"), "{err}");
    assert!(err.contains(&guid), "{err}");
}

#[test]
fn calls_out_of_order_and_bad_values_return_an_error_status() {
    let (dir, guid) = resources(FmuKind::Fom);
    let uri = CString::new(format!("file://{}", dir.path().display())).unwrap();
    let guid = CString::new(guid).unwrap();
    // SAFETY: valid C strings, no callbacks.
    let inst = unsafe {
        fmi2Instantiate(
            c"t".as_ptr(),
            1,
            guid.as_ptr(),
            uri.as_ptr(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(!inst.is_null());
    // fmi2Error (3): stepping before initialisation, setting an output, an unknown reference.
    assert_eq!(fmi2DoStep(inst, 0.0, 1e-3, 0), 3);
    let (output, unknown) = ([2u32], [99u32]);
    let x = [1.0];
    assert_eq!(
        unsafe { fmi2SetReal(inst, output.as_ptr(), 1, x.as_ptr()) },
        3
    );
    assert_eq!(
        unsafe { fmi2SetReal(inst, unknown.as_ptr(), 1, x.as_ptr()) },
        3
    );
    let model_exchange = unsafe {
        fmi2Instantiate(
            c"t".as_ptr(),
            0,
            guid.as_ptr(),
            uri.as_ptr(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(model_exchange.is_null());
    unsafe { fmi2FreeInstance(inst) };
}
