#version 330 core
// Multiple render targets from one pass:
//   0: linear depth, z along the optical axis in metres, from the interpolated eye-space
//      position (never from the depth buffer)          R32F
//   1: instance id                                       R32UI
//   2: semantic id                                       R16UI
//   3: colour, Lambert with a head light (WITH_COLOR)    RGBA8
//   4: camera-frame unit normal (WITH_NORMAL)            RGBA32F
// PACKED_IDS (the renderer's default, genie_gl/render/readback.py): target 0 is RG32UI, the
//      depth's float bits and the instance id (0 bits with NO_LINEAR_DEPTH), no semantic
//      target (looked up from the instance id on read-back), colour at 1, normal at 2.
// NO_LINEAR_DEPTH leaves target 0 alone (depth then comes from the depth buffer);
// DEPTH_ONLY writes no target (the 24-bit depth pass).
// WITH_PRIMITIVE (asked for by the lens, genie_gl/triangles.py): one more RG32UI target after
//      the others, the draw slot + 1 and gl_PrimitiveID (the triangle within its draw).

in vec3 v_eye;
flat in uint v_instance;
flat in uint v_semantic;
flat in vec3 v_color;
#ifdef WITH_PRIMITIVE
flat in uint v_slot;
#endif

#ifdef PACKED_IDS
#define LOC_COLOR 1
#define LOC_NORMAL 2
#ifndef DEPTH_ONLY
layout(location = 0) out uvec2 o_packed;
#endif
#else
#define LOC_COLOR 3
#define LOC_NORMAL 4
#ifndef NO_LINEAR_DEPTH
layout(location = 0) out float o_depth;
#endif
#ifndef DEPTH_ONLY
layout(location = 1) out uint o_instance;
layout(location = 2) out uint o_semantic;
#endif
#endif
#ifdef WITH_COLOR
layout(location = LOC_COLOR) out vec4 o_color;
#endif
#ifdef WITH_NORMAL
layout(location = LOC_NORMAL) out vec4 o_normal;
#endif
#ifdef WITH_PRIMITIVE
// after the colour and normal targets the framebuffer holds (a normal target comes with a
// colour target, used or not)
// (locations are literals: GLSL 3.30 takes no expressions there)
#if defined(PACKED_IDS) && defined(WITH_NORMAL)
#define LOC_PRIMITIVE 3
#elif defined(PACKED_IDS) && defined(WITH_COLOR)
#define LOC_PRIMITIVE 2
#elif defined(PACKED_IDS)
#define LOC_PRIMITIVE 1
#elif defined(WITH_NORMAL)
#define LOC_PRIMITIVE 5
#elif defined(WITH_COLOR)
#define LOC_PRIMITIVE 4
#else
#define LOC_PRIMITIVE 3
#endif
layout(location = LOC_PRIMITIVE) out uvec2 o_primitive;
#endif

void main() {
#ifdef PACKED_IDS
#ifndef DEPTH_ONLY
#ifdef NO_LINEAR_DEPTH
    o_packed = uvec2(0u, v_instance);
#else
    o_packed = uvec2(floatBitsToUint(v_eye.z), v_instance);
#endif
#endif
#else
#ifndef NO_LINEAR_DEPTH
    o_depth = v_eye.z;
#endif
#ifndef DEPTH_ONLY
    o_instance = v_instance;
    o_semantic = v_semantic;
#endif
#endif
#if defined(WITH_COLOR) || defined(WITH_NORMAL)
    // Face normal from screen-space derivatives (exact for planar triangles); turned to face
    // the camera. A vanishing cross product (grazing, sub-pixel) falls back to the view ray.
    vec3 c = cross(dFdx(v_eye), dFdy(v_eye));
    float len = length(c);
    vec3 view = normalize(v_eye);
    vec3 n = len > 1e-30 ? c / len : -view;
    if (dot(n, view) > 0.0) n = -n;
#endif
#ifdef WITH_COLOR
    float lambert = max(dot(n, -view), 0.0);
    o_color = vec4(v_color * (0.2 + 0.8 * lambert), 1.0);
#endif
#ifdef WITH_NORMAL
    o_normal = vec4(n, 0.0);
#endif
#ifdef WITH_PRIMITIVE
    o_primitive = uvec2(v_slot + 1u, uint(gl_PrimitiveID));
#endif
}
