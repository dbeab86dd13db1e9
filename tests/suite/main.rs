//! heliar's integration tests, as one test binary: every module below was once a binary of its
//! own, and each of those linked wgpu, OpenCV and egui again (21 links of ~100 MB on two cores,
//! and the disk that CI ran out of). One binary links once; `cargo test --features opencv
//! --test suite <module>::` runs one module, e.g. `render::` or `bad_input::`.

mod common;
mod render;
mod architecture;
mod augment_video;
mod bad_input;
mod bad_input_calib;
mod bad_input_run;
mod behaviour;
mod bench_cli;
mod calib_tool;
mod chunks;
mod cli;
mod cloud_lag;
mod estimate_courtyard;
mod estimate_dusk;
mod estimate_dusk_rows;
mod estimate_slices;
mod estimator_stiff;
mod interrupt_resume;
mod irradiance_volume;
mod lamp_hindsight;
mod lamps_estimate;
mod live;
mod live_drag;
mod object_cuts;
mod object_cuts_far;
mod object_cuts_gpu;
mod object_cuts_static;
mod object_cuts_turned;
mod object_cuts_two;
mod object_motion;
mod scene_errors;
mod shader_validation;
mod sky_terrain;
mod uniform_branches;
mod vem_allocation;
mod vem_cli;
mod vem_coherent_cut;
mod vem_motion;
mod vem_render;
mod vem_sequences;
mod vem_stiff;
mod vem_temporal;
