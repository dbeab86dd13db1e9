//! Reading textures and buffers back to the CPU (copy into a mappable buffer, wait, unpad rows).

use super::{Gpu, GpuError};

/// Bytes per row of a buffer copy must be a multiple of this.
const COPY_ALIGN: u32 = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;

/// Copies `texture` into a new mappable buffer, waits, and returns the rows without padding.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture, bytes_per_texel: u32) -> Result<Vec<u8>, GpuError> {
    let size = texture.size();
    let row = size.width * bytes_per_texel;
    let padded = row.div_ceil(COPY_ALIGN) * COPY_ALIGN;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * size.height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(size.height) },
        },
        size,
    );
    gpu.queue.submit([enc.finish()]);
    read_buffer(gpu, &buffer, row, padded, size.height)
}

/// Maps `buffer` (rows of `padded` bytes) and returns `height` rows of `row` bytes.
pub fn read_buffer(gpu: &Gpu, buffer: &wgpu::Buffer, row: u32, padded: u32, height: u32) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv().map_err(|e| GpuError::Device(e.to_string()))?.map_err(|e| GpuError::Device(e.to_string()))?;
    let data = slice.get_mapped_range().map_err(|e| GpuError::Device(e.to_string()))?;
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
    }
    drop(data);
    buffer.unmap();
    Ok(out)
}

/// Copies the first `size` bytes of `buffer` (which needs `COPY_SRC`) to the CPU.
pub fn read_buffer_bytes(gpu: &Gpu, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, GpuError> {
    let size = size.max(4).next_multiple_of(4);
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    gpu.queue.submit([enc.finish()]);
    read_buffer(gpu, &staging, size as u32, size as u32, 1)
}
