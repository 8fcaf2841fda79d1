"""The transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan`) as GLSL compute shaders: the
frame's images in shader storage buffers (float32; the slots as int32), the plan's width tables baked into the
source as constants (:func:`spread_source`), one invocation per camera pixel: steps 0-1 (per pixel a_c = 1 /
sigma_c, g_c = sqrt(z / sigma_c), the widest sigma and the depth, two vec4s), then step 2 horizontally and
vertically with the pair's terms from them (one exp2 per tap and channel, no root or division; the weight's
form is :mod:`ssskit.backends._numba_spread`'s), the images staying on the device between the three
dispatches."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import PassError
from ..spread_plan import SpreadPlan
from .separable import GL_PROFILE_IDS, _array, _f

#: invocations per work group
LOCAL = 64
#: the profile ids of one frame the shader takes: 1024 slots baked into it
PROFILE_IDS = GL_PROFILE_IDS.within(hi=1023, reason="the spread's per-slot tables are constants of one shader")

_BODY = """
layout(local_size_x = LOCAL) in;
layout(std430, binding = 0) readonly buffer Slots { int slots[]; };
layout(std430, binding = 1) readonly buffer Uvz { float uvz[]; };
layout(std430, binding = 2) readonly buffer Shadow { float shadow[]; };
layout(std430, binding = 3) readonly buffer Depth { float depth[]; };
layout(std430, binding = 4) readonly buffer Src { float src[]; };
layout(std430, binding = 5) writeonly buffer Dst { float dst[]; };
// the pixel's terms and values as RGBA32F textures (texelFetch: on llvmpipe 4x faster than storage buffers):
// (a_c, z), (g_c, the widest sigma), (the exitance, the slot), (the horizontal pass, the slot)
layout(rgba32f, binding = 0) uniform writeonly image2D i_a;
layout(rgba32f, binding = 1) uniform writeonly image2D i_g;
layout(rgba32f, binding = 2) uniform writeonly image2D i_v;
layout(binding = 0) uniform sampler2D t_a;
layout(binding = 1) uniform sampler2D t_g;
layout(binding = 2) uniform sampler2D t_v;
uniform int u_n;
uniform int u_w;
uniform int u_h;
uniform int u_stage;      // 0: steps 0-1 (the pixel's terms); 1: step 2 horizontally; 2: vertically
uniform float u_focal;
uniform ivec2 u_shadow_size;

const float NLOG2E_2 = -0.72134752044448170;  // -log2(e) / 2

bool finite(float v) { return !(isinf(v) || isnan(v)); }

float map_depth(float px, float py) {  // the transmittance pass's step 1; NaN-free: -1 flags none
    float x = px - 0.5, y = py - 0.5;
    if (!(finite(x) && finite(y))) return -1.0;
    float fi = floor(x), fj = floor(y);
    float fx = x - fi, fy = y - fj;
    int i0 = int(fi), j0 = int(fj);
    float acc = 0.0, wsum = 0.0;
    for (int q = 0; q < 4; ++q) {
        int di = q & 1, dj = q >> 1;
        float wgt = (di == 1 ? fx : 1.0 - fx) * (dj == 1 ? fy : 1.0 - fy);
        int ii = i0 + di, jj = j0 + dj;
        if (wgt > 0.0 && ii >= 0 && ii < u_shadow_size.x && jj >= 0 && jj < u_shadow_size.y) {
            float d = shadow[jj * u_shadow_size.x + ii];
            if (finite(d)) { acc += wgt * d; wsum += wgt; }
        }
    }
    return wsum > 0.0 ? acc / wsum : -1.0;
}

void terms(int p, int s) {  // steps 0-1, then a_c = 1 / sigma_c, g_c = sqrt(z / sigma_c) (0 where sigma_c = 0)
    float d = map_depth(uvz[3 * p], uvz[3 * p + 1]);
    float t = d >= 0.0 ? uvz[3 * p + 2] - d : 0.0;
    if (!(finite(t) && t > BIAS)) t = 0.0;
    int n = N_KNOTS[s];
    int k = 0;
    while (k < n - 1 && KNOTS[s * NK + k + 1] < t) ++k;
    vec3 sig;
    for (int c = 0; c < 3; ++c) {
        int row = (s * 3 + c) * NK;
        float v;
        if (n == 1 || t <= KNOTS[s * NK]) v = TABLE[row];
        else if (t >= KNOTS[s * NK + n - 1]) v = TABLE[row + n - 1];
        else {
            float f = (t - KNOTS[s * NK + k]) / (KNOTS[s * NK + k + 1] - KNOTS[s * NK + k]);
            v = TABLE[row + k] + f * (TABLE[row + k + 1] - TABLE[row + k]);
        }
        sig[c] = v;
    }
    float z = depth[p];
    vec3 a = vec3(sig.x > 0.0 ? 1.0 / sig.x : 0.0, sig.y > 0.0 ? 1.0 / sig.y : 0.0, sig.z > 0.0 ? 1.0 / sig.z : 0.0);
    ivec2 xy = ivec2(p % u_w, p / u_w);
    imageStore(i_a, xy, vec4(a, z));
    imageStore(i_g, xy, vec4(sqrt(z * a), max(sig.x, max(sig.y, sig.z))));
}

/* step 2 along one axis: the pair's terms with a_c = 1 / sigma_c and g_c = sqrt(z / sigma_c), S_c = f / (g_p g_q):
   w_c = step g_p g_q / (sqrt(2 pi) f) 2^(-log2(e) a_p a_q (d^2 z_p z_q / f^2 + dz^2) / 2), |d| g_p g_q <= 3 f */
vec3 spread_axis(ivec2 xy, float s, bool horizontal, vec3 vp) {
    vec4 p0 = texelFetch(t_a, xy, 0), p1 = texelFetch(t_g, xy, 0);
    float zp = p0.w;
    float m = p1.w * (u_focal / zp);
    if (m < MIN_PX) return vp;
    int stride = max(1, int(ceil(3.0 * m / float(MAX_TAPS))));
    int kk = int(ceil(3.0 * m / float(stride)));
    float cst = float(stride) / (2.5066282746310002 * u_focal);
    float kz = NLOG2E_2 / (u_focal * u_focal);
    float f3 = 3.0 * u_focal;
    ivec2 axis = horizontal ? ivec2(stride, 0) : ivec2(0, stride);
    vec3 acc = vec3(0.0);
    for (int j = -kk; j <= kk; ++j) {
        if (j == 0) continue;
        ivec2 q = xy + j * axis;
        if (q.x < 0 || q.x >= u_w || q.y < 0 || q.y >= u_h) continue;
        vec4 vq = texelFetch(t_v, q, 0);
        if (vq.w != s) continue;
        vec4 q0 = texelFetch(t_a, q, 0), q1 = texelFetch(t_g, q, 0);
        float d = float(j * stride);
        float dz = q0.w - zp;
        float num = (d * d * kz) * (zp * q0.w) + NLOG2E_2 * (dz * dz);
        vec3 gg = p1.xyz * q1.xyz;
        vec3 w = (cst * gg) * exp2(max(num * (p0.xyz * q0.xyz), vec3(-100.0)));
        acc += step(abs(d) * gg, vec3(f3)) * w * (vq.xyz - vp);
    }
    return vp + acc;
}

void main() {
    int p = int(gl_GlobalInvocationID.x);
    if (p >= u_n) return;
    ivec2 xy = ivec2(p % u_w, p / u_w);
    if (u_stage == 0) {
        int s = slots[p];
        imageStore(i_v, xy, vec4(src[3 * p], src[3 * p + 1], src[3 * p + 2], float(s)));
        if (s > 0) terms(p, s);
        else { imageStore(i_a, xy, vec4(0.0)); imageStore(i_g, xy, vec4(0.0)); }
        return;
    }
    vec4 v = texelFetch(t_v, xy, 0);  // stage 1: the exitance; stage 2: the horizontal pass
    vec3 o = v.w > 0.0 ? spread_axis(xy, v.w, u_stage == 1, v.xyz) : v.xyz;
    if (u_stage == 1) imageStore(i_v, xy, vec4(o, v.w));
    else { dst[3 * p] = o.x; dst[3 * p + 1] = o.y; dst[3 * p + 2] = o.z; }
}
"""


def spread_source(plan: SpreadPlan) -> str:
    """The complete GLSL 4.30 source of the step for ``plan``."""
    PROFILE_IDS.check(plan.slots - 1, error=PassError)
    return "\n".join([
        "#version 430",
        "// ---- generated by ssskit.backends.gl.spread_source ----",
        f"#define LOCAL {LOCAL}",
        f"#define NK {plan.knots_mm.shape[1]}",
        f"#define BIAS {_f(plan.bias_mm)}",
        f"#define MIN_PX {_f(plan.min_px)}",
        f"#define MAX_TAPS {int(plan.max_taps)}",
        _array("float", "KNOTS", [_f(v) for v in plan.knots_mm.reshape(-1)]),
        _array("float", "TABLE", [_f(v) for v in plan.sigma_mm.reshape(-1)]),
        _array("int", "N_KNOTS", [str(int(v)) for v in plan.n_knots]),
        _BODY,
    ])


def run_spread(plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
               light_uvz: np.ndarray, shadow_mm: np.ndarray) -> np.ndarray:
    """Upload, dispatch the three stages, read back (the caller holds the context): a new (H, W, 3) float32 array."""
    from .context import context, program

    ctx = context()
    prog = program(spread_source(plan), "spread")
    import moderngl

    h, w = np.shape(slots)
    n = h * w
    f32 = np.float32
    inputs = [np.ascontiguousarray(slots, np.int32), np.ascontiguousarray(light_uvz, f32),
              np.ascontiguousarray(shadow_mm, f32), np.ascontiguousarray(depth_mm, f32),
              np.ascontiguousarray(exitance, f32)]
    bufs = [ctx.buffer(a.tobytes()) for a in inputs] + [ctx.buffer(reserve=max(4, 12 * n))]
    texs = []
    for _ in range(4):  # (a, z), (g, widest sigma), the exitance and the horizontal pass (with the slot)
        tex = ctx.texture((w, h), 4, dtype="f4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texs.append(tex)
    t_a, t_g, t_src, t_tmp = texs
    try:
        for i, buf in enumerate(bufs):
            buf.bind_to_storage_buffer(i)
        prog["u_n"], prog["u_w"], prog["u_h"] = n, w, h
        if "u_shadow_size" in prog:
            prog["u_shadow_size"] = (int(np.shape(shadow_mm)[1]), int(np.shape(shadow_mm)[0]))
        groups = max(1, -(-n // LOCAL))
        # stage 0 writes (a, g, the exitance); 1 reads them and writes the horizontal pass; 2 reads that
        # (image unit, texture) written; textures read, by sampler unit
        stages: tuple[tuple[int, float, tuple[tuple[int, Any], ...], tuple[Any, ...]], ...] = (
            (0, plan.fx, ((0, t_a), (1, t_g), (2, t_src)), ()),
            (1, plan.fx, ((2, t_tmp),), (t_a, t_g, t_src)),
            (2, plan.fy, (), (t_a, t_g, t_tmp)))
        for stage, focal, images, samplers in stages:
            for unit, tex in images:
                tex.bind_to_image(unit, read=False, write=True)
            for unit, tex in enumerate(samplers):
                tex.use(unit)
            prog["u_stage"] = stage
            if "u_focal" in prog:
                prog["u_focal"] = float(focal)
            prog.run(groups, 1, 1)
            ctx.memory_barrier()
        return np.frombuffer(bufs[5].read(), f32)[: 3 * n].reshape(h, w, 3).copy()
    finally:
        for obj in bufs + texs:
            obj.release()


__all__ = ["run_spread", "spread_source"]
