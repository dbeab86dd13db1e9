// Camera constants of the pinhole canvas the 3D passes draw into.
// Mirrors `CameraUniform` in src/gpu/canvas.rs.
//
// Projection: OpenCV camera (x right, y down, z forward) to wgpu clip space with reversed depth
// and an infinite far plane: z_ndc = near / z_cam, so points at infinity (w = 0, the ends of
// the shadow volumes) land exactly at depth 0 and nothing is clipped behind the scene.

struct Camera {
    // World (homogeneous) to clip space.
    clip_from_world: mat4x4<f32>,
    // Camera centre in the world frame (w = 1).
    eye_world: vec4<f32>,
    // Canvas width and height in pixels, and their reciprocals.
    canvas_size: vec4<f32>,
}

// Clip-space position of a homogeneous world point. Every pass that compares depth with the
// prepass goes through this one function, so the arithmetic is identical.
fn clip_from_world_point(camera: Camera, p: vec4<f32>) -> vec4<f32> {
    return camera.clip_from_world * p;
}
