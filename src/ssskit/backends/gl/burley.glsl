// ssskit: the per-pixel body of the Burley Monte Carlo screen-space SSS pass (Xie et al. 2020, Eqs. 19-24):
// ONE source, wrapped as the GLSL 4.30 compute shader the gl backend runs (burley.comp) and as the GLSL ES 3.00
// fragment shader engines and browsers run (burley.frag); ssskit.backends.gl.burley joins them.
//
// The wrapper provides u_size (ivec2), load_src(q) (vec4: E in .rgb, depth in mm in .a, -1 without SSS),
// load_slot(q) (int, MULTI_SLOT), load_count(q) (int, COUNT_IMAGE), and with MIPS load_mip(ivec3) and
// sample_mip(vec3) on the pyramid atlas. The plan's constants (the generated block) come first.

uniform float u_fx;
uniform float u_fy;
uniform uint u_base;   // frame_base(frame, seed) (frame 0 with a stable pattern)
uniform int u_spp;
#if MIPS
uniform int u_mip_x[MAX_MIP + 1];        // x offset of each level in the atlas
uniform ivec2 u_atlas_size;
#endif

const float PI = 3.14159265358979;

uint mix32(uint h) {   // lowbias32 (ssskit.sampling.hashes.mix32)
    h ^= h >> 16; h *= 0x7FEB352Du;
    h ^= h >> 15; h *= 0x846CA68Bu;
    h ^= h >> 16;
    return h;
}

float unit(uint u) {   // (float(U >> 8) + 0.5) 2^-24, exact in float32 (step 3)
    return (float(u >> 8u) + 0.5) * 5.9604644775390625e-8;
}

float expm1_(float x) {
    return abs(x) < 1e-2 ? x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0)))) : exp(x) - 1.0;
}

float log1p_(float x) {
    float u = 1.0 + x;
    return u == 1.0 ? x : log(u) * x / (u - 1.0);
}

float sinh_(float x) {
    return abs(x) < 1e-2 ? x * (1.0 + x * x / 6.0) : 0.5 * (exp(x) - exp(-x));
}

float asinh_(float y) {
    return abs(y) < 1e-2 ? y * (1.0 - y * y / 6.0) : log(y + sqrt(y * y + 1.0));
}

// The exact inverse of Eq. 20 for d = 1 (step 4): Cardano's root u = exp(-r/3) of u^3 + 3u = 4 eta,
// u = 2 sinh(asinh(2 eta) / 3) (no cancellation near eta = 0), or the series near xi = 0; then two
// Newton steps on cdf(r) - xi with t = expm1(-r/3) (float32 keeps the precision at both ends).
float inverse_cdf_unit(float xi) {
    float eta = 1.0 - xi;
    float r;
    if (xi < 1e-3) {
        r = xi * (2.0 + xi * (4.0 / 3.0 + xi * (28.0 / 27.0)));
    } else {
        r = -3.0 * log(2.0 * sinh_(asinh_(2.0 * eta) / 3.0));
    }
    for (int i = 0; i < 2; ++i) {
        float t = expm1_(-r / 3.0);
        float e = 1.0 + t;
        float p = (e * e * e + e) * 0.25;
        if (xi <= 0.5) {
            r -= (-(t * t * t + 3.0 * t * t + 3.0 * t) * 0.25 - 0.75 * t - xi) / p;
        } else {
            r -= (eta - e * e * e * 0.25 - 0.75 * e) / p;
        }
    }
    return r;
}

#if MIPS
// Step 5b: the coverage-normalised trilinear fetch of layer `layer` at level-0 position q, level m.
// Level k sits at (u_mip_x[k], 1) in the atlas with a border of zero texels around it, so the bilinear
// texels just off the level read 0 (as the plan says) without a bounds test.
vec4 mip_bilinear(vec2 q, int level, int layer) {
    vec2 uv = q * exp2(-float(level)) - 0.5;
#if FILTERED_MIPS
    // the texture unit's bilinear filter (its weights are rounded: about 1e-3 of the texel differences)
    return sample_mip(vec3((vec2(u_mip_x[level], 1) + uv + 0.5) / vec2(u_atlas_size), float(layer)));
#else
    vec2 f = floor(uv);
    vec2 t = uv - f;
    ivec3 i0 = ivec3(ivec2(f) + ivec2(u_mip_x[level], 1), layer);
    return (1.0 - t.y) * ((1.0 - t.x) * load_mip(i0) + t.x * load_mip(i0 + ivec3(1, 0, 0)))
         + t.y * ((1.0 - t.x) * load_mip(i0 + ivec3(0, 1, 0)) + t.x * load_mip(i0 + ivec3(1, 1, 0)));
#endif
}

vec3 mip_fetch(vec2 q, float m, int layer) {
    int lo = int(floor(m));
    float f = m - float(lo);
    vec4 acc = (1.0 - f) * mip_bilinear(q, lo, layer);
    if (f > 0.0 && lo + 1 <= MAX_MIP) acc += f * mip_bilinear(q, lo + 1, layer);
    return acc.rgb / acc.a;
}
#endif

// The pass's result at pixel p (row 0 at the top of the image, as ssskit's arrays), before the albedo.
vec4 burley_texel(ivec2 p) {
    vec4 c = load_src(p);
#if MULTI_SLOT
    int s = load_slot(p);
#else
    int s = c.a < 0.0 ? 0 : 1;   // one profile: the depth's sign is the mask
#endif
#if COUNT_IMAGE
    int n = load_count(p);
#else
    int n = u_spp;
#endif
    if (s == 0 || n == 0) return c;
    float zp = c.a;
    float sx = u_fx / zp, sy = u_fy / zp;   // pixels per mm at the centre's depth
    // step 1: the pixel key
    uint h = mix32(mix32(u_base ^ uint(p.y)) ^ uint(p.x));
#if STABLE
    h = mix32(h ^ floatBitsToUint(zp));
#endif
    uint h1 = h, h2 = mix32(h ^ 0x6A09E667u);
#if SAMPLER == 2
    // step 2: golubev caps the count by the footprint
    float r997 = R997[s];
    n = max(1, min(n, int(floor(PI * r997 * r997 * sx * sy / 4.0))));
#endif
    vec3 d = D_MM[s];
    float ds = D_SAMPLE[s];
    vec3 num = vec3(0.0), den = vec3(0.0);
    for (int j = 0; j < n; ++j) {
        // step 3: uniforms
        float xi1, xi2;
        uint uj = uint(j);
#if SAMPLER == 2
        xi1 = (float(j) + 0.5) / float(n);
        xi2 = unit(h2 + uj * 0x9E3779B9u);
#elif SEQUENCE == 0
        xi1 = unit(h1 + uj * 0xC13FA9A9u);
        xi2 = unit(h2 + uj * 0x91E10DA6u);
#else
        uint k = uj * 0x9E3779B9u;
        xi1 = unit(mix32(h1 ^ k));
        xi2 = unit(mix32(h2 ^ k));
#endif
        // step 4: the radius in the sampling channel
#if SAMPLER == 1
        float r = ds * ((2.0 - XIE_C) * xi1 - 2.0) * log1p_(-xi1);   // Eq. 21
#else
        float r = ds * inverse_cdf_unit(xi1);                          // Eq. 20 inverted
#endif
        // step 5: the position (phi = 2 pi xi2, evaluated as phi - pi in [-pi, pi))
        float a = (xi2 - 0.5) * 2.0 * PI;
        vec2 q = vec2(p) + 0.5 + r * vec2(-cos(a) * sx, -sin(a) * sy);
        ivec2 qi = ivec2(floor(q));
        // step 6: the indicator
        if (qi.x < 0 || qi.y < 0 || qi.x >= u_size.x || qi.y >= u_size.y) continue;
#if MULTI_SLOT
        int qs = load_slot(qi);
        float ind = qs == s ? 1.0 : (qs > 0 ? BLEED : 0.0);
        if (ind == 0.0) continue;
        vec4 t = load_src(qi);
#else
        vec4 t = load_src(qi);
        if (t.a < 0.0) continue;
        const int qs = 1;
        const float ind = 1.0;
#endif
        // step 7: Eq. 24's weights
        float dz = t.a - zp;
        float rp = sqrt(r * r + dz * dz);
        float es = exp(-r / (3.0 * ds));            // exp(-r/d) = exp(-r/(3d))^3: half the exponentials
        float pdf = es * es * es + es;
        vec3 e3 = exp(-rp / (3.0 * d));
        vec3 w = ind * (ds / d) * (e3 * e3 * e3 + e3) / pdf;
#if MIPS
        // Eq. 22 in Xie's units: radial pdf (mm^-1), the slot's largest dmfp (mm), Eq. 23's t (UV^2 per mm^2)
        float p_r = pdf / (4.0 * ds);
        float t_uv = (sx / float(u_size.x)) * (sy / float(u_size.y));
        float ell = L_MAX[s];
        float m = min(float(MAX_MIP), 0.5 * max(-log2(MIP_SCALE * float(n) * p_r / (ell * ell * t_uv)), 0.0));
        vec3 value = mip_fetch(q, m, qs - 1);
#else
        vec3 value = t.rgb;
#endif
        num += w * value;
        den += w;
    }
    // step 8: the self-normalised estimate (E(p) where every sample was rejected)
    vec3 outc = vec3(den.x > 0.0 ? num.x / den.x : c.r, den.y > 0.0 ? num.y / den.y : c.g,
                     den.z > 0.0 ? num.z / den.z : c.b);
    return vec4(outc, zp);
}
