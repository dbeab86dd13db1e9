// Constants shared by the passes.

const PI: f32 = 3.14159265358979;

