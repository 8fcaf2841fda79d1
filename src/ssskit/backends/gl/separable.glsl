// ssskit: the per-pixel body of one 1D pass of the screen-space separable SSS filter: ONE source, wrapped
// as the GLSL 4.30 compute shader the gl backend runs (separable.comp) and as the GLSL ES 3.00 fragment
// shader engines and browsers run (separable.frag); ssskit.backends.gl.separable joins them.
//
// The wrapper provides u_size (ivec2), load_src(q) (vec4: E in .rgb, linear depth in mm in .a, -1 without
// SSS), load_dst(q) (the destination's earlier value: the sum of the earlier terms), load_slot(q) (uint,
// MULTI_SLOT only), and the SRC_BUFFER define (1 only where an invalid border makes the bounds test moot).
// The plan's constants (the generated block) come first.

uniform float u_f;      // focal length along the pass axis, pixels
uniform uint u_base;    // per-frame hash key: ssskit.sampling.hashes.frame_base(frame, seed)
uniform int u_accumulate;  // vertical pass: 1 adds to the sum of the earlier terms in u_dst

// Wellons' lowbias32 (ssskit.sampling.hashes.mix32)
uint mix32(uint h) {
    h ^= h >> 16; h *= 0x7FEB352Du;
    h ^= h >> 15; h *= 0x846CA68Bu;
    h ^= h >> 16;
    return h;
}

#if VERTICAL
const ivec2 AXIS = ivec2(0, 1);
#else
const ivec2 AXIS = ivec2(1, 0);
#endif

float depth_factor(float dz, float param) {
#if DEPTH_MODE == 0
    return exp(-dz * dz * param);             // gaussian: exp(-dz^2 / (2 tau_max)), supplement E
#elif DEPTH_MODE == 1
    return max(0.0, 1.0 - abs(dz) * param);   // follow: max(0, 1 - |dz| / width)
#else
    return 1.0;                               // none
#endif
}

// (f E(q), f) with f = f(z_q - z) for a texel q of the pixel's slot, else 0 (off the image, off the
// slot); a tap's sum S of these gives sum_j b_j f_j (E(j) - E(p)) = S.rgb - S.a E(p)
vec4 texel(ivec2 q, vec4 c, uint slot, float param) {
#if !(SRC_BUFFER && !MULTI_SLOT)
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, u_size))) return vec4(0.0);
#endif
    vec4 t = load_src(q);
#if MULTI_SLOT
    if (load_slot(q) != slot) return vec4(0.0);
#else
    if (t.a < 0.0) return vec4(0.0);
#endif
    return depth_factor(t.a - c.a, param) * vec4(t.rgb, 1.0);
}

// a tap d pixels along the pass axis: the two texels of a 1D linear fetch
vec4 tap1d(ivec2 p, float d, vec4 c, uint slot, float param) {
    float fl = floor(d);
    float t = d - fl;
    ivec2 q = p + int(fl) * AXIS;
    return (1.0 - t) * texel(q, c, slot, param) + t * texel(q + AXIS, c, slot, param);
}

// a tap at offset d (pixels, 2D): the four texels of a bilinear fetch
vec4 tap2d(ivec2 p, vec2 d, vec4 c, uint slot, float param) {
    vec2 fl = floor(d);
    vec2 t = d - fl;
    ivec2 q = p + ivec2(fl);
    return (1.0 - t.y) * ((1.0 - t.x) * texel(q, c, slot, param) + t.x * texel(q + ivec2(1, 0), c, slot, param))
         + t.y * ((1.0 - t.x) * texel(q + ivec2(0, 1), c, slot, param) + t.x * texel(q + ivec2(1, 1), c, slot, param));
}

// Row k of the pass: the taps at +- o_k (2D and rotated for the first nj rows, 1D along the axis after), weighted
// by ROW_PLUS / ROW_MINUS, or one weight for a mirror pair. A macro, so the rows can be written out with constant k.
#define SSS_ROW(k) \
    if ((k) < nr) { \
        int i = t * KMAX + (k); \
        float reach = ROW_PLUS[i].w * scale; \
        vec4 sp, sm; \
        if ((k) < nj) { \
            sp = tap2d(p, reach * u, c, slot, param); \
            sm = tap2d(p, -reach * u, c, slot, param); \
        } else { \
            sp = tap1d(p, reach, c, slot, param); \
            sm = tap1d(p, -reach, c, slot, param); \
        } \
        if (ROW_SYMMETRIC[i]) { \
            sp += sm; \
            acc += ROW_PLUS[i].rgb * (sp.rgb - sp.a * c.rgb); \
        } else { \
            acc += ROW_PLUS[i].rgb * (sp.rgb - sp.a * c.rgb) + ROW_MINUS[i] * (sm.rgb - sm.a * c.rgb); \
        } \
    }

// The pass's value at pixel p (row 0 at the top of the image, as ssskit's arrays): what the destination
// holds there after the pass.
vec4 separable_texel(ivec2 p) {
    vec4 c = load_src(p);
#if MULTI_SLOT
    uint slot = load_slot(p);
    int s = int(slot);
    if (slot == 0u) {
#else
    uint slot = 1u;
    const int s = 1;
    if (c.a < 0.0) {
#endif
#if VERTICAL
        return u_accumulate == 0 ? c : load_dst(p);   // no SSS: E, or the earlier terms' sum kept
#else
        return c;
#endif
    }
#if MULTI_SLOT
    int t = TERM * NSLOTS + s;   // this term's table of slot s
#else
    const int t = TERM * NSLOTS + 1;   // one slot: every table index below is a constant
#endif
    float param = DEPTH_PARAM[s];
    float scale = u_f / c.a;     // pixels per mm at the pixel's depth
    vec3 acc = CENTRE[t] * c.rgb;
    int nj = N_JIT[t];
    int nr = N_ROWS[t];
    vec2 u = vec2(AXIS);
    if (nj > 0) {
        // theta = 2 pi h / 2^32 (ssskit.sampling.hashes.jitter_angles), evaluated as theta - pi in
        // [-pi, pi) where float32 sin/cos are accurate: cos(theta) = -cos(theta - pi), likewise sin
        uint h = mix32(mix32(u_base ^ uint(p.y)) ^ uint(p.x));
        float a = (float(h) * 2.3283064365386963e-10 - 0.5) * 6.283185307179586;
        float cs = -cos(a), sn = -sin(a);
#if VERTICAL
        u = vec2(-sn, cs);
#else
        u = vec2(cs, sn);
#endif
    }
    // the rows, written out for k < 16 (a software rasteriser such as SwiftShader neither unrolls the loop nor
    // folds a table index it cannot see is constant; measured in benchmarks/RESULTS.md), else a loop
#if KMAX <= 16
    SSS_ROW(0)
#if KMAX > 1
    SSS_ROW(1)
#endif
#if KMAX > 2
    SSS_ROW(2)
#endif
#if KMAX > 3
    SSS_ROW(3)
#endif
#if KMAX > 4
    SSS_ROW(4)
#endif
#if KMAX > 5
    SSS_ROW(5)
#endif
#if KMAX > 6
    SSS_ROW(6)
#endif
#if KMAX > 7
    SSS_ROW(7)
#endif
#if KMAX > 8
    SSS_ROW(8)
#endif
#if KMAX > 9
    SSS_ROW(9)
#endif
#if KMAX > 10
    SSS_ROW(10)
#endif
#if KMAX > 11
    SSS_ROW(11)
#endif
#if KMAX > 12
    SSS_ROW(12)
#endif
#if KMAX > 13
    SSS_ROW(13)
#endif
#if KMAX > 14
    SSS_ROW(14)
#endif
#if KMAX > 15
    SSS_ROW(15)
#endif
#else
    for (int k = 0; k < KMAX; ++k) {
        SSS_ROW(k)
    }
#endif
#if VERTICAL
    vec3 outc = SIGN[t] * acc;
    if (u_accumulate != 0) outc += load_dst(p).rgb;
    return vec4(outc, c.a);
#else
    return vec4(acc, c.a);
#endif
}
