//! From captured frames to polar maps: the VEM sequence's frames (fisheye, equirect or polar,
//! EXR or PNG), the lens file `calib/fisheye.toml` that describes the capture camera, its
//! photometric response, and the precomputed resampling into the decomposer's polar map.

pub mod input;
pub mod lens_file;
pub mod photometric;
pub mod resample;
