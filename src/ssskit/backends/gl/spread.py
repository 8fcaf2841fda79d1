"""The transmitted light's lateral spread (:mod:`ssskit.backends.spread_plan`) as GLSL compute shaders: the
frame's images in shader storage buffers (float32; the slots as int32), the plan's width tables baked into the
source as constants (:func:`spread_source`), one invocation per camera pixel: steps 0-1 (the widths), then step
2 horizontally and vertically, the images staying on the device between the three dispatches."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...errors import PassError
from ..spread_plan import SpreadPlan
from .separable import _array, _f

if TYPE_CHECKING:
    import moderngl

#: invocations per work group
LOCAL = 64
#: most profile slots baked into one shader
MAX_SLOTS = 1024

_BODY = """
layout(local_size_x = LOCAL) in;
layout(std430, binding = 0) readonly buffer Slots { int slots[]; };
layout(std430, binding = 1) readonly buffer Uvz { float uvz[]; };
layout(std430, binding = 2) readonly buffer Shadow { float shadow[]; };
layout(std430, binding = 3) readonly buffer Depth { float depth[]; };
layout(std430, binding = 4) buffer Sigma { float sig[]; };
layout(std430, binding = 5) readonly buffer Src { float src[]; };
layout(std430, binding = 6) writeonly buffer Dst { float dst[]; };
uniform int u_n;
uniform int u_w;
uniform int u_h;
uniform int u_stage;      // 0: steps 0-1 (the widths into sig); 1: step 2 horizontally; 2: vertically
uniform float u_focal;
uniform ivec2 u_shadow_size;

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

void widths(int p, int s) {  // steps 0-1
    float d = map_depth(uvz[3 * p], uvz[3 * p + 1]);
    float t = d >= 0.0 ? uvz[3 * p + 2] - d : 0.0;
    if (!(finite(t) && t > BIAS)) t = 0.0;
    int n = N_KNOTS[s];
    int k = 0;
    while (k < n - 1 && KNOTS[s * NK + k + 1] < t) ++k;
    for (int c = 0; c < 3; ++c) {
        int row = (s * 3 + c) * NK;
        float v;
        if (n == 1 || t <= KNOTS[s * NK]) v = TABLE[row];
        else if (t >= KNOTS[s * NK + n - 1]) v = TABLE[row + n - 1];
        else {
            float f = (t - KNOTS[s * NK + k]) / (KNOTS[s * NK + k + 1] - KNOTS[s * NK + k]);
            v = TABLE[row + k] + f * (TABLE[row + k + 1] - TABLE[row + k]);
        }
        sig[3 * p + c] = v;
    }
}

void spread_axis(int p, int s, bool horizontal) {  // step 2
    int x = p % u_w, y = p / u_w;
    float zp = depth[p];
    float kpx = u_focal / zp;
    vec3 sp = vec3(sig[3 * p], sig[3 * p + 1], sig[3 * p + 2]);
    vec3 spx = sp * kpx;
    float m = max(spx.x, max(spx.y, spx.z));
    vec3 acc = vec3(0.0);
    vec3 vp = vec3(src[3 * p], src[3 * p + 1], src[3 * p + 2]);
    if (m < MIN_PX) { dst[3 * p] = vp.x; dst[3 * p + 1] = vp.y; dst[3 * p + 2] = vp.z; return; }
    int step = max(1, int(ceil(3.0 * m / float(MAX_TAPS))));
    int kk = int(ceil(3.0 * m / float(step)));
    for (int j = -kk; j <= kk; ++j) {
        if (j == 0) continue;
        int qx = horizontal ? x + j * step : x;
        int qy = horizontal ? y : y + j * step;
        if (qx < 0 || qx >= u_w || qy < 0 || qy >= u_h) continue;
        int q = qy * u_w + qx;
        if (slots[q] != s) continue;
        float d = float(j * step);
        float zq = depth[q];
        float dz = zq - zp;
        vec3 sq = vec3(sig[3 * q], sig[3 * q + 1], sig[3 * q + 2]);
        vec3 pair_px = sqrt(spx * sq * (u_focal / zq));
        vec3 pair_mm = sqrt(sp * sq);
        for (int c = 0; c < 3; ++c) {
            if (!(pair_px[c] > 0.0 && abs(d) <= 3.0 * pair_px[c])) continue;
            float wgt = float(step) * exp(-(d * d) / (2.0 * pair_px[c] * pair_px[c])) / (2.5066282746310002 * pair_px[c])
                        * exp(-(dz * dz) / (2.0 * pair_mm[c] * pair_mm[c]));
            acc[c] += wgt * (src[3 * q + c] - vp[c]);
        }
    }
    vec3 o = vp + acc;
    dst[3 * p] = o.x; dst[3 * p + 1] = o.y; dst[3 * p + 2] = o.z;
}

void main() {
    int p = int(gl_GlobalInvocationID.x);
    if (p >= u_n) return;
    int s = slots[p];
    if (u_stage == 0) {
        if (s > 0) widths(p, s);
        else { sig[3 * p] = 0.0; sig[3 * p + 1] = 0.0; sig[3 * p + 2] = 0.0; }
        return;
    }
    if (s <= 0) { dst[3 * p] = src[3 * p]; dst[3 * p + 1] = src[3 * p + 1]; dst[3 * p + 2] = src[3 * p + 2]; return; }
    spread_axis(p, s, u_stage == 1);
}
"""


def spread_source(plan: SpreadPlan) -> str:
    """The complete GLSL 4.30 source of the step for ``plan``."""
    if plan.slots > MAX_SLOTS:
        raise PassError(f"the gl backend's spread holds at most {MAX_SLOTS - 1} profile ids, got {plan.slots - 1}")
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


_PROGRAMS: dict[str, moderngl.ComputeShader] = {}


def run_spread(plan: SpreadPlan, exitance: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
               light_uvz: np.ndarray, shadow_mm: np.ndarray) -> np.ndarray:
    """Upload, dispatch the three stages, read back (the caller holds the context): a new (H, W, 3) float32 array."""
    from .context import compile_compute, context

    ctx = context()
    src_text = spread_source(plan)
    prog = _PROGRAMS.get(src_text)
    if prog is None:
        if len(_PROGRAMS) > 64:
            _PROGRAMS.clear()
        prog = _PROGRAMS[src_text] = compile_compute(src_text, "spread")
    h, w = np.shape(slots)
    n = h * w
    f32 = np.float32
    inputs = [np.ascontiguousarray(slots, np.int32), np.ascontiguousarray(light_uvz, f32),
              np.ascontiguousarray(shadow_mm, f32), np.ascontiguousarray(depth_mm, f32)]
    bufs = [ctx.buffer(a.tobytes()) for a in inputs]
    sigma = ctx.buffer(reserve=max(4, 12 * n))
    images = [ctx.buffer(np.ascontiguousarray(exitance, f32).tobytes()), ctx.buffer(reserve=max(4, 12 * n)),
              ctx.buffer(reserve=max(4, 12 * n))]
    try:
        for i, buf in enumerate(bufs + [sigma]):
            buf.bind_to_storage_buffer(i)
        prog["u_n"], prog["u_w"], prog["u_h"] = n, w, h
        for name, value in (("u_shadow_size", (int(np.shape(shadow_mm)[1]), int(np.shape(shadow_mm)[0]))),):
            if name in prog:
                prog[name] = value
        groups = max(1, -(-n // LOCAL))
        for stage, (a, b, focal) in enumerate(((0, 1, plan.fx), (0, 1, plan.fx), (1, 2, plan.fy))):
            images[a].bind_to_storage_buffer(5)
            images[b].bind_to_storage_buffer(6)
            prog["u_stage"] = stage
            if "u_focal" in prog:
                prog["u_focal"] = float(focal)
            prog.run(groups, 1, 1)
            ctx.memory_barrier()
        return np.frombuffer(images[2].read(), f32)[: 3 * n].reshape(h, w, 3).copy()
    finally:
        for buf in bufs + [sigma] + images:
            buf.release()


__all__ = ["run_spread", "spread_source"]
