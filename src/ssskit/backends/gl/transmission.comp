// ssskit: the transmittance pass (ssskit.backends.transmission_plan), GLSL 4.30 compute: the compute wrapper of
// the per-pixel body transmission.glsl (inserted at the BODY marker; transmission.frag is its fragment wrapper).
// The frame's images are shader storage buffers (float32, pixel order y * W + x; the slots int32).
#version 430

// @GENERATED@

layout(local_size_x = LOCAL) in;
layout(std430, binding = 0) readonly buffer Slots { int slots[]; };
layout(std430, binding = 1) readonly buffer Uvz { float uvz[]; };
layout(std430, binding = 2) readonly buffer Shadow { float shadow[]; };
layout(std430, binding = 3) readonly buffer Ndl { float ndl[]; };
layout(std430, binding = 4) readonly buffer Light { float light[]; };
layout(std430, binding = 5) writeonly buffer Out { float result[]; };
uniform int u_n;
uniform ivec2 u_shadow_size;


float load_shadow(int i, int j) { return shadow[j * u_shadow_size.x + i]; }

// @BODY@

void main() {
    int p = int(gl_GlobalInvocationID.x);
    if (p >= u_n) return;
    vec3 r = transmission_texel(slots[p], vec3(uvz[3 * p], uvz[3 * p + 1], uvz[3 * p + 2]), ndl[p],
                                vec3(light[3 * p], light[3 * p + 1], light[3 * p + 2]));
    result[3 * p] = r.x; result[3 * p + 1] = r.y; result[3 * p + 2] = r.z;
}
