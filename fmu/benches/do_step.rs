//! The full-order FMU's cost per `fmi2DoStep` against the same steps taken in process
//! (docs/validation/fmu.md): `cargo bench -p beltwin-fmu --features bench --bench do_step`.
//!
//! "in process": `Model::step` and the row accumulation, as `rom simulate` runs them;
//! "fmi2DoStep": the exported C function on an instance made by `fmi2Instantiate` from the
//! FMU's resources, the way an importer calls it (without the dynamic loading).

use std::ffi::CString;

use beltwin_fmu::ffi::{
    fmi2DoStep, fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance,
    fmi2Instantiate, fmi2SetupExperiment,
};
use beltwin_fmu::package::{contents, FmuKind};
use criterion::{criterion_group, criterion_main, Criterion};
use fom::integrator::{StepMode, StepWorkspace};
use fom::simulation::RowState;

fn bench(c: &mut Criterion) {
    let cfg = fom::ValidConfig::default_hvac();
    let dir = std::env::temp_dir().join(format!("beltwin-fmu-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary folder");
    let fmu = contents(FmuKind::Fom, &cfg, None).expect("the default drive packs");
    for (name, bytes) in &fmu.resources {
        std::fs::write(dir.join(name), bytes).expect("resources written");
    }
    let uri = CString::new(format!("file://{}", dir.display())).expect("a path");
    let guid = CString::new(fmu.guid.clone()).expect("a guid");
    let (mut model, _) = fom::simulation::prepare(&cfg).expect("equilibrium");
    let dt = model.params.step_s;
    let mut ws = StepWorkspace::default();
    let mut rows = RowState::new(&model);
    // SAFETY: the arguments are valid C strings; no callbacks (null).
    let inst = unsafe {
        fmi2Instantiate(
            c"bench".as_ptr(),
            1,
            guid.as_ptr(),
            uri.as_ptr(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(!inst.is_null(), "the FMU instantiates");
    assert_eq!(fmi2SetupExperiment(inst, 0, 0.0, 0.0, 0, 0.0), 0);
    assert_eq!(fmi2EnterInitializationMode(inst), 0);
    assert_eq!(fmi2ExitInitializationMode(inst), 0);
    let mut t = 0.0;
    for (name, steps) in [("one model step", 1usize), ("1 ms (100 model steps)", 100)] {
        let mut g = c.benchmark_group(name);
        g.bench_function("in process", |b| {
            b.iter(|| {
                for _ in 0..steps {
                    model.step(StepMode::Dynamic, &mut ws);
                    rows.accumulate(&model);
                }
                rows.finish(&model, &mut None)
            })
        });
        g.bench_function("fmi2DoStep", |b| {
            b.iter(|| {
                let h = steps as f64 * dt;
                assert_eq!(fmi2DoStep(inst, t, h, 0), 0);
                t += h;
            })
        });
        g.finish();
    }
    // SAFETY: made above, freed once.
    unsafe { fmi2FreeInstance(inst) };
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
