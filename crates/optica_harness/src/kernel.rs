//! One compute dispatch with a readback: WGSL functions against their CPU
//! twins, number for number.

use bevy::render::RenderApp;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use wgpu::util::DeviceExt;

use crate::HarnessError;
use crate::headless::{Headless, adapter_info, check_adapter, finish, lock};

/// Workgroup size a kernel must declare: `@workgroup_size(64)`.
pub const KERNEL_WORKGROUP: u32 = 64;

impl Headless {
    /// Runs the compute entry point `entry` of `wgsl` once over `outputs`
    /// invocations and returns what it wrote: the way to hold a WGSL
    /// function to its CPU twin on the test adapter.
    ///
    /// The shader sees `@group(0) @binding(0) var<storage, read> input:
    /// array<f32>` (the `input` slice; one zero when empty) and
    /// `@group(0) @binding(1) var<storage, read_write> output: array<f32>`
    /// (`outputs` floats, zeroed), and must declare
    /// `@workgroup_size(64)` ([`KERNEL_WORKGROUP`]); invocations past the end
    /// of `output` must return early. `wgsl` is plain WGSL: paste the
    /// function under test in (for a `#define_import_path` library, its
    /// source without that line).
    ///
    /// ```no_run
    /// use optica_harness::Headless;
    ///
    /// let wgsl = "
    /// @group(0) @binding(0) var<storage, read> input: array<f32>;
    /// @group(0) @binding(1) var<storage, read_write> output: array<f32>;
    /// @compute @workgroup_size(64)
    /// fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    ///     if id.x >= arrayLength(&output) { return; }
    ///     output[id.x] = sqrt(input[id.x]);
    /// }";
    /// let out = Headless::new(1, 1).run_kernel(wgsl, "main", &[4.0, 9.0], 2)?;
    /// assert_eq!(out, vec![2.0, 3.0]);
    /// # Ok::<(), optica_harness::HarnessError>(())
    /// ```
    pub fn run_kernel(
        &self,
        wgsl: &str,
        entry: &str,
        input: &[f32],
        outputs: usize,
    ) -> Result<Vec<f32>, HarnessError> {
        let _one_at_a_time = lock();
        if self.adapter == crate::Adapter::Noop {
            return Err(HarnessError::NoPixelsOnNoop);
        }
        let mut app = self.build_app(false)?;
        finish(&mut app)?;
        check_adapter(&self.adapter, &adapter_info(&mut app)?)?;
        let render = app.get_sub_app(RenderApp).ok_or(HarnessError::NoAdapter)?;
        let device = render
            .world()
            .get_resource::<RenderDevice>()
            .ok_or(HarnessError::NoAdapter)?
            .wgpu_device()
            .clone();
        let queue = render
            .world()
            .get_resource::<RenderQueue>()
            .ok_or(HarnessError::NoAdapter)?;
        let outputs = outputs.max(1);
        let input: Vec<f32> = if input.is_empty() {
            vec![0.0]
        } else {
            input.to_vec()
        };

        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("optica_harness kernel"),
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("optica_harness kernel"),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        let bytes = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let input_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("optica_harness kernel input"),
            contents: &bytes(&input),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (outputs * 4) as u64;
        let output_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("optica_harness kernel output"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("optica_harness kernel staging"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("optica_harness kernel"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: input_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: output_buffer.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups((outputs as u32).div_ceil(KERNEL_WORKGROUP), 1, 1);
        }
        encoder.copy_buffer_to_buffer(&output_buffer, 0, &staging, 0, size);
        queue.submit([encoder.finish()]);
        if let Some(error) = bevy::tasks::block_on(scope.pop()) {
            return Err(HarnessError::Wgpu(error.to_string()));
        }
        staging.slice(..).map_async(wgpu::MapMode::Read, |result| {
            result.expect("mapping the kernel's output");
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| HarnessError::Wgpu(e.to_string()))?;
        let data = staging.slice(..).get_mapped_range();
        Ok(data
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }
}
