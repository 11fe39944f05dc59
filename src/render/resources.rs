//! What the renderer's passes share to make their GPU resources: 2D targets, bind group
//! layout entries, and the render passes that add to a layer or clear it.

use super::timestamps;

/// A 2D texture of `size` (one mip level, one sample): the passes' targets.
pub(super) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A bind group layout entry (no array).
pub(super) fn layout_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty,
        count: None,
    }
}

/// A uniform buffer binding of any size.
pub(super) const UNIFORM_BINDING: wgpu::BindingType = wgpu::BindingType::Buffer {
    ty: wgpu::BufferBindingType::Uniform,
    has_dynamic_offset: false,
    min_binding_size: None,
};

/// A read-only storage buffer binding of any size.
pub(super) const STORAGE_BINDING: wgpu::BindingType = wgpu::BindingType::Buffer {
    ty: wgpu::BufferBindingType::Storage { read_only: true },
    has_dynamic_offset: false,
    min_binding_size: None,
};

/// A 2D float texture binding.
pub(super) fn texture_binding(filterable: bool) -> wgpu::BindingType {
    wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Float { filterable },
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: false,
    }
}

/// A render pass that adds to (or overwrites) the caustics layer `view` as it stands after the
/// direct pass, timed as pass `name` when the adapter has timestamps: how the per-pixel caustics
/// passes (transport, pinhole) draw.
pub(super) fn caustics_pass<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    name: &'static str,
    timestamps: Option<&mut timestamps::Timestamps>,
) -> wgpu::RenderPass<'e> {
    caustics_pass_to(enc, &[view], name, timestamps)
}

/// [`caustics_pass`] onto several layers at once (each kept and added to).
pub(super) fn caustics_pass_to<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    views: &[&wgpu::TextureView],
    name: &'static str,
    timestamps: Option<&mut timestamps::Timestamps>,
) -> wgpu::RenderPass<'e> {
    let ts = timestamps.map(|t| {
        let k = t.pass(name);
        (&*t, k)
    });
    let attachments: Vec<_> = views.iter().map(|v| kept_attachment(v)).collect();
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(name),
        color_attachments: &attachments,
        depth_stencil_attachment: None,
        timestamp_writes: ts.map(|(t, k)| t.writes(k, true, true)),
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A colour attachment whose contents are kept and stored.
fn kept_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        },
    })
}

/// [`caustics_pass`] with the timestamp writes given (a pass timed together with the ones after
/// it writes only its beginning) and an optional depth attachment.
pub(super) fn caustics_pass_timed<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    name: &'static str,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
) -> wgpu::RenderPass<'e> {
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(name),
        color_attachments: &[kept_attachment(view)],
        depth_stencil_attachment: depth,
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A colour attachment cleared to transparent black and stored: how every pass here starts.
pub(super) fn cleared_attachment(
    view: &wgpu::TextureView,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}
