// ssskit: the prefiltered irradiance of the Burley pass (Xie 2020 Eqs. 22-23; ssskit.backends.burley_plan
// step 5b), GLSL 4.30 compute. One dispatch per level into an RGBA32F 2D array (one layer per slot;
// level k at (u_mip_x[k], 1), u_mip_size[k] = ceil(size / 2^k), inside a border of zero texels that is
// never written): level 0 holds the premultiplied
// colour and coverage (E [slot = layer + 1], [slot = layer + 1]), level k the mean of the 2 x 2 children
// of level k - 1 (children off that level count 0).

#version 430

// @GENERATED@

layout(local_size_x = 16, local_size_y = 16, local_size_z = 1) in;

layout(binding = 0) uniform sampler2D u_src;
layout(binding = 1) uniform usampler2D u_slots;
layout(rgba32f, binding = 1) uniform image2DArray u_atlas;
uniform int u_level;
uniform int u_mip_x[MAX_MIP + 1];     // x offset of each level in the atlas
uniform ivec2 u_mip_size[MAX_MIP + 1];  // ceil(size / 2^k)

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);
    ivec2 size = u_mip_size[u_level];
    if (g.x >= size.x || g.y >= size.y) return;
    vec4 v = vec4(0.0);
    if (u_level == 0) {
        bool mine = int(texelFetch(u_slots, g.xy, 0).r) == g.z + 1;
        v = mine ? vec4(texelFetch(u_src, g.xy, 0).rgb, 1.0) : vec4(0.0);
    } else {
        ivec2 child = u_mip_size[u_level - 1];
        for (int dj = 0; dj < 2; ++dj) {
            for (int di = 0; di < 2; ++di) {
                ivec2 q = 2 * g.xy + ivec2(di, dj);
                if (q.x < child.x && q.y < child.y)
                    v += imageLoad(u_atlas, ivec3(q.x + u_mip_x[u_level - 1], q.y + 1, g.z));
            }
        }
        v *= 0.25;
    }
    imageStore(u_atlas, ivec3(g.x + u_mip_x[u_level], g.y + 1, g.z), v);
}
