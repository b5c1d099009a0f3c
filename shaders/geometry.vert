#version 330 core
// One geometry pass for every buffer genie-gl renders (see shaders/geometry.frag).
// Positions are model-space float32; the per-instance camera_from_model rows were composed
// in float64 on the CPU relative to the camera, so far-away scenes stay exact.

in vec3 in_position;
in vec4 in_row0;        // camera_from_model, row 0
in vec4 in_row1;        // row 1
in vec4 in_row2;        // row 2
in uint in_instance;
in uint in_semantic;
in vec4 in_color;       // normalised RGBA8
#ifdef WITH_PRIMITIVE
in uint in_slot;        // the instance's row (a static buffer 0, 1, 2, ... read per instance)
#endif

// OpenCV pinhole to clip space: u = fx x/z + s y/z + cx, v = fy y/z + cy, pixel centres at
// integer (u, v). Window x = u + 0.5, window y = v + 0.5 (row 0 of the read-back is v = 0).
uniform vec3 u_proj_x;  // (2 fx / W, 2 s / W, 2 (cx + 0.5) / W - 1)
uniform vec2 u_proj_y;  // (2 fy / H, 2 (cy + 0.5) / H - 1)
uniform vec2 u_depth;   // window depth = A + B / z (clip z = A z + B, w = z), [0, 1] with clip
                        // control: (0, near) is reversed, infinite-far Z (near / z)

out vec3 v_eye;
flat out uint v_instance;
flat out uint v_semantic;
flat out vec3 v_color;
#ifdef WITH_PRIMITIVE
flat out uint v_slot;
#endif

void main() {
    vec4 p = vec4(in_position, 1.0);
    vec3 e = vec3(dot(in_row0, p), dot(in_row1, p), dot(in_row2, p));
    v_eye = e;
    v_instance = in_instance;
    v_semantic = in_semantic;
    v_color = in_color.rgb;
#ifdef WITH_PRIMITIVE
    v_slot = in_slot;
#endif
    gl_Position = vec4(u_proj_x.x * e.x + u_proj_x.y * e.y + u_proj_x.z * e.z,
                       u_proj_y.x * e.y + u_proj_y.y * e.z,
                       u_depth.x * e.z + u_depth.y,
                       e.z);
}
