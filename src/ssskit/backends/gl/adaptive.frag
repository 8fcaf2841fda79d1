#version 300 es
// ssskit: the guiding phase of the variance-guided adaptive sampler (Xie et al. 2020, Sec. 4.1, Fig. 8) as a
// GLSL ES 3.00 fragment shader (WebGL2, OpenGL ES 3): the fragment wrapper of the per-pixel body adaptive.glsl
// (inserted at the BODY marker), the same body the gl backend's compute shader (adaptive.comp) runs.
//
// Draw a full-screen triangle. With UPDATE: two targets, 0 the new history (RGBA32F), 1 the next counts (R32I);
// without (the estimate): one target, the counts (R32I). Pixel p of the body counts rows from the top of the
// image (ssskit's arrays); every fetch flips y. Textures: u_hist (RGBA32F) the previous history; u_mask (R32F or
// any float format, .r > 0 with SSS); u_motion (HAS_MOTION, .rg in pixels, ssskit's axes: y down); u_valid
// (R8UI, HAS_VALID); u_rgb (RGBA32F, UPDATE) the Burley result; u_counts (R32I, UPDATE) this frame's counts.

precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;
precision highp isampler2D;

// @GENERATED@

uniform ivec2 u_size;
uniform sampler2D u_hist;
uniform sampler2D u_mask;
#if HAS_MOTION
uniform sampler2D u_motion;
#endif
#if HAS_VALID
uniform usampler2D u_valid;
#endif
#if UPDATE
uniform sampler2D u_rgb;
uniform isampler2D u_counts;
#endif

ivec2 flip_y(ivec2 q) { return ivec2(q.x, u_size.y - 1 - q.y); }
vec4 load_hist(ivec2 q) { return texelFetch(u_hist, flip_y(q), 0); }
float load_mask(ivec2 q) { return texelFetch(u_mask, flip_y(q), 0).r; }
#if HAS_MOTION
vec2 load_motion(ivec2 q) { return texelFetch(u_motion, flip_y(q), 0).rg; }
#endif
#if HAS_VALID
uint load_valid(ivec2 q) { return texelFetch(u_valid, flip_y(q), 0).r; }
#endif
#if UPDATE
vec3 load_rgb(ivec2 q) { return texelFetch(u_rgb, flip_y(q), 0).rgb; }
int load_count(ivec2 q) { return texelFetch(u_counts, flip_y(q), 0).r; }
#endif

// @BODY@

#if UPDATE
layout(location = 0) out vec4 o_hist;
layout(location = 1) out ivec4 o_count;
#else
layout(location = 0) out ivec4 o_count;
#endif

void main() {
    vec4 h;
    int n = adaptive_texel(flip_y(ivec2(gl_FragCoord.xy)), h);
#if UPDATE
    o_hist = h;
#endif
    o_count = ivec4(n);
}
