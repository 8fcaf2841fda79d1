#version 300 es
// ssskit: the Burley Monte Carlo screen-space SSS pass (Xie et al. 2020, Eqs. 19-24) as a GLSL ES 3.00
// fragment shader (WebGL2, OpenGL ES 3): the fragment wrapper of the per-pixel body burley.glsl (inserted at
// the BODY marker), the same body the gl backend's compute shader (burley.comp) runs.
//
// Draw a full-screen triangle into a W x H RGBA32F target. Pixel p of the body counts rows from the top of
// the image (ssskit's arrays); GL's rows count from the bottom, so every fetch flips y.
// Textures: u_src (RGBA32F) E in .rgb, depth in mm in .a (-1 without SSS); u_slots (R16UI, MULTI_SLOT);
// u_counts (R32I, COUNT_IMAGE) the per-pixel sample counts. The mip pyramid (MIPS) is not built in this form.

precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;
precision highp isampler2D;

// @GENERATED@

#if MIPS
#error the fragment form of the Burley pass has no mip pyramid (build the plan with mips off)
#endif

uniform ivec2 u_size;
uniform sampler2D u_src;
#if MULTI_SLOT
uniform usampler2D u_slots;
#endif
#if COUNT_IMAGE
uniform isampler2D u_counts;
#endif

ivec2 flip_y(ivec2 q) { return ivec2(q.x, u_size.y - 1 - q.y); }
vec4 load_src(ivec2 q) { return texelFetch(u_src, flip_y(q), 0); }
#if MULTI_SLOT
int load_slot(ivec2 q) { return int(texelFetch(u_slots, flip_y(q), 0).r); }
#endif
#if COUNT_IMAGE
int load_count(ivec2 q) { return texelFetch(u_counts, flip_y(q), 0).r; }
#endif

// @BODY@

out vec4 o_color;

void main() {
    o_color = burley_texel(flip_y(ivec2(gl_FragCoord.xy)));
}
