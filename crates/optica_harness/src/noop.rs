//! wgpu's noop backend: a device that validates shaders and pipelines and draws
//! nothing, so pipeline checks run on machines with no Vulkan driver at all.

use std::sync::Arc;

use bevy::render::{
    renderer::{
        RenderAdapter, RenderAdapterInfo, RenderDevice, RenderInstance, RenderQueue, WgpuWrapper,
    },
    settings::RenderCreation,
};
use wgpu::{
    BackendOptions, Backends, DeviceDescriptor, Features, Instance, InstanceDescriptor,
    InstanceFlags, Limits, NoopBackendOptions, RequestAdapterOptions,
};

use crate::HarnessError;

/// Renderer resources on the noop backend.
pub(crate) fn render_creation() -> Result<RenderCreation, HarnessError> {
    let instance = Instance::new(InstanceDescriptor {
        backends: Backends::NOOP,
        flags: InstanceFlags::default(),
        memory_budget_thresholds: Default::default(),
        display: None,
        backend_options: BackendOptions {
            noop: NoopBackendOptions { enable: true },
            ..Default::default()
        },
    });
    let adapter =
        bevy::tasks::block_on(instance.request_adapter(&RequestAdapterOptions::default()))
            .map_err(|e| HarnessError::Noop(e.to_string()))?;
    // Everything the noop adapter claims, less what Bevy must not switch on blindly.
    let features = adapter.features()
        - Features::all_experimental_mask()
        - Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
    let (device, queue) = bevy::tasks::block_on(adapter.request_device(&DeviceDescriptor {
        label: Some("optica noop device"),
        required_features: features,
        required_limits: Limits::default(),
        ..Default::default()
    }))
    .map_err(|e| HarnessError::Noop(e.to_string()))?;
    let info = adapter.get_info();
    Ok(RenderCreation::manual(
        RenderDevice::from(device),
        RenderQueue(Arc::new(WgpuWrapper::new(queue))),
        RenderAdapterInfo(WgpuWrapper::new(info)),
        RenderAdapter(Arc::new(WgpuWrapper::new(adapter))),
        RenderInstance(Arc::new(WgpuWrapper::new(instance))),
    ))
}
