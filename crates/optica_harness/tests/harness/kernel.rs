//! `Headless::run_kernel`: one compute dispatch, read back.

use optica_harness::{Adapter, HarnessError, Headless};

const SQRT: &str = "
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&output) { return; }
    output[id.x] = sqrt(input[id.x]) + f32(id.x);
}";

#[test]
fn a_kernel_runs_over_every_output_and_reads_back() {
    // 130 outputs: three workgroups, the last one partly idle.
    let input: Vec<f32> = (0..130).map(|i| (i * i) as f32).collect();
    let out = Headless::new(1, 1)
        .run_kernel(SQRT, "main", &input, 130)
        .expect("kernel");
    assert_eq!(out.len(), 130);
    for (i, v) in out.iter().enumerate() {
        // WGSL's sqrt may be a few ULP off on some adapters.
        let want = 2.0 * i as f32;
        assert!(
            (v - want).abs() <= 1e-5 * want.max(1.0),
            "output {i}: {v}, want {want}"
        );
    }
}

#[test]
fn invalid_wgsl_is_an_error_not_a_panic() {
    let err = Headless::new(1, 1)
        .run_kernel("fn main( {", "main", &[], 1)
        .expect_err("broken WGSL");
    assert!(matches!(err, HarnessError::Wgpu(_)), "{err:?}");
    let noop = Headless::new(1, 1)
        .adapter(Adapter::Noop)
        .run_kernel(SQRT, "main", &[1.0], 1);
    assert!(
        matches!(noop, Err(HarnessError::NoPixelsOnNoop)),
        "{noop:?}"
    );
}
