#version 300 es
// ssskit: one 1D pass of the screen-space separable SSS filter as a GLSL ES 3.00 fragment shader (WebGL2,
// OpenGL ES 3): the fragment wrapper of the per-pixel body separable.glsl (inserted at the BODY marker),
// the same body the gl backend's compute shader (separable.comp) runs.
//
// Draw a full-screen triangle into a W x H RGBA32F target per pass. Pixel p of the body counts rows from the
// top of the image (ssskit's arrays); GL's rows count from the bottom, so every fetch flips y.
// Textures: u_src (RGBA32F) E in .rgb, linear depth in mm in .a (-1 without SSS); u_dst (RGBA32F, vertical
// passes of later terms) the earlier terms' sum; u_slots (R16UI, MULTI_SLOT) the slot of each pixel.

precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;

// @GENERATED@

#define SRC_BUFFER 0

uniform ivec2 u_size;   // image width, height
uniform sampler2D u_src;
uniform sampler2D u_dst;
#if MULTI_SLOT
uniform usampler2D u_slots;
#endif

ivec2 flip_y(ivec2 q) { return ivec2(q.x, u_size.y - 1 - q.y); }
vec4 load_src(ivec2 q) { return texelFetch(u_src, flip_y(q), 0); }
vec4 load_dst(ivec2 q) { return texelFetch(u_dst, flip_y(q), 0); }
#if MULTI_SLOT
uint load_slot(ivec2 q) { return texelFetch(u_slots, flip_y(q), 0).r; }
#endif

// @BODY@

out vec4 o_color;

void main() {
    o_color = separable_texel(flip_y(ivec2(gl_FragCoord.xy)));
}
