#version 300 es
// ssskit: the transmittance pass (ssskit.backends.transmission_plan) as a GLSL ES 3.00 fragment shader (WebGL2,
// OpenGL ES 3): the fragment wrapper of the per-pixel body transmission.glsl (inserted at the BODY marker), the
// same body the gl backend's compute shader (transmission.comp) runs.
//
// Draw a full-screen triangle into a W x H RGBA32F target (rgb: T(t) E). Pixel p counts rows from the top of the
// image (ssskit's arrays); every camera-image fetch flips y. Textures: u_id (float, .r the profile slot: 0 no
// SSS); u_lightspace (RGBA32F: the pixel's map texel x, y, its depth along the light in mm, and N . L);
// u_shadow (R32F, the light's depth map in mm, row j = the map's array row j, not flipped). Uniforms: u_size =
// (W, H); u_shadow_size = the map's (width, height); u_light_rgb = the irradiance of a surface facing the light.

precision highp float;
precision highp int;
precision highp sampler2D;

// @GENERATED@

uniform ivec2 u_size;
uniform ivec2 u_shadow_size;
uniform vec3 u_light_rgb;
uniform sampler2D u_id;
uniform sampler2D u_lightspace;
uniform sampler2D u_shadow;

ivec2 flip_y(ivec2 q) { return ivec2(q.x, u_size.y - 1 - q.y); }
float load_shadow(int i, int j) { return texelFetch(u_shadow, ivec2(i, j), 0).r; }

// @BODY@

out vec4 o_color;

void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);   // GL's pixel: the same texel of every camera image
    vec4 ls = texelFetch(u_lightspace, q, 0);
    int s = int(texelFetch(u_id, q, 0).r + 0.5);
    o_color = vec4(transmission_texel(s, ls.xyz, ls.w, u_light_rgb), 1.0);
}
